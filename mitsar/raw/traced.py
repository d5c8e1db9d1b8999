"""Ray-traced acquisitions: scene -> range histograms -> raw (docs/design.md §2, §5.4, §5.5).

:func:`trace` runs the Mitsuba ``radar`` integrator (``mitsar/plugins/radar.py``) over every
sweep of an acquisition -- direct backscatter and, with ``max_depth > 1``, multipath by shooting
and bouncing rays (``docs/multipath.md``) -- and returns the *histogram product*;
:func:`histogram_to_raw_product` turns it into the raw product (one inverse FFT per sweep),
:func:`trace_paths` returns the path log of some rays of one sweep (ray-geometry figures), and
:func:`simulate_scene` traces and synthesises while streaming over sweep chunks, optionally
adding analytic point targets and a background from :func:`mitsar.simulate_point_targets`.

Histogram product
-----------------
``histogram`` (sweep, order, bin) complex
    Sum of the deposits ``a exp{j 2 pi (f_c tau_0 - K tau_0^2/2 + phi)}`` at each apparent range
    bin [sqrt(W)]. ``order`` is the number of specular reflections on the path (0: direct
    backscatter; 1: e.g. a mirror; 2: dihedral; 3: trihedral), ``0 .. max_depth - 1``.
``apparent_range`` (bin) [m]
    ``(k_0 + j) dr``, ``dr`` = range cell / ``bins_per_cell`` (:mod:`mitsar.model.histogram`).
``slow_time``, ``platform_position``, ``platform_velocity``, ``boresight``, ``attitude``
    As in the raw product; ``sweep`` holds the absolute sweep indices of the acquisition.
attributes
    ``radar_*``, ``look_*``, ``product = "histogram"``, ``rvp``, ``normalized``, ``seed``,
    ``scatterer_count``, ``point_target_count``, ``scatterer_density``, ``bins_per_cell``,
    ``histogram_first_index``, ``acquisition_sweeps``, ``integrator`` (JSON), ``scene``,
    ``traced_pairs``, ``traced_candidate_pairs``, ``traced_shadow_rays``, ``traced_launches``,
    ``traced_rays``, ``traced_segments``, ``traced_captures`` (work counters), ``backscatter``,
    ``receiver_offset``, ``rays_per_sweep``, provenance.
"""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.budget import require_memory
from mitsar.errors import MitsarWarning, ParameterError
from mitsar.model import histogram as hg
from mitsar.model.geometry.attitude import Look, antenna_frame
from mitsar.model.geometry.navigation import (
    NavigationErrors,
    describe_navigation,
    resolve_navigation,
)
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.noise import check_noise, thermal_noise
from mitsar.model.radar import Radar
from mitsar.model.signal import sweep_count
from mitsar.model.targets import Background, PointTarget
from mitsar.plugins.integrators.radar import make_setup
from mitsar.raw.analytic import simulate_point_targets
from mitsar.raw.physical_optics import FacetEchoes
from mitsar.raw.product import (
    GEOMETRY_BYTES_PER_SWEEP,
    look_of,
    make_raw_product,
    radar_of,
    require_raw_memory,
    sweep_geometry,
    track_geometry,
    track_variables,
)
from mitsar.scene import (
    ScattererSet,
    collect_scatterers,
    empty_scatterers,
    load_scene,
    range_limits,
    register_plugins,
)
from mitsar.scene.facets import FacetSet, scene_facets
from mitsar.scene.motion import SceneMotion, parse_motion, surface_velocities
from mitsar.version import __version__

__all__ = ["histogram_to_raw_product", "simulate_scene", "trace", "trace_paths"]


# --------------------------------------------------------------------------------------------
# Set-up shared by trace and simulate_scene
# --------------------------------------------------------------------------------------------

def _scene_scatterers(integrator: Any, scene: Any, density: float, seed: int) -> ScattererSet:
    """The scene's scatterers for ``density`` and ``seed``, kept on the scene's integrator so
    that repeated traces of one scene reuse the draw and its device arrays."""
    key = (id(scene), float(density), int(seed))
    if integrator.cache.get("key") != key:
        integrator.cache.clear()
        integrator.cache.update(key=key, scatterers=collect_scatterers(scene, density, seed))
    return integrator.cache["scatterers"]


