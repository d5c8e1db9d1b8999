"""Mitsuba integrator ``radar``: traces an FMCW SAR acquisition into range histograms.

XML (every parameter optional)::

    <integrator type="radar">
        <float   name="scatterer_density"   value="900"/>  <!-- surface scatterers per m² -->
        <float   name="scatterers_per_cell" value="9"/>    <!-- used when no density is given -->
        <integer name="max_depth"   value="1"/>    <!-- surface interactions per path -->
        <integer name="chunk_lanes" value="16777216"/>  <!-- lanes per kernel launch, < 2^26 -->
        <integer name="seed"        value="0"/>    <!-- scatterer draw and speckle phases -->
        <integer name="bins_per_cell" value="16"/> <!-- histogram bins per range cell -->
        <float   name="beam_cull"   value="2"/>    <!-- cull |u| > beam_cull * beamwidth -->
    </integrator>

Unknown parameters raise :class:`~mitsar.errors.ParameterError` naming the parameter. Without a
density the scene is sampled at ``scatterers_per_cell / (c/2B * 0.10 m)`` per m² (9 per
resolution cell of paper Table 1: about 900 per m²).

What it computes (DESIGN §5.4 mechanism 1, §5.5; ``docs/integrator.md``)
-----------------------------------------------------------------------
A fixed set of surface scatterers (:func:`mitsar.scene.sample_surface_scatterers`: area
sampling, one area share and one frozen speckle phase each) and the scene's point targets
(:func:`mitsar.scene.scene_point_targets`) are traced against every sweep of an acquisition in
one vectorised wavefront: one lane per (scatterer, sweep) pair, in chunks of up to 64 sweeps and
``chunk_lanes`` lanes. Per chunk, a kernel over all scatterers keeps those that can be in the beam
of some sweep of the chunk (``_candidate_kernel``); over candidate x sweep lanes a second kernel
applies the exact beam and bin-grid test and compacts the survivors (``_cull_kernel``,
``dr.compress``); the deposit kernels then do, per surviving lane:

1. platform state at mid-sweep ``eta_k + T/2`` (position, velocity, antenna frame) and scatterer
   position (point targets move with their velocity);
2. beam culling: ``cos(boresight) > 0`` and ``|u_az| < beam_cull beta_az``,
   ``|u_el| < beam_cull beta_el`` (direction sines, :mod:`mitsar.geometry.antenna`);
3. visibility: ``scene.ray_test`` on the segment from the antenna to the scatterer, ending a
   small offset above the surface on the antenna's side (so the scatterer's own shape does not
   occlude it), or, for a point target, before its shape's bounding sphere;
4. amplitude ``sqrt(P_T G^2 lambda^2 / (4 pi)^3) P(u) sqrt(sigma) / R^2`` (radar equation of
   :mod:`mitsar.signal`, two-way pattern ``P^2`` with the sinc^2 aperture pattern ``P``),
   ``sigma = sigma0(theta_i) * area share`` from the material's monostatic table
   (:func:`mitsar.doublelobe.monostatic_sigma0_table`) or the point target's RCS;
5. phase ``2 pi (f_c tau_0 - K tau_0^2 / 2 + speckle)`` in float64, apparent range
   ``R + (f_c / K) dR/dt`` (:func:`mitsar.histogram.apparent_range`);
6. ``dr.scatter_reduce`` of the complex value, split linearly between the two neighbouring bins,
   into a float64 histogram (sweep x order x bin).

Per-acquisition values (radar constants, bin grid, chunk offsets) are packed into padded device
arrays and every other input is a device array, so each kernel is compiled once and reused from
Dr.Jit's cache for every chunk, acquisition and trajectory (``docs/integrator.md``). Only
order 0 (direct backscatter) exists yet; the ``order`` axis is kept for the multipath mechanism
(``max_depth > 1``).

Use it through :func:`mitsar.trace` / :func:`mitsar.simulate_scene`; ``mi.render`` is refused.
"""

from __future__ import annotations

import dataclasses
import math
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar import histogram as hg
from mitsar.doublelobe import monostatic_sigma0_table
from mitsar.errors import MitsarError, ParameterError
from mitsar.plugins import plugin_where, read_properties
from mitsar.radar import SPEED_OF_LIGHT, Radar
from mitsar.signal import radar_equation_amplitude

PLUGIN_NAME = "radar"
"""XML type name."""

PARAMETERS: tuple[str, ...] = ("scatterer_density", "scatterers_per_cell", "max_depth",
                               "chunk_lanes", "seed", "bins_per_cell", "beam_cull")
"""Accepted XML parameters."""

