"""Mechanism 2: multipath by shooting and bouncing rays (docs/design.md §5.4, docs/multipath.md).

A fixed grid of launch directions in the antenna's ray frame
(:func:`mitsar.model.multipath.ray_set`) is traced for every sweep of a chunk in one wavefront
(one lane per ray x sweep), with ``scene.ray_intersect`` per bounce (a Python loop over the depth
only). Each lane carries its origin and direction, the transmitter's image (float64), the
reflected ray frame and the product of the field factors ``Γ R``. After every reflection:

1. **capture** — the receiver is tested against the ray's tube
   (:func:`mitsar.model.multipath.capture_weight` on the launch coordinates of the receiver seen
   from the image); captured lanes deposit the image-method amplitude at order = number of
   reflections, delay ``L/c``, Doppler of the image geometry (:func:`capture_deposit`);
2. **ghosts** (optional) — every hit after the first scatters back to the receiver through the
   material's bistatic double-lobe pattern, shadow-tested (:func:`ghost_deposit`);
3. **reflection** — direction, frame and image are mirrored (paper eq. 5) and the field factor
   multiplied by ``Γ(θ_i) R`` of the material, interpolated at the hit's incidence in the
   material's θ-table (:func:`mitsar.model.doublelobe.specular_field_table`): constant for a
   ``doublelobe``, the Fresnel slab reflection for Sionna's radio materials.
"""

from __future__ import annotations

import math
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np

from mitsar.model.doublelobe import (
    TABLE_SIZE,
    bistatic_lobe_tables,
    double_lobe_pattern,
    interp_theta_table,
    specular_field_table,
)
from mitsar.model.geometry.antenna import field_pattern
from mitsar.model.multipath import capture_weight
from mitsar.plugins.integrators.radar.constants import Constants, lane_pairs
from mitsar.plugins.integrators.radar.deposit import deposit
from mitsar.plugins.ops import DRJIT_OPS


def shape_table(scene: Any, absorbers: tuple[Any, ...] = ()) -> dict:
    """Per-shape values of the multipath kernel, indexed by Dr.Jit registry id of the shape.

    ``rho``: stacked θ-tables of the specular field factor ``Γ(θ_i) R``
    (:func:`mitsar.model.doublelobe.specular_field_table`), row ``srow`` of the shape (row 0 is
    zero: the ray stops: absorbers, point-target markers, other BSDFs, and the shapes in
    ``absorbers``, whose specular returns physical optics gives, docs/physical_optics.md §5);
    ``gscale``: 1 where
    ghosts may scatter (double-lobe materials); ``grow``: row of the ghost tables ``wb``,
    ``wf``, ``ab``, ``af`` (:func:`mitsar.model.doublelobe.bistatic_lobe_tables`).
    """
    shapes = list(scene.shapes())
    ids = [int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0]) for shape in shapes]
    stops = {int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0]) for shape in absorbers}
    size = max(ids + [0]) + 1
    srow = np.zeros(size, dtype=np.uint32)
    specular: list[Any] = [None]
    gscale = np.zeros(size)
    grow = np.zeros(size, dtype=np.uint32)
    rows: list[Any] = []
    for ident, shape in zip(ids, shapes, strict=True):
        bsdf = shape.bsdf()
        material = getattr(bsdf, "material", None) \
            if getattr(bsdf, "MITSAR_KIND", None) == "doublelobe" else None
        if material is None:
            continue
        if material.specular_fraction > 0.0 and ident not in stops:
            if material not in specular:
                specular.append(material)
            srow[ident] = specular.index(material)
        if material.scattered_fraction > 0.0:
            if material not in rows:
                rows.append(material)
            gscale[ident] = 1.0
            grow[ident] = rows.index(material)
    wb, wf, ab, af = bistatic_lobe_tables(rows, TABLE_SIZE)
    f32 = mi.Float
    rho = specular_field_table(specular, TABLE_SIZE)
    out = {"rho": f32(rho.ravel()), "srow": mi.UInt32(srow), "gscale": f32(gscale),
           "grow": mi.UInt32(grow),
           "wb": f32(wb.ravel()), "wf": f32(wf.ravel()), "ab": f32(ab), "af": f32(af)}
    dr.make_opaque(*out.values())
    return out


def _column(get: Any, prefix: str, j: int) -> Any:
    return mi.Vector3f(get(f"{prefix}0{j}"), get(f"{prefix}1{j}"), get(f"{prefix}2{j}"))