class _Run:
    """Everything one traced acquisition needs, resolved and validated."""

    def __init__(self, where: str, radar: Radar, trajectory: Trajectory, look: Look, scene: Any,
                 density: float | None, seed: int | None, sweeps: Any, chunk_lanes: int | None,
                 bins_per_cell: int | None, beam_cull: float | None,
                 scene_params: dict | None, multipath: dict | None = None,
                 receiver_offset: Any = None, receiver_look: Look | None = None,
                 backscatter: bool = True,
                 navigation: Trajectory | NavigationErrors | None = None,
                 motion: dict | None = None,
                 physical_optics: bool | Sequence[str] | None = False) -> None:
        if not isinstance(radar, Radar):
            raise ParameterError(where, "radar", "a mitsar.Radar", type(radar))
        if not isinstance(trajectory, Trajectory):
            raise ParameterError(where, "trajectory", "a mitsar.Trajectory", type(trajectory))
        if not isinstance(look, Look):
            raise ParameterError(where, "look", "a mitsar.Look", type(look))
        radar.check_prf(trajectory.max_speed())
        total = sweep_count(radar, trajectory.duration)
        if total < 1:
            raise ParameterError(where, "trajectory.duration",
                                 f">= one sweep ({radar.sweep_duration:g} s)", trajectory.duration)
        require_memory(where, "trajectory.duration", 2.0 * total * GEOMETRY_BYTES_PER_SWEEP,
                       f"{total} sweeps (duration x prf): shorten the flight")
        self.sweeps = _select_sweeps(where, sweeps, total)
        require_raw_memory(where, radar, len(self.sweeps))
        register_plugins()
        import mitsuba as mi  # lazy: a variant is set by register_plugins just above

        self.scene_name = scene if isinstance(scene, str | os.PathLike) else "<mitsuba.Scene>"
        self.scene = load_scene(scene, **(scene_params or {}))
        self.integrator = _radar_integrator(self.scene, mi)
        self.config = self.integrator.config.replace(
            where, scatterer_density=density, seed=seed, chunk_lanes=chunk_lanes,
            bins_per_cell=bins_per_cell, beam_cull=beam_cull, **(multipath or {}))
        self.radar, self.trajectory, self.look = radar, trajectory, look
        self.total = total
        self.geometry = sweep_geometry(radar, trajectory, look, total)
        self.navigation = navigation
        self.recorded = resolve_navigation(where, trajectory, navigation)
        self.recorded_geometry = (None if self.recorded is None
                                  else sweep_geometry(radar, self.recorded, look, total))
        self.frames = antenna_frame(look, *self.geometry["attitude"].T)
        if receiver_look is not None and not isinstance(receiver_look, Look):
            raise ParameterError(where, "receiver_look", "None or a mitsar.Look", receiver_look)
        rx_frames = (None if receiver_look is None
                     else antenna_frame(receiver_look, *self.geometry["attitude"].T))
        self.setup = make_setup(radar, self.frames, self.config, receiver_offset, rx_frames)
        self.backscatter = bool(backscatter)
        if self.setup.bistatic and self.backscatter:
            raise ParameterError(where, "backscatter", "False with a bistatic receiver (direct "
                                 "backscatter is traced monostatically only)", backscatter)
        self.receiver_look = receiver_look
        if self.backscatter:
            self.scatterers = _scene_scatterers(self.integrator, self.scene,
                                                self.config.density(radar), self.config.seed)
        else:  # multipath only: no surface scatterers to sample
            self.scatterers = empty_scatterers(self.config.density(radar), self.config.seed)
        # Moving shapes (docs/integrator.md §Moving objects): their scatterers get their velocity.
        self.motion = SceneMotion(where, self.scene, parse_motion(where, motion),
                                  trajectory.duration)
        if self.motion.moving:
            self.scatterers = _moving_scatterers(self.scatterers, surface_velocities(
                self.scene, self.motion.motion))
        facets = self._facets(where, physical_optics)
        low, high = range_limits(self.scatterers, self.geometry["position"],
                                 trajectory.max_speed(), radar, trajectory.duration)
        if self.config.max_depth > 1:
            low, high = _multipath_limits(self.scene, self.geometry["position"], low, high,
                                          radar, trajectory.max_speed(), self.config.max_depth,
                                          self.setup.receiver_offset)
        if facets is not None:
            low, high = _facet_limits(facets.triangles, self.geometry["position"], low, high,
                                      radar, trajectory.max_speed() + self.motion.max_speed())
        if self.motion.rotating:  # rotating shapes and paths: their bounding spheres' ranges
            near, far = self.motion.range_span(self.geometry["position"],
                                               self.geometry["slow_time"])
            margin = (radar.carrier_frequency / radar.chirp_rate) * 2.0 * (
                trajectory.max_speed() + self.motion.max_speed()) + 2 * radar.range_resolution
            low, high = min(low, near - margin), max(high, min(far, radar.max_range) + margin)
        self.grid = hg.bin_grid(radar, low, high, self.config.bins_per_cell)
        self.ranges = hg.bin_ranges(radar, *self.grid, self.config.bins_per_cell)
        # Physical optics (docs/physical_optics.md §5): chains of up to max_depth - 1 facets
        # (at least the single facets), at order = their length; the tracer's rays stop on the
        # same shapes, so no specular path through them is counted twice.
        self.facet_echoes = None if facets is None else FacetEchoes(
            radar, self.scene, facets, self.geometry, self.frames, self.ranges,
            self.config.bins_per_cell, max(1, self.config.max_depth - 1),
            surface_velocities(self.scene, self.motion.motion)[list(facets.surface_index)],
            self.config.beam_cull,
            self.motion.shape_motions(facets.shape_ids) if self.motion.rotating else None)
        self.orders = max(self.config.max_depth, 1 if facets is None else 2)

    def _facets(self, where: str, physical_optics: Any) -> FacetSet | None:
        """The facets that use physical optics, or None; their shapes stop multipath rays."""
        if physical_optics is False or physical_optics is None:
            return None
        if self.setup.bistatic or self.setup.planar:
            raise ParameterError(where, "physical_optics", "false with a bistatic receiver or "
                                 "in 2D mode (physical optics is monostatic and 3-D)",
                                 physical_optics)
        facets = scene_facets(self.scene, physical_optics)
        if len(facets) == 0:          # True, and no mesh with a radar material
            return None
        self.setup = dataclasses.replace(self.setup, absorbers=facets.shapes)
        return facets

    def chunks(self, rvp: bool, normalized: bool, progress: bool
               ) -> Iterator[tuple[NDArray, NDArray]]:
        """(sweep indices, histograms (sweeps, orders, bins)) chunk by chunk: the tracer's,
        plus the physical-optics echoes of the same sweeps (one path for :func:`trace` and
        :func:`simulate_scene`)."""
        if self.motion.moving:
            source = self._moving_chunks(rvp, normalized, progress)
        else:
            source = self.integrator.trace_histograms(
                self.scene, self.geometry, self.radar, self.frames, self.scatterers, self.grid,
                sweeps=self.sweeps, config=self.config, rvp=rvp, normalized=normalized,
                progress=progress, setup=self.setup, backscatter=self.backscatter)
        for chosen, hist in source:
            if self.facet_echoes is None:
                yield chosen, hist
                continue
            # the scene is in the state of these sweeps here (the moving generator is
            # suspended inside its sweep), so the PO shadow rays see the shapes where they are
            po = self.facet_echoes.histogram(chosen, self.orders, rvp, normalized)
            po[:, :hist.shape[1]] += hist
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
                middle = float(self.geometry["slow_time"][sweep]) + self.radar.sweep_duration / 2
                self.motion.set_time(middle)
                yield from self.integrator.trace_histograms(
                    self.scene, self.geometry, self.radar, self.frames,
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
                "integrator": self.config.to_dict(), "scene": str(self.scene_name),
                **{f"traced_{key}": int(value)
                   for key, value in self.integrator.statistics.items()},
                "backscatter": int(self.backscatter),
                **({} if self.facet_echoes is None else {
                    "physical_optics_shapes": list(self.facet_echoes.facets.shape_ids),
                    "physical_optics_subfacets": len(self.facet_echoes),
                    "physical_optics_chains": self.facet_echoes.chain_counts}),
                "motion": self.motion.describe(),
                "receiver_offset": [float(v) for v in self.setup.receiver_offset],
                "rays_per_sweep": 0 if self.setup.rays is None else len(self.setup.rays),
                "trajectory_kind": (self.recorded or self.trajectory).kind,
                "trajectory_straight": int((self.recorded or self.trajectory).is_straight),
                "config": {"trajectory": self.trajectory.describe(),
                           "navigation": describe_navigation(self.navigation)}}

    def geometry_of(self, sweeps: NDArray) -> tuple[dict[str, NDArray], dict | None]:
        """(recorded, true) geometry of some sweeps; true is None without navigation errors."""
        true = {key: value[sweeps] for key, value in self.geometry.items()}
        if self.recorded_geometry is None:
            return true, None
        return {key: value[sweeps] for key, value in self.recorded_geometry.items()}, true