MAX_LANES = 2**26
"""Upper bound on lanes per kernel launch (Dr.Jit wavefront size; DESIGN §7)."""

DEFAULT_CHUNK_LANES = 2**24
"""Default lanes (scatterer x sweep pairs) per kernel launch."""

SWEEPS_PER_CHUNK = 64
"""Sweeps traced together (one histogram buffer, one chunk-level beam cull)."""

HISTOGRAM_CHUNK_ELEMENTS = 2**22
"""Bound on sweeps x orders x bins of the histogram buffer of one launch (2 x 32 MiB)."""

AZIMUTH_CELL = 0.10
"""Azimuth size of the resolution cell for ``scatterers_per_cell`` [m] (paper Table 1)."""

SIGMA0_TABLE_SIZE = 1025
"""Nodes of the monostatic sigma0 tables (uniform in theta_i over [0, 90] deg)."""

SURFACE_OFFSET = 2e-5
"""Offset of a shadow ray's end above the surface, relative to ``1 + max|p|`` [-]."""

POINT_TARGET_MARGIN = 1.01
"""Shadow rays to a point target stop this factor times its bounding radius before the centre."""


# --------------------------------------------------------------------------------------------
# Configuration (pure Python)
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RadarIntegratorConfig:
    """Parameters of the ``radar`` integrator (see the module docstring)."""

    scatterer_density: float | None = None
    scatterers_per_cell: float = 9.0
    max_depth: int = 1
    chunk_lanes: int = DEFAULT_CHUNK_LANES
    seed: int = 0
    bins_per_cell: int = hg.DEFAULT_BINS_PER_CELL
    beam_cull: float = 2.0

    def __post_init__(self) -> None:
        self.validate("radar")

    def validate(self, where: str) -> None:
        """Raise ParameterError naming the first invalid parameter."""
        def integer(name: str, low: int, high: int | None = None) -> None:
            value = getattr(self, name)
            ok = (not isinstance(value, bool) and isinstance(value, int | np.integer)
                  and value >= low and (high is None or value <= high))
            if not ok:
                bound = f"an integer in [{low}, {high}]" if high else f"an integer >= {low}"
                raise ParameterError(where, name, bound, value)

        def positive(name: str, allow_none: bool = False) -> None:
            value = getattr(self, name)
            if allow_none and value is None:
                return
            ok = (not isinstance(value, bool) and isinstance(value, int | float | np.floating)
                  and math.isfinite(value) and value > 0)
            if not ok:
                raise ParameterError(where, name, ("None or " if allow_none else "")
                                     + "a finite number > 0", value)

        positive("scatterer_density", allow_none=True)
        positive("scatterers_per_cell")
        integer("max_depth", 1)
        integer("chunk_lanes", 1, MAX_LANES - 1)
        integer("seed", 0)
        integer("bins_per_cell", 1, 256)
        value = self.beam_cull
        if isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
            raise ParameterError(where, "beam_cull", "a number of beamwidths > 0 (inf: no "
                                 "culling)", value)

    @classmethod
    def from_values(cls, values: dict[str, Any], where: str = "radar") -> RadarIntegratorConfig:
        """Build from XML property values (already checked against :data:`PARAMETERS`)."""
        values = dict(values)
        for name in ("scatterer_density", "scatterers_per_cell", "beam_cull"):
            if name in values and isinstance(values[name], int) \
                    and not isinstance(values[name], bool):
                values[name] = float(values[name])
        obj = cls.__new__(cls)
        for f in dataclasses.fields(cls):
            object.__setattr__(obj, f.name, values.get(f.name, f.default))
        obj.validate(where)
        return obj

    def replace(self, where: str = "radar", **changes: Any) -> RadarIntegratorConfig:
        """A validated copy with some parameters changed (``None`` values are ignored)."""
        changes = {k: v for k, v in changes.items() if v is not None}
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            name = sorted(unknown)[0]
            raise ParameterError(where, name, f"one of {list(PARAMETERS)}", changes[name])
        obj = self.__class__.__new__(self.__class__)
        for f in dataclasses.fields(self):
            object.__setattr__(obj, f.name, changes.get(f.name, getattr(self, f.name)))
        obj.validate(where)
        return obj

    def density(self, radar: Radar) -> float:
        """Surface scatterers per m²: given, or ``scatterers_per_cell`` per resolution cell."""
        if self.scatterer_density is not None:
            return float(self.scatterer_density)
        return self.scatterers_per_cell / (radar.range_resolution * AZIMUTH_CELL)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (provenance)."""
        return dataclasses.asdict(self)


# --------------------------------------------------------------------------------------------
# Scatterers of a scene (NumPy side)
# --------------------------------------------------------------------------------------------

@dataclass
class ScattererSet:
    """All scatterers of a scene as flat arrays: surface scatterers first, then point targets.

    ``weight`` is the area share [m²] of a surface scatterer (RCS = sigma0 x weight) or the RCS
    [m²] of a point target (its table row is 1); ``phase`` is in cycles; ``stop`` is the distance
    before the centre where a point target's shadow ray stops (0 for surfaces).
    """

    position: NDArray[np.float64]
    normal: NDArray[np.float64]
    velocity: NDArray[np.float64]
    weight: NDArray[np.float64]
    phase: NDArray[np.float64]
    table_row: NDArray[np.int64]
    stop: NDArray[np.float64]
    tables: NDArray[np.float64]
    surface_count: int
    point_target_count: int
    density: float
    seed: int
    device: dict = dataclasses.field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return len(self.weight)

    def extent(self, duration: float) -> tuple[NDArray, NDArray]:
        """Bounding box of every scatterer over ``[0, duration]`` seconds."""
        if len(self) == 0:
            return np.zeros(3), np.zeros(3)
        if "static_box" not in self.device:
            self.device["static_box"] = (self.position.min(axis=0), self.position.max(axis=0))
        lo, hi = self.device["static_box"]
        moving = np.any(self.velocity != 0.0, axis=1)
        if np.any(moving):
            ends = self.position[moving] + self.velocity[moving] * duration
            lo, hi = np.minimum(lo, ends.min(axis=0)), np.maximum(hi, ends.max(axis=0))
        return lo, hi


def collect_scatterers(scene: Any, density: float, seed: int) -> ScattererSet:
    """Surface scatterers and point targets of a loaded scene (:mod:`mitsar.scene`)."""
    from mitsar.scene import sample_surface_scatterers, scene_point_targets, scene_surfaces

    surf = sample_surface_scatterers(scene, density, seed)
    targets = scene_point_targets(scene)
    radii = [_bounding_radius(s.shape) for s in scene_surfaces(scene)
             if getattr(s.shape.bsdf(), "MITSAR_KIND", None) == "pointtarget"]
    materials = list(surf.materials)
    tables = np.vstack([monostatic_sigma0_table(materials, SIGMA0_TABLE_SIZE),
                        np.ones((1, SIGMA0_TABLE_SIZE))])
    point_row = len(materials)
    m, p = len(surf), len(targets)
    return ScattererSet(
        position=np.vstack([surf.positions, np.array([t.position for t in targets]
                                                     ).reshape(p, 3)]),
        normal=np.vstack([surf.normals, np.zeros((p, 3))]),
        velocity=np.vstack([np.zeros((m, 3)), np.array([t.velocity for t in targets]
                                                       ).reshape(p, 3)]),
        weight=np.concatenate([surf.area, [t.rcs for t in targets]]),
        phase=np.concatenate([surf.phase / (2 * np.pi), np.zeros(p)]),
        table_row=np.concatenate([surf.shape_index.astype(np.int64),
                                  np.full(p, point_row, dtype=np.int64)]),
        stop=np.concatenate([np.zeros(m), POINT_TARGET_MARGIN * np.asarray(radii, float)]),
        tables=tables, surface_count=m, point_target_count=p, density=float(density),
        seed=int(seed))


def _bounding_radius(shape: Any) -> float:
    box = shape.bbox()
    lo = np.array([float(v) for v in box.min])
    hi = np.array([float(v) for v in box.max])
    return float(0.5 * np.linalg.norm(hi - lo))


def range_limits(scatterers: ScattererSet, positions: NDArray, max_speed: float,
                 radar: Radar, duration: float) -> tuple[float, float]:
    """Apparent ranges that can occur: antenna-to-scatterer-box distances plus Doppler margin."""
    lo, hi = scatterers.extent(duration)
    nearest = np.clip(positions, lo, hi) - positions
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    farthest = np.linalg.norm(positions[:, None, :] - corners[None], axis=-1).max()
    target_speed = float(np.linalg.norm(scatterers.velocity, axis=1).max()) if len(
        scatterers) else 0.0
    margin = (radar.carrier_frequency / radar.chirp_rate) * (max_speed + target_speed) \
        + 2 * radar.range_resolution
    return (max(0.0, float(np.linalg.norm(nearest, axis=1).min())) - margin,
            float(farthest) + margin)


# --------------------------------------------------------------------------------------------
# The kernel
# --------------------------------------------------------------------------------------------

_FLOAT_CONSTANTS = ("fc", "chirp_rate", "fc_over_k", "first_range", "inv_step", "last_lower",
                    "inv_beta_az", "inv_beta_el", "cull_az", "cull_el", "radar_const", "rvp",
                    "normalized", "doppler_bins",
                    # chunk-level cull: mid-sweep antenna position and frame, margins
                    "mid_px", "mid_py", "mid_pz", "mid_f00", "mid_f10", "mid_f20", "mid_f01",
                    "mid_f11", "mid_f21", "mid_f02", "mid_f12", "mid_f22", "mid_disp",
                    "mid_turn", "mid_time")
_UINT_CONSTANTS = ("sweep_stride", "first", "sweeps")
_PACK = 32  # pad the constant arrays: small allocations may be unaligned, and the alignment
#             of a load is part of the kernel hash (measured: size-1 opaque scalars recompile)


class _Constants:
    """Per-launch scalars packed in two device arrays, read with literal-index gathers."""

    def __init__(self, values: dict) -> None:
        floats = np.zeros(_PACK)
        assert len(_FLOAT_CONSTANTS) <= _PACK
        floats[:len(_FLOAT_CONSTANTS)] = [values[n] for n in _FLOAT_CONSTANTS]
        uints = np.zeros(_PACK, dtype=np.uint32)
        uints[:len(_UINT_CONSTANTS)] = [values[n] for n in _UINT_CONSTANTS]
        self._f = mi.Float64(floats)
        self._u = mi.UInt32(uints)
        dr.make_opaque(self._f, self._u)

    def __getitem__(self, name: str) -> Any:
        if name in _UINT_CONSTANTS:
            return dr.gather(mi.UInt32, self._u, _UINT_CONSTANTS.index(name))
        return dr.gather(mi.Float64, self._f, _FLOAT_CONSTANTS.index(name))

    def f32(self, name: str) -> Any:
        return mi.Float(self[name])


def _pack_constants(values: dict) -> _Constants:
    return _Constants(values)


def _sinc(x: Any) -> Any:
    px = dr.pi * x
    return dr.select(dr.abs(px) < 1e-4, 1.0, dr.sin(px) / px)


def _lane_pairs(idx: Any, k: _Constants, candidates: Any) -> tuple[Any, Any]:
    """Lane index -> (sweep of the chunk, scatterer): sweep ``idx % sweeps`` and the candidate
    ``first + idx // sweeps``. Neighbouring lanes belong to different sweeps, so their deposits
    go to different histograms (neighbouring scatterers of one sweep would fight over the same
    bins in the atomic scatter-add)."""
    local = idx // k["sweeps"]
    return idx - local * k["sweeps"], dr.gather(mi.UInt32, candidates, local + k["first"])


def _candidate_kernel(sc: dict, k: _Constants, count: int) -> Any:
    """Scatterers that may lie in the beam of some sweep of the chunk (``dr.compress``).

    The beam test of :func:`_cull_kernel` at the chunk's middle sweep, widened by how much a
    direction sine can change over the chunk: ``|u_s - u_mid| <= |d_s - d_mid| + |e_s - e_mid|``
    with ``|d_s - d_mid| <= 2 disp / R_mid`` (antenna and target displacement ``disp``) and
    ``|e_s - e_mid| <= turn`` (the frame's largest column change).
    """
    f32 = mi.Float
    m = dr.arange(mi.UInt32, count)
    t = k.f32("mid_time")
    o = mi.Vector3f(
        dr.gather(f32, sc["px32"], m) + dr.gather(f32, sc["vx32"], m) * t - k.f32("mid_px"),
        dr.gather(f32, sc["py32"], m) + dr.gather(f32, sc["vy32"], m) * t - k.f32("mid_py"),
        dr.gather(f32, sc["pz32"], m) + dr.gather(f32, sc["vz32"], m) * t - k.f32("mid_pz"))
    r = dr.norm(o)
    d = o / r
    u_az = d.x * k.f32("mid_f00") + d.y * k.f32("mid_f10") + d.z * k.f32("mid_f20")
    u_el = d.x * k.f32("mid_f01") + d.y * k.f32("mid_f11") + d.z * k.f32("mid_f21")
    cos_b = d.x * k.f32("mid_f02") + d.y * k.f32("mid_f12") + d.z * k.f32("mid_f22")
    margin = 2.0 * k.f32("mid_disp") / r + k.f32("mid_turn") + 1e-4
    active = ((cos_b > -margin) & (dr.abs(u_az) < k.f32("cull_az") + margin)
              & (dr.abs(u_el) < k.f32("cull_el") + margin)) | (r <= 2.0 * k.f32("mid_disp"))
    return dr.compress(active)


def _cull_kernel(sc: dict, sw: dict, k: _Constants, candidates: Any, lanes: int) -> Any:
    """Indices of the (scatterer, sweep) lanes inside the beam and the bin grid.

    Cheap float32 geometry over every lane; only the surviving lanes (a small fraction for a
    room: the beam) pay for shadow rays, float64 phase and the scatter (``dr.compress``).
    """
    f32 = mi.Float
    idx = dr.arange(mi.UInt32, lanes)
    s, m = _lane_pairs(idx, k, candidates)

    def gs(name: str) -> Any:
        return dr.gather(f32, sw[name], s)

    def gm(name: str) -> Any:
        return dr.gather(f32, sc[name], m)

    t = gs("time32")
    o = mi.Vector3f(gm("px32") + gm("vx32") * t - gs("px32"),
                    gm("py32") + gm("vy32") * t - gs("py32"),
                    gm("pz32") + gm("vz32") * t - gs("pz32"))
    r = dr.norm(o)
    d = o / r
    u_az = d.x * gs("f00") + d.y * gs("f10") + d.z * gs("f20")
    u_el = d.x * gs("f01") + d.y * gs("f11") + d.z * gs("f21")
    cos_b = d.x * gs("f02") + d.y * gs("f12") + d.z * gs("f22")
    slack = 2.0 * k.f32("inv_step")  # float32 range error << 2 bins
    x = (r - k.f32("first_range")) * k.f32("inv_step")
    active = ((cos_b > 0.0) & (dr.abs(u_az) < k.f32("cull_az"))
              & (dr.abs(u_el) < k.f32("cull_el")) & (r > 0.0)
              & (x > -slack - k.f32("doppler_bins")) & (x < k.f32("last_lower") + slack
                                                          + k.f32("doppler_bins")))
    return dr.compress(active)


def _deposit_kernel(scene: Any, sc: dict, sw: dict, k: _Constants, candidates: Any,
                    lanes: Any, re: Any, im: Any) -> None:
    """Trace the culled lanes ``lanes`` and scatter-add their deposits into ``re``/``im``.

    Everything variable is in ``sc`` (scatterer arrays), ``sw`` (sweep arrays of the chunk) and
    ``k`` (packed constants), so the traced kernel is the same for every launch.
    """
    from mitsar.plugins.doublelobe import DRJIT_OPS

    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    s, m = _lane_pairs(lanes, k, candidates)

    def gs(name: str, kind: type = f64) -> Any:
        return dr.gather(kind, sw[name], s)

    def gm(name: str, kind: type = f64) -> Any:
        return dr.gather(kind, sc[name], m)

    t = gs("time")
    vqx, vqy, vqz = gm("vx"), gm("vy"), gm("vz")
    qx, qy, qz = gm("px") + vqx * t, gm("py") + vqy * t, gm("pz") + vqz * t
    ax, ay, az = gs("px"), gs("py"), gs("pz")
    ox, oy, oz = qx - ax, qy - ay, qz - az
    r = dr.sqrt(ox * ox + oy * oy + oz * oz)
    inv_r = 1.0 / r
    rdot = (ox * (vqx - gs("vx")) + oy * (vqy - gs("vy")) + oz * (vqz - gs("vz"))) * inv_r
    d = mi.Vector3f(f32(ox * inv_r), f32(oy * inv_r), f32(oz * inv_r))

    # Two-way pattern: the one-way sinc^2 power pattern is the amplitude factor.
    u_az = d.x * gs("f00", f32) + d.y * gs("f10", f32) + d.z * gs("f20", f32)
    u_el = d.x * gs("f01", f32) + d.y * gs("f11", f32) + d.z * gs("f21", f32)
    one_way = dr.square(_sinc(u_az * k.f32("inv_beta_az"))
                        * _sinc(u_el * k.f32("inv_beta_el")))

    # sigma0 from the material's monostatic table (point targets: a row of ones).
    n = mi.Vector3f(gm("nx", f32), gm("ny", f32), gm("nz", f32))
    n_dot_d = dr.dot(n, d)
    sigma0 = _interp_table(sc["tables"], dr.abs(n_dot_d), gm("row", u32), DRJIT_OPS)
    sigma = sigma0 * gm("weight", f32)

    # Apparent range and its two bins.
    r_app = r + k["fc_over_k"] * rdot
    lower, w_lo, w_hi = hg.split_weights((r_app - k["first_range"]) * k["inv_step"], dr.floor)
    active = (sigma > 0.0) & (lower >= 0.0) & (lower < k["last_lower"])

    # Visibility: segment antenna -> point just above the surface on the antenna's side.
    q = mi.Point3f(f32(qx), f32(qy), f32(qz))
    a = mi.Point3f(f32(ax), f32(ay), f32(az))
    side = dr.select(n_dot_d > 0.0, -1.0, 1.0)
    eps = SURFACE_OFFSET * (1.0 + dr.max(dr.abs(q)))
    seg = (q + n * (side * eps)) - a
    dist = dr.norm(seg)
    ray = mi.Ray3f(a, seg / dist)
    ray.maxt = dist * (1.0 - 1e-6) - gm("stop", f32)
    active &= ray.maxt > 0.0
    active &= ~scene.ray_test(ray, active)

    # Amplitude (radar equation) and float64 phase.
    amp = one_way * dr.sqrt(sigma) * dr.select(k["normalized"] > 0.0, 1.0,
                                               f32(k["radar_const"] * inv_r * inv_r))
    delay = r * (2.0 / SPEED_OF_LIGHT)
    cycles = k["fc"] * delay - k["rvp"] * (0.5 * k["chirp_rate"]) * delay * delay + gm("phase")
    # Wrapped in float64 (f_c tau ~ 2e4 cycles), then float32 is exact to ~4e-7 rad.
    sin_p, cos_p = dr.sincos((2.0 * dr.pi) * f32(cycles - dr.floor(cycles)))
    v_re, v_im = f64(amp * cos_p), f64(amp * sin_p)

    index = s * k["sweep_stride"] + u32(dr.select(active, lower, 0.0))
    for offset, weight in ((0, w_lo), (1, w_hi)):
        dr.scatter_reduce(dr.ReduceOp.Add, re, v_re * weight, index + offset, active)
        dr.scatter_reduce(dr.ReduceOp.Add, im, v_im * weight, index + offset, active)


def _interp_table(table: Any, cos_theta: Any, row: Any, ops: Any) -> Any:
    from mitsar.doublelobe import interp_theta_table

    return interp_theta_table(table, SIGMA0_TABLE_SIZE, cos_theta, ops,
                              offset=mi.Float(row * SIGMA0_TABLE_SIZE))


# --------------------------------------------------------------------------------------------
# The integrator
# --------------------------------------------------------------------------------------------

def _make_class() -> type:
    """Create the integrator class for the active variant (classes are tied to a variant)."""

    class RadarIntegrator(mi.SamplingIntegrator):
        """FMCW SAR histogram tracer (see the module docstring)."""

        MITSAR_KIND = "radar"

        def __init__(self, props: Any) -> None:
            mi.SamplingIntegrator.__init__(self, props)
            self._where = plugin_where(PLUGIN_NAME, props)
            values = read_properties(props, self._where, PARAMETERS)
            self.config = RadarIntegratorConfig.from_values(values, self._where)
            self._cache: dict = {}
            self.statistics: dict[str, int] = {}

        # ---- Mitsuba interface --------------------------------------------------------

        def sample(self, scene: Any, sampler: Any, ray: Any, medium: Any = None,
                   active: Any = True) -> Any:
            raise MitsarError("the 'radar' integrator makes range histograms, not images: "
                              "use mitsar.trace(...) or mitsar.simulate_scene(...)")

        def render(self, scene: Any, sensor: Any = None, seed: int = 0, spp: int = 0,
                   develop: bool = True, evaluate: bool = True) -> Any:
            raise MitsarError("the 'radar' integrator makes range histograms, not images: "
                              "use mitsar.trace(...) or mitsar.simulate_scene(...)")

        def aov_names(self) -> list[str]:
            return []

        def traverse(self, callback: Any) -> None:
            pass

        def to_string(self) -> str:
            fields = ", ".join(f"{k}={v}" for k, v in self.config.to_dict().items())
            return f"RadarIntegrator[{fields}]"

        # ---- radar interface -----------------------------------------------------------

        def scatterers(self, scene: Any, density: float, seed: int) -> ScattererSet:
            """The scene's scatterers for ``density`` and ``seed`` (cached per scene)."""
            key = (id(scene), float(density), int(seed))
            if key not in self._cache:
                self._cache.clear()
                self._cache[key] = (scene, collect_scatterers(scene, density, seed))
            return self._cache[key][1]

        def trace_histograms(self, scene: Any, geometry: dict, radar: Radar, frames: NDArray,
                             scatterers: ScattererSet, grid: tuple[int, int], *,
                             sweeps: NDArray | None = None, config: RadarIntegratorConfig
                             | None = None, rvp: bool = True, normalized: bool = False,
                             progress: bool = False
                             ) -> Iterator[tuple[NDArray, NDArray[np.complex128]]]:
            """Trace sweeps into histograms, one chunk of sweeps at a time.

            Parameters
            ----------
            scene : mitsuba.Scene
            geometry : dict
                :func:`mitsar.raw.sweep_geometry` of the whole acquisition.
            radar : Radar
            frames : ndarray, shape (sweeps, 3, 3)
                Antenna-to-world rotation at mid-sweep (:func:`antenna_frame`).
            scatterers : ScattererSet
            grid : (first_index, count)
                Histogram bin grid (:func:`mitsar.histogram.bin_grid`).
            sweeps : ndarray of int, optional
                Sweep indices to trace (default all), increasing.
            config : RadarIntegratorConfig, optional
                Overrides this integrator's configuration.
            rvp, normalized : bool
                Keep the residual video phase; unit amplitude per unit sqrt(RCS) (as
                :func:`mitsar.simulate_point_targets`).
            progress : bool
                Progress bar over launches.

            Yields
            ------
            sweep_indices : ndarray of int
            histogram : ndarray, shape (len(sweep_indices), orders, bins), complex128

            Notes
            -----
            ``self.statistics`` counts, for the last call: ``pairs`` (scatterer x sweep pairs of
            the acquisition), ``candidate_pairs`` (left by the chunk-level beam cull),
            ``shadow_rays`` (in the beam and the bin grid: traced and deposited if visible) and
            kernel ``launches``.
            """
            config = self.config if config is None else config
            if config.max_depth > 1:
                raise ParameterError(self._where, "max_depth", "1 (direct backscatter; the "
                                     "multipath mechanism is not implemented yet)",
                                     config.max_depth)
            orders = 1
            total = len(geometry["slow_time"])
            sweeps = np.arange(total) if sweeps is None else np.asarray(sweeps, dtype=np.int64)
            first_index, bins = grid
            count = len(scatterers)
            if count == 0:
                for start in range(0, len(sweeps), 1024):
                    chosen = sweeps[start:start + 1024]
                    yield chosen, np.zeros((len(chosen), orders, bins), np.complex128)
                return
            self.statistics = {"pairs": 0, "candidate_pairs": 0, "shadow_rays": 0,
                               "launches": 0}
            per_chunk = max(1, min(SWEEPS_PER_CHUNK, config.chunk_lanes,
                                   HISTOGRAM_CHUNK_ELEMENTS // (orders * bins)))
            device = self._upload(scatterers)
            step = hg.range_step(radar, config.bins_per_cell)
            target_speed = float(np.linalg.norm(scatterers.velocity, axis=1).max())
            max_speed = float(np.linalg.norm(geometry["velocity"], axis=1).max()) + target_speed
            k = self._constants(radar, config, first_index, bins, step, orders, rvp,
                                normalized, max_speed)
            bar = tqdm(total=len(sweeps), disable=not progress, desc="trace", unit="sweep")
            try:
                for s0 in range(0, len(sweeps), per_chunk):
                    chosen = sweeps[s0:s0 + per_chunk]
                    sw = self._sweep_arrays(geometry, frames, radar, chosen)
                    k.update(self._chunk_bounds(geometry, frames, radar, chosen, target_speed))
                    k["first"], k["sweeps"] = 0, len(chosen)
                    candidates = _candidate_kernel(device, _pack_constants(k), count)
                    size = len(chosen) * orders * bins
                    re = dr.zeros(mi.Float64, size)
                    im = dr.zeros(mi.Float64, size)
                    found = dr.width(candidates)
                    block = max(1, config.chunk_lanes // len(chosen))
                    self.statistics["pairs"] += count * len(chosen)
                    self.statistics["candidate_pairs"] += found * len(chosen)
                    for m0 in range(0, found, block):
                        width = min(block, found - m0)
                        k["first"] = m0
                        consts = _pack_constants(k)
                        lanes = _cull_kernel(device, sw, consts, candidates, len(chosen) * width)
                        self.statistics["shadow_rays"] += dr.width(lanes)
                        self.statistics["launches"] += 1
                        if dr.width(lanes):
                            _deposit_kernel(scene, device, sw, consts, candidates, lanes, re, im)
                        dr.eval(re, im)
                    hist = (np.asarray(re) + 1j * np.asarray(im)).reshape(
                        len(chosen), orders, bins)
                    bar.update(len(chosen))
                    yield chosen, hist
            finally:
                bar.close()

        # ---- helpers -----------------------------------------------------------------

        def _upload(self, sc: ScattererSet) -> dict:
            if "px" not in sc.device:
                f64, f32 = mi.Float64, mi.Float
                dev = {}
                for i, axis in enumerate("xyz"):
                    dev["p" + axis] = f64(np.ascontiguousarray(sc.position[:, i]))
                    dev["v" + axis] = f64(np.ascontiguousarray(sc.velocity[:, i]))
                    dev["n" + axis] = f32(np.ascontiguousarray(sc.normal[:, i]))
                    dev["p" + axis + "32"] = f32(np.ascontiguousarray(sc.position[:, i]))
                    dev["v" + axis + "32"] = f32(np.ascontiguousarray(sc.velocity[:, i]))
                dev["weight"] = f32(sc.weight)
                dev["phase"] = f64(sc.phase)
                dev["row"] = mi.UInt32(sc.table_row.astype(np.uint32))
                dev["stop"] = f32(sc.stop)
                dev["tables"] = f32(np.ascontiguousarray(sc.tables.ravel()))
                dr.make_opaque(*dev.values())
                sc.device.update(dev)
            return sc.device

        @staticmethod
        def _sweep_arrays(geometry: dict, frames: NDArray, radar: Radar,
                          chosen: NDArray) -> dict:
            padded = np.concatenate([chosen, np.full(-len(chosen) % _PACK, chosen[-1])])

            def upload(kind: type, values: NDArray) -> Any:
                return kind(np.ascontiguousarray(values))

            pos = geometry["position"][padded]
            vel = geometry["velocity"][padded]
            sw = {"time": upload(mi.Float64, geometry["slow_time"][padded]
                                 + radar.sweep_duration / 2)}
            sw["time32"] = upload(mi.Float, geometry["slow_time"][padded]
                                  + radar.sweep_duration / 2)
            for i, axis in enumerate("xyz"):
                sw["p" + axis] = upload(mi.Float64, pos[:, i])
                sw["v" + axis] = upload(mi.Float64, vel[:, i])
                sw["p" + axis + "32"] = upload(mi.Float, pos[:, i])
            for i in range(3):
                for j in range(3):
                    sw[f"f{i}{j}"] = upload(mi.Float, frames[padded, i, j])
            dr.make_opaque(*sw.values())
            return sw

        @staticmethod
        def _chunk_bounds(geometry: dict, frames: NDArray, radar: Radar, chosen: NDArray,
                          target_speed: float) -> dict:
            """Middle sweep of a chunk and how far the antenna moves and turns around it."""
            mid = chosen[len(chosen) // 2]
            pos = geometry["position"]
            times = geometry["slow_time"]
            disp = (np.linalg.norm(pos[chosen] - pos[mid], axis=1).max()
                    + target_speed * np.abs(times[chosen] - times[mid]).max())
            turn = np.linalg.norm(frames[chosen] - frames[mid], axis=1).max()
            out = {"mid_disp": float(disp), "mid_turn": float(turn),
                   "mid_time": float(times[mid] + radar.sweep_duration / 2)}
            for i, axis in enumerate("xyz"):
                out["mid_p" + axis] = float(pos[mid, i])
            for i in range(3):
                for j in range(3):
                    out[f"mid_f{i}{j}"] = float(frames[mid, i, j])
            return out

        @staticmethod
        def _constants(radar: Radar, config: RadarIntegratorConfig, first_index: int,
                       bins: int, step: float, orders: int, rvp: bool,
                       normalized: bool, max_speed: float) -> dict:
            cull = min(float(config.beam_cull), 1e30)
            return {
                "fc": radar.carrier_frequency,
                "chirp_rate": radar.chirp_rate,
                "fc_over_k": radar.carrier_frequency / radar.chirp_rate,
                "first_range": first_index * step,
                "inv_step": 1.0 / step,
                "last_lower": float(bins - 1),
                "inv_beta_az": 1.0 / radar.azimuth_beamwidth,
                "inv_beta_el": 1.0 / radar.elevation_beamwidth,
                "cull_az": cull * radar.azimuth_beamwidth,
                "cull_el": cull * radar.elevation_beamwidth,
                "radar_const": float(radar_equation_amplitude(radar, 1.0, 1.0)),
                "rvp": 1.0 if rvp else 0.0,
                "normalized": 1.0 if normalized else 0.0,
                "doppler_bins": max_speed * radar.carrier_frequency / radar.chirp_rate / step,
                "sweep_stride": orders * bins,
                "first": 0,
                "sweeps": 1,
            }

    return RadarIntegrator


_CLASSES: dict[str, type] = {}


def integrator_class() -> type:
    """The integrator class for the active variant (created once per variant)."""
    variant = mi.variant()
    if variant not in _CLASSES:
        _CLASSES[variant] = _make_class()
    return _CLASSES[variant]


def register() -> None:
    """Register ``radar`` for the active Mitsuba variant."""
    cls = integrator_class()
    mi.register_integrator(PLUGIN_NAME, lambda props: cls(props))