def _field_pattern(direction: Any, az: Any, el: Any, k: Constants) -> Any:
    """One-way field pattern of ``direction`` for the antenna axes ``az``, ``el``."""
    return field_pattern(dr.dot(direction, az), dr.dot(direction, el), k.f32("beta_az"),
                         k.f32("beta_el"), DRJIT_OPS)


def _order_base(k: Constants, s: Any, order: int) -> Any:
    return s * k["sweep_stride"] + k["bins"] * order


def capture_deposit(k: Constants, re: Any, im: Any, sw: dict, chosen: Any, s_all: Any,
                    img_all: list, frame_all: tuple, field_all: Any, amp_tx_all: Any,
                    weight_all: Any, order: int) -> None:
    """Deposit the captured lanes ``chosen``: image-method amplitude (capture-weighted), delay
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
    deposit(k, re, im, _order_base(k, s, order), 0.5 * length, 0.5 * f64(rate), amp, None,
            dr.full(mi.Bool, True, dr.width(chosen)))


def ghost_deposit(scene: Any, table: dict, k: Constants, re: Any, im: Any, s: Any,
                  order: int, si: Any, sid: Any, n: Any, d: Any, hit: Any, img: list,
                  rx32: Any, v_rx: Any, v_img: Any, g_axes: tuple, field: Any, amp_tx: Any,
                  z: Any, planar: bool) -> None:
    """Bistatic double-lobe scattering of the hits back to the receiver (ghosts).

    ``σ⁰ = cos θ_i [W_B lobe(ψ_B)^α_B + W_F lobe(ψ_F)^α_F]`` from the material's tables, over
    the ray tube's area (solid angle ``dp dq / z`` in 3D, ``dq x slab`` in 2D), with a speckle
    phase frozen per half-wavelength cell of the hit point.
    """
    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    g_az, g_el, g_b = g_axes
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
    row = dr.gather(u32, table["grow"], sid)
    offset = f32(row * TABLE_SIZE)
    wb = interp_theta_table(table["wb"], TABLE_SIZE, cos_i, DRJIT_OPS, offset)
    wf = interp_theta_table(table["wf"], TABLE_SIZE, cos_i, DRJIT_OPS, offset)
    ab, af = dr.gather(f32, table["ab"], row), dr.gather(f32, table["af"], row)
    f_term = double_lobe_pattern(-dr.dot(ks, d), dr.dot(ks, mirror), wb, wf, ab, af, DRJIT_OPS)
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
    x_amp = amp_tx * field * amp_rx * dr.sqrt(solid * f_term / (4.0 * math.pi)) / r_r
    scale = dr.select(k["normalized"] > 0.0,
                      math.sqrt(4.0 * math.pi) * dr.square(0.5 * length), k["amp_const"])
    rate = dr.dot(ks, v_rx) - dr.dot(d, v_img)
    cell = k.f32("ghost_cell_inv")
    ix, iy, iz = (u32(mi.Int32(dr.floor(c * cell))) for c in (h.x, h.y, h.z))
    speckle = mi.sample_tea_float32((ix * 73856093) ^ (iy * 19349663), (iz * 83492791) ^ sid)
    deposit(k, re, im, _order_base(k, s, order), 0.5 * length, 0.5 * f64(rate),
            f32(scale) * x_amp, speckle, ok)


def launch(scene: Any, table: dict, rays: dict, sw: dict, k: Constants, ray_ids: Any,
           lanes: int, re: Any, im: Any, depth: int, capture: str, ghosts: bool, planar: bool,
           log: list | None = None, stats: dict | None = None) -> None:
    """Shoot ``lanes`` rays (ray x sweep lanes) through up to ``depth`` hits and deposit.

    Lane ``idx`` is sweep ``idx % sweeps`` of the chunk and ray ``ray_ids[first + idx //
    sweeps]``. ``log`` (a list) receives per segment a dict of NumPy arrays (path log);
    ``stats`` counts ``segments`` and ``captures``.
    """
    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    s, i = lane_pairs(dr.arange(u32, lanes), k, ray_ids)

    def gs(name: str, kind: type = f32) -> Any:
        return dr.gather(kind, sw[name], s)

    p = dr.gather(f32, rays["p"], i)
    q = dr.gather(f32, rays["q"], i)
    z = dr.safe_sqrt(1.0 - p * p - q * q)
    e0, e1, e2 = _column(gs, "r", 0), _column(gs, "r", 1), _column(gs, "r", 2)
    d = dr.normalize(e0 * p + e1 * q + e2 * z)
    amp_tx = _field_pattern(d, _column(gs, "f", 0), _column(gs, "f", 1), k)
    dr.eval(amp_tx, s, p, q, z)
    g_axes = (_column(gs, "g", 0), _column(gs, "g", 1), _column(gs, "g", 2))
    rx32 = mi.Point3f(gs("qx32"), gs("qy32"), gs("qz32"))
    v_rx = mi.Vector3f(gs("vx"), gs("vy"), gs("vz"))
    va0, va1, va2 = gs("va0"), gs("va1"), gs("va2")
    img = [gs("px", f64), gs("py", f64), gs("pz", f64)]
    o = mi.Point3f(gs("px32"), gs("py32"), gs("pz32"))
    field = dr.full(f32, 1.0, lanes)
    alive = z > 0.0
    counts = dr.zeros(u32, lanes)  # segments + 2^16 x captures of the lane (work counters)

    for kk in range(depth):
        counts = counts + dr.select(alive, 1, 0)
        si = scene.ray_intersect(mi.Ray3f(o, d), mi.RayFlags.Minimal, False, alive)
        hit = alive & si.is_valid()
        t_hit = dr.select(hit, si.t, dr.inf)
        v_img = e0 * va0 + e1 * va1 + e2 * va2  # image velocity M v_tx
        weight = dr.zeros(f32, lanes)
        if kk >= 1:
            # 1. Capture test in float32 on every lane: the receiver's launch coordinates seen
            # from the image; the float64 deposit runs on the few captured lanes only.
            wn = dr.normalize(rx32 - mi.Point3f(f32(img[0]), f32(img[1]), f32(img[2])))
            t_r = dr.dot(rx32 - o, d)
            ok = (alive & (dr.dot(wn, e2) > 0.0) & (t_r > 0.0) & (t_r < t_hit)
                  & (dr.dot(wn, g_axes[2]) < 0.0))
            weight = (capture_weight(dr.dot(wn, e0) - p, k.f32("dp"), capture, DRJIT_OPS)
                      * capture_weight(dr.dot(wn, e1) - q, k.f32("dq"), capture, DRJIT_OPS))
            ok &= weight > 0.0
            weight = dr.select(ok, weight, 0.0)
            dr.eval(weight)
            chosen = dr.compress(weight > 0.0)
            if dr.width(chosen):
                capture_deposit(k, re, im, sw, chosen, s, img, (e0, e1, e2), field, amp_tx,
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
        sid = dr.select(hit, dr.reinterpret_array(u32, si.shape), 0)
        n = dr.normalize(si.n)
        if ghosts and kk >= 1:
            # 2. Ghosts: bistatic scattering of the hit back to the receiver.
            ghost_deposit(scene, table, k, re, im, s, kk, si, sid, n, d, hit, img, rx32, v_rx,
                          v_img, g_axes, field, amp_tx, z, planar)
        if last:
            dr.eval(counts)
            break
        # 3. Specular reflection (paper eq. 5): direction, frame, image (float64), field factor.
        # The table lookup gathers without a mask: keep the index finite on every lane.
        cos_i = dr.select(hit, dr.minimum(dr.abs(dr.dot(d, n)), 1.0), 1.0)
        row = f32(dr.gather(u32, table["srow"], sid) * TABLE_SIZE)
        rho = interp_theta_table(table["rho"], TABLE_SIZE, cos_i, DRJIT_OPS, row)
        nx, ny, nz = f64(n.x), f64(n.y), f64(n.z)
        off = ((img[0] - f64(si.p.x)) * nx + (img[1] - f64(si.p.y)) * ny
               + (img[2] - f64(si.p.z)) * nz)
        img = [img[0] - 2.0 * off * nx, img[1] - 2.0 * off * ny, img[2] - 2.0 * off * nz]
        d = dr.normalize(d - 2.0 * dr.dot(d, n) * n)
        e0, e1, e2 = (e - 2.0 * dr.dot(e, n) * n for e in (e0, e1, e2))
        field = field * rho
        alive = hit & (rho > 0.0)
        o = si.spawn_ray(d).o
        dr.eval(o, d, e0, e1, e2, img, field, alive, counts)
    if stats is not None:
        totals = np.asarray(counts, dtype=np.int64)
        stats["segments"] = stats.get("segments", 0) + int(np.sum(totals & 0xFFFF))
        stats["captures"] = stats.get("captures", 0) + int(np.sum(totals >> 16))
