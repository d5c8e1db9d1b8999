"""One ray-traced acquisition: what :func:`mitsar.raw.traced.trace` and
:func:`~mitsar.raw.traced.simulate_scene` share (docs/design.md §5.4, docs/integrator.md).

:class:`TraceRun` holds the resolved inputs of a run (radar, true and navigation tracks, the
scene's scatterer set, its physical-optics facets and moving shapes, the selected sweeps, the
range grid) and traces it chunk by chunk of sweeps (:meth:`TraceRun.chunks`; one sweep at a
time when something moves). The helpers bound the range grid for multipath and facets and select
sweeps.
"""

from __future__ import annotations

import dataclasses
import math
import os
import warnings
from collections.abc import Iterator
from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.budget import require_memory
from mitsar.errors import MitsarWarning, ParameterError
from mitsar.model import histogram as hg
from mitsar.model.elements import element_beam, element_frame
from mitsar.model.geometry.attitude import (
    Look,
    antenna_frame,
    body_offset_to_world,
    body_to_world,
)
from mitsar.model.geometry.navigation import (
    NavigationErrors,
    describe_navigation,
    resolve_navigation,
)
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.model.reception import scene_reception_warnings
from mitsar.model.scatterers import ScattererSet, empty_scatterers, range_limits
from mitsar.model.signal import sweep_count
from mitsar.model.trace_options import TraceOptions
from mitsar.plugins.integrators.radar import make_setup
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.plugins.threads import deterministic_threads
from mitsar.plugins.variant import register_plugins
from mitsar.raw.physical_optics import FacetEchoes
from mitsar.raw.product import (
    GEOMETRY_BYTES_PER_SWEEP,
    require_raw_memory,
    sweep_geometry,
)
from mitsar.scene import collect_scatterers, load_scene
from mitsar.scene.facets import FacetSet, scene_facets
from mitsar.scene.motion import SceneMotion, parse_motion, surface_velocities

__all__ = ["TraceRun"]


# --------------------------------------------------------------------------------------------
# Set-up shared by trace and simulate_scene
# --------------------------------------------------------------------------------------------

_SCATTERER_SETS: dict[tuple[int, float, int], tuple[Any, ScattererSet]] = {}
"""The scatterer sets of recently traced scenes, ``(id(scene), density, seed) -> (scene, set)``
(the scene is held so that its id is not reused while the entry lives); at most
:data:`SCATTERER_SETS_KEPT`, the oldest dropped first."""

SCATTERER_SETS_KEPT = 2
"""Scatterer sets kept between traces (each holds its device arrays: ~100 MB for the paper's
room at the default density)."""


def _scene_scatterers(scene: Any, density: float, seed: int) -> ScattererSet:
    """The scene's scatterers for ``density`` and ``seed``, kept here (not on the plugin) so
    that repeated traces of one loaded scene, and the channels of one acquisition, reuse the
    draw and its device arrays."""
    key = (id(scene), float(density), int(seed))
    if key not in _SCATTERER_SETS:
        while len(_SCATTERER_SETS) >= SCATTERER_SETS_KEPT:
            _SCATTERER_SETS.pop(next(iter(_SCATTERER_SETS)))
        _SCATTERER_SETS[key] = (scene, collect_scatterers(scene, density, seed))
    return _SCATTERER_SETS[key][1]


