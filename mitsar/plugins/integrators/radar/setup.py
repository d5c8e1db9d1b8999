"""Per-acquisition geometry of the rays and the receiver (pure NumPy, no Mitsuba).

2D mode, the bistatic receiver and the multipath ray grid are resolved here once per acquisition,
before any kernel runs (docs/multipath.md).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.model.multipath import RaySet, ray_frame_2d, ray_set
from mitsar.model.radar import Radar
from mitsar.model.trace_options import TraceOptions


@dataclass
class TraceSetup:
    """Per-acquisition geometry of the rays and the receiver.

    Attributes
    ----------
    ray_frames : ndarray, shape (sweeps, 3, 3)
        Ray-to-world rotations: the antenna frames (3D) or
        :func:`mitsar.model.multipath.ray_frame_2d`.
    plane_normals : ndarray, shape (sweeps, 3)
        2D mode: the normal of the plane of the rays; zeros in 3D.
    receiver_offset : ndarray, shape (3,)
        Receiver position minus transmitter position, world frame [m] (zeros: monostatic).
    receiver_frames : ndarray, shape (sweeps, 3, 3)
        Antenna-to-world rotations of the receiving antenna.
    rays : RaySet or None
        The multipath ray grid (None: ``max_depth = 1``).
    planar : bool
        2D mode.
    absorbers : tuple of mitsuba.Shape
        Shapes on which multipath rays stop instead of reflecting: those whose specular
        returns physical optics gives (docs/physical_optics.md §5).
    channel_receivers : tuple of (ndarray, shape (sweeps, 3), or None), or None
        The receivers of one transmitter of a multi-channel radar (docs/interferometry.md):
        per receiver its phase centre per sweep [m], or None for one at the transmitter.
        One trace serves them all: the transmitter's scatterers, beam and shadow rays are
        shared (each receiver away from it casts its own shadow rays too with
        ``receiver_visibility``), and each receiver's direct backscatter is deposited at half
        its exact path
        ``(|t - q| + |q - r|) / 2`` into its own histogram rows. None: one monostatic
        receiver.
    channel_beams : tuple of (ElementBeam, ElementBeam, float), or None
        Per receiver of :attr:`channel_receivers`, the (transmit, receive)
        :class:`~mitsar.model.elements.ElementBeam` of its channel and its gain ratio
        ``sqrt(G_t G_r) / G`` (radar equation; G the gain of the antenna traced: the radar's,
        or the transmit element's own, ``trace_run._transmit_beam``) when some element has
        its own pattern or boresight (docs/interferometry.md §8), in the traced antenna's
        frame: its deposits then take :func:`~mitsar.model.elements.channel_amplitude_factor`
        in place of the shared two-way pattern. None: every receiver uses the radar's
        antenna.
    """

    ray_frames: NDArray
    plane_normals: NDArray
    receiver_offset: NDArray
    receiver_frames: NDArray
    rays: RaySet | None
    planar: bool
    absorbers: tuple[Any, ...] = ()
    channel_receivers: tuple[NDArray | None, ...] | None = None
    channel_beams: tuple[tuple[Any, Any, float], ...] | None = None

    @property
    def receiver_count(self) -> int:
        """Histograms per sweep: the receivers of :attr:`channel_receivers` (1 without)."""
        return 1 if self.channel_receivers is None else len(self.channel_receivers)

    @property
    def bistatic(self) -> bool:
        """True when the receiver is not at the transmitter."""
        return bool(np.any(self.receiver_offset != 0.0))


def make_setup(radar: Radar, frames: NDArray, config: TraceOptions,
               receiver_offset: Any = None, receiver_frames: NDArray | None = None
               ) -> TraceSetup:
    """The :class:`TraceSetup` of an acquisition (2D mode, bistatic receiver, ray grid).

    Parameters
    ----------
    radar : Radar
    frames : ndarray, shape (sweeps, 3, 3)
        Antenna-to-world rotations at mid-sweep.
    config : TraceOptions
    receiver_offset : array_like, optional
        Receiver minus transmitter position [m] (default: monostatic).
    receiver_frames : ndarray, optional
        Receiving antenna frames (default: ``frames``).
    """
    planar = config.plane_normal is not None
    if planar:
        ray_frames = ray_frame_2d(frames, config.plane_normal)
        normals = np.ascontiguousarray(ray_frames[:, :, 0])
        # Beamwidth along the fan (in-plane axis t) from the sinc² pattern's axes.
        t = ray_frames[0, :, 1]
        ua, ue = t @ frames[0, :, 0], t @ frames[0, :, 1]
        along = 1.0 / math.sqrt((ua / radar.azimuth_beamwidth) ** 2
                                + (ue / radar.elevation_beamwidth) ** 2)
        beams = (along, along)
    else:
        ray_frames = frames
        normals = np.zeros((len(frames), 3))
        beams = None
    rays = None
    if config.max_depth > 1:
        rays = ray_set(radar, int(config.rays), float(config.ray_cover), planar, beams)
    offset = np.zeros(3) if receiver_offset is None else np.asarray(receiver_offset, float)
    if offset.shape != (3,) or not np.all(np.isfinite(offset)):
        raise ParameterError("trace", "receiver_offset", "None or 3 finite numbers [m]",
                             receiver_offset)
    rx_frames = frames if receiver_frames is None else np.asarray(receiver_frames, float)
    return TraceSetup(ray_frames=np.asarray(ray_frames, float), plane_normals=normals,
                      receiver_offset=offset, receiver_frames=rx_frames, rays=rays,
                      planar=planar)
