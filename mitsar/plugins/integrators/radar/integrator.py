"""Mitsuba integrator ``radar``: traces an FMCW SAR acquisition into range histograms.

XML (every parameter optional)::

    <integrator type="radar">
        <float   name="scatterer_density"   value="900"/>  <!-- surface scatterers per m² -->
        <float   name="scatterers_per_cell" value="9"/>    <!-- used when no density is given -->
        <integer name="max_depth"   value="1"/>    <!-- hits per ray (paper N_HITS); 1: no
                                                        multipath, k: up to k-1 reflections -->
        <integer name="chunk_lanes" value="16777216"/>  <!-- lanes per kernel launch, < 2^26 -->
        <integer name="seed"        value="0"/>    <!-- scatterer draw and speckle phases -->
        <integer name="bins_per_cell" value="16"/> <!-- histogram bins per range cell -->
        <float   name="beam_cull"   value="2"/>    <!-- cull |u| > beam_cull * beamwidth -->
        <integer name="rays"        value="4096"/> <!-- multipath rays per sweep (2D: the fan) -->
        <float   name="ray_cover"   value="1"/>    <!-- ray grid half-width in beamwidths -->
        <string  name="capture"     value="tent"/> <!-- ray-tube capture: tent or box -->
        <boolean name="ghosts"      value="false"/><!-- bistatic scattering at hits >= 2 -->
        <vector  name="plane_normal" x="1" y="0" z="0"/>  <!-- 2D mode (default: 3D) -->
        <float   name="slab_width"  value="0.1"/>  <!-- 2D mode: width of the scatterer slab -->
        <float   name="visibility_feature" value="0.03"/>  <!-- m: shadow rays shared across
                                                   sweeps; 0: a ray per sweep -->
        <boolean name="block_kernel" value="true"/>  <!-- static 3-D direct backscatter by the
                                                   block kernel; false: the lane kernels -->
    </integrator>

Unknown parameters raise :class:`~mitsar.errors.ParameterError` naming the parameter. Without a
density the scene is sampled at ``scatterers_per_cell / (c/2B * 0.10 m)`` per m² (9 per
resolution cell of paper Table 1: about 900 per m²).

The class orchestrates the stages: per chunk of sweeps, direct backscatter
(:mod:`.backscatter`) and multipath (:mod:`.bounce`) deposit into one histogram buffer
(:mod:`.deposit`), which is yielded as NumPy. Use it through :func:`mitsar.raw.traced.trace` /
:func:`mitsar.simulate_scene`; ``mi.render`` is refused.
"""

from __future__ import annotations

import math
from collections.abc import Iterator
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.errors import MitsarError, ParameterError
from mitsar.model import histogram as hg
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.radar import Radar
from mitsar.model.scatterers import ScattererSet
from mitsar.model.trace_options import TraceOptions
from mitsar.plugins import PerVariant, parse_vector3, plugin_where, read_properties
from mitsar.plugins.integrators.radar import blocks, bounce
from mitsar.plugins.integrators.radar.backscatter import backscatter_chunk
from mitsar.plugins.integrators.radar.config import (
    HISTOGRAM_CHUNK_ELEMENTS,
    MULTIPATH_CHUNK_LANES,
    PARAMETERS,
    PLUGIN_NAME,
    SWEEPS_PER_CHUNK,
    histogram_buffer_length,
)
from mitsar.plugins.integrators.radar.constants import (
    Constants,
    backscatter_constants,
    multipath_constants,
    multipath_sweep_arrays,
    scatterer_arrays,
)
from mitsar.plugins.integrators.radar.setup import TraceSetup, make_setup
from mitsar.plugins.kind import PluginKind

_NOT_AN_IMAGE = ("the 'radar' integrator makes range histograms, not images: use "
                 "mitsar.trace(...) or mitsar.simulate_scene(...)")