class TraceRun:
    """Everything one traced acquisition needs, resolved and validated."""

    def __init__(self, where: str, radar: Radar, trajectory: Trajectory, look: Look, scene: Any,
                 options: TraceOptions,
                 navigation: Trajectory | NavigationErrors | None = None,
                 motion: dict | None = None, channels: tuple[int, ...] | None = None
                 ) -> None:
        """Resolve and validate one acquisition.

        Parameters
        ----------
        where : str
            The caller, for error messages.
        radar, trajectory, look, scene, navigation, motion
            As :func:`mitsar.raw.traced.trace`.
        options : TraceOptions
            The caller's layer of the trace request (its ``options=`` with its keywords over
            them); laid over the scene integrator's layer and the defaults
            (:mod:`mitsar.model.trace_options`) into :attr:`config`.
        channels : tuple of int, optional
            Channels of a multi-channel radar that share one transmitter, traced together
            (one trace, a histogram per receiver; :meth:`_channels`); default the request's
            ``channel``.
        """
        if not isinstance(radar, Radar):
            raise ParameterError(where, "radar", "a mitsar.Radar", type(radar))
        if not isinstance(trajectory, Trajectory):
            raise ParameterError(where, "trajectory", "a mitsar.Trajectory", type(trajectory))
        if not isinstance(look, Look):
            raise ParameterError(where, "look", "a mitsar.Look", type(look))
        options.resolve(where)  # the caller's errors before any scene is loaded
        radar.check_prf(trajectory.max_speed())
        total = sweep_count(radar, trajectory.duration)
        if total < 1:
            raise ParameterError(where, "trajectory.duration",
                                 f">= one sweep ({radar.sweep_duration:g} s)", trajectory.duration)
        require_memory(where, "trajectory.duration", 2.0 * total * GEOMETRY_BYTES_PER_SWEEP,
                       f"{total} sweeps (duration x prf): shorten the flight")
        self.sweeps = _select_sweeps(where, options.sweeps, total)
        # the sweeps asked for; self.sweeps: those traced (TDM-MIMO: the channel's slot only)
        self.acquisition_sweeps = self.sweeps
        require_raw_memory(where, radar, len(self.sweeps))
        register_plugins()
        import mitsuba as mi  # lazy: a variant is set by register_plugins just above

        self.scene_name = scene if isinstance(scene, str | os.PathLike) else "<mitsuba.Scene>"
        self.scene = load_scene(scene, **dict(options.scene_params or {}))
        self.integrator = _radar_integrator(self.scene, mi)
        # The one merge of the trace request: defaults < the scene's XML < options= < keywords
        self.config: TraceOptions = options.over(self.integrator.options).resolve(where)
        self.deterministic = self.config.deterministic
        self.radar, self.trajectory, self.look = radar, trajectory, look
        self.total = total
        self.geometry = sweep_geometry(radar, trajectory, look, total)
        self.navigation = navigation
        self.recorded = resolve_navigation(where, trajectory, navigation)
        self.recorded_geometry = (None if self.recorded is None
                                  else sweep_geometry(radar, self.recorded, look, total))
        # The antenna the tracer follows: the radar's, or a transmit element's own beam
        # (_transmit_beam: its frame, beamwidths and gain for the candidates, the beam cull,
        # the rays and the shadow rays; each receiver its own element beam relative to it).
        self.trace_radar, self.antenna_body = _transmit_beam(radar, look, self.config.channel
                                                             if channels is None else
                                                             channels[0])
        self.frames = (antenna_frame(look, *self.geometry.attitude.T)
                       if self.antenna_body is None
                       else body_to_world(*self.geometry.attitude.T) @ self.antenna_body)
        receiver_look = self.config.receiver_look
        rx_frames = (None if receiver_look is None
                     else antenna_frame(receiver_look, *self.geometry.attitude.T))
        self.setup = make_setup(self.trace_radar, self.frames, self.config,
                                self.config.receiver_offset, rx_frames)
        self.channels, self.trace_geometry = self._channels(where, radar, channels)
        self.channel = None if self.channels is None else self.channels[0]
        self.backscatter = self.config.backscatter
        if self.setup.bistatic and self.backscatter:
            raise ParameterError(where, "backscatter", "False with a bistatic receiver (direct "
                                 "backscatter is traced monostatically only)", self.backscatter)
        self.receiver_look = receiver_look
        if self.backscatter:
            self.scatterers = _scene_scatterers(self.scene, self.config.density(radar),
                                                self.config.seed)
        else:  # multipath only: no surface scatterers to sample
            self.scatterers = empty_scatterers(self.config.density(radar), self.config.seed)
        # Moving shapes (docs/integrator.md §Moving objects): their scatterers get their velocity.
        self.motion = SceneMotion(where, self.scene, parse_motion(where, motion),
                                  trajectory.duration)
        if self.motion.moving:
            self.scatterers = _moving_scatterers(self.scatterers, surface_velocities(
                self.scene, self.motion.motion))
        self.reception_warnings = self._reception(where) if self.backscatter else []
        facets = self._facets(where, self.config.physical_optics)
        low, high = range_limits(self.scatterers, self.geometry.position,
                                 trajectory.max_speed(), radar, trajectory.duration)
        reach = 0.0
        if self.channels is not None:  # half paths of phase centres off the track point
            reach = max(float(np.linalg.norm(offset))
                        for offset in (*radar.channel_offsets()[0], *radar.channel_offsets()[1]))
            low, high = low - reach, high + reach
        if self.config.max_depth > 1:
            # the phase centres' reach from the track point (any attitude): the channels', or
            # the bistatic receiver's offset
            offset = (self.setup.receiver_offset if self.channels is None
                      else np.full(3, reach))
            low, high = _multipath_limits(self.scene, self.geometry.position, low, high,
                                          radar, trajectory.max_speed(), self.config.max_depth,
                                          offset)
        if facets is not None:
            low, high = _facet_limits(facets.triangles, self.geometry.position, low, high,
                                      radar, trajectory.max_speed() + self.motion.max_speed(),
                                      reach)
        if self.motion.rotating:  # rotating shapes and paths: their bounding spheres' ranges
            near, far = self.motion.range_span(self.geometry.position,
                                               self.geometry.slow_time)
            margin = (radar.carrier_frequency / radar.chirp_rate) * 2.0 * (
                trajectory.max_speed() + self.motion.max_speed()) + 2 * radar.range_resolution
            low, high = min(low, near - margin), max(high, min(far, radar.max_range) + margin)
        self.grid = hg.bin_grid(radar, low, high, self.config.bins_per_cell)
        self.ranges = hg.bin_ranges(radar, *self.grid, self.config.bins_per_cell)
        # Physical optics (docs/physical_optics.md §5): chains of up to max_depth - 1 facets
        # (at least the single facets), at order = their length; the tracer's rays stop on the
        # same shapes, so no specular path through them is counted twice.
        # (from the transmitter's phase centre; each receive channel its own echoes)
        self.facet_echoes = None if facets is None else FacetEchoes(
            self.trace_radar, self.scene, facets, self.trace_geometry, self.frames, self.ranges,
            self.config.bins_per_cell, max(1, self.config.max_depth - 1),
            surface_velocities(self.scene, self.motion.motion)[list(facets.surface_index)],
            self.config.beam_cull,
            self.motion.shape_motions(facets.shape_ids) if self.motion.rotating else None,
            self.setup.channel_receivers, self.setup.channel_beams)
        self.orders = max(self.config.max_depth, 1 if facets is None else 2)

    def _channels(self, where: str, radar: Radar, channels: tuple[int, ...] | None
                  ) -> tuple[tuple[int, ...] | None, SweepGeometry]:
        """The channels traced together and the geometry the integrator traces them from.

        A radar with phase centres (:attr:`Radar.has_channels`) is traced one transmitter at a
        time: ``channels`` (default ``(config.channel,)``) must share it, offset and slot. It
        sits at the track point plus its body-frame offset rotated by the attitude of the
        sweep; each channel's receiver is one of :attr:`TraceSetup.channel_receivers`: None
        where it is the transmitter, else its position per sweep (its direct backscatter is
        then deposited at half the exact path). One trace serves them all: the transmitter's
        rays are shared, each receiver away from it adding its own shadow rays
        (``receiver_visibility``; docs/interferometry.md §8). Under TDM-MIMO (:attr:`Radar.is_tdm`)
        only the sweeps of the transmitter's slot are traced (:meth:`Radar.firing`), each from
        its own track point. A single-channel radar: the track itself.
        """
        if not radar.has_channels:
            return None, self.geometry
        channels = (self.config.channel,) if channels is None else tuple(channels)
        for channel in channels:
            if not 0 <= channel < radar.channel_count:
                raise ParameterError(where, "channel", f"a channel of the radar, in [0, "
                                     f"{radar.channel_count})", channel)
        if self.setup.bistatic:
            raise ParameterError(where, "receiver_offset", "None with a multi-channel radar "
                                 "(its receivers are the radar's: Radar(receivers=...), "
                                 "docs/interferometry.md)", self.config.receiver_offset)
        transmitters, receivers = radar.channel_offsets()
        slots = radar.firing(np.arange(radar.transmitter_count))
        elements = radar.channel_elements()[0]
        group = {(elements[c], tuple(slots[c])) for c in channels}
        if len(group) != 1:
            raise ParameterError(where, "channels", "channels of one transmitter (one "
                                 "element: offset and beam; one time slot) traced together",
                                 channels)
        channel = channels[0]
        if radar.is_tdm:
            self.sweeps = self.sweeps[radar.firing(self.sweeps)[channel]]
        attitude = self.geometry.attitude.T
        transmitter = self.geometry.position + body_offset_to_world(transmitters[channel],
                                                                    *attitude)
        beams = None
        if radar.has_element_beams:  # elements with their own pattern or boresight, in the
            # frame of the antenna traced (the radar's or the transmit element's)
            beams = tuple((transmit, receive, math.sqrt(transmit.gain * receive.gain)
                           / self.trace_radar.antenna_gain)
                          for c in channels
                          for transmit, receive in (
                              radar.channel_beams(self.look, self.antenna_body)[c],))
        self.setup = dataclasses.replace(self.setup, channel_receivers=tuple(
            None if receivers[c] == transmitters[c]
            else self.geometry.position + body_offset_to_world(receivers[c], *attitude)
            for c in channels), channel_beams=beams)
        return channels, dataclasses.replace(self.geometry, position=transmitter)

    def _reception(self, where: str) -> list[str]:
        """Warn (:class:`MitsarWarning`), before tracing, about the scene's point targets and
        the part of its surface in the beam that cannot be received as modelled: beyond
        ``max_range`` or in the near field (:func:`scene_reception_warnings`); the traced
        product records the sentences (``reception_warnings``)."""
        messages = scene_reception_warnings(
            self.trace_radar, self.scatterers.position, self.scatterers.point_target_count,
            self.trace_geometry.position[self.sweeps], self.frames[self.sweeps],
            reference=self.geometry.position[self.sweeps], channels=self.channels,
            attitude=body_to_world(*self.geometry.attitude[self.sweeps].T))  # per channel
        for message in messages:
            warnings.warn(f"{where}: {message}", MitsarWarning, stacklevel=4)
        return messages

    def _facets(self, where: str, physical_optics: Any) -> FacetSet | None:
        """The facets that use physical optics, or None; their shapes stop multipath rays."""
        if physical_optics is False or physical_optics is None:
            return None
        if self.setup.bistatic or self.setup.planar:
            raise ParameterError(where, "physical_optics", "false with a bistatic receiver_offset "
                                 "or in 2D mode (physical optics is traced in 3-D from one "
                                 "phase centre per transmitter: receive channels, "
                                 "Radar(receivers=...), each get their echoes)",
                                 physical_optics)
        facets = scene_facets(self.scene, physical_optics)
        if len(facets) == 0:          # True, and no mesh with a radar material
            return None
        self.setup = dataclasses.replace(self.setup, absorbers=facets.shapes)
        return facets

    def chunks(self, reuse: bool = False) -> Iterator[tuple[NDArray, NDArray]]:
        """(sweep indices, histograms (sweeps, orders, bins)) chunk by chunk: the tracer's,
        plus the physical-optics echoes of the same sweeps (one path for :func:`trace` and
        :func:`simulate_scene`). Deterministic runs trace on one Dr.Jit thread
        (:func:`mitsar.plugins.threads.deterministic_threads`). ``reuse``: the histograms of
        every chunk in one array, overwritten by the next (the integrator's
        ``trace_histograms(reuse=)``), for a caller done with a chunk before the next."""
        with deterministic_threads(self.deterministic):
            yield from self._chunks(self.config.rvp, self.config.normalized,
                                    self.config.progress, reuse)

    def _chunks(self, rvp: bool, normalized: bool, progress: bool, reuse: bool = False
                ) -> Iterator[tuple[NDArray, NDArray]]:
        if self.motion.moving:
            source = self._moving_chunks(rvp, normalized, progress)
        else:
            source = self.integrator.trace_histograms(
                self.scene, self.trace_geometry, self.trace_radar, self.frames, self.scatterers,
                self.grid,
                sweeps=self.sweeps, config=self.config, rvp=rvp, normalized=normalized,
                progress=progress, setup=self.setup, backscatter=self.backscatter, reuse=reuse)
        for chosen, hist in source:
            if self.facet_echoes is None:
                yield chosen, hist
                continue
            # the scene is in the state of these sweeps here (the moving generator is
            # suspended inside its sweep), so the PO shadow rays see the shapes where they are
            po = self.facet_echoes.histogram(chosen, self.orders, rvp, normalized)
            po[..., :hist.shape[-2], :] += hist  # (sweeps, [receivers,] orders, bins)
            yield chosen, po

    def _moving_chunks(self, rvp: bool, normalized: bool, progress: bool
                       ) -> Iterator[tuple[NDArray, NDArray]]:
        """One scene state per sweep: the moving shapes are put where they are at mid-sweep,
        the time at which the integrator places the scatterers and casts the shadow rays, so
        a scatterer on a moving face stays on its visible side (the shadow ray's end sits only
        ``SURFACE_OFFSET (1 + |p|)``, ~0.4 mm, above it, less than the 2 mm a 0.5 m/s shape
        moves in a 4 ms sweep: blocks of several sweeps would shadow moving faces by
        themselves). Static scenes keep the chunked path of :meth:`chunks`."""
        totals: dict[str, int] = {}
        try:
            for sweep in tqdm(self.sweeps, disable=not progress, desc="trace (moving shapes)",
                              unit="sweep"):
                middle = float(self.geometry.slow_time[sweep]) + self.radar.sweep_duration / 2
                self.motion.set_time(middle)
                yield from self.integrator.trace_histograms(
                    self.scene, self.trace_geometry, self.trace_radar, self.frames,
                    self.motion.scatterers_at(self.scatterers, middle),
                    self.grid, sweeps=np.array([sweep]), config=self.config, rvp=rvp,
                    normalized=normalized, progress=False, setup=self.setup,
                    backscatter=self.backscatter)
                for key, value in self.integrator.statistics.items():
                    totals[key] = totals.get(key, 0) + value
        finally:
            self.motion.reset()
            self.integrator.statistics = totals

    def attrs(self) -> dict[str, Any]:
        return {"seed": int(self.config.seed), "scatterer_count": self.scatterers.surface_count,
                "point_target_count": self.scatterers.point_target_count,
                "scatterer_density": float(self.scatterers.density),
                "bins_per_cell": int(self.config.bins_per_cell),
                "acquisition_sweeps": int(self.total),
                "integrator": self.config.integrator_dict(), "scene": str(self.scene_name),
                **{f"traced_{key}": int(value)
                   for key, value in self.integrator.statistics.items()},
                "backscatter": int(self.backscatter),
                **({} if self.facet_echoes is None else {
                    "physical_optics_shapes": list(self.facet_echoes.facets.shape_ids),
                    "physical_optics_subfacets": len(self.facet_echoes),
                    "physical_optics_chains": self.facet_echoes.chain_counts}),
                "motion": self.motion.describe(),
                **({"reception_warnings": "\n".join(self.reception_warnings)}
                   if self.reception_warnings else {}),
                "receiver_offset": [float(v) for v in self.setup.receiver_offset],
                "receiver_visibility": int(self.config.receiver_visibility),
                "rays_per_sweep": 0 if self.setup.rays is None else len(self.setup.rays),
                "trajectory_kind": (self.recorded or self.trajectory).kind,
                "trajectory_straight": int((self.recorded or self.trajectory).is_straight),
                "config": {"trajectory": self.trajectory.describe(),
                           "navigation": describe_navigation(self.navigation)}}

    def geometry_of(self, sweeps: NDArray) -> tuple[SweepGeometry, SweepGeometry | None]:
        """(recorded, true) geometry of some sweeps; true is None without navigation errors."""
        true = self.geometry.select(sweeps)
        if self.recorded_geometry is None:
            return true, None
        return self.recorded_geometry.select(sweeps), true


