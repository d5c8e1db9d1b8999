"""What a flight observes of a scene, for the ground truth of a map (docs/features.md).

A point is observable when, from at least one antenna position of the flight
(:func:`observer_from_track`: a few positions per pass), it is inside the nominal beam
(direction sines within half the beamwidths, the footprint's convention of
:func:`mitsar.scene.footprint.beam_directions`, and within ``max_range``) and nothing in the
scene blocks the segment between them (one batched Mitsuba ``ray_test``,
:func:`mitsar.scene.facets.segments_visible`); :func:`observe_points`. A feature no pass
observes is "not visible" in the scores (:mod:`mitsar.features.scores`), not "missed".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.features.mesh_features import PAIR_CHUNK, chunked_pairs
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.model.radar import Radar
from mitsar.products.raw import look_of, radar_of
from mitsar.scene.facets import segments_visible

__all__ = ["Observer", "observe_points", "observer_from_track"]

@dataclass(frozen=True)
class Observer:
    """Antenna positions and frames of a flight, and the beam they carry.

    Attributes
    ----------
    positions : numpy.ndarray, shape (P, 3)
        Antenna phase centres [m].
    frames : numpy.ndarray, shape (P, 3, 3)
        Antenna-to-world rotations (columns: azimuth axis, elevation axis, boresight).
    azimuth_beamwidth, elevation_beamwidth : float
        Full beamwidths as direction sines [rad] (``lambda / D``).
    max_range : float
        Largest range the receiver holds [m].
    cover : float
        Half-width of the beam counted as the footprint, in half beamwidths (1: the nominal
        -3.9 dB one-way edge of :func:`mitsar.scene.footprint.beam_directions`).
    passes : int
        Number of passes the positions come from.
    """

    positions: NDArray[np.float64]
    frames: NDArray[np.float64]
    azimuth_beamwidth: float
    elevation_beamwidth: float
    max_range: float
    cover: float = 1.0
    passes: int = 1


def as_observer(track: Any, samples: int | None, cover: float) -> Observer:
    if isinstance(track, Observer):
        return track
    return observer_from_track(track, samples=samples, cover=cover)


def observer_from_track(track: xr.Dataset | Sequence[xr.Dataset], samples: int | None = None,
                        cover: float = 1.0) -> Observer:
    """The antenna positions of one or more raw products (passes), a few per pass.

    Parameters
    ----------
    track : xarray.Dataset or sequence of them
        Raw (or histogram) products: ``platform_position``, ``attitude``, the look and radar
        attributes (:data:`mitsar.products.raw.RAW_SCHEMA`); the recorded (navigation) track.
    samples : int, optional
        Positions per pass, evenly spaced over its sweeps, ends included. Default: as many as
        keep consecutive positions within half the azimuth footprint at 1 m range
        (``0.5 · beta_az · 1 m``), between 2 and 256.
    cover : float
        See :class:`Observer`.

    Returns
    -------
    Observer
    """
    products = [track] if isinstance(track, xr.Dataset) else list(track)
    if not products or not all(isinstance(p, xr.Dataset) and "platform_position" in p
                               for p in products):
        raise ParameterError("observer_from_track", "track",
                             "a raw product or a list of them (one per pass)", type(track))
    if not (isinstance(cover, int | float) and cover > 0):
        raise ParameterError("observer_from_track", "cover", "a number > 0", cover)
    positions, frames = [], []
    radars: list[Radar] = []
    for product in products:                                 # one per pass
        radar = radar_of(product)
        radars.append(radar)
        pos = np.asarray(product["platform_position"].values, dtype=float).reshape(-1, 3)
        attitude = np.asarray(product["attitude"].values, dtype=float).reshape(-1, 3)
        count = samples
        if count is None:
            length = float(np.sum(np.linalg.norm(np.diff(pos, axis=0), axis=1)))
            count = int(np.clip(math.ceil(length / (0.5 * radar.azimuth_beamwidth)) + 1, 2, 256))
        if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
            raise ParameterError("observer_from_track", "samples", "an integer >= 1", samples)
        chosen = np.unique(np.round(np.linspace(0, len(pos) - 1, int(count))).astype(int))
        positions.append(pos[chosen])
        frames.append(antenna_frame(look_of(product), *attitude[chosen].T).reshape(-1, 3, 3))
    return Observer(np.vstack(positions), np.vstack(frames),
                    azimuth_beamwidth=max(r.azimuth_beamwidth for r in radars),
                    elevation_beamwidth=max(r.elevation_beamwidth for r in radars),
                    max_range=max(r.max_range for r in radars), cover=float(cover),
                    passes=len(products))


def observe_points(scene: Any, points: ArrayLike, normals: ArrayLike, observer: Observer
                   ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Which points some antenna position has in its beam, and sees unoccluded.

    Parameters
    ----------
    scene : mitsuba.Scene
    points, normals : array_like, shape (N, 3)
        Points [m] and the unit normals of the surface they lie on (for the ray's offset off
        it; :func:`mitsar.scene.facets.segments_visible`).
    observer : Observer

    Returns
    -------
    in_footprint : numpy.ndarray of bool, shape (N,)
        Inside the beam (direction sines within ``cover`` half beamwidths, in front of the
        antenna, within ``max_range``) of at least one position.
    observable : numpy.ndarray of bool, shape (N,)
        Inside the beam of, and unoccluded from, at least one position.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    pos, frames = observer.positions, observer.frames
    half_az = observer.cover * observer.azimuth_beamwidth / 2
    half_el = observer.cover * observer.elevation_beamwidth / 2

    # Antenna-frame coordinates of every (point, position) pair by one matrix product:
    # local = F_p^T (x - p_p), the rows of F_p^T stacked over positions.
    # Single precision (1e-7 of the range at the beam's edge) halves the memory traffic.
    axes = np.transpose(frames, (0, 2, 1)).reshape(-1, 3)              # (3P, 3)
    shift = np.einsum("pk,pck->pc", pos, np.transpose(frames, (0, 2, 1))).reshape(-1)
    origin = pos.mean(axis=0)                                         # keep float32 local
    shift = (shift - axes @ origin).astype(np.float32)
    axes32 = axes.T.astype(np.float32)
    centred = (points - origin).astype(np.float32)

    def test(rows: slice) -> NDArray:
        local = (centred[rows] @ axes32 - shift).reshape(-1, len(pos), 3)
        distance = np.sqrt(np.einsum("npk,npk->np", local, local))
        # Direction sines (mitsar.model.geometry.antenna.direction_sines) without dividing:
        # |u| <= h  <=>  |local| <= h * distance.
        return ((local[..., 2] > 0) & (np.abs(local[..., 0]) <= half_az * distance)
                & (np.abs(local[..., 1]) <= half_el * distance)
                & (distance <= observer.max_range))

    i, p = chunked_pairs(len(points), len(pos), test)
    in_footprint = np.zeros(len(points), dtype=bool)
    in_footprint[i] = True
    observable = np.zeros(len(points), dtype=bool)
    for start in range(0, len(i), PAIR_CHUNK):  # blocks of rays
        block = slice(start, start + PAIR_CHUNK)
        seen = segments_visible(scene, points[i[block]], normals[i[block]], pos[p[block]])
        observable[i[block][seen]] = True
    return in_footprint, observable
