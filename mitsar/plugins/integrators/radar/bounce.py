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
from collections.abc import Callable
from dataclasses import dataclass, fields
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
from mitsar.model.elements import element_field_pattern
from mitsar.model.geometry.antenna import field_pattern
from mitsar.model.multipath import RaySet, capture_weight
from mitsar.plugins.integrators.radar.constants import (
    Constants,
    Frame,
    MultipathSweepArrays,
    lane_pairs,
    padded_lanes,
)
from mitsar.plugins.integrators.radar.deposit import deposit
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.plugins.ops import DRJIT_OPS


@dataclass
class ShapeTable:
    """Per-shape device arrays of the multipath kernel (:func:`shape_table`); the per-shape
    ones are indexed by the Dr.Jit registry id of the shape.

    Attributes
    ----------
    specular_field : mi.Float
        Stacked θ-tables of the specular field factor ``Γ(θ_i) R``
        (:func:`mitsar.model.doublelobe.specular_field_table`), flattened.
    specular_row : mi.UInt32
        Per shape, its row of ``specular_field``; row 0 is zero: the ray stops (absorbers,
        point-target markers, other BSDFs, and the shapes whose specular returns physical
        optics gives, docs/physical_optics.md §5).
    ghost_scale : mi.Float
        Per shape, 1 where ghosts may scatter (double-lobe materials), else 0.
    ghost_row : mi.UInt32
        Per shape, its row of the ghost tables.
    backscatter_weight, forward_weight : mi.Float
        Stacked θ-tables ``4π Γ² S² w_B,F(θ_i)`` [1/sr] of the backscatter and specular lobes
        (:func:`mitsar.model.doublelobe.bistatic_lobe_tables`), flattened.
    backscatter_exponent, forward_exponent : mi.Float
        Per row, the lobe exponents ``α_B``, ``α_F``.
    speckle_key : mi.UInt32
        Per shape, the key of its ghosts' frozen speckle phases: a hash of the shape's place in
        the scene and the trace's seed (:attr:`~mitsar.model.trace_options.TraceOptions.seed`),
        so that the same scene and seed give the same ghosts on every load (the registry id
        of a shape changes from one load to the next).
    """

    specular_field: Any
    specular_row: Any
    ghost_scale: Any
    ghost_row: Any
    backscatter_weight: Any
    forward_weight: Any
    backscatter_exponent: Any
    forward_exponent: Any
    speckle_key: Any


@dataclass
class RayArrays:
    """The multipath ray grid (:class:`~mitsar.model.multipath.RaySet`) as device arrays.

    Attributes
    ----------
    sine_p, sine_q : mi.Float
        Direction sines of each launch direction along the ray frame's axes 0 and 1.
    """

    sine_p: Any
    sine_q: Any


def ray_arrays(rays: RaySet) -> tuple[RayArrays, Any]:
    """The ray grid's device arrays and the ray indices ``0 .. len(rays) - 1`` (UInt32)."""
    arrays = RayArrays(sine_p=mi.Float(rays.p), sine_q=mi.Float(rays.q))
    ids = mi.UInt32(np.arange(len(rays), dtype=np.uint32))
    dr.make_opaque(arrays.sine_p, arrays.sine_q, ids)
    return arrays, ids


def shape_table(scene: Any, absorbers: tuple[Any, ...] = (), seed: int = 0) -> ShapeTable:
    """The :class:`ShapeTable` of a scene; the shapes in ``absorbers`` stop multipath rays;
    ``seed`` keys the ghosts' speckle phases."""
    shapes = list(scene.shapes())
    ids = [int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0]) for shape in shapes]
    stops = {int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0]) for shape in absorbers}
    size = max(ids + [0]) + 1
    srow = np.zeros(size, dtype=np.uint32)
    # the shape's place in the scene and the seed, mixed (splitmix-style odd multipliers)
    key = np.zeros(size, dtype=np.uint32)
    key[ids] = ((np.arange(1, len(ids) + 1, dtype=np.uint64) * 0x9E3779B1
                 + (int(seed) & 0xFFFFFFFF) * 0x85EBCA77) & 0xFFFFFFFF).astype(np.uint32)
    specular: list[Any] = [None]
    gscale = np.zeros(size)
    grow = np.zeros(size, dtype=np.uint32)
    rows: list[Any] = []
    for ident, shape in zip(ids, shapes, strict=True):
        bsdf = shape.bsdf()
        material = getattr(bsdf, "material", None) \
            if plugin_kind(bsdf) is PluginKind.DOUBLELOBE else None
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
    table = ShapeTable(specular_field=f32(rho.ravel()), specular_row=mi.UInt32(srow),
                       ghost_scale=f32(gscale), ghost_row=mi.UInt32(grow),
                       backscatter_weight=f32(wb.ravel()), forward_weight=f32(wf.ravel()),
                       backscatter_exponent=f32(ab), forward_exponent=f32(af),
                       speckle_key=mi.UInt32(key))
    dr.make_opaque(*(getattr(table, field.name) for field in fields(table)))
    return table


