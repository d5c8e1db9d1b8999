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
   ``|u_el| < beam_cull beta_el`` (direction sines, :mod:`mitsar.model.geometry.antenna`);
3. visibility: ``scene.ray_test`` on the segment from the antenna to the scatterer, ending a
   small offset above the surface on the antenna's side (so the scatterer's own shape does not
   occlude it), or, for a point target, before its shape's bounding sphere;
4. amplitude ``sqrt(P_T G^2 lambda^2 / (4 pi)^3) P(u) sqrt(sigma) / R^2`` (radar equation of
   :mod:`mitsar.model.signal`, two-way pattern ``P^2`` with the sinc^2 aperture pattern ``P``),
   ``sigma = sigma0(theta_i) * area share`` from the material's monostatic table
   (:func:`mitsar.model.doublelobe.monostatic_sigma0_table`) or the point target's RCS;
5. phase ``2 pi (f_c tau_0 - K tau_0^2 / 2 + speckle)`` in float64, apparent range
   ``R + (f_c / K) dR/dt`` (:func:`mitsar.model.histogram.apparent_range`);
6. ``dr.scatter_reduce`` of the complex value, split linearly between the two neighbouring bins,
   into a float64 histogram (sweep x order x bin).

Per-acquisition values (radar constants, bin grid, chunk offsets) are packed into padded device
arrays and every other input is a device array, so each kernel is compiled once and reused from
Dr.Jit's cache for every chunk, acquisition and trajectory (``docs/integrator.md``).

Multipath (DESIGN §5.4 mechanism 2, ``max_depth > 1``; ``docs/multipath.md``)
-----------------------------------------------------------------------------
Shooting and bouncing rays: a fixed grid of launch directions in the antenna's ray frame
(:func:`mitsar.model.multipath.ray_set`) is traced for every sweep of a chunk in one wavefront (one lane
per ray x sweep, ``_multipath_launch``), with ``scene.ray_intersect`` per bounce (a Python loop
over the depth only). Each lane carries its origin and direction, the transmitter's image
(float64), the reflected ray frame and the product of the field factors ``Γ R``. After every
reflection the receiver is tested against the ray's tube (:func:`mitsar.model.multipath.capture_weight`
on the launch coordinates of the receiver seen from the image) and, when captured, the
image-method amplitude is deposited at order = number of reflections, with delay ``L/c`` and the
Doppler of the image geometry. Optionally (``ghosts``) every hit after the first scatters back to
the receiver through the material's bistatic double-lobe pattern (shadow-tested). A 2D mode
(``plane_normal``) restricts the rays to a fan in the plane through the antenna containing the
boresight, and the surface scatterers to a slab of ``slab_width`` around that plane.

Use it through :func:`mitsar.raw.traced` / :func:`mitsar.simulate_scene`; ``mi.render`` is refused.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterator
from dataclasses import dataclass
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.errors import MitsarError, ParameterError
from mitsar.model import histogram as hg
from mitsar.model.doublelobe import monostatic_sigma0_table
from mitsar.model.multipath import CAPTURE_KINDS, multipath_amplitude_constant
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import radar_equation_amplitude
from mitsar.plugins import parse_vector3, plugin_where, read_properties

PLUGIN_NAME = "radar"
"""XML type name."""

PARAMETERS: tuple[str, ...] = ("scatterer_density", "scatterers_per_cell", "max_depth",
                               "chunk_lanes", "seed", "bins_per_cell", "beam_cull", "rays",
                               "ray_cover", "capture", "ghosts", "plane_normal", "slab_width")
"""Accepted XML parameters."""

MAX_LANES = 2**26
"""Upper bound on lanes per kernel launch (Dr.Jit wavefront size; DESIGN §7)."""

DEFAULT_CHUNK_LANES = 2**24
"""Default lanes (scatterer x sweep pairs) per kernel launch."""

MAX_DEPTH = 8
"""Largest ``max_depth`` (hits per ray; up to 7 reflections)."""

MULTIPATH_CHUNK_LANES = 2**20
"""Ray x sweep lanes per multipath launch (each lane holds ~40 floats of state)."""