def _moving_scatterers(scatterers: ScattererSet, shape_velocities: NDArray) -> ScattererSet:
    """A copy of a scatterer set whose surface scatterers move with their shape (row
    ``table_row`` = ``shape_index`` of :func:`mitsar.scene.surfaces.scene_surfaces`)."""
    velocity = scatterers.velocity.copy()
    surface = scatterers.surface_count
    velocity[:surface] = shape_velocities[scatterers.table_row[:surface]]
    return dataclasses.replace(scatterers, velocity=velocity, device={})


def _facet_limits(triangles: NDArray, positions: NDArray, low: float, high: float,
                  radar: Radar, max_speed: float, reach: float = 0.0) -> tuple[float, float]:
    """Widen the apparent-range limits to the PO facets' ranges (single facets; chains lie
    within the multipath limits), with the Doppler margin of :func:`_multipath_limits`;
    ``reach``: how far the phase centres may be from the track points ``positions`` [m] (a
    channel's half path lies within it of the track point's range)."""
    lo, hi = triangles.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).max(axis=0)
    nearest = np.linalg.norm(positions - np.clip(positions, lo, hi), axis=1).min()
    corners = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij")).reshape(3, -1).T
    farthest = np.linalg.norm(positions[:, None, :] - corners[None], axis=-1).max()
    margin = (radar.carrier_frequency / radar.chirp_rate) * 2.0 * max_speed \
        + 2 * radar.range_resolution
    return (min(low, nearest - reach - margin),
            max(high, min(farthest + reach, radar.max_range) + margin))


