"""Mechanism 1: direct backscatter of the scene's scatterers, traced as three staged kernels.

Per chunk of sweeps (docs/design.md §5.4, docs/integrator.md):

1. :func:`candidates` — over all scatterers, those that may be in the beam of some sweep of the
   chunk (the beam test at the middle sweep, widened by how far the antenna moves and turns);
2. :func:`cull` — over candidate x sweep lanes, the exact beam, 2D-slab and bin-grid test in
   float32, compacted with ``dr.compress``: only survivors pay for shadow rays;
3. :func:`trace` — per surviving lane: geometry in float64, two-way pattern, σ⁰ from the
   material's monostatic table, a shadow ray, the radar-equation amplitude and the
   :func:`~.deposit.deposit`.

:func:`backscatter_chunk` runs the three for one chunk of sweeps.
"""

from __future__ import annotations

from typing import Any

import drjit as dr
import mitsuba as mi
from numpy.typing import NDArray

from mitsar.model.doublelobe import TABLE_SIZE, interp_theta_table
from mitsar.model.geometry.antenna import field_pattern
from mitsar.model.radar import Radar
from mitsar.plugins.integrators.radar.config import RadarIntegratorConfig
from mitsar.plugins.integrators.radar.constants import (
    BACKSCATTER_FLOATS,
    Constants,
    backscatter_sweep_arrays,
    chunk_bounds,
    lane_pairs,
)
from mitsar.plugins.integrators.radar.deposit import deposit
from mitsar.plugins.integrators.radar.setup import TraceSetup
from mitsar.plugins.ops import DRJIT_OPS

SURFACE_OFFSET = 2e-5
"""Offset of a shadow ray's end above the surface, relative to ``1 + max|p|`` [-]."""


def _frame_sines(d: Any, get: Any, prefix: str) -> tuple[Any, Any, Any]:
    """Direction sines of ``d`` in the frame whose entries ``get(prefix + "ij")`` returns."""
    return tuple(d.x * get(f"{prefix}0{j}") + d.y * get(f"{prefix}1{j}")
                 + d.z * get(f"{prefix}2{j}") for j in range(3))


def candidates(sc: dict, k: Constants, count: int) -> Any:
    """Scatterers that may lie in the beam of some sweep of the chunk (``dr.compress``).

    The beam test of :func:`cull` at the chunk's middle sweep, widened by how much a direction
    sine can change over the chunk: ``|u_s - u_mid| <= |d_s - d_mid| + |e_s - e_mid|`` with
    ``|d_s - d_mid| <= 2 disp / R_mid`` (antenna and target displacement ``disp``) and
    ``|e_s - e_mid| <= turn`` (the frame's largest column change).
    """
    f32 = mi.Float
    m = dr.arange(mi.UInt32, count)
    t = k.f32("mid_time")
    o = mi.Vector3f(*(dr.gather(f32, sc[f"p{a}32"], m) + dr.gather(f32, sc[f"v{a}32"], m) * t
                      - k.f32(f"mid_p{a}") for a in "xyz"))
    r = dr.norm(o)
    u_az, u_el, cos_b = _frame_sines(o / r, k.f32, "mid_f")
    margin = 2.0 * k.f32("mid_disp") / r + k.f32("mid_turn") + 1e-4
    active = ((cos_b > -margin) & (dr.abs(u_az) < k.f32("cull_az") + margin)
              & (dr.abs(u_el) < k.f32("cull_el") + margin)) | (r <= 2.0 * k.f32("mid_disp"))
    return dr.compress(active)


def cull(sc: dict, sw: dict, k: Constants, found: Any, lanes: int) -> Any:
    """Indices of the (scatterer, sweep) lanes inside the beam and the bin grid.

    Cheap float32 geometry over every lane; only the surviving lanes (a small fraction for a
    room: the beam) pay for shadow rays, float64 phase and the scatter (``dr.compress``).
    """
    f32 = mi.Float
    s, m = lane_pairs(dr.arange(mi.UInt32, lanes), k, found)

    def gs(name: str) -> Any:
        return dr.gather(f32, sw[name], s)

    def gm(name: str) -> Any:
        return dr.gather(f32, sc[name], m)

    t = gs("time32")
    o = mi.Vector3f(*(gm(f"p{a}32") + gm(f"v{a}32") * t - gs(f"p{a}32") for a in "xyz"))
    r = dr.norm(o)
    u_az, u_el, cos_b = _frame_sines(o / r, gs, "f")
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