DEFAULT_RAYS = 4096
"""Default number of multipath rays per sweep."""

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
    rays: int = DEFAULT_RAYS
    ray_cover: float = 1.0
    capture: str = "tent"
    ghosts: bool = False
    plane_normal: tuple[float, float, float] | None = None
    slab_width: float = AZIMUTH_CELL

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
        integer("max_depth", 1, MAX_DEPTH)
        integer("chunk_lanes", 1, MAX_LANES - 1)
        integer("rays", 1, MULTIPATH_CHUNK_LANES)
        positive("ray_cover")
        positive("slab_width")
        if self.capture not in CAPTURE_KINDS:
            raise ParameterError(where, "capture", f"one of {list(CAPTURE_KINDS)}", self.capture)
        if not isinstance(self.ghosts, bool | np.bool_):
            raise ParameterError(where, "ghosts", "true or false", self.ghosts)
        if self.plane_normal is not None:
            normal = np.asarray(self.plane_normal, dtype=float)
            if normal.shape != (3,) or not np.all(np.isfinite(normal)) \
                    or not np.linalg.norm(normal) > 0:
                raise ParameterError(where, "plane_normal", "None (3D) or a non-zero 3-vector "
                                     "(2D mode: normal of the plane of the rays)",
                                     self.plane_normal)
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
        if "plane_normal" in values and values["plane_normal"] is not None:
            values["plane_normal"] = parse_vector3(values["plane_normal"], where,
                                                   "plane_normal")
        for name in ("scatterer_density", "scatterers_per_cell", "beam_cull", "ray_cover",
                     "slab_width"):
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
        if "plane_normal" in changes:
            changes["plane_normal"] = tuple(float(v) for v in np.ravel(changes["plane_normal"]))
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
    surfaces = scene_surfaces(scene)
    radii = [_bounding_radius(s.shape) for s in surfaces
             if getattr(s.shape.bsdf(), "MITSAR_KIND", None) == "pointtarget"]
    foreign = [s.id or f"shape {s.index}" for s in surfaces
               if getattr(s.shape.bsdf(), "MITSAR_KIND", None) is None]
    if foreign:
        # Shapes with a non-radar BSDF (e.g. Mitsuba's default diffuse) block rays but return
        # nothing; usually a forgotten <bsdf type="doublelobe">.
        warnings.warn("radar integrator: shapes without a radar material (doublelobe or "
                      f"pointtarget) return no echo and only block rays: {', '.join(foreign)}",
                      stacklevel=3)
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


def empty_scatterers(density: float, seed: int) -> ScattererSet:
    """A scatterer set without scatterers (multipath-only tracing)."""
    return ScattererSet(position=np.zeros((0, 3)), normal=np.zeros((0, 3)),
                        velocity=np.zeros((0, 3)), weight=np.zeros(0), phase=np.zeros(0),
                        table_row=np.zeros(0, dtype=np.int64), stop=np.zeros(0),
                        tables=np.zeros((1, SIGMA0_TABLE_SIZE)), surface_count=0,
                        point_target_count=0, density=float(density), seed=int(seed))


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
                    "mid_turn", "mid_time", "slab_half")
_UINT_CONSTANTS = ("sweep_stride", "first", "sweeps")
_MP_FLOAT_CONSTANTS = ("fc", "chirp_rate", "fc_over_k", "first_range", "inv_step", "last_lower",
                       "inv_beta_az", "inv_beta_el", "rvp", "normalized", "amp_const",
                       "norm_const", "dp", "dq", "inv_dp", "inv_dq", "slab_width",
                       "ghost_cell_inv")
_MP_UINT_CONSTANTS = ("sweep_stride", "bins", "first", "sweeps")
_PACK = 32  # pad the constant arrays: small allocations may be unaligned, and the alignment
#             of a load is part of the kernel hash (measured: size-1 opaque scalars recompile)