def _multipath_limits(scene: Any, positions: NDArray, low: float, high: float, radar: Radar,
                      max_speed: float, max_depth: int, receiver_offset: NDArray
                      ) -> tuple[float, float]:
    """Widen the apparent-range limits for multipath paths.

    An image path of ``k <= max_depth - 1`` reflections has ``k + 1`` segments, each no longer
    than the diagonal ``D`` of the box holding the scene and the antennas, so its half length is
    at most ``max_depth D / 2``. The grid stops at the radar's ``max_range`` (beat frequencies
    beyond it are outside the receiver's band), so longer paths are dropped.
    """
    box = scene.bbox()
    lo = np.minimum(np.array([float(v) for v in box.min]), positions.min(axis=0))
    hi = np.maximum(np.array([float(v) for v in box.max]), positions.max(axis=0))
    lo, hi = lo - np.abs(receiver_offset), hi + np.abs(receiver_offset)
    diagonal = float(np.linalg.norm(hi - lo))
    margin = (radar.carrier_frequency / radar.chirp_rate) * 2.0 * max_speed \
        + 2 * radar.range_resolution
    far = min(0.5 * max_depth * diagonal, radar.max_range) + margin
    near = 0.5 * float(np.linalg.norm(receiver_offset)) - margin
    return min(low, near), max(high, far)