def _make_class() -> type:
    """Create the integrator class for the active variant (classes are tied to a variant)."""

    class RadarIntegrator(mi.SamplingIntegrator):
        """FMCW SAR histogram tracer (see the module docstring)."""

        PLUGIN_KIND = PluginKind.RADAR

        def __init__(self, props: Any) -> None:
            mi.SamplingIntegrator.__init__(self, props)
            self._where = plugin_where(PLUGIN_NAME, props)
            values = read_properties(props, self._where, PARAMETERS)
            if values.get("plane_normal") is not None:
                values["plane_normal"] = parse_vector3(values["plane_normal"], self._where,
                                                       "plane_normal")
            # the XML's layer of the trace request, and the request it makes on its own
            self.options = TraceOptions.from_xml(values, self._where)
            self.config = self.options.resolve(self._where)
            self.statistics: dict[str, int] = {}

        # ---- Mitsuba interface --------------------------------------------------------

        def sample(self, scene: Any, sampler: Any, ray: Any, medium: Any = None,
                   active: Any = True) -> Any:
            raise MitsarError(_NOT_AN_IMAGE)

        def render(self, scene: Any, sensor: Any = None, seed: int = 0, spp: int = 0,
                   develop: bool = True, evaluate: bool = True) -> Any:
            raise MitsarError(_NOT_AN_IMAGE)

        def aov_names(self) -> list[str]:
            return []

        def traverse(self, callback: Any) -> None:
            """Nothing to expose: the integrator has no differentiable parameters."""

        def to_string(self) -> str:
            fields = ", ".join(f"{k}={v}" for k, v in self.config.integrator_dict().items())
            return f"RadarIntegrator[{fields}]"

        # ---- radar interface -----------------------------------------------------------

        def trace_histograms(self, scene: Any, geometry: SweepGeometry, radar: Radar,
                             frames: NDArray,
                             scatterers: ScattererSet, grid: tuple[int, int], *,
                             sweeps: NDArray | None = None, config: TraceOptions
                             | None = None, rvp: bool = True, normalized: bool = False,
                             progress: bool = False, setup: TraceSetup | None = None,
                             backscatter: bool = True, visibility_block: int | None = None,
                             reuse: bool = False
                             ) -> Iterator[tuple[NDArray, NDArray[np.complex128]]]:
            """Trace sweeps into histograms, one chunk of sweeps at a time.

            Parameters
            ----------
            scene : mitsuba.Scene
            geometry : SweepGeometry
                :func:`mitsar.raw.product.sweep_geometry` of the whole acquisition.
            radar : Radar
            frames : ndarray, shape (sweeps, 3, 3)
                Antenna-to-world rotation at mid-sweep (:func:`antenna_frame`).
            scatterers : ScattererSet
                :func:`mitsar.scene.scatterers.collect_scatterers` of the scene.
            grid : (first_index, count)
                Histogram bin grid (:func:`mitsar.model.histogram.bin_grid`).
            sweeps : ndarray of int, optional
                Sweep indices to trace (default all), increasing.
            config : TraceOptions, optional
                Overrides this integrator's configuration.
            rvp, normalized : bool
                Keep the residual video phase; unit amplitude per unit sqrt(RCS) (as
                :func:`mitsar.simulate_point_targets`).
            progress : bool
                Progress bar over sweeps.
            setup : TraceSetup, optional
                Ray frames, 2D plane, receiver and ray grid (:func:`make_setup`; default:
                monostatic, from ``config``).
            backscatter : bool
                Trace mechanism 1 (direct backscatter, order 0). It is monostatic: a bistatic
                ``setup`` needs ``backscatter=False``.
            visibility_block : int, optional
                Largest number of consecutive sweeps that may share shadow rays (default: a
                chunk; within it blocks are cut where the sight lines move more than
                ``config.visibility_feature``, docs/integrator.md §"Visibility reuse"). A caller
                that changes the scene between sweeps passes sweeps of one scene state per call
                (blocks never span two calls) or caps it here; 1 casts a shadow ray per sweep.
            reuse : bool
                Yield every chunk's histograms in one array, overwritten by the next chunk,
                for a caller that is done with a chunk before asking for the next (the raw
                path): a multi-receiver or multipath chunk is tens of MB, which the C
                allocator maps afresh and the kernel zeroes page by page every time (14 ->
                6 ms per chunk of 2 receivers x 3 orders here).

            Yields
            ------
            sweep_indices : ndarray of int
            histogram : ndarray, shape (len(sweep_indices), max_depth, bins), complex128
                Orders 0 .. max_depth - 1 (number of specular reflections); with
                ``setup.channel_receivers``, shape (len(sweep_indices), receivers, max_depth,
                bins): one histogram per receiver of the transmitter, from one trace.

            Notes
            -----
            ``self.statistics`` counts, for the last call: ``pairs`` (scatterer x sweep pairs of
            the acquisition), ``candidate_pairs`` (left by the chunk-level beam cull),
            ``shadow_rays`` (in the beam and the bin grid: traced and deposited if visible),
            kernel ``launches``, ``visibility_rays`` (rays of the visibility probes of sweep
            blocks), ``visibility_split`` (candidate x block pairs re-tested per sweep), and for
            multipath ``rays`` (ray x sweep lanes), ``segments``
            (ray segments intersected) and ``captures`` (capture deposits).
            """
            config = self.config if config is None else config
            setup = make_setup(radar, frames, config) if setup is None else setup
            if setup.bistatic and backscatter:
                raise ParameterError(self._where, "backscatter", "False with a bistatic "
                                     "receiver (direct backscatter is traced monostatically "
                                     "only)", backscatter)
            orders = config.max_depth
            sweeps = (np.arange(len(geometry.slow_time)) if sweeps is None
                      else np.asarray(sweeps, dtype=np.int64))
            bins = grid[1]
            count = len(scatterers) if backscatter else 0
            multipath = config.max_depth > 1 and setup.rays is not None
            self.statistics = {"pairs": 0, "candidate_pairs": 0, "shadow_rays": 0,
                               "launches": 0, "rays": 0, "segments": 0, "captures": 0,
                               "visibility_rays": 0, "visibility_split": 0}
            per_sweep = ((orders, bins) if setup.channel_receivers is None
                         else (setup.receiver_count, orders, bins))
            if count == 0 and not multipath:
                for start in range(0, len(sweeps), 1024):
                    chosen = sweeps[start:start + 1024]
                    yield chosen, np.zeros((len(chosen), *per_sweep), np.complex128)
                return
            per_chunk = max(1, min(SWEEPS_PER_CHUNK, config.chunk_lanes,
                                   HISTOGRAM_CHUNK_ELEMENTS // (setup.receiver_count * orders
                                                                * bins)))
            arrays = scatterer_arrays(scatterers) if count else None
            target_speed = scatterers.max_speed() if count else 0.0
            receivers = setup.receiver_count
            if count and blocks.block_kernel_applies(config, target_speed == 0.0,
                                                     setup.planar):
                per_chunk = blocks.block_chunk_sweeps(per_chunk, receivers * bins,
                                                      geometry.position[sweeps])
            max_speed = float(np.linalg.norm(geometry.velocity, axis=1).max()) + target_speed
            constants = backscatter_constants(radar, config, grid,
                                              hg.range_step(radar, config.bins_per_cell),
                                              orders, rvp, normalized, max_speed, setup.planar,
                                              receivers)
            if multipath:
                table = bounce.shape_table(scene, setup.absorbers, config.seed)
                rays, ray_ids = bounce.ray_arrays(setup.rays)
                ray_constants = multipath_constants(radar, config, constants, setup.rays)
            bar = tqdm(total=len(sweeps), disable=not progress, desc="trace", unit="sweep")
            kept = None  # the array reused from chunk to chunk (reuse)
            try:
                for s0 in range(0, len(sweeps), per_chunk):
                    chosen = sweeps[s0:s0 + per_chunk]
                    size = len(chosen) * receivers * orders * bins
                    # A buffer of a power-of-two size: its length is a literal of the compiled
                    # kernels, so sizing it per acquisition would recompile them every time
                    # (at most 7 sizes; a fixed 2^22 cost ~5 ms of zeroing per chunk).
                    length = histogram_buffer_length(size)
                    re = dr.zeros(mi.Float64, length)
                    im = dr.zeros(mi.Float64, length)
                    if count:
                        backscatter_chunk(scene, arrays, geometry, frames, radar, setup, chosen,
                                          constants, target_speed, config, re, im,
                                          self.statistics, visibility_block)
                    if multipath:
                        self._multipath_chunk(scene, table, rays, ray_ids, geometry, frames,
                                              setup, chosen, ray_constants, config, re, im)
                    shape = (len(chosen), *per_sweep)
                    if reuse and kept is not None and kept.size >= math.prod(shape):
                        hist = kept.reshape(-1)[:math.prod(shape)].reshape(shape)
                    else:  # filled part by part below: no temporaries
                        hist = np.empty(shape, np.complex128)
                        kept = hist if reuse else None
                    hist.real[...] = np.asarray(re)[:size].reshape(shape)
                    hist.imag[...] = np.asarray(im)[:size].reshape(shape)
                    bar.update(len(chosen))
                    yield chosen, hist
            finally:
                bar.close()

        def trace_paths(self, scene: Any, geometry: SweepGeometry, radar: Radar, frames: NDArray,
                        sweep: int, rays: NDArray, config: TraceOptions,
                        setup: TraceSetup) -> dict[str, NDArray]:
            """Path log of some rays of one sweep (same kernel as :meth:`trace_histograms`).

            Returns
            -------
            dict
                Per segment (axis 1) and ray (axis 0): ``origin``, ``direction`` (n, k, 3),
                ``t_hit``, ``hit``, ``alive``, ``field`` (product of ``Γ R`` at the segment's
                start), ``pattern`` (transmit power pattern of the ray), ``image`` (n, k, 3),
                ``captured`` (capture weight of the segment, 0: not captured).
            """
            rays = np.asarray(rays, dtype=np.uint32)
            constants = backscatter_constants(radar, config, (0, 2),
                                              hg.range_step(radar, config.bins_per_cell),
                                              config.max_depth, True, False, 0.0, False)
            ray_constants = multipath_constants(radar, config, constants, setup.rays).replace(
                first=0, sweeps=1, last_lower=-1.0)  # deposit nothing
            ray_grid, _ = bounce.ray_arrays(setup.rays)
            sweep_arrays = multipath_sweep_arrays(geometry, frames, setup,
                                                  np.array([int(sweep)]))
            re = dr.zeros(mi.Float64, config.max_depth * 2)
            im = dr.zeros(mi.Float64, config.max_depth * 2)
            log: list = []
            bounce.launch(scene, bounce.shape_table(scene, setup.absorbers, config.seed), ray_grid,
                          sweep_arrays, ray_constants, mi.UInt32(rays), len(rays), re, im,
                          config.max_depth, config.capture, False, setup.planar, log=log)
            return {key: np.stack([entry[key] for entry in log], axis=1) for key in log[0]}

        def _multipath_chunk(self, scene: Any, table: bounce.ShapeTable,
                             rays: bounce.RayArrays, ray_ids: Any, geometry: SweepGeometry,
                             frames: NDArray, setup: TraceSetup, chosen: NDArray,
                             acquisition: Constants, config: TraceOptions,
                             re: Any, im: Any) -> None:
            """Mechanism 2 for one chunk of sweeps, in blocks of rays (``acquisition``: the
            :func:`~.constants.multipath_constants`)."""
            sweep_arrays = multipath_sweep_arrays(geometry, frames, setup, chosen)
            block = max(1, min(config.chunk_lanes, MULTIPATH_CHUNK_LANES) // len(chosen))
            for r0 in range(0, len(setup.rays), block):
                width = min(block, len(setup.rays) - r0)
                constants = acquisition.replace(first=r0, sweeps=len(chosen))
                bounce.launch(scene, table, rays, sweep_arrays, constants, ray_ids,
                              width * len(chosen), re, im, config.max_depth,
                              config.capture, config.ghosts, setup.planar,
                              stats=self.statistics)
                self.statistics["rays"] += width * len(chosen)
                self.statistics["launches"] += 1
                dr.eval(re, im)

    return RadarIntegrator


integrator_class = PerVariant(_make_class)
"""The integrator class for the active variant (created once per variant)."""


def register() -> None:
    """Register ``radar`` for the active Mitsuba variant."""
    cls = integrator_class()
    mi.register_integrator(PLUGIN_NAME, lambda props: cls(props))