class _Constants:
    """Per-launch scalars packed in two device arrays, read with literal-index gathers."""

    def __init__(self, values: dict, floats: tuple[str, ...] = _FLOAT_CONSTANTS,
                 uints: tuple[str, ...] = _UINT_CONSTANTS) -> None:
        self._float_names, self._uint_names = floats, uints
        packed = np.zeros(_PACK)
        assert len(floats) <= _PACK and len(uints) <= _PACK
        packed[:len(floats)] = [values[n] for n in floats]
        packed_u = np.zeros(_PACK, dtype=np.uint32)
        packed_u[:len(uints)] = [values[n] for n in uints]
        self._f = mi.Float64(packed)
        self._u = mi.UInt32(packed_u)
        dr.make_opaque(self._f, self._u)

    def __getitem__(self, name: str) -> Any:
        if name in self._uint_names:
            return dr.gather(mi.UInt32, self._u, self._uint_names.index(name))
        return dr.gather(mi.Float64, self._f, self._float_names.index(name))

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
    # 2D mode: only the slab |(q - a).n| <= slab_half around the plane (3D: n = 0, half = inf).
    off_plane = dr.abs(o.x * gs("n2x") + o.y * gs("n2y") + o.z * gs("n2z"))
    active = ((cos_b > 0.0) & (dr.abs(u_az) < k.f32("cull_az"))
              & (off_plane <= k.f32("slab_half"))
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
    from mitsar.plugins.bsdfs.doublelobe import DRJIT_OPS

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
    from mitsar.model.doublelobe import interp_theta_table

    return interp_theta_table(table, SIGMA0_TABLE_SIZE, cos_theta, ops,
                              offset=mi.Float(row * SIGMA0_TABLE_SIZE))


# --------------------------------------------------------------------------------------------
# Multipath: shooting and bouncing rays (DESIGN §5.4 mechanism 2, docs/multipath.md)
# --------------------------------------------------------------------------------------------

@dataclass
class TraceSetup:
    """Per-acquisition geometry of the rays and the receiver (NumPy side).

    Attributes
    ----------
    ray_frames : ndarray, shape (sweeps, 3, 3)
        Ray-to-world rotations: the antenna frames (3D) or :func:`mitsar.model.multipath.ray_frame_2d`.
    plane_normals : ndarray, shape (sweeps, 3)
        2D mode: the normal of the plane of the rays; zeros in 3D.
    receiver_offset : ndarray, shape (3,)
        Receiver position minus transmitter position, world frame (zeros: monostatic).
    receiver_frames : ndarray, shape (sweeps, 3, 3)
        Antenna-to-world rotations of the receiving antenna.
    rays : RaySet or None
        The multipath ray grid (None: ``max_depth = 1``).
    """

    ray_frames: NDArray
    plane_normals: NDArray
    receiver_offset: NDArray
    receiver_frames: NDArray
    rays: Any
    planar: bool

    @property
    def bistatic(self) -> bool:
        return bool(np.any(self.receiver_offset != 0.0))


def make_setup(radar: Radar, frames: NDArray, config: RadarIntegratorConfig,
               receiver_offset: Any = None, receiver_frames: NDArray | None = None
               ) -> TraceSetup:
    """The :class:`TraceSetup` of an acquisition (2D mode, bistatic receiver, ray grid)."""
    from mitsar.model.multipath import ray_frame_2d, ray_set

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


def shape_table(scene: Any) -> dict:
    """Per-shape values of the multipath kernel, indexed by Dr.Jit registry id of the shape.

    ``rho``: specular field factor ``Γ R`` (0: the ray stops: absorbers, point-target markers,
    other BSDFs); ``gscale``: 1 where ghosts may scatter (double-lobe materials); ``grow``: row of
    the ghost tables ``wb``, ``wf`` (``4π Γ² S² w_B,F(θ_i)`` uniform in θ_i, so that the bistatic
    ``σ⁰ = cos θ_i [wb lobe_B^α_B + wf lobe_F^α_F]``) and exponents ``ab``, ``af``.
    """
    from mitsar.model.doublelobe import _HALF_PI

    shapes = list(scene.shapes())
    ids = [int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0]) for shape in shapes]
    size = max(ids + [0]) + 1
    rho = np.zeros(size)
    gscale = np.zeros(size)
    grow = np.zeros(size, dtype=np.uint32)
    rows: list[Any] = []
    for ident, shape in zip(ids, shapes, strict=True):
        bsdf = shape.bsdf()
        material = getattr(bsdf, "material", None) \
            if getattr(bsdf, "MITSAR_KIND", None) == "doublelobe" else None
        if material is None:
            continue
        rho[ident] = math.sqrt(material.specular_fraction)
        if material.scattered_fraction > 0.0:
            if material not in rows:
                rows.append(material)
            gscale[ident] = 1.0
            grow[ident] = rows.index(material)
    n = SIGMA0_TABLE_SIZE
    cos_theta = np.cos(np.linspace(0.0, _HALF_PI, n))
    cos_theta[-1] = 0.0
    wb = np.zeros((max(1, len(rows)), n))
    wf = np.zeros_like(wb)
    ab, af = np.ones(max(1, len(rows))), np.ones(max(1, len(rows)))
    for r, material in enumerate(rows):
        w_b, w_f = material.weights(np.maximum(cos_theta, 1e-6))
        wb[r] = 4.0 * math.pi * material.scattered_fraction * w_b
        wf[r] = 4.0 * math.pi * material.scattered_fraction * w_f
        ab[r], af[r] = material.alpha_b, material.alpha_f
    f32 = mi.Float
    out = {"rho": f32(rho), "gscale": f32(gscale), "grow": mi.UInt32(grow),
           "wb": f32(wb.ravel()), "wf": f32(wf.ravel()), "ab": f32(ab), "af": f32(af)}
    dr.make_opaque(*out.values())
    return out


def _column(get: Any, prefix: str, j: int) -> Any:
    return mi.Vector3f(get(f"{prefix}0{j}"), get(f"{prefix}1{j}"), get(f"{prefix}2{j}"))


def _field_pattern(direction: Any, az: Any, el: Any, k: _Constants) -> Any:
    """One-way *field* pattern ``sinc(u_az/β_az) sinc(u_el/β_el)`` (its square is the power
    pattern of :mod:`mitsar.model.geometry.antenna`)."""
    return (_sinc(dr.dot(direction, az) * k.f32("inv_beta_az"))
            * _sinc(dr.dot(direction, el) * k.f32("inv_beta_el")))