def _select_sweeps(where: str, sweeps: Any, total: int) -> NDArray[np.int64]:
    if sweeps is None:
        return np.arange(total)
    if isinstance(sweeps, slice):
        chosen = np.arange(total)[sweeps]
    else:
        chosen = np.asarray(sweeps)
        if chosen.ndim != 1 or not np.issubdtype(chosen.dtype, np.integer):
            raise ParameterError(where, "sweeps", "None, a slice or a 1-D array of sweep "
                                 "indices", sweeps)
        chosen = chosen.astype(np.int64)
    if len(chosen) == 0 or chosen.min() < 0 or chosen.max() >= total \
            or np.any(np.diff(chosen) <= 0):
        raise ParameterError(where, "sweeps", f"increasing sweep indices in [0, {total})",
                             sweeps)
    return chosen


_DEFAULT_INTEGRATORS: dict[int, tuple[Any, Any]] = {}
"""Default integrators of recently used scenes (id -> (scene, integrator)); the integrator
caches the scene's scatterers, so tracing a loaded scene again does not resample it."""


def _radar_integrator(scene: Any, mi: Any) -> Any:
    """The scene's ``radar`` integrator if the XML declares one, else a default one."""
    integrator = scene.integrator()
    if plugin_kind(integrator) is PluginKind.RADAR:
        return integrator
    if integrator is not None:  # a rendering integrator: not ours to use, and said so
        name = str(integrator).split("[", 1)[0].strip() or type(integrator).__name__
        warnings.warn(f"the scene's <integrator> ({name}) is not a radar integrator: it is "
                      "ignored and a default <integrator type=\"radar\"/> traces the scene "
                      "(declare one to set the trace's options in the XML)", MitsarWarning,
                      stacklevel=4)
    if id(scene) not in _DEFAULT_INTEGRATORS:
        while len(_DEFAULT_INTEGRATORS) >= 2:
            _DEFAULT_INTEGRATORS.pop(next(iter(_DEFAULT_INTEGRATORS)))
        _DEFAULT_INTEGRATORS[id(scene)] = (scene, mi.load_dict({"type": "radar"}))
    return _DEFAULT_INTEGRATORS[id(scene)][1]