def _column(frame: Frame, j: int, at_sweep: Callable[[Any], Any]) -> Any:
    """Column ``j`` of a per-sweep rotation (an antenna or ray axis, world frame), each entry
    gathered by ``at_sweep``."""
    return mi.Vector3f(at_sweep(frame[0][j]), at_sweep(frame[1][j]), at_sweep(frame[2][j]))


def _field_pattern(direction: Any, az: Any, el: Any, constants: Constants) -> Any:
    """One-way field pattern of ``direction`` for the antenna axes ``az``, ``el``."""
    return field_pattern(dr.dot(direction, az), dr.dot(direction, el), constants.f32("beta_az"),
                         constants.f32("beta_el"), DRJIT_OPS)


def receive_pattern(arrival: Any, axes: tuple, constants: Constants,
                    sweep_arrays: MultipathSweepArrays, receiver: int) -> Any:
    """One-way field pattern [-] of receiver ``receiver`` toward the unit ``arrival`` direction
    (from the receiver): the radar's antenna (``axes``: its azimuth, elevation and boresight
    axes, world frame), or the receive element's own beam (``sweep_arrays.beams``) on the
    direction sines in the radar's frame, times ``sqrt(G_t G_r) / G`` with the radar equation
    (:func:`mitsar.model.elements.channel_amplitude_factor`'s receive part; the launch
    pattern is the transmitter's: the radar's antenna, or its element's own beam, which the
    tracer then follows, ``trace_run._transmit_beam``)."""
    if sweep_arrays.beams is None:
        return _field_pattern(arrival, axes[0], axes[1], constants)
    _, receive, gain_ratio = sweep_arrays.beams[receiver]
    u_az, u_el, u_b = (dr.dot(arrival, axis) for axis in axes)
    pattern = element_field_pattern(u_az, u_el, u_b, receive, DRJIT_OPS)
    if constants.value("normalized") > 0.0:
        return pattern
    return pattern * gain_ratio


def receive_front(axes: tuple, sweep_arrays: MultipathSweepArrays, receiver: int) -> Any:
    """The receiver's boresight (world frame): the radar's (``axes[2]``), or its element's
    (the third row of its rotation, in the radar's axes ``axes``)."""
    if sweep_arrays.beams is None or sweep_arrays.beams[receiver][1].identity:
        return axes[2]
    row = sweep_arrays.beams[receiver][1].rotation[2]
    return axes[0] * row[0] + axes[1] * row[1] + axes[2] * row[2]


def _order_base(constants: Constants, sweep: Any, order: int, receiver: int = 0) -> Any:
    """Index of bin 0 of the histogram row (sweep, receiver, order)."""
    base = sweep * constants["sweep_stride"] + constants["bins"] * order
    return base if receiver == 0 else base + receiver * constants["receiver_stride"]