def _mp_deposit(k: _Constants, re: Any, im: Any, s: Any, order: int, length: Any, rate: Any,
                amp: Any, extra_cycles: Any, active: Any) -> None:
    """Deposit a path of unfolded length ``length`` (float64) and length rate ``rate``."""
    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    r_app = 0.5 * length + k["fc_over_k"] * (0.5 * f64(rate))
    lower, w_lo, w_hi = hg.split_weights((r_app - k["first_range"]) * k["inv_step"], dr.floor)
    active = active & (lower >= 0.0) & (lower < k["last_lower"])
    delay = length * (1.0 / SPEED_OF_LIGHT)
    cycles = k["fc"] * delay - k["rvp"] * (0.5 * k["chirp_rate"]) * delay * delay
    if extra_cycles is not None:
        cycles = cycles + f64(extra_cycles)
    sin_p, cos_p = dr.sincos((2.0 * dr.pi) * f32(cycles - dr.floor(cycles)))
    v_re, v_im = f64(amp * cos_p), f64(amp * sin_p)
    index = s * k["sweep_stride"] + k["bins"] * order + u32(dr.select(active, lower, 0.0))
    for offset, weight in ((0, w_lo), (1, w_hi)):
        dr.scatter_reduce(dr.ReduceOp.Add, re, v_re * weight, index + offset, active)
        dr.scatter_reduce(dr.ReduceOp.Add, im, v_im * weight, index + offset, active)


def _mp_capture_deposit(k: _Constants, re: Any, im: Any, sw: dict, chosen: Any, s_all: Any,
                        img_all: list, frame_all: tuple, field_all: Any, amp_tx_all: Any,
                        weight_all: Any, order: int) -> None:
    """Deposit the captured lanes ``chosen``: image-method amplitude (tent-weighted), delay
    ``L/c`` with ``L = |rx - img|`` in float64, Doppler of the image geometry."""
    f64, f32 = mi.Float64, mi.Float
    s = dr.gather(mi.UInt32, s_all, chosen)

    def gs(name: str, kind: type = f32) -> Any:
        return dr.gather(kind, sw[name], s)

    def gl(values: Any, kind: type = f32) -> Any:
        return dr.gather(kind, values, chosen)

    img = [gl(c, f64) for c in img_all]
    e0, e1, e2 = (mi.Vector3f(gl(e.x), gl(e.y), gl(e.z)) for e in frame_all)
    wx, wy, wz = gs("qx", f64) - img[0], gs("qy", f64) - img[1], gs("qz", f64) - img[2]
    length = dr.sqrt(wx * wx + wy * wy + wz * wz)
    inv = 1.0 / length
    wn = mi.Vector3f(f32(wx * inv), f32(wy * inv), f32(wz * inv))
    amp_rx = _field_pattern(-wn, _column(gs, "g", 0), _column(gs, "g", 1), k)
    scale = dr.select(k["normalized"] > 0.0, k["norm_const"] * length, k["amp_const"] * inv)
    amp = f32(scale) * gl(weight_all) * gl(field_all) * gl(amp_tx_all) * amp_rx
    v_img = e0 * gs("va0") + e1 * gs("va1") + e2 * gs("va2")
    rate = dr.dot(wn, mi.Vector3f(gs("vx"), gs("vy"), gs("vz")) - v_img)
    _mp_deposit(k, re, im, s, order, length, rate, amp, None, dr.full(mi.Bool, True,
                                                                     dr.width(chosen)))