def _transmit_beam(radar: Radar, look: Look, channel: int) -> tuple[Radar, NDArray | None]:
    """The antenna the tracer follows for the channels of ``channel``'s transmitter: the
    radar's, ``(radar, None)``; or, where that transmit element has a pattern or boresight of
    its own (ping-pong: the channel's element), a copy of the radar with the element's
    beamwidths (its gain, :attr:`Radar.antenna_gain`) and the element's antenna-to-body
    rotation (:func:`mitsar.model.elements.element_frame`). Then the candidates, the beam
    cull, the multipath rays and the two-way pattern follow the transmitter's own beam, and
    every receiver takes its own element beam (the radar's antenna for one without)
    expressed in that frame (:meth:`Radar.channel_beams`; docs/interferometry.md §8)."""
    if not radar.has_channels or not 0 <= channel < radar.channel_count:
        return radar, None   # (a channel out of range is refused by name in _channels)
    element = radar.channel_elements()[0][channel]
    if not element.has_own_beam:
        return radar, None
    beam = element_beam(element, (radar.azimuth_beamwidth, radar.elevation_beamwidth), look)
    return (dataclasses.replace(radar, azimuth_beamwidth_deg=math.degrees(beam.beamwidth_az),
                                elevation_beamwidth_deg=math.degrees(beam.beamwidth_el),
                                receivers=radar.receiver_elements,
                                transmitters=radar.transmitter_elements),
            element_frame(element, look))