def _moving_scatterers(scatterers: ScattererSet, shape_velocities: NDArray) -> ScattererSet:
    """A copy of a scatterer set whose surface scatterers move with their shape (row
    ``table_row`` = ``shape_index`` of :func:`mitsar.scene.surfaces.scene_surfaces`)."""
    velocity = scatterers.velocity.copy()
    surface = scatterers.surface_count
    velocity[:surface] = shape_velocities[scatterers.table_row[:surface]]
    return dataclasses.replace(scatterers, velocity=velocity, device={})


def _facet_limits(triangles: NDArray, positions: NDArray, low: float, high: float,
                  radar: Radar, max_speed: float) -> tuple[float, float]:
    """Widen the apparent-range limits to the PO facets' ranges (single facets; chains lie
    within the multipath limits), with the Doppler margin of :func:`_multipath_limits`."""
    lo, hi = triangles.reshape(-1, 3).min(axis=0), triangles.reshape(-1, 3).max(axis=0)
    nearest = np.linalg.norm(positions - np.clip(positions, lo, hi), axis=1).min()
    corners = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij")).reshape(3, -1).T
    farthest = np.linalg.norm(positions[:, None, :] - corners[None], axis=-1).max()
    margin = (radar.carrier_frequency / radar.chirp_rate) * 2.0 * max_speed \
        + 2 * radar.range_resolution
    return min(low, nearest - margin), max(high, min(farthest, radar.max_range) + margin)


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
    if getattr(integrator, "MITSAR_KIND", None) == "radar":
        return integrator
    if id(scene) not in _DEFAULT_INTEGRATORS:
        while len(_DEFAULT_INTEGRATORS) >= 2:
            _DEFAULT_INTEGRATORS.pop(next(iter(_DEFAULT_INTEGRATORS)))
        _DEFAULT_INTEGRATORS[id(scene)] = (scene, mi.load_dict({"type": "radar"}))
    return _DEFAULT_INTEGRATORS[id(scene)][1]


