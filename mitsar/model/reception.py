"""Can an echo be received at all? Receiver band, antenna beam and near field per scatterer.

A producer writes whatever its model gives; a real radar receives an echo only if (1) its beat
frequency lies in the receiver's band, i.e. the slant range is at most ``max_range`` (the IF
band ends at the beat frequency ``2 K R_max / c``, paper eq. 1; beyond it the anti-alias
filter rejects the echo and the ray tracer's bin grid stops), (2) the antenna's main lobe
sees it in some sweep (outside it only the sinc sidelobes, and behind the antenna nothing),
and (3) it lies in the antenna's far field, ``R >= 2 D^2 / lambda`` (the Fraunhofer
distance, Balanis, *Antenna Theory*, 3rd ed., §2.2.4, eq. 2-31, with ``D`` the aperture's
largest dimension, here its diagonal from the beamwidths ``lambda / beta``), where the
far-field pattern and the point-scatterer model hold. :func:`reception` measures the three
over a flight; :func:`reception_warnings` words them for the user, naming each scatterer
(docs/reliability.md §"Echoes that cannot be received"). Pure NumPy.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.model.geometry.antenna import direction_sines, one_way_pattern
from mitsar.model.radar import Radar

SWEEPS_SAMPLED = 257
"""Sweeps at which :func:`reception` evaluates a long flight (evenly spaced, ends included):
the beam moves by less than a beamwidth between two of them on any flight mitsar simulates at
the paper's geometry (a 2 m pass at 10 cm resolution spans ~20 beamwidths of sight-line
motion); the ranges and patterns are extrema over these sweeps."""


def fraunhofer_distance(radar: Radar) -> float:
    """Far-field distance ``2 D^2 / lambda`` [m] of the radar's aperture (Balanis eq. 2-31).

    ``D`` is the aperture's largest dimension, the diagonal of ``lambda / beta_az`` by
    ``lambda / beta_el`` (the uniform aperture whose sinc pattern the models use).
    """
    wavelength = radar.wavelength
    diagonal = math.hypot(wavelength / radar.azimuth_beamwidth,
                          wavelength / radar.elevation_beamwidth)
    return 2.0 * diagonal**2 / wavelength


@dataclass(frozen=True)
class Reception:
    """Per scatterer, over the sweeps of a flight (:func:`reception`).

    Attributes
    ----------
    min_range, max_range : ndarray, shape (n,)
        Smallest and largest slant range from the antenna at mid-sweep [m].
    in_band : ndarray of float, shape (n,)
        Fraction of the sweeps whose slant range is at most ``radar.max_range``.
    peak_pattern : ndarray, shape (n,)
        Largest two-way power pattern over the sweeps (1 on boresight, 0 behind); NaN where
        not asked for (:func:`reception` with ``pattern=False``).
    main_lobe : ndarray of bool, shape (n,)
        In the main lobe (``|u_az| < beta_az``, ``|u_el| < beta_el``, in front) in some sweep.
    near_field : ndarray of bool, shape (n,)
        Nearer than :func:`fraunhofer_distance` in some sweep.
    far_field_distance : float
        :func:`fraunhofer_distance` [m].
    """

    min_range: NDArray[np.float64]
    max_range: NDArray[np.float64]
    in_band: NDArray[np.float64]
    peak_pattern: NDArray[np.float64]
    main_lobe: NDArray[np.bool_]
    near_field: NDArray[np.bool_]
    far_field_distance: float


def reception(radar: Radar, positions: ArrayLike, antenna: ArrayLike, frames: ArrayLike,
              velocities: ArrayLike | None = None, times: ArrayLike | None = None,
              pattern: bool = True) -> Reception:
    """Band, beam and near field of scatterers over a flight (module docstring).

    Parameters
    ----------
    radar : Radar
    positions : array_like, shape (n, 3)
        Scatterer positions [m] (at time 0 if ``velocities`` are given).
    antenna : array_like, shape (sweeps, 3)
        Antenna phase centre at mid-sweep [m].
    frames : array_like, shape (sweeps, 3, 3)
        Antenna-to-world rotations at mid-sweep.
    velocities : array_like, shape (n, 3), optional
        Scatterer velocities [m/s]; ``times`` [s] (sweeps,) are then the mid-sweep times.
    pattern : bool
        Evaluate the peak two-way pattern (False: ``peak_pattern`` is NaN; the surface check
        of :func:`scene_reception_warnings` reads only the main lobe, band and near field).

    Returns
    -------
    Reception
    """
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    antenna = np.asarray(antenna, dtype=float).reshape(-1, 3)
    frames = np.asarray(frames, dtype=float).reshape(-1, 3, 3)
    chosen = np.unique(np.linspace(0, len(antenna) - 1, min(len(antenna), SWEEPS_SAMPLED))
                       .round().astype(int))
    where = positions[None, :, :]
    if velocities is not None and times is not None:
        where = where + (np.asarray(velocities, float).reshape(-1, 3)[None]
                         * np.asarray(times, float)[chosen, None, None])
    offset = where - antenna[chosen, None, :]  # (sweeps, n, 3)
    slant = np.linalg.norm(offset, axis=-1)
    directions = offset / np.maximum(slant, 1e-300)[..., None]
    frame = frames[chosen, None]
    u_az, u_el, cos_b = direction_sines(directions, frame)
    lobe = ((cos_b > 0.0) & (np.abs(u_az) < radar.azimuth_beamwidth)
            & (np.abs(u_el) < radar.elevation_beamwidth))
    # two_way_pattern's P^2 from the sines above (computed once)
    peak = (one_way_pattern(u_az, u_el, radar.azimuth_beamwidth, radar.elevation_beamwidth,
                            cos_b).max(axis=0) ** 2 if pattern
            else np.full(slant.shape[1:], np.nan))
    far = fraunhofer_distance(radar)
    return Reception(min_range=slant.min(axis=0), max_range=slant.max(axis=0),
                     in_band=np.mean(slant <= radar.max_range, axis=0),
                     peak_pattern=peak, main_lobe=lobe.any(axis=0),
                     near_field=(slant < far).any(axis=0), far_field_distance=far)


def reception_warnings(radar: Radar, seen: Reception, names: list[str], *,
                       pattern: bool = True) -> list[str]:
    """One sentence per scatterer that cannot be received as modelled, naming it.

    Parameters
    ----------
    radar : Radar
    seen : Reception
        :func:`reception` of the scatterers.
    names : list of str
        How to name each scatterer to the user (e.g. ``"targets[2] at [1, 2, 3] m"``).
    pattern : bool
        Whether the producer applies the antenna pattern (without it the beam is not
        checked).
    """
    messages = []
    for i, name in enumerate(names):
        if pattern and not seen.main_lobe[i]:
            if seen.peak_pattern[i] <= 0.0:
                messages.append(f"{name} is behind the antenna or on a null of its pattern "
                                "in every sweep: no echo (check the look angles and the "
                                "target's position, e.g. below a down-looking antenna)")
            else:
                messages.append(
                    f"{name} is outside the antenna's main lobe in every sweep (peak two-way "
                    f"pattern {10 * np.log10(seen.peak_pattern[i]):.1f} dB): its echo comes "
                    "through the sidelobes only (check the look angles and the track)")
        if seen.in_band[i] < 1.0:
            share = ("every sweep" if seen.in_band[i] == 0.0
                     else f"{100 * (1 - seen.in_band[i]):.0f} % of the sweeps")
            messages.append(
                f"{name} is beyond max_range = {radar.max_range:g} m in {share} (slant range "
                f"{seen.min_range[i]:.3f} to {seen.max_range[i]:.3f} m): its beat frequency "
                f"lies above the receiver's band ({radar.max_beat_frequency:.4g} Hz), where a "
                "real receiver's IF filter rejects it and the ray tracer drops it; the analytic "
                "simulator keeps it (raise max_range or move the target)")
        if seen.near_field[i]:
            messages.append(
                f"{name} comes within {seen.min_range[i]:.3f} m of the antenna, inside its "
                f"near field (2 D^2 / lambda = {seen.far_field_distance:.3f} m): the far-field "
                "pattern and the point-scatterer model do not hold there")
    return messages


SCENE_SAMPLE = 4096
"""Surface scatterers of a scene :func:`scene_reception_warnings` evaluates (evenly strided
through the set: the sentence gives fractions of the scene, so a sample does)."""


def scene_reception_warnings(radar: Radar, positions: ArrayLike, point_targets: int,
                             antenna: ArrayLike, frames: ArrayLike, *,
                             reference: ArrayLike | None = None,
                             attitude: ArrayLike | None = None,
                             channels: Sequence[int] | None = None) -> list[str]:
    """:func:`reception_warnings` of a traced scene: each point target by name, and the part
    of the surface that the main lobe sees in some sweep but that lies beyond ``max_range``
    or in the near field (a fraction of an evenly strided sample of :data:`SCENE_SAMPLE`
    surface scatterers; parts never in the main lobe are the beam's business, not a warning).

    Parameters
    ----------
    positions : array_like, shape (n, 3)
        The scene's scatterers [m], surface scatterers first, then ``point_targets`` point
        targets (:class:`mitsar.model.scatterers.ScattererSet`).
    antenna, frames
        As :func:`reception` (at :data:`SWEEPS_SAMPLED` sweeps at most).
    reference, attitude, channels : optional
        The radar's reference point [m] and body-to-world rotations at the same sweeps, and
        the channels traced: the point targets are then checked per channel too
        (:func:`channel_warnings`).
    """
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    surface = len(positions) - point_targets
    messages = []
    if point_targets:
        targets = positions[surface:]
        names = [f"the scene's point target {i} at [{', '.join(f'{v:g}' for v in p)}] m"
                 for i, p in enumerate(targets)]
        seen = reception(radar, targets, antenna, frames)
        messages += reception_warnings(radar, seen, names)
        if attitude is not None and reference is not None:
            messages += channel_warnings(radar, targets, reference, attitude, names, seen,
                                         channels=channels)
    if surface:
        sample = positions[:surface][::max(1, surface // SCENE_SAMPLE)]
        seen = reception(radar, sample, antenna[::max(1, len(antenna) // 64)],
                         np.asarray(frames)[::max(1, len(antenna) // 64)], pattern=False)
        lit = seen.main_lobe
        if lit.any():
            beyond = lit & (seen.in_band < 1.0)
            if beyond.any():
                messages.append(
                    f"{100 * beyond.sum() / lit.sum():.0f} % of the surface in the antenna's "
                    f"main lobe lies beyond max_range = {radar.max_range:g} m in some sweep "
                    f"(up to {seen.max_range[beyond].max():.2f} m): its echoes are above the "
                    "receiver's band and dropped (raise max_range to keep them)")
            near = lit & seen.near_field
            if near.any():
                messages.append(
                    f"{100 * near.sum() / lit.sum():.0f} % of the surface in the antenna's "
                    f"main lobe comes within its near field (2 D^2 / lambda = "
                    f"{seen.far_field_distance:.3f} m): the far-field pattern does not hold "
                    "there")
    return messages


def channel_warnings(radar: Radar, positions: ArrayLike, antenna: ArrayLike,
                     attitude: ArrayLike, names: list[str], reference: Reception,
                     velocities: ArrayLike | None = None, times: ArrayLike | None = None,
                     channels: Sequence[int] | None = None) -> list[str]:
    """Per interferometric channel (docs/interferometry.md): the band and near-field checks of
    :func:`reception_warnings` at each channel's own geometry, said where a channel loses more
    than the radar's reference point does (which :func:`reception_warnings` already names).

    A bistatic channel (transmitter at ``t``, receiver at ``r``) beats at the half path
    ``R = (|q - t| + |q - r|) / 2`` (the range its deposit is binned at, paper eq. 1 with the
    two-way delay ``2R/c``): it is out of the receiver's band where ``R > max_range``. Each
    receive element (and each transmitter) sees its own near field, ``2 D^2 / lambda`` from its
    own phase centre (:func:`fraunhofer_distance`, Balanis eq. 2-31).

    Parameters
    ----------
    radar : Radar
        With ``receivers`` (and ``transmitters``); a single-channel radar gives no sentence.
    positions : array_like, shape (n, 3)
        Scatterers [m] (at time 0 when ``velocities`` are given).
    antenna : array_like, shape (sweeps, 3)
        The radar's reference point at mid-sweep [m].
    attitude : array_like, shape (sweeps, 3, 3)
        Body-to-world rotations at mid-sweep (the phase centres are body-frame offsets).
    names : list of str
        The scatterers' names, as :func:`reception_warnings`.
    reference : Reception
        :func:`reception` at the reference point (what is already said).
    velocities, times
        As :func:`reception`.
    channels : sequence of int, optional
        The channels produced (a traced run of one transmitter's channels); all by default.

    Returns
    -------
    list of str
        One sentence per scatterer and condition, listing the channels (``c = i N_rx + j``,
        :meth:`mitsar.model.radar.Radar.channel_pairs`) or elements concerned.
    """
    if radar.channel_count < 2 and not radar.receivers:
        return []
    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    antenna = np.asarray(antenna, dtype=float).reshape(-1, 3)
    attitude = np.asarray(attitude, dtype=float).reshape(-1, 3, 3)
    chosen = np.unique(np.linspace(0, len(antenna) - 1, min(len(antenna), SWEEPS_SAMPLED))
                       .round().astype(int))
    where = np.broadcast_to(positions[None], (len(chosen),) + positions.shape)
    if velocities is not None and times is not None:
        where = where + (np.asarray(velocities, float).reshape(-1, 3)[None]
                         * np.asarray(times, float)[chosen, None, None])
    transmitters, receivers = radar.channel_offsets()
    if channels is not None:
        kept = sorted(set(channels))
        transmitters, receivers = ([t for c, t in enumerate(transmitters) if c in kept],
                                   [r for c, r in enumerate(receivers) if c in kept])
    else:
        kept = list(range(len(receivers)))

    def centre(offset: tuple[float, float, float]) -> NDArray[np.float64]:
        """World position of a body-frame phase centre at the sampled sweeps, (sweeps, 3)."""
        return antenna[chosen] + attitude[chosen] @ np.asarray(offset, dtype=float)

    def distance(offset: tuple[float, float, float]) -> NDArray[np.float64]:
        return np.linalg.norm(where - centre(offset)[:, None, :], axis=-1)  # (sweeps, n)

    ranges = {offset: distance(offset) for offset in dict.fromkeys(transmitters + receivers)}
    messages = []
    in_band = np.stack([np.mean((ranges[t] + ranges[r]) / 2 <= radar.max_range, axis=0)
                        for t, r in zip(transmitters, receivers, strict=True)])  # (ch, n)
    far = fraunhofer_distance(radar)
    for i, name in enumerate(names):
        lost = np.flatnonzero(in_band[:, i] < reference.in_band[i])
        if lost.size:
            half = [(ranges[transmitters[c]][:, i] + ranges[receivers[c]][:, i]) / 2
                    for c in lost]
            messages.append(
                f"{name} is beyond max_range = {radar.max_range:g} m for channels "
                f"{[kept[c] for c in lost]} in more sweeps than at the radar's reference point "
                "(their half path (|q - t| + |q - r|) / 2 reaches "
                f"{max(h.max() for h in half):.3f} m): those channels' beat frequency lies "
                "above the receiver's band, where a real receiver rejects it (raise max_range "
                "or move the target)")
        near = [offset for offset in dict.fromkeys(list(receivers) + list(transmitters))
                if ranges[offset][:, i].min() < far]
        if near and not reference.near_field[i]:
            messages.append(
                f"{name} comes inside the near field (2 D^2 / lambda = {far:.3f} m) of the "
                f"phase centres at {[list(o) for o in near]} m (body frame): the far-field "
                "pattern and the point-scatterer model do not hold for their channels")
    return messages