def capture_deposit(constants: Constants, re: Any, im: Any, sweep_arrays: MultipathSweepArrays,
                    chosen: Any, s_all: Any, img_all: list, frame_all: tuple, field_all: Any,
                    amp_tx_all: Any, weight_all: Any, order: int, receiver: int = 0) -> None:
    """Deposit the captured lanes ``chosen``: image-method amplitude (capture-weighted), delay
    ``L/c`` with ``L = |rx - img|`` in float64, Doppler of the image geometry; into the rows
    of ``receiver`` (its index in ``sweep_arrays.receivers``)."""
    f64, f32 = mi.Float64, mi.Float
    position, valid = padded_lanes(dr.width(chosen))  # the extra lanes deposit nothing
    if dr.width(position) != dr.width(chosen):
        chosen = dr.gather(mi.UInt32, chosen, position)
    s = dr.gather(mi.UInt32, s_all, chosen)

    def gs(array: Any, kind: type = f32) -> Any:
        return dr.gather(kind, array, s)

    def gl(values: Any, kind: type = f32) -> Any:
        return dr.gather(kind, values, chosen)

    img = [gl(c, f64) for c in img_all]
    e0, e1, e2 = (mi.Vector3f(gl(e.x), gl(e.y), gl(e.z)) for e in frame_all)
    at = sweep_arrays.receivers[receiver]  # the receiver's position per sweep
    wx, wy, wz = (gs(at[0], f64) - img[0], gs(at[1], f64) - img[1], gs(at[2], f64) - img[2])
    length = dr.sqrt(wx * wx + wy * wy + wz * wz)
    inv = 1.0 / length
    wn = mi.Vector3f(f32(wx * inv), f32(wy * inv), f32(wz * inv))
    amp_rx = receive_pattern(-wn, tuple(_column(sweep_arrays.receiver_frame, j, gs)
                                        for j in range(3)), constants, sweep_arrays, receiver)
    scale = dr.select(constants["normalized"] > 0.0, constants["norm_const"] * length,
                      constants["amp_const"] * inv)
    amp = f32(scale) * gl(weight_all) * gl(field_all) * gl(amp_tx_all) * amp_rx
    va = sweep_arrays.ray_velocity
    v_img = e0 * gs(va[0]) + e1 * gs(va[1]) + e2 * gs(va[2])
    velocity = sweep_arrays.velocity
    rate = dr.dot(wn, mi.Vector3f(gs(velocity[0]), gs(velocity[1]), gs(velocity[2])) - v_img)
    deposit(constants, re, im, _order_base(constants, s, order, receiver), 0.5 * length,
            0.5 * f64(rate), amp, None, dr.full(mi.Bool, True, dr.width(chosen)) & valid)


def ghost_deposit(scene: Any, table: ShapeTable, constants: Constants, re: Any, im: Any, s: Any,
                  order: int, si: Any, sid: Any, n: Any, d: Any, hit: Any, img: list,
                  rx32: Any, v_rx: Any, v_img: Any, g_axes: tuple, field: Any, amp_tx: Any,
                  z: Any, planar: bool, sweep_arrays: MultipathSweepArrays,
                  receiver: int = 0) -> None:
    """Bistatic double-lobe scattering of the hits back to the receiver (ghosts).

    ``σ⁰ = cos θ_i [W_B lobe(ψ_B)^α_B + W_F lobe(ψ_F)^α_F]`` from the material's tables, over
    the ray tube's area (solid angle ``dp dq / z`` in 3D, ``dq x slab`` in 2D), with a speckle
    phase frozen per half-wavelength cell of the hit point. ``rx32`` is receiver ``receiver``'s
    position (its rows of the histogram); its own shadow ray.
    """
    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    h = si.p
    to_rx = rx32 - h
    r_r = dr.norm(to_rx)
    ks = to_rx / r_r
    cos_i = -dr.dot(d, n)
    cos_s = dr.dot(ks, n)
    gscale = dr.gather(f32, table.ghost_scale, sid)
    ok = hit & (cos_i * cos_s > 0.0) & (gscale > 0.0)
    # Table lookups gather without a mask: keep the index finite on every lane.
    cos_i = dr.select(ok, dr.minimum(dr.abs(cos_i), 1.0), 1.0)
    mirror = d - 2.0 * dr.dot(d, n) * n
    row = dr.gather(u32, table.ghost_row, sid)
    offset = f32(row * TABLE_SIZE)
    wb = interp_theta_table(table.backscatter_weight, TABLE_SIZE, cos_i, DRJIT_OPS, offset)
    wf = interp_theta_table(table.forward_weight, TABLE_SIZE, cos_i, DRJIT_OPS, offset)
    ab = dr.gather(f32, table.backscatter_exponent, row)
    af = dr.gather(f32, table.forward_exponent, row)
    f_term = double_lobe_pattern(-dr.dot(ks, d), dr.dot(ks, mirror), wb, wf, ab, af, DRJIT_OPS)
    arrival = -ks
    ok &= (dr.dot(arrival, receive_front(g_axes, sweep_arrays, receiver)) > 0.0) & (f_term > 0.0)
    ok &= ~scene.ray_test(si.spawn_ray_to(rx32), ok)
    hx, hy, hz = f64(h.x) - img[0], f64(h.y) - img[1], f64(h.z) - img[2]
    s_len = dr.sqrt(hx * hx + hy * hy + hz * hz)
    if planar:
        solid = constants.f32("dq") * constants.f32("slab_width") / f32(s_len)
    else:
        solid = constants.f32("dp") * constants.f32("dq") / z
    amp_rx = receive_pattern(arrival, g_axes, constants, sweep_arrays, receiver)
    length = s_len + f64(r_r)
    x_amp = amp_tx * field * amp_rx * dr.sqrt(solid * f_term / (4.0 * math.pi)) / r_r
    scale = dr.select(constants["normalized"] > 0.0,
                      math.sqrt(4.0 * math.pi) * dr.square(0.5 * length),
                      constants["amp_const"])
    rate = dr.dot(ks, v_rx) - dr.dot(d, v_img)
    cell = constants.f32("ghost_cell_inv")
    ix, iy, iz = (u32(mi.Int32(dr.floor(c * cell))) for c in (h.x, h.y, h.z))
    key = dr.gather(u32, table.speckle_key, sid)
    speckle = mi.sample_tea_float32((ix * 73856093) ^ (iy * 19349663), (iz * 83492791) ^ key)
    deposit(constants, re, im, _order_base(constants, s, order, receiver), 0.5 * length,
            0.5 * f64(rate), f32(scale) * x_amp, speckle, ok)