# --------------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------------

def trace(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
          density: float | None = None, seed: int | None = None, sweeps: Any = None,
          chunk_lanes: int | None = None, bins_per_cell: int | None = None,
          beam_cull: float | None = None, rvp: bool = True, normalized: bool = False,
          scene_params: dict | None = None, progress: bool = False,
          max_depth: int | None = None, rays: int | None = None,
          ray_cover: float | None = None, capture: str | None = None,
          ghosts: bool | None = None, plane_normal: Any = None,
          slab_width: float | None = None, receiver_offset: Any = None,
          receiver_look: Look | None = None, backscatter: bool = True,
          navigation: Trajectory | NavigationErrors | None = None,
          visibility_feature: float | None = None, motion: dict | None = None,
          physical_optics: bool | Sequence[str] = False) -> xr.Dataset:
    """Ray-trace an acquisition of a Mitsuba scene into range histograms.

    Parameters
    ----------
    radar, trajectory, look : Radar, Trajectory, Look
    scene : str, os.PathLike or mitsuba.Scene
        An XML file, a canned scene name, or a loaded scene. Its ``<integrator type="radar">``
        gives the defaults of the tracing parameters (else the integrator's defaults).
    density : float, optional
        Surface scatterers per m² (default: 9 per resolution cell, about 900 per m²).
    seed : int, optional
        Seed of the scatterer positions and speckle phases (default: the integrator's, 0).
    sweeps : slice or array of int, optional
        Sweeps of the acquisition to trace (default all). The bin grid does not depend on it,
        so pieces traced separately concatenate to the whole.
    chunk_lanes : int, optional
        Scatterer x sweep pairs per kernel launch (< 2^26).
    bins_per_cell : int, optional
        Histogram bins per range cell (default 16).
    beam_cull : float, optional
        Cull scatterers beyond this many beamwidths in direction sine (default 2: the
        two-way power beyond is about -33 dB of the total per axis).
    rvp : bool
        Keep the residual video phase ``-K tau^2/2`` (default).
    normalized : bool
        Unit amplitude per unit sqrt(RCS), no range loss (as :func:`simulate_point_targets`).
    scene_params : dict, optional
        Values of the scene's ``<default>`` parameters (:func:`mitsar.scene.load_scene`), e.g.
        ``{"rcs": 2.0}`` for the canned ``point_target``.
    progress : bool
        Show a progress bar.
    max_depth : int, optional
        Hits per ray, the paper's N_HITS (default 1: direct backscatter only). ``k > 1`` turns
        on multipath with up to ``k - 1`` specular reflections (paper: 3 in 2D, 4 for the
        trihedral's three reflections); the ``order`` axis then has ``k`` entries.
    rays : int, optional
        Multipath rays per sweep (default 4096; 2D mode: the size of the fan).
    ray_cover : float, optional
        Half-width of the ray grid in beamwidths (default 1: the main lobe to the first nulls).
    capture : {"tent", "box"}, optional
        Ray-tube capture kernel (default ``"tent"``; :mod:`mitsar.model.multipath`).
    ghosts : bool, optional
        Bistatic double-lobe scattering back to the receiver at every hit after the first
        (default False, as the paper).
    plane_normal : array_like, optional
        2D mode: rays in the plane through the antenna containing the boresight with this
        normal (e.g. ``[1, 0, 0]`` for the paper's y-z analyses), surface scatterers in a slab
        of ``slab_width`` around it.
    slab_width : float, optional
        Width of the 2D mode's scatterer slab [m] (default 0.1, the azimuth cell).
    receiver_offset : array_like, optional
        Bistatic receiver at the transmitter's position plus this world-frame offset [m]
        (default: monostatic). Needs ``backscatter=False``.
    receiver_look : Look, optional
        Mounting of the bistatic receiving antenna (default: the transmitter's ``look``).
    backscatter : bool
        Trace the direct backscatter of surface scatterers and point targets (order 0).
    navigation : Trajectory or NavigationErrors, optional
        What the navigation system records (``trajectory`` is then the true track); see
        :func:`mitsar.simulate_point_targets`.
    visibility_feature : float, optional
        Smallest occluder (or gap) width [m] that the reuse of shadow rays across sweeps must
        resolve (default 0.03; 0: a shadow ray per sweep); docs/integrator.md §"Visibility
        reuse".
    motion : dict, optional
        ``{shape id: [vx, vy, vz]}`` [m/s] or ``{shape id: {"velocity": ..,
        "angular_velocity_deg": .., "centre": .., "path": {"times", "positions",
        "attitude_deg"}}}``: shapes that move during the acquisition, on top of the motion
        properties of the XML's shapes and the moving point targets
        (:mod:`mitsar.scene.motion`; docs/integrator.md §Moving objects). With any moving
        shape the scene is traced one sweep at a time, each with the shapes where they are.
    physical_optics : bool or sequence of str
        Physical optics of planar facets (docs/physical_optics.md §5): ``True`` for every mesh
        with a radar material, or the ids of the shapes. Their specular returns come from PO:
        single facets at order 1 and, with ``max_depth = k > 2``, the bounce chains of up to
        ``k − 1`` of their facets (dihedrals, trihedrals) at order = chain length; multipath
        rays stop on these shapes (no path is counted twice). Monostatic, 3-D only; moving
        shapes carry their facets.

    Returns
    -------
    xarray.Dataset
        The histogram product (module docstring).
    """
    run = _Run("trace", radar, trajectory, look, scene, density, seed, sweeps, chunk_lanes,
               bins_per_cell, beam_cull, scene_params,
               {**_multipath_options(max_depth, rays, ray_cover, capture, ghosts, plane_normal,
                                     slab_width), "visibility_feature": visibility_feature},
               receiver_offset, receiver_look, backscatter, navigation, motion, physical_optics)
    parts, indices = [], []
    for chosen, hist in run.chunks(rvp, normalized, progress):
        indices.append(chosen)
        parts.append(hist)
    return _histogram_product(np.concatenate(parts, axis=0), run, np.concatenate(indices), rvp,
                              normalized)