def trace(scene: Any, sc: dict, sw: dict, k: Constants, found: Any, lanes: Any, re: Any,
          im: Any) -> None:
    """Trace the culled lanes ``lanes`` and deposit them into ``re``/``im`` (order 0).

    Everything variable is in ``sc`` (scatterer arrays), ``sw`` (sweep arrays of the chunk) and
    ``k`` (packed constants), so the traced kernel is the same for every launch.
    """
    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    s, m = lane_pairs(lanes, k, found)

    def gs(name: str, kind: type = f64) -> Any:
        return dr.gather(kind, sw[name], s)

    def gm(name: str, kind: type = f64) -> Any:
        return dr.gather(kind, sc[name], m)

    # 1. Geometry at mid-sweep in float64: scatterer (moving with its velocity) and antenna.
    t = gs("time")
    q = [gm(f"p{a}") + gm(f"v{a}") * t for a in "xyz"]
    a = [gs(f"p{a}") for a in "xyz"]
    o = [qi - ai for qi, ai in zip(q, a, strict=True)]
    r = dr.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
    inv_r = 1.0 / r
    rdot = sum(oi * (gm(f"v{ax}") - gs(f"v{ax}")) for oi, ax in zip(o, "xyz", strict=True)) * inv_r
    d = mi.Vector3f(*(f32(oi * inv_r) for oi in o))

    # 2. Two-way pattern: the one-way sinc^2 power pattern is the amplitude factor.
    u_az, u_el, _ = _frame_sines(d, lambda name: gs(name, f32), "f")
    one_way = dr.square(field_pattern(u_az, u_el, k.f32("beta_az"), k.f32("beta_el"),
                                      DRJIT_OPS))

    # 3. sigma0 from the material's monostatic table (point targets: a row of ones).
    n = mi.Vector3f(gm("nx", f32), gm("ny", f32), gm("nz", f32))
    n_dot_d = dr.dot(n, d)
    sigma0 = interp_theta_table(sc["tables"], TABLE_SIZE, dr.abs(n_dot_d), DRJIT_OPS,
                                offset=f32(gm("row", u32) * TABLE_SIZE))
    sigma = sigma0 * gm("weight", f32)
    active = sigma > 0.0

    # 4. Visibility: segment antenna -> point just above the surface on the antenna's side.
    q32 = mi.Point3f(*(f32(qi) for qi in q))
    a32 = mi.Point3f(*(f32(ai) for ai in a))
    side = dr.select(n_dot_d > 0.0, -1.0, 1.0)
    eps = SURFACE_OFFSET * (1.0 + dr.max(dr.abs(q32)))
    seg = (q32 + n * (side * eps)) - a32
    dist = dr.norm(seg)
    ray = mi.Ray3f(a32, seg / dist)
    ray.maxt = dist * (1.0 - 1e-6) - gm("stop", f32)
    active &= ray.maxt > 0.0
    active &= ~scene.ray_test(ray, active)

    # 5. Amplitude (radar equation, paper eq. 2 with the two-way pattern) and the deposit.
    amp = one_way * dr.sqrt(sigma) * dr.select(k["normalized"] > 0.0, 1.0,
                                               f32(k["radar_const"] * inv_r * inv_r))
    deposit(k, re, im, s * k["sweep_stride"], r, rdot, amp, gm("phase"), active)


def backscatter_chunk(scene: Any, device: dict, geometry: dict, frames: NDArray, radar: Radar,
                      setup: TraceSetup, chosen: NDArray, k: dict, target_speed: float,
                      config: RadarIntegratorConfig, re: Any, im: Any,
                      statistics: dict[str, int]) -> None:
    """Mechanism 1 for one chunk of sweeps ``chosen`` (deposits into order 0).

    ``k`` holds the acquisition's constants (:func:`~.constants.backscatter_constants`); the
    chunk's bounds are added to it. ``statistics`` counts pairs, candidate pairs, shadow rays
    and launches.
    """
    count = dr.width(device["weight"])
    sw = backscatter_sweep_arrays(geometry, frames, radar, chosen, setup.plane_normals)
    k.update(chunk_bounds(geometry, frames, radar, chosen, target_speed))
    k["first"], k["sweeps"] = 0, len(chosen)
    found = candidates(device, Constants(k, BACKSCATTER_FLOATS), count)
    width_found = dr.width(found)
    block = max(1, config.chunk_lanes // len(chosen))
    statistics["pairs"] += count * len(chosen)
    statistics["candidate_pairs"] += width_found * len(chosen)
    for m0 in range(0, width_found, block):
        width = min(block, width_found - m0)
        k["first"] = m0
        consts = Constants(k, BACKSCATTER_FLOATS)
        lanes = cull(device, sw, consts, found, len(chosen) * width)
        statistics["shadow_rays"] += dr.width(lanes)
        statistics["launches"] += 1
        if dr.width(lanes):
            trace(scene, device, sw, consts, found, lanes, re, im)
        dr.eval(re, im)