def launch(scene: Any, table: ShapeTable, rays: RayArrays, sweep_arrays: MultipathSweepArrays,
           constants: Constants, ray_ids: Any,
           lanes: int, re: Any, im: Any, depth: int, capture: str, ghosts: bool, planar: bool,
           log: list | None = None, stats: dict | None = None) -> None:
    """Shoot ``lanes`` rays (ray x sweep lanes) through up to ``depth`` hits and deposit.

    Lane ``idx`` is sweep ``idx % sweeps`` of the chunk and ray ``ray_ids[first + idx //
    sweeps]``. ``log`` (a list) receives per segment a dict of NumPy arrays (path log);
    ``stats`` counts ``segments`` and ``captures``.
    """
    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32
    lane, valid = padded_lanes(lanes)  # the extra lanes are never alive
    traced, lanes = lanes, dr.width(lane)
    s, i = lane_pairs(lane, constants, ray_ids)

    def gs(array: Any, kind: type = f32) -> Any:
        return dr.gather(kind, array, s)

    p = dr.gather(f32, rays.sine_p, i)
    q = dr.gather(f32, rays.sine_q, i)
    z = dr.safe_sqrt(1.0 - p * p - q * q)
    ray_frame, antenna_frame = sweep_arrays.ray_frame, sweep_arrays.antenna_frame
    e0, e1, e2 = (_column(ray_frame, 0, gs), _column(ray_frame, 1, gs),
                  _column(ray_frame, 2, gs))
    d = dr.normalize(e0 * p + e1 * q + e2 * z)
    amp_tx = _field_pattern(d, _column(antenna_frame, 0, gs), _column(antenna_frame, 1, gs),
                            constants)
    dr.eval(amp_tx, s, p, q, z)
    g_axes = tuple(_column(sweep_arrays.receiver_frame, j, gs) for j in range(3))
    # every receiver of the transmitter: captures and ghosts of the same rays, each into its
    # own rows (docs/interferometry.md §8)
    receivers32 = [mi.Point3f(*(gs(c) for c in rx)) for rx in sweep_arrays.receivers32]
    v_rx = mi.Vector3f(*(gs(c) for c in sweep_arrays.velocity))
    va0, va1, va2 = (gs(c) for c in sweep_arrays.ray_velocity)
    img = [gs(c, f64) for c in sweep_arrays.transmitter]
    o = mi.Point3f(*(gs(c) for c in sweep_arrays.transmitter32))
    field = dr.full(f32, 1.0, lanes)
    alive = (z > 0.0) & valid
    counts = dr.zeros(u32, lanes)  # segments + 2^16 x captures of the lane (work counters)

    for kk in range(depth):
        counts = counts + dr.select(alive, 1, 0)
        si = scene.ray_intersect(mi.Ray3f(o, d), mi.RayFlags.Minimal, False, alive)
        hit = alive & si.is_valid()
        t_hit = dr.select(hit, si.t, dr.inf)
        v_img = e0 * va0 + e1 * va1 + e2 * va2  # image velocity M v_tx
        weight = dr.zeros(f32, lanes)
        captures = []
        for k, rx32 in enumerate(receivers32 if kk >= 1 else ()):
            # 1. Capture test in float32 on every lane: the receiver's launch coordinates seen
            # from the image; the float64 deposit runs on the few captured lanes only.
            wn = dr.normalize(rx32 - mi.Point3f(f32(img[0]), f32(img[1]), f32(img[2])))
            t_r = dr.dot(rx32 - o, d)
            ok = (alive & (dr.dot(wn, e2) > 0.0) & (t_r > 0.0) & (t_r < t_hit)
                  & (dr.dot(wn, receive_front(g_axes, sweep_arrays, k)) < 0.0))
            captured = (capture_weight(dr.dot(wn, e0) - p, constants.f32("dp"), capture,
                                       DRJIT_OPS)
                        * capture_weight(dr.dot(wn, e1) - q, constants.f32("dq"), capture,
                                         DRJIT_OPS))
            captures.append(dr.select(ok & (captured > 0.0), captured, 0.0))
        if captures:
            dr.eval(*captures)  # every receiver's test in one pass over the lanes
            for k, captured in enumerate(captures):
                chosen = dr.compress(captured > 0.0)
                if dr.width(chosen):
                    capture_deposit(constants, re, im, sweep_arrays, chosen, s, img,
                                    (e0, e1, e2), field, amp_tx, captured, kk, k)
            # the path log and the work counters follow the first receiver
            weight = captures[0]
            counts = counts + dr.select(weight > 0.0, 65536, 0)
        if log is not None:  # the traced lanes, not the padding
            log.append({"origin": np.array(o, dtype=np.float64).T[:traced],
                        "direction": np.array(d, dtype=np.float64).T[:traced],
                        "t_hit": np.array(t_hit, dtype=np.float64)[:traced],
                        "hit": np.array(hit, dtype=bool)[:traced],
                        "alive": np.array(alive, dtype=bool)[:traced],
                        "field": np.array(field, dtype=np.float64)[:traced],
                        "pattern": np.array(amp_tx, dtype=np.float64)[:traced] ** 2,
                        "image": np.array([np.array(c, dtype=np.float64)
                                           for c in img]).T[:traced],
                        "captured": np.array(weight, dtype=np.float64)[:traced]})
        last = kk == depth - 1
        if last and not ghosts:
            dr.eval(counts)
            break
        sid = dr.select(hit, dr.reinterpret_array(u32, si.shape), 0)
        n = dr.normalize(si.n)
        for k, rx32 in enumerate(receivers32 if ghosts and kk >= 1 else ()):
            # 2. Ghosts: bistatic scattering of the hit back to each receiver.
            ghost_deposit(scene, table, constants, re, im, s, kk, si, sid, n, d, hit, img, rx32,
                          v_rx, v_img, g_axes, field, amp_tx, z, planar, sweep_arrays, k)
        if last:
            dr.eval(counts)
            break
        # 3. Specular reflection (paper eq. 5): direction, frame, image (float64), field factor.
        # The table lookup gathers without a mask: keep the index finite on every lane.
        cos_i = dr.select(hit, dr.minimum(dr.abs(dr.dot(d, n)), 1.0), 1.0)
        row = f32(dr.gather(u32, table.specular_row, sid) * TABLE_SIZE)
        rho = interp_theta_table(table.specular_field, TABLE_SIZE, cos_i, DRJIT_OPS, row)
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