def _multipath_options(max_depth: Any, rays: Any, ray_cover: Any, capture: Any, ghosts: Any,
                       plane_normal: Any, slab_width: Any) -> dict[str, Any]:
    return {"max_depth": max_depth, "rays": rays, "ray_cover": ray_cover, "capture": capture,
            "ghosts": ghosts, "plane_normal": plane_normal, "slab_width": slab_width}


def trace_paths(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
                sweep: int = 0, rays: Any = 64, max_depth: int | None = None,
                ray_count: int | None = None, ray_cover: float | None = None,
                capture: str | None = None, plane_normal: Any = None,
                receiver_offset: Any = None, receiver_look: Look | None = None,
                scene_params: dict | None = None) -> xr.Dataset:
    """Path log of a subset of the multipath rays of one sweep (ray-geometry figures).

    The rays are traced by the same kernel as :func:`trace` (nothing is deposited).

    Parameters
    ----------
    radar, trajectory, look, scene
        As :func:`trace`.
    sweep : int
        The sweep.
    rays : int or array_like of int
        How many rays of the grid to log (evenly spaced over the grid), or their indices.
    max_depth, ray_cover, capture, plane_normal, receiver_offset, receiver_look, scene_params
        As :func:`trace` (``max_depth`` defaults to the scene integrator's, at least 2).
    ray_count : int, optional
        Size of the ray grid (``rays`` of :func:`trace`).

    Returns
    -------
    xarray.Dataset
        Dims ``path`` (logged ray), ``segment`` (0: from the transmitter, k: after k
        reflections), ``xyz``. ``start`` and ``end`` (path, segment, xyz) [m]: the segment's
        origin and its hit, or a point 1.5x the scene's size away when it escapes (``hit``
        False); ``alive`` (the segment exists), ``field`` (product of ``Γ R`` at its start),
        ``power`` (transmit pattern x field², relative to the boresight ray's power density
        ignoring spreading), ``captured`` (capture weight; > 0: this segment's tube reaches the
        receiver), ``image`` (the transmitter's image the segment comes from), ``ray`` (grid
        index), ``launch`` (path, 2: launch direction sines p, q); ``transmitter``,
        ``receiver`` (xyz). Attribute ``plane_normal`` in 2D mode.
    """
    options = _multipath_options(max_depth, ray_count, ray_cover, capture, None, plane_normal,
                                 None)
    run = _Run("trace_paths", radar, trajectory, look, scene, None, None, np.array([sweep]),
               None, None, None, scene_params, options, receiver_offset, receiver_look,
               backscatter=False)
    config = run.config
    if config.max_depth < 2:
        config = config.replace("trace_paths", max_depth=2)
        run.setup = _setup_for(run, config)
    grid = run.setup.rays
    chosen = np.asarray(rays)
    if chosen.ndim == 0:
        count = int(min(max(int(chosen), 1), len(grid)))
        chosen = np.unique(np.round(np.linspace(0, len(grid) - 1, count)).astype(np.int64))
    if chosen.ndim != 1 or np.any(chosen < 0) or np.any(chosen >= len(grid)):
        raise ParameterError("trace_paths", "rays", f"a count or ray indices in [0, "
                             f"{len(grid)})", rays)
    log = run.integrator.trace_paths(run.scene, run.geometry, radar, run.frames, int(sweep),
                                     chosen, config, run.setup)
    box = run.scene.bbox()
    size = float(np.linalg.norm(np.array([float(v) for v in box.max])
                                - np.array([float(v) for v in box.min]))) or 1.0
    reach = np.where(log["hit"], log["t_hit"], 1.5 * size)
    end = log["origin"] + log["direction"] * reach[..., None]
    dead = ~log["alive"]
    for key in ("origin", "image"):
        log[key] = np.where(dead[..., None], np.nan, log[key])
    end = np.where(dead[..., None], np.nan, end)
    log["hit"] = log["hit"] & log["alive"]
    tx = run.geometry["position"][sweep]
    data = xr.Dataset(
        {"start": (("path", "segment", "xyz"), log["origin"], {"units": "m"}),
         "end": (("path", "segment", "xyz"), end, {"units": "m"}),
         "hit": (("path", "segment"), log["hit"]),
         "alive": (("path", "segment"), log["alive"]),
         "field": (("path", "segment"), log["field"], {"long_name": "product of Gamma R"}),
         "power": (("path", "segment"), log["pattern"] * log["field"] ** 2,
                   {"long_name": "transmit pattern x field^2"}),
         "captured": (("path", "segment"), log["captured"]),
         "image": (("path", "segment", "xyz"), log["image"], {"units": "m"}),
         "launch": (("path", "pq"), np.stack([grid.p[chosen], grid.q[chosen]], axis=-1)),
         "transmitter": ("xyz", tx, {"units": "m"}),
         "receiver": ("xyz", tx + run.setup.receiver_offset, {"units": "m"}),
         "boresight": ("xyz", run.frames[sweep][:, 2])},
        coords={"path": np.arange(len(chosen)), "ray": ("path", chosen),
                "segment": np.arange(config.max_depth), "xyz": ["x", "y", "z"],
                "pq": ["p", "q"]})
    half_p = np.abs(grid.p).max() + 0.5 * grid.dp if not grid.planar else 0.0
    half_q = np.abs(grid.q).max() + 0.5 * grid.dq
    data.attrs.update(product="path_log", sweep=int(sweep), max_depth=int(config.max_depth),
                      rays_per_sweep=len(grid), scene=str(run.scene_name),
                      ray_cover=float(grid.cover), ray_dp=float(grid.dp), ray_dq=float(grid.dq),
                      beamwidth_p=float(half_p / grid.cover),
                      beamwidth_q=float(half_q / grid.cover),
                      look_off_nadir_deg=look.off_nadir_deg, look_squint_deg=look.squint_deg)
    if run.setup.planar:
        data.attrs["plane_normal"] = [float(v) for v in run.setup.plane_normals[sweep]]
        data.attrs["plane_axis"] = [float(v) for v in run.setup.ray_frames[sweep][:, 1]]
    data.attrs.update(run.radar.to_attrs())
    return data