def _multipath_launch(scene: Any, table: dict, rays: dict, sw: dict, k: _Constants,
                      candidates: Any, lanes: int, re: Any, im: Any, depth: int, capture: str,
                      ghosts: bool, planar: bool, log: list | None = None,
                      stats: dict | None = None) -> None:
    """Shoot ``lanes`` rays (ray x sweep lanes) through up to ``depth`` hits and deposit.

    Lane ``idx`` is sweep ``idx % sweeps`` of the chunk and ray ``candidates[first + idx //
    sweeps]``. State per lane: segment origin ``o`` and direction ``d``, the transmitter's image
    ``img`` (float64), the reflected ray frame ``e0, e1, e2`` and the field factor ``ρ``.
    ``log`` (a list) receives per segment a dict of NumPy arrays (path log).
    """
    from mitsar.model.doublelobe import interp_theta_table
    from mitsar.plugins.bsdfs.doublelobe import DRJIT_OPS

    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    s, i = _lane_pairs(dr.arange(u32, lanes), k, candidates)

    def gs(name: str, kind: type = f32) -> Any:
        return dr.gather(kind, sw[name], s)

    p = dr.gather(f32, rays["p"], i)
    q = dr.gather(f32, rays["q"], i)
    z = dr.safe_sqrt(1.0 - p * p - q * q)
    e0, e1, e2 = _column(gs, "r", 0), _column(gs, "r", 1), _column(gs, "r", 2)
    d = dr.normalize(e0 * p + e1 * q + e2 * z)
    amp_tx = _field_pattern(d, _column(gs, "f", 0), _column(gs, "f", 1), k)
    dr.eval(amp_tx, s, p, q, z)
    g_az, g_el, g_b = _column(gs, "g", 0), _column(gs, "g", 1), _column(gs, "g", 2)
    rx32 = mi.Point3f(gs("qx32"), gs("qy32"), gs("qz32"))
    v_rx = mi.Vector3f(gs("vx"), gs("vy"), gs("vz"))
    va0, va1, va2 = gs("va0"), gs("va1"), gs("va2")
    img = [gs("px", f64), gs("py", f64), gs("pz", f64)]
    o = mi.Point3f(gs("px32"), gs("py32"), gs("pz32"))
    field = dr.full(f32, 1.0, lanes)
    alive = z > 0.0
    inv_4pi = 1.0 / (4.0 * math.pi)
    counts = dr.zeros(u32, lanes)  # segments + 2^16 x captures of the lane (work counters)

    for kk in range(depth):
        counts = counts + dr.select(alive, 1, 0)
        si = scene.ray_intersect(mi.Ray3f(o, d), mi.RayFlags.Minimal, False, alive)
        hit = alive & si.is_valid()
        t_hit = dr.select(hit, si.t, dr.inf)
        v_img = e0 * va0 + e1 * va1 + e2 * va2  # image velocity M v_tx
        weight = dr.zeros(f32, lanes)
        if kk >= 1:
            # Capture test in float32 on every lane: the receiver's launch coordinates seen
            # from the image; the float64 deposit runs on the few captured lanes only.
            w = rx32 - mi.Point3f(f32(img[0]), f32(img[1]), f32(img[2]))
            wn = dr.normalize(w)
            ps, qs, zs = dr.dot(wn, e0), dr.dot(wn, e1), dr.dot(wn, e2)
            t_r = dr.dot(rx32 - o, d)
            ok = alive & (zs > 0.0) & (t_r > 0.0) & (t_r < t_hit) & (dr.dot(wn, g_b) < 0.0)
            x = (ps - p) * k.f32("inv_dp")
            y = (qs - q) * k.f32("inv_dq")
            if capture == "tent":
                weight = dr.maximum(0.0, 1.0 - dr.abs(x)) * dr.maximum(0.0, 1.0 - dr.abs(y))
            else:
                inside = (x >= -0.5) & (x < 0.5) & (y >= -0.5) & (y < 0.5)
                weight = dr.select(inside, 1.0, 0.0)
            ok &= weight > 0.0
            weight = dr.select(ok, weight, 0.0)
            dr.eval(weight)
            chosen = dr.compress(weight > 0.0)
            if dr.width(chosen):
                _mp_capture_deposit(k, re, im, sw, chosen, s, img, (e0, e1, e2), field, amp_tx,
                                    weight, kk)
            counts = counts + dr.select(ok, 65536, 0)
        if log is not None:
            log.append({"origin": np.array(o, dtype=np.float64).T,
                        "direction": np.array(d, dtype=np.float64).T,
                        "t_hit": np.array(t_hit, dtype=np.float64),
                        "hit": np.array(hit, dtype=bool),
                        "alive": np.array(alive, dtype=bool),
                        "field": np.array(field, dtype=np.float64),
                        "pattern": np.array(amp_tx, dtype=np.float64) ** 2,
                        "image": np.array([np.array(c, dtype=np.float64) for c in img]).T,
                        "captured": np.array(weight, dtype=np.float64)})
        last = kk == depth - 1
        if last and not ghosts:
            dr.eval(counts)
            break
        sid = dr.reinterpret_array(u32, si.shape)
        sid = dr.select(hit, sid, 0)
        n = dr.normalize(si.n)
        if ghosts and kk >= 1:
            # Bistatic double-lobe scattering of the hit back to the receiver (ghosts).
            h = si.p
            to_rx = rx32 - h
            r_r = dr.norm(to_rx)
            ks = to_rx / r_r
            cos_i = -dr.dot(d, n)
            cos_s = dr.dot(ks, n)
            gscale = dr.gather(f32, table["gscale"], sid)
            ok = hit & (cos_i * cos_s > 0.0) & (gscale > 0.0)
            # Table lookups gather without a mask: keep the index finite on every lane.
            cos_i = dr.select(ok, dr.minimum(dr.abs(cos_i), 1.0), 1.0)
            mirror = d - 2.0 * dr.dot(d, n) * n
            lobe_b = dr.maximum(0.5 * (1.0 - dr.dot(ks, d)), 0.0)
            lobe_f = dr.maximum(0.5 * (1.0 + dr.dot(ks, mirror)), 0.0)
            row = dr.gather(u32, table["grow"], sid)
            offset = f32(row * SIGMA0_TABLE_SIZE)
            wb = interp_theta_table(table["wb"], SIGMA0_TABLE_SIZE, cos_i, DRJIT_OPS, offset)
            wf = interp_theta_table(table["wf"], SIGMA0_TABLE_SIZE, cos_i, DRJIT_OPS, offset)
            ab, af = dr.gather(f32, table["ab"], row), dr.gather(f32, table["af"], row)
            f_term = (wb * dr.select(lobe_b > 0.0, dr.exp(ab * dr.log(lobe_b)), 0.0)
                      + wf * dr.select(lobe_f > 0.0, dr.exp(af * dr.log(lobe_f)), 0.0))
            arrival = -ks
            ok &= (dr.dot(arrival, g_b) > 0.0) & (f_term > 0.0)
            ok &= ~scene.ray_test(si.spawn_ray_to(rx32), ok)
            hx, hy, hz = f64(h.x) - img[0], f64(h.y) - img[1], f64(h.z) - img[2]
            s_len = dr.sqrt(hx * hx + hy * hy + hz * hz)
            if planar:
                solid = k.f32("dq") * k.f32("slab_width") / f32(s_len)
            else:
                solid = k.f32("dp") * k.f32("dq") / z
            amp_rx = _field_pattern(arrival, g_az, g_el, k)
            length = s_len + f64(r_r)
            x_amp = amp_tx * field * amp_rx * dr.sqrt(solid * f_term * inv_4pi) / r_r
            scale = dr.select(k["normalized"] > 0.0,
                              math.sqrt(4.0 * math.pi) * dr.square(0.5 * length),
                              k["amp_const"])
            amp = f32(scale) * x_amp
            rate = dr.dot(ks, v_rx) - dr.dot(d, v_img)
            cell = k.f32("ghost_cell_inv")
            ix = u32(mi.Int32(dr.floor(h.x * cell)))
            iy = u32(mi.Int32(dr.floor(h.y * cell)))
            iz = u32(mi.Int32(dr.floor(h.z * cell)))
            speckle = mi.sample_tea_float32((ix * 73856093) ^ (iy * 19349663),
                                            (iz * 83492791) ^ sid)
            _mp_deposit(k, re, im, s, kk, length, rate, amp, speckle, ok)
        if last:
            dr.eval(counts)
            break
        # Specular reflection (paper eq. 5): direction, frame, image (float64), field factor.
        rho = dr.gather(f32, table["rho"], sid)
        nx, ny, nz = f64(n.x), f64(n.y), f64(n.z)
        off = ((img[0] - f64(si.p.x)) * nx + (img[1] - f64(si.p.y)) * ny
               + (img[2] - f64(si.p.z)) * nz)
        img = [img[0] - 2.0 * off * nx, img[1] - 2.0 * off * ny, img[2] - 2.0 * off * nz]
        d = dr.normalize(d - 2.0 * dr.dot(d, n) * n)
        e0 = e0 - 2.0 * dr.dot(e0, n) * n
        e1 = e1 - 2.0 * dr.dot(e1, n) * n
        e2 = e2 - 2.0 * dr.dot(e2, n) * n
        field = field * rho
        alive = hit & (rho > 0.0)
        o = si.spawn_ray(d).o
        dr.eval(o, d, e0, e1, e2, img, field, alive, counts)
    if stats is not None:
        totals = np.asarray(counts, dtype=np.int64)
        stats["segments"] = stats.get("segments", 0) + int(np.sum(totals & 0xFFFF))
        stats["captures"] = stats.get("captures", 0) + int(np.sum(totals >> 16))


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
            """Nothing to expose: the integrator has no differentiable parameters."""

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
                             progress: bool = False, setup: TraceSetup | None = None,
                             backscatter: bool = True
                             ) -> Iterator[tuple[NDArray, NDArray[np.complex128]]]:
            """Trace sweeps into histograms, one chunk of sweeps at a time.

            Parameters
            ----------
            scene : mitsuba.Scene
            geometry : dict
                :func:`mitsar.raw.product.sweep_geometry` of the whole acquisition.
            radar : Radar
            frames : ndarray, shape (sweeps, 3, 3)
                Antenna-to-world rotation at mid-sweep (:func:`antenna_frame`).
            scatterers : ScattererSet
            grid : (first_index, count)
                Histogram bin grid (:func:`mitsar.model.histogram.bin_grid`).
            sweeps : ndarray of int, optional
                Sweep indices to trace (default all), increasing.
            config : RadarIntegratorConfig, optional
                Overrides this integrator's configuration.
            rvp, normalized : bool
                Keep the residual video phase; unit amplitude per unit sqrt(RCS) (as
                :func:`mitsar.simulate_point_targets`).
            progress : bool
                Progress bar over launches.
            setup : TraceSetup, optional
                Ray frames, 2D plane, receiver and ray grid (:func:`make_setup`; default:
                monostatic, from ``config``).
            backscatter : bool
                Trace mechanism 1 (direct backscatter, order 0). It is monostatic: a bistatic
                ``setup`` needs ``backscatter=False``.

            Yields
            ------
            sweep_indices : ndarray of int
            histogram : ndarray, shape (len(sweep_indices), max_depth, bins), complex128
                Orders 0 .. max_depth - 1 (number of specular reflections).

            Notes
            -----
            ``self.statistics`` counts, for the last call: ``pairs`` (scatterer x sweep pairs of
            the acquisition), ``candidate_pairs`` (left by the chunk-level beam cull),
            ``shadow_rays`` (in the beam and the bin grid: traced and deposited if visible),
            kernel ``launches``, and for multipath ``rays`` (ray x sweep lanes), ``segments``
            (ray segments intersected) and ``captures`` (capture deposits).
            """
            config = self.config if config is None else config
            setup = make_setup(radar, frames, config) if setup is None else setup
            if setup.bistatic and backscatter:
                raise ParameterError(self._where, "backscatter", "False with a bistatic "
                                     "receiver (direct backscatter is traced monostatically "
                                     "only)", backscatter)
            orders = config.max_depth
            total = len(geometry["slow_time"])
            sweeps = np.arange(total) if sweeps is None else np.asarray(sweeps, dtype=np.int64)
            first_index, bins = grid
            count = len(scatterers) if backscatter else 0
            multipath = config.max_depth > 1 and setup.rays is not None
            self.statistics = {"pairs": 0, "candidate_pairs": 0, "shadow_rays": 0,
                               "launches": 0, "rays": 0, "segments": 0, "captures": 0}
            if count == 0 and not multipath:
                for start in range(0, len(sweeps), 1024):
                    chosen = sweeps[start:start + 1024]
                    yield chosen, np.zeros((len(chosen), orders, bins), np.complex128)
                return
            per_chunk = max(1, min(SWEEPS_PER_CHUNK, config.chunk_lanes,
                                   HISTOGRAM_CHUNK_ELEMENTS // (orders * bins)))
            device = self._upload(scatterers) if count else None
            step = hg.range_step(radar, config.bins_per_cell)
            target_speed = (float(np.linalg.norm(scatterers.velocity, axis=1).max())
                            if count else 0.0)
            max_speed = float(np.linalg.norm(geometry["velocity"], axis=1).max()) + target_speed
            k = self._constants(radar, config, first_index, bins, step, orders, rvp,
                                normalized, max_speed)
            k["slab_half"] = 0.5 * config.slab_width if setup.planar else 1e30
            if multipath:
                table = shape_table(scene)
                ray_dev = {"p": mi.Float(setup.rays.p), "q": mi.Float(setup.rays.q)}
                ray_ids = mi.UInt32(np.arange(len(setup.rays), dtype=np.uint32))
                dr.make_opaque(*ray_dev.values(), ray_ids)
                kmp = self._mp_constants(radar, config, k, setup.rays)
            bar = tqdm(total=len(sweeps), disable=not progress, desc="trace", unit="sweep")
            try:
                for s0 in range(0, len(sweeps), per_chunk):
                    chosen = sweeps[s0:s0 + per_chunk]
                    size = len(chosen) * orders * bins
                    # A buffer of one fixed size: its length is a literal of the compiled
                    # kernels, so sizing it per acquisition would recompile them every time.
                    re = dr.zeros(mi.Float64, max(size, HISTOGRAM_CHUNK_ELEMENTS))
                    im = dr.zeros(mi.Float64, max(size, HISTOGRAM_CHUNK_ELEMENTS))
                    if count:
                        self._backscatter_chunk(scene, device, geometry, frames, radar, setup,
                                                chosen, k, target_speed, count, config, re, im)
                    if multipath:
                        sw = self._mp_sweep_arrays(geometry, frames, setup, chosen)
                        block = max(1, min(config.chunk_lanes, MULTIPATH_CHUNK_LANES)
                                    // len(chosen))
                        for r0 in range(0, len(setup.rays), block):
                            width = min(block, len(setup.rays) - r0)
                            kmp["first"], kmp["sweeps"] = r0, len(chosen)
                            consts = _Constants(kmp, _MP_FLOAT_CONSTANTS, _MP_UINT_CONSTANTS)
                            _multipath_launch(scene, table, ray_dev, sw, consts, ray_ids,
                                              width * len(chosen), re, im, config.max_depth,
                                              config.capture, config.ghosts, setup.planar,
                                              stats=self.statistics)
                            self.statistics["rays"] += width * len(chosen)
                            self.statistics["launches"] += 1
                            dr.eval(re, im)
                    hist = (np.asarray(re)[:size] + 1j * np.asarray(im)[:size]).reshape(
                        len(chosen), orders, bins)
                    bar.update(len(chosen))
                    yield chosen, hist
            finally:
                bar.close()

        def trace_paths(self, scene: Any, geometry: dict, radar: Radar, frames: NDArray,
                        sweep: int, rays: NDArray, config: RadarIntegratorConfig,
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
            chosen = np.array([int(sweep)])
            k = self._constants(radar, config, 0, 2, hg.range_step(radar, config.bins_per_cell),
                                config.max_depth, True, False, 0.0)
            k["slab_half"] = 1e30
            kmp = self._mp_constants(radar, config, k, setup.rays)
            kmp["first"], kmp["sweeps"] = 0, 1
            kmp["last_lower"] = -1.0  # deposit nothing
            table = shape_table(scene)
            ray_dev = {"p": mi.Float(setup.rays.p), "q": mi.Float(setup.rays.q)}
            sw = self._mp_sweep_arrays(geometry, frames, setup, chosen)
            re = dr.zeros(mi.Float64, config.max_depth * 2)
            im = dr.zeros(mi.Float64, config.max_depth * 2)
            log: list = []
            _multipath_launch(scene, table, ray_dev, sw,
                              _Constants(kmp, _MP_FLOAT_CONSTANTS, _MP_UINT_CONSTANTS),
                              mi.UInt32(rays), len(rays), re, im, config.max_depth,
                              config.capture, False, setup.planar, log=log)
            return {key: np.stack([entry[key] for entry in log], axis=1) for key in log[0]}

        # ---- helpers -----------------------------------------------------------------

        def _backscatter_chunk(self, scene: Any, device: dict, geometry: dict, frames: NDArray,
                               radar: Radar, setup: TraceSetup, chosen: NDArray, k: dict,
                               target_speed: float, count: int,
                               config: RadarIntegratorConfig, re: Any, im: Any) -> None:
            """Mechanism 1 for one chunk of sweeps (deposits into order 0)."""
            sw = self._sweep_arrays(geometry, frames, radar, chosen, setup.plane_normals)
            k.update(self._chunk_bounds(geometry, frames, radar, chosen, target_speed))
            k["first"], k["sweeps"] = 0, len(chosen)
            candidates = _candidate_kernel(device, _pack_constants(k), count)
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

        @staticmethod
        def _mp_constants(radar: Radar, config: RadarIntegratorConfig, k: dict,
                          rays: Any) -> dict:
            out = {name: k[name] for name in ("fc", "chirp_rate", "fc_over_k", "first_range",
                                              "inv_step", "last_lower", "inv_beta_az",
                                              "inv_beta_el", "rvp", "normalized",
                                              "sweep_stride")}
            out.update(amp_const=multipath_amplitude_constant(radar),
                       norm_const=0.5 * math.sqrt(math.pi), dp=rays.dp, dq=rays.dq,
                       inv_dp=1.0 / rays.dp, inv_dq=1.0 / rays.dq,
                       slab_width=float(config.slab_width),
                       ghost_cell_inv=2.0 / radar.wavelength,
                       bins=k["sweep_stride"] // config.max_depth, first=0, sweeps=1)
            return out

        @staticmethod
        def _mp_sweep_arrays(geometry: dict, frames: NDArray, setup: TraceSetup,
                             chosen: NDArray) -> dict:
            padded = np.concatenate([chosen, np.full(-len(chosen) % _PACK, chosen[-1])])

            def upload(kind: type, values: NDArray) -> Any:
                return kind(np.ascontiguousarray(values))

            pos = geometry["position"][padded]
            vel = geometry["velocity"][padded]
            rx = pos + setup.receiver_offset
            ray_frames = setup.ray_frames[padded]
            va = np.einsum("sij,si->sj", ray_frames, vel)
            sw = {}
            for i, axis in enumerate("xyz"):
                sw["p" + axis] = upload(mi.Float64, pos[:, i])
                sw["p" + axis + "32"] = upload(mi.Float, pos[:, i])
                sw["q" + axis] = upload(mi.Float64, rx[:, i])
                sw["q" + axis + "32"] = upload(mi.Float, rx[:, i])
                sw["v" + axis] = upload(mi.Float, vel[:, i])
                sw[f"va{i}"] = upload(mi.Float, va[:, i])
            for name, values in (("f", frames[padded]), ("r", ray_frames),
                                 ("g", setup.receiver_frames[padded])):
                for i in range(3):
                    for j in range(3):
                        sw[f"{name}{i}{j}"] = upload(mi.Float, values[:, i, j])
            dr.make_opaque(*sw.values())
            return sw

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
                          chosen: NDArray, plane_normals: NDArray | None = None) -> dict:
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
            normals = (np.zeros((len(padded), 3)) if plane_normals is None
                       else plane_normals[padded])
            for i, axis in enumerate("xyz"):
                sw["n2" + axis] = upload(mi.Float, normals[:, i])
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