def _setup_for(run: _Run, config: Any) -> Any:
    rx_frames = (None if run.receiver_look is None
                 else antenna_frame(run.receiver_look, *run.geometry["attitude"].T))
    return make_setup(run.radar, run.frames, config, run.setup.receiver_offset, rx_frames)


def _histogram_product(histogram: NDArray, run: _Run, sweeps: NDArray,
                       rvp: bool, normalized: bool) -> xr.Dataset:
    geometry = run.geometry_of(sweeps)[0]
    data = xr.Dataset(
        {
            "histogram": (("sweep", "order", "bin"), histogram,
                          {"units": "sqrt(W)", "long_name": "complex range histogram"}),
            **track_variables(*run.geometry_of(sweeps)),
        },
        coords={
            "sweep": sweeps,
            "order": np.arange(histogram.shape[1]),
            "bin": np.arange(histogram.shape[2]),
            "apparent_range": ("bin", run.ranges, {"units": "m", "long_name":
                                                   "apparent range c f / (2K)"}),
            "slow_time": ("sweep", geometry["slow_time"], {"units": "s",
                                                          "long_name": "sweep start time"}),
            "xyz": ["x", "y", "z"],
            "angle": ["heading", "pitch", "roll"],
        },
    )
    data.attrs.update(run.radar.to_attrs())
    data.attrs.update(product="histogram", look_off_nadir_deg=run.look.off_nadir_deg,
                      look_squint_deg=run.look.squint_deg, rvp=int(rvp),
                      normalized=int(normalized), histogram_first_index=int(run.grid[0]),
                      mitsar_version=__version__)
    for key, value in run.attrs().items():
        data.attrs[key] = json.dumps(value) if isinstance(value, dict | list) else value
    return data


def _order_mask(where: str, orders: Any, available: NDArray) -> NDArray[np.bool_]:
    if orders is None:
        return np.ones(len(available), dtype=bool)
    wanted = np.atleast_1d(np.asarray(orders))
    if wanted.ndim != 1 or not np.issubdtype(wanted.dtype, np.integer) or np.any(wanted < 0):
        raise ParameterError(where, "orders", "None or path orders (integers >= 0)", orders)
    return np.isin(available, wanted)


def histogram_to_raw_product(histogram: xr.Dataset, orders: Any = None) -> xr.Dataset:
    """The raw product of a histogram product (one inverse FFT per sweep).

    Parameters
    ----------
    histogram : xarray.Dataset
        Output of :func:`trace`.
    orders : int or sequence of int, optional
        Path orders to keep (e.g. ``0`` for direct backscatter only); default all, summed.

    Returns
    -------
    xarray.Dataset
        Raw product (:mod:`mitsar.raw.product`).
    """
    if histogram.attrs.get("product") != "histogram":
        raise ParameterError("histogram_to_raw_product", "histogram",
                             "a histogram product (attribute product='histogram')",
                             histogram.attrs.get("product"))
    radar = radar_of(histogram)
    mask = _order_mask("histogram_to_raw_product", orders, histogram["order"].values)
    summed = histogram["histogram"].values[:, mask, :].sum(axis=1)
    samples = hg.histogram_to_raw(summed, histogram["apparent_range"].values, radar)

    attrs = {key: histogram.attrs[key] for key in (
        "seed", "normalized", "scatterer_count", "point_target_count", "scatterer_density",
        "bins_per_cell", "integrator", "scene", "trajectory_kind", "trajectory_straight",
        "config") if key in histogram.attrs}
    attrs.update({key: value for key, value in histogram.attrs.items()
                  if key.startswith(("traced_", "physical_optics_", "motion"))})
    attrs.update(simulator="ray tracing (radar integrator)",
                 orders=[int(o) for o in histogram["order"].values[mask]])
    product = make_raw_product(samples, radar, look_of(histogram), track_geometry(histogram),
                               rvp=bool(histogram.attrs.get("rvp", 1)), attrs=attrs,
                               true_geometry=track_geometry(histogram, "true_"))
    return product.assign_coords(sweep=histogram["sweep"].values)


def simulate_scene(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
                   targets: Sequence[PointTarget] = (), background: Background | None = None,
                   density: float | None = None, seed: int | None = None,
                   orders: Any = None, sweeps: Any = None, chunk_lanes: int | None = None,
                   bins_per_cell: int | None = None, beam_cull: float | None = None,
                   rvp: bool = True, normalized: bool = False, scene_params: dict | None = None,
                   progress: bool = False, max_depth: int | None = None,
                   rays: int | None = None, ray_cover: float | None = None,
                   capture: str | None = None, ghosts: bool | None = None,
                   plane_normal: Any = None, slab_width: float | None = None,
                   navigation: Trajectory | NavigationErrors | None = None,
                   noise: bool = False,
                   physical_optics: bool | Sequence[str] = False,
                   motion: dict | None = None) -> xr.Dataset:
    """Raw data of a Mitsuba scene: trace, synthesise (streaming), add analytic targets.

    Histograms are turned into raw sweeps chunk by chunk, so memory stays bounded by the chunk
    size and the raw output. Analytic ``targets`` and ``background``
    (:func:`mitsar.simulate_point_targets`, same ``seed``, ``rvp`` and ``normalized``) are added
    on top; they are not shadowed by the scene.

    Parameters
    ----------
    radar, trajectory, look, scene
        As :func:`trace`.
    targets : sequence of PointTarget
        Extra analytic point targets.
    background : Background, optional
        Extra analytic fluctuating background (paper eq. 4).
    orders : int or sequence of int, optional
        Path orders to keep (``0``: direct backscatter only); default all.
    density, seed, sweeps, chunk_lanes, bins_per_cell, beam_cull, rvp, normalized,
    scene_params, progress, max_depth, rays, ray_cover, capture, ghosts, plane_normal,
    slab_width, navigation
        As :func:`trace` (monostatic).
    noise : bool
        Add receiver noise ``k T0 F f_s`` per complex sample (needs ``radar.noise_figure_db``),
        drawn by :func:`mitsar.model.noise.thermal_noise` from the run's seed and each sample's
        sweep and index (so a subset of ``sweeps`` gets the same noise as in the full run).
    physical_optics : bool or sequence of str
        Physical-optics specular returns of planar facets and their bounce chains, as
        :func:`trace` (docs/physical_optics.md §5).
    motion : dict, optional
        Moving shapes, as :func:`trace`.

    Returns
    -------
    xarray.Dataset
        Raw product (:mod:`mitsar.raw.product`).
    """
    run = _Run("simulate_scene", radar, trajectory, look, scene, density, seed, sweeps,
               chunk_lanes, bins_per_cell, beam_cull, scene_params,
               _multipath_options(max_depth, rays, ray_cover, capture, ghosts, plane_normal,
                                  slab_width), navigation=navigation, motion=motion,
               physical_optics=physical_optics)
    _order_mask("simulate_scene", orders, np.arange(1))  # validate early
    check_noise("simulate_scene", radar, noise, normalized)
    samples = np.zeros((len(run.sweeps), radar.samples_per_sweep), dtype=np.complex128)
    row = 0
    kept = np.arange(0)
    for chosen, hist in run.chunks(rvp, normalized, progress):
        mask = _order_mask("simulate_scene", orders, np.arange(hist.shape[1]))
        kept = np.arange(hist.shape[1])[mask]
        summed = hist[:, mask, :].sum(axis=1)
        samples[row:row + len(chosen)] = hg.histogram_to_raw(summed, run.ranges, radar)
        row += len(chosen)
    attrs = run.attrs()
    attrs.update(simulator="ray tracing (radar integrator)", normalized=int(normalized),
                 orders=[int(o) for o in kept])
    if targets or background is not None:
        analytic = simulate_point_targets(radar, trajectory, look, targets, background,
                                          seed=attrs["seed"], rvp=rvp, normalized=normalized,
                                          navigation=run.recorded)
        samples += analytic["raw"].values[run.sweeps]
        attrs["simulator"] += " + analytic point targets"
        attrs["analytic_config"] = analytic.attrs.get("config", "{}")
    if not np.any(samples):
        warnings.warn(f"simulate_scene: raw data of exact zeros: nothing of the scene is in the "
                      f"beam ({attrs['scatterer_count']} surface scatterers, "
                      f"{attrs['point_target_count']} point targets, orders {attrs['orders']}): "
                      "check the look angles, the trajectory, the materials and the orders",
                      MitsarWarning, stacklevel=2)
    attrs["noise"] = int(noise)
    if noise:
        samples += thermal_noise(radar, attrs["seed"], run.sweeps)
        attrs.update(noise_power=radar.noise_power, noise_seed=int(attrs["seed"]))
    recorded, true = run.geometry_of(run.sweeps)
    product = make_raw_product(samples, radar, look, recorded, rvp=rvp, attrs=attrs,
                               true_geometry=true)
    return product.assign_coords(sweep=run.sweeps)
