"""Mechanism 1: direct backscatter of the scene's scatterers, traced as staged kernels.

Per chunk of sweeps (docs/design.md §5.4, docs/integrator.md):

1. :func:`candidates` — over all scatterers, those that may be in the beam of some sweep of the
   chunk (the beam test at the middle sweep, widened by how far the antenna moves and turns);
2. :func:`cull` — over candidate x sweep lanes, the exact beam, 2D-slab and bin-grid test in
   float32, compacted with ``dr.compress``: only survivors pay for shadow rays;
3. :func:`trace` — per surviving lane: geometry in float64, two-way pattern, σ⁰ from the
   material's monostatic table, visibility, the radar-equation amplitude and the
   :func:`~.deposit.deposit`.

Visibility is a shadow ray per lane, or, with visibility reuse (docs/integrator.md
§"Visibility reuse"), the answer of :func:`probe`, which casts the shadow rays of the first and
last sweep of each block of sweeps per candidate: lanes whose block ends agree take that answer,
the others cast their own ray.

Static 3-D scatterer sets with visibility reuse take the block kernel instead of steps 2-3
(:mod:`.blocks`, docs/integrator.md §"Performance"): :func:`shared_probe` (one ray per block
boundary), :func:`~.blocks.block_trace` over (candidate, block) pairs whose ends agree, and
:func:`split_trace` (steps 2-3 with a ray per lane) over the pairs whose ends disagree.
:func:`backscatter_chunk` runs the kernels for one chunk of sweeps.
"""

from __future__ import annotations

from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np
from numpy.typing import NDArray

from mitsar.model.doublelobe import TABLE_SIZE, interp_theta_table
from mitsar.model.elements import channel_amplitude_factor
from mitsar.model.geometry.antenna import field_pattern
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.geometry.visibility import (
    shared_probe_sweeps,
    sight_line_motion,
    visibility_blocks,
)
from mitsar.model.radar import Radar
from mitsar.model.signal import half_path
from mitsar.model.trace_options import TraceOptions
from mitsar.plugins.integrators.radar.blocks import (
    add_packets,
    amplitude_polynomial_holds,
    block_kernel_applies,
    block_trace,
    deposit_runs,
    fixed_point_scale,
    frame_sines,
    packet_buffer,
    packet_window,
)
from mitsar.plugins.integrators.radar.constants import (
    MAX_CHUNK_SWEEPS,
    Constants,
    ScattererArrays,
    SweepArrays,
    VisibilityBlocks,
    backscatter_sweep_arrays,
    chunk_bounds,
    chunk_step_arrays,
    lane_pairs,
    padded_lanes,
    shared_probe_arrays,
    visibility_block_arrays,
)
from mitsar.plugins.integrators.radar.deposit import deposit
from mitsar.plugins.integrators.radar.receivers import receiver_polynomial_holds
from mitsar.plugins.integrators.radar.setup import TraceSetup
from mitsar.plugins.ops import DRJIT_OPS
from mitsar.plugins.threads import deterministic, order_independent

SURFACE_OFFSET = 2e-5
"""Offset of a shadow ray's end above the surface, relative to ``1 + max|p|`` [-]."""


def _moved(position: Any, velocity: Any, scatterer: Any, time: Any, static: bool) -> Any:
    """A scatterer coordinate at ``time`` [s]: ``position + velocity[scatterer] time``
    (``velocity``: the device array of that coordinate's velocity, gathered as ``position``'s
    type); ``position`` itself in a static set (a kernel variant without the velocity gathers,
    compiled once)."""
    if static:
        return position
    return position + dr.gather(type(position), velocity, scatterer) * time


def candidates(scatterers: ScattererArrays, constants: Constants, count: int
               ) -> tuple[Any, Any, Any]:
    """Scatterers that may lie in the beam of some sweep of the chunk (``dr.compress``), and
    the smallest and largest of their ranges from the antenna at the middle sweep [m]
    (Float32, width 1).

    The beam test of :func:`cull` at the chunk's middle sweep, widened by how much a direction
    sine can change over the chunk: ``|u_s - u_mid| <= |d_s - d_mid| + |e_s - e_mid|`` with
    ``|d_s - d_mid| <= 2 disp / R_mid`` (antenna and target displacement ``disp``) and
    ``|e_s - e_mid| <= turn`` (the frame's largest column change).
    """
    f32 = mi.Float
    m, valid = padded_lanes(count)
    t = constants.f32("mid_time")
    o = mi.Vector3f(*(_moved(dr.gather(f32, position, m), velocity, m, t, scatterers.static)
                      - constants.f32(f"mid_p{a}")
                      for position, velocity, a in zip(scatterers.position32,
                                                       scatterers.velocity32, "xyz",
                                                       strict=True)))
    r = dr.norm(o)
    u_az, u_el, cos_b = frame_sines(o / r, lambda i, j: constants.f32(f"mid_f{i}{j}"))
    margin = 2.0 * constants.f32("mid_disp") / r + constants.f32("mid_turn") + 1e-4
    active = valid & (((cos_b > -margin) & (dr.abs(u_az) < constants.f32("cull_az") + margin)
                       & (dr.abs(u_el) < constants.f32("cull_el") + margin))
                      | (r <= 2.0 * constants.f32("mid_disp")))
    return (dr.compress(active), dr.min(dr.select(active, r, dr.inf)),
            dr.max(dr.select(active, r, 0.0)))


def cull(scatterers: ScattererArrays, sweep_arrays: SweepArrays, constants: Constants,
         found: Any, lanes: int) -> Any:
    """Indices of the (scatterer, sweep) lanes inside the beam and the bin grid.

    Cheap float32 geometry over every lane; only the surviving lanes (a small fraction for a
    room: the beam) pay for shadow rays, float64 phase and the scatter (``dr.compress``).
    """
    lane, valid = padded_lanes(lanes)
    s, m = lane_pairs(lane, constants, found)
    return dr.compress(valid & _in_beam(constants, scatterers, sweep_arrays, s, m))


def _in_beam(constants: Constants, scatterers: ScattererArrays, sweep_arrays: SweepArrays,
             sweep: Any, scatterer: Any) -> Any:
    """The exact beam, 2D-slab (``sweep_arrays.planar``) and bin-grid test of (``sweep``,
    ``scatterer``) lanes in float32."""
    f32 = mi.Float

    def at_sweep(array: Any) -> Any:
        return dr.gather(f32, array, sweep)

    t = None if scatterers.static else at_sweep(sweep_arrays.time32)
    o = mi.Vector3f(*(_moved(dr.gather(f32, position, scatterer), velocity, scatterer, t,
                             scatterers.static) - at_sweep(antenna)
                      for position, velocity, antenna in zip(
                          scatterers.position32, scatterers.velocity32,
                          sweep_arrays.position32, strict=True)))
    r = dr.norm(o)
    u_az, u_el, cos_b = frame_sines(o / r, lambda i, j: at_sweep(sweep_arrays.frame[i][j]))
    slack = 2.0 * constants.f32("inv_step")  # float32 range error << 2 bins
    x = (r - constants.f32("first_range")) * constants.f32("inv_step")
    active = ((cos_b > 0.0) & (dr.abs(u_az) < constants.f32("cull_az"))
              & (dr.abs(u_el) < constants.f32("cull_el")) & (r > 0.0))
    if sweep_arrays.planar:  # 2D mode: only the slab |(q - a).n| <= slab_half around the plane
        normal = sweep_arrays.plane_normal
        active &= dr.abs(o.x * at_sweep(normal[0]) + o.y * at_sweep(normal[1])
                         + o.z * at_sweep(normal[2])) <= constants.f32("slab_half")
    return (active
            & (x > -slack - constants.f32("doppler_bins"))
            & (x < constants.f32("last_lower") + slack + constants.f32("doppler_bins")))


def _lane_geometry(scatterers: ScattererArrays, sweep_arrays: SweepArrays, sweep: Any,
                   scatterer: Any) -> tuple[list, list, Any, Any, Any]:
    """Mid-sweep geometry of (``sweep``, ``scatterer``) lanes in float64: scatterer ``q``
    (moving with its velocity), antenna ``a``, range ``r``, ``1/r`` and the unit direction ``d``
    (float32), antenna -> scatterer."""
    f64, f32 = mi.Float64, mi.Float
    t = None if scatterers.static else dr.gather(f64, sweep_arrays.time, sweep)
    q = [_moved(dr.gather(f64, position, scatterer), velocity, scatterer, t, scatterers.static)
         for position, velocity in zip(scatterers.position, scatterers.velocity, strict=True)]
    a = [dr.gather(f64, antenna, sweep) for antenna in sweep_arrays.position]
    o = [qi - ai for qi, ai in zip(q, a, strict=True)]
    r = dr.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
    inv_r = 1.0 / r
    d = mi.Vector3f(*(f32(oi * inv_r) for oi in o))
    return q, a, r, inv_r, d


def _shadow_ray(scatterers: ScattererArrays, scatterer: Any, target: list, antenna: list,
                direction: Any, lit: Any = None) -> tuple[Any, Any]:
    """The shadow segment antenna -> point just above the surface of ``scatterer`` (at
    ``target``, float64 [m]) on the antenna's side (docs/integrator.md, "Shadow rays"), and the
    scatterer's normal; ``direction``: the unit vector antenna -> scatterer. ``lit``: the
    transmitter's direction, whose side a receiver's segment ends on (the lit face: a
    receiver across the surface's plane does not see it)."""
    f32 = mi.Float
    n = mi.Vector3f(*(dr.gather(f32, c, scatterer) for c in scatterers.normal))
    q32 = mi.Point3f(*(f32(qi) for qi in target))
    a32 = mi.Point3f(*(f32(ai) for ai in antenna))
    side = dr.select(dr.dot(n, direction if lit is None else lit) > 0.0, -1.0, 1.0)
    eps = SURFACE_OFFSET * (1.0 + dr.max(dr.abs(q32)))
    seg = (q32 + n * (side * eps)) - a32
    dist = dr.norm(seg)
    ray = mi.Ray3f(a32, seg / dist)
    ray.maxt = dist * (1.0 - 1e-6) - dr.gather(f32, scatterers.stop, scatterer)
    return ray, n


def _visible(scene: Any, scatterers: ScattererArrays, sweep_arrays: SweepArrays, sweep: Any,
             scatterer: Any, active: Any, antenna: Any = None) -> Any:
    """Shadow test of (``sweep``, ``scatterer``) lanes: True where the segment is free; from
    the transmitter, or from ``antenna`` (a receiver's position per sweep, Float64 Vector)."""
    q, a, _, _, d = _lane_geometry(scatterers, sweep_arrays, sweep, scatterer)
    lit = None
    if antenna is not None:  # its segment ends on the transmitter's (lit) side
        lit = d
        a, d = _toward(q, [dr.gather(mi.Float64, c, sweep) for c in antenna])
    ray, _ = _shadow_ray(scatterers, scatterer, q, a, d, lit)
    active = active & (ray.maxt > 0.0)
    return active & ~scene.ray_test(ray, active)


def _toward(target: list, antenna: list) -> tuple[list, Any]:
    """``antenna`` and the unit vector (float32) from it to ``target`` (float64 [m])."""
    o = [qi - ai for qi, ai in zip(target, antenna, strict=True)]
    inv = 1.0 / dr.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
    return antenna, mi.Vector3f(*(mi.Float(oi * inv) for oi in o))


def _agreed(transmitter: Any, receivers: list) -> Any:
    """One visibility code for a transmitter and its shadowing receivers (codes 0/1/2 of
    :func:`_block_visibility`): 0 where the transmitter is hidden at both ends (no echo for
    any receiver), 2 where it and every receiver see both ends, else 1 (the pair is traced
    sweep by sweep, each receiver its own ray)."""
    if not receivers:
        return transmitter
    u32 = mi.UInt32
    every = transmitter == 2
    for code in receivers:
        every &= code == 2
    return dr.select(transmitter == 0, u32(0), dr.select(every, u32(2), u32(1)))


def probe(scene: Any, scatterers: ScattererArrays, sweep_arrays: SweepArrays,
          constants: Constants, found: Any, width: int, blocks: int) -> Any:
    """Visibility of each (candidate, block) pair at its block's first and last sweep.

    Lanes are the ``width`` candidates ``first ..`` of the launch times the ``blocks`` blocks of
    the chunk, block-fastest. Returns the :func:`_block_visibility` code of each pair, read by
    :func:`trace` at ``local * blocks + block`` (docs/integrator.md §"Visibility reuse").
    """
    u32 = mi.UInt32
    idx, valid = padded_lanes(width * blocks)  # padding: code 0, never read
    local = idx // constants["blocks"]
    block = idx - local * constants["blocks"]
    m = dr.gather(u32, found, local + constants["first"])
    return dr.select(valid, _block_visibility(
        scene, scatterers, sweep_arrays, m,
        dr.gather(u32, sweep_arrays.blocks.first_sweep, block),
        dr.gather(u32, sweep_arrays.blocks.last_sweep, block)), 0)


def shared_probe(scene: Any, scatterers: ScattererArrays, sweep_arrays: SweepArrays,
                 constants: Constants, found: Any, width: int, probes: int, blocks: int
                 ) -> Any:
    """Visibility codes as :func:`probe` returns them, from one shadow ray per candidate and
    probed sweep (``sweep_arrays.probes.sweep``), each shared by two neighbouring blocks: block
    ``b`` counts the rays at its sweeps ``probes.first[b]`` and ``probes.end[b]`` (the next
    block's first; docs/integrator.md §"Visibility reuse", ``shared_ends``). Two kernels: the
    rays (lanes probe-slowest, ``constants["width"]`` candidates each), then the codes."""
    u32 = mi.UInt32
    shared = sweep_arrays.probes
    idx, _ = padded_lanes(width * probes)  # the extra rays repeat the last one, never read
    probe_index = idx // constants["width"]
    m = dr.gather(u32, found, idx - probe_index * constants["width"] + constants["first"])
    sweep = dr.gather(u32, shared.sweep, probe_index)
    lit = _visible(scene, scatterers, sweep_arrays, sweep, m, mi.Bool(True))
    # a receiver's ray only where the transmitter's sees (elsewhere no echo: _agreed)
    seen = [u32(dr.select(visible, 1, 0)) for visible in (lit, *(
        _visible(scene, scatterers, sweep_arrays, sweep, m, lit, antenna)
        for antenna in sweep_arrays.shadowing_receivers))]
    dr.eval(*seen)
    idx, valid = padded_lanes(width * blocks)  # padding: code 0, never read
    local = idx // constants["blocks"]
    block = idx - local * constants["blocks"]
    first = dr.gather(u32, shared.first, block) * constants["width"] + local
    end = dr.gather(u32, shared.end, block) * constants["width"] + local
    codes = [dr.gather(u32, rays, first) + dr.gather(u32, rays, end) for rays in seen]
    return dr.select(valid, _agreed(codes[0], codes[1:]), 0)


def trace(scene: Any, scatterers: ScattererArrays, sweep_arrays: SweepArrays,
          constants: Constants, found: Any, lanes: Any, re: Any, im: Any,
          visibility: Any = None) -> None:
    """Trace the culled lanes ``lanes`` and deposit them into ``re``/``im`` (order 0).

    Everything variable is in ``scatterers``, ``sweep_arrays`` (the chunk's) and ``constants``
    (packed), so the traced kernel is the same for every launch.
    ``visibility`` (optional) holds the :func:`probe` codes of the launch: lanes of pairs seen
    (hidden) at both ends of their block are taken as seen (hidden) without a ray, the others
    cast their own; without it every lane casts its own shadow ray.
    """
    position, valid = padded_lanes(dr.width(lanes))
    if dr.width(position) != dr.width(lanes):
        lanes = dr.gather(mi.UInt32, lanes, position)
    s, m = lane_pairs(lanes, constants, found)
    code = None
    if visibility is not None:
        local = lanes // constants["sweeps"]
        code = dr.gather(mi.UInt32, visibility,
                         local * constants["blocks"]
                         + dr.gather(mi.UInt32, sweep_arrays.blocks.block_of, s))
    _contribute(scene, scatterers, sweep_arrays, constants, s, m, valid, code, re, im)


def _block_visibility(scene: Any, scatterers: ScattererArrays, sweep_arrays: SweepArrays,
                      scatterer: Any, first_sweep: Any, last_sweep: Any) -> Any:
    """Visibility code of ``scatterer`` over blocks of sweeps ``first_sweep .. last_sweep``:
    the number of the two ends that see it (0, 1 or 2; one ray if they are one sweep), and
    with shadowing receivers the code they agree on (:func:`_agreed`)."""
    u32 = mi.UInt32
    single = first_sweep == last_sweep

    def ends(antenna: Any, lit: tuple[Any, Any]) -> tuple[Any, Any]:
        first = _visible(scene, scatterers, sweep_arrays, first_sweep, scatterer, lit[0],
                         antenna)
        last = dr.select(single, first, _visible(scene, scatterers, sweep_arrays, last_sweep,
                                                 scatterer, ~single & lit[1], antenna))
        return first, last

    def code(seen: tuple[Any, Any]) -> Any:
        return u32(dr.select(seen[0], 1, 0)) + u32(dr.select(seen[1], 1, 0))

    # a receiver's ray only where the transmitter's sees (elsewhere no echo: _agreed)
    transmitter = ends(None, (mi.Bool(True), mi.Bool(True)))
    return _agreed(code(transmitter), [code(ends(rx, transmitter))
                                       for rx in sweep_arrays.shadowing_receivers])


def _contribute(scene: Any, scatterers: ScattererArrays, sweep_arrays: SweepArrays,
                constants: Constants, sweep: Any, scatterer: Any, active: Any, code: Any,
                re: Any, im: Any) -> None:
    """Contribution of (``sweep``, ``scatterer``) lanes, deposited into ``re``/``im``.

    ``code`` (optional) is the visibility of the lane's block (:func:`_block_visibility`):
    2 / 0 take the lane as seen / hidden without a ray, 1 casts its own; None: every lane casts
    its own shadow ray.
    """
    f64, f32, u32 = mi.Float64, mi.Float, mi.UInt32

    def at_sweep(array: Any, kind: type = f64) -> Any:
        return dr.gather(kind, array, sweep)

    def at_scatterer(array: Any, kind: type = f64) -> Any:
        return dr.gather(kind, array, scatterer)

    # 1. Geometry at mid-sweep in float64: scatterer (moving with its velocity) and antenna.
    q, a, r, inv_r, d = _lane_geometry(scatterers, sweep_arrays, sweep, scatterer)
    v_rel = [-at_sweep(antenna) if scatterers.static
             else at_scatterer(target) - at_sweep(antenna)
             for target, antenna in zip(scatterers.velocity, sweep_arrays.velocity,
                                        strict=True)]
    rdot = sum((qi - ai) * vi for qi, ai, vi in zip(q, a, v_rel, strict=True)) * inv_r

    # 2. Two-way pattern: the one-way sinc^2 power pattern is the amplitude factor.
    u_az, u_el, u_b = frame_sines(d, lambda i, j: at_sweep(sweep_arrays.frame[i][j], f32))
    one_way = dr.square(field_pattern(u_az, u_el, constants.f32("beta_az"),
                                      constants.f32("beta_el"), DRJIT_OPS))

    # 3. sigma0 from the material's monostatic table (point targets: a row of ones).
    ray, n = _shadow_ray(scatterers, scatterer, q, a, d)
    sigma0 = interp_theta_table(scatterers.tables, TABLE_SIZE, dr.abs(dr.dot(n, d)), DRJIT_OPS,
                                offset=f32(at_scatterer(scatterers.table_row, u32)
                                           * TABLE_SIZE))
    sigma = sigma0 * at_scatterer(scatterers.weight, f32)
    active = active & (sigma > 0.0) & (ray.maxt > 0.0)

    # 4. Visibility: segment antenna -> point just above the surface on the antenna's side,
    #    or the block's shared answer when both of its ends agree.
    if code is None:
        active &= ~scene.ray_test(ray, active)
    else:
        retest = active & (code == 1)
        active &= dr.select(retest, ~scene.ray_test(ray, retest), code == 2)

    # 5. Amplitude (radar equation, paper eq. 2 with the two-way pattern) and the deposit of
    #    each receiver of the transmitter into its own histogram rows: at the range (one at
    #    the transmitter) or at half the exact path of a receiver elsewhere, with its rate
    #    (the receiver rides with the antenna: its velocity; the attitude's rate neglected).
    #    The scatterers and the transmitter's shadow ray are shared by its receivers (each
    #    away from it casts its own too, with receiver_visibility), and so is the two-way
    #    pattern unless receive elements have their own beams (sweep_arrays.beams): then each
    #    channel takes f_t f_r sqrt(G_t G_r) / G (channel_amplitude_factor,
    #    docs/interferometry.md §8).
    root_sigma = dr.sqrt(sigma)
    equation = dr.select(constants["normalized"] > 0.0, 1.0,
                         f32(constants["radar_const"] * inv_r * inv_r))
    amp = one_way * root_sigma * equation
    normalized = constants.value("normalized") > 0.0
    phase = at_scatterer(scatterers.phase)
    row = sweep * constants["sweep_stride"]
    for k, receiver in enumerate(sweep_arrays.receivers):
        if sweep_arrays.beams is not None:
            transmit, receive, gain_ratio = sweep_arrays.beams[k]
            amp = channel_amplitude_factor(u_az, u_el, u_b, transmit, receive, None,
                                           DRJIT_OPS) * root_sigma * equation
            if not normalized:  # sqrt(G_t G_r) / G: the radar equation's gain, per channel
                amp = amp * gain_ratio
        path, path_rate, seen = r, rdot, active
        if receiver is not None:
            b = [qi - at_sweep(rx) for qi, rx in zip(q, receiver, strict=True)]
            rb = dr.sqrt(b[0] * b[0] + b[1] * b[1] + b[2] * b[2])
            rbdot = sum(bi * vi for bi, vi in zip(b, v_rel, strict=True)) / rb
            path, path_rate = half_path(r, rb), half_path(rdot, rbdot)
            if sweep_arrays.receiver_visibility:  # 4'. its own shadow ray (the block's code
                # 2 holds for every receiver, _agreed)
                ray_rx, _ = _shadow_ray(scatterers, scatterer, q, *_toward(
                    q, [at_sweep(c) for c in receiver]), lit=d)
                test = active & (ray_rx.maxt > 0.0)
                if code is not None:
                    test &= code == 1
                seen = active & (ray_rx.maxt > 0.0) & ~scene.ray_test(ray_rx, test)
        base = row if k == 0 else row + k * constants["receiver_stride"]
        deposit(constants, re, im, base, path, path_rate, amp, phase, seen)


def backscatter_chunk(scene: Any, scatterers: ScattererArrays, geometry: SweepGeometry,
                      frames: NDArray, radar: Radar, setup: TraceSetup, chosen: NDArray,
                      acquisition: Constants, target_speed: float, config: TraceOptions,
                      re: Any, im: Any, statistics: dict[str, int],
                      visibility_block: int | None = None) -> None:
    """Mechanism 1 for one chunk of sweeps ``chosen`` (deposits into order 0).

    ``acquisition`` holds the acquisition's constants (:func:`~.constants.backscatter_constants`);
    the chunk's bounds and launch offsets replace theirs. ``statistics`` counts pairs,
    candidate pairs, shadow rays (contributions: lanes in the beam and the bin grid), launches,
    ``visibility_rays`` (rays of the block probes, every shadowing receiver's included: an
    upper bound, its rays being cast only where the transmitter's sees) and
    ``visibility_split`` (candidate x block pairs traced sweep by sweep: their ends, or the
    transmitter and a receiver, disagree). ``visibility_block`` caps the sweeps that share
    shadow rays (e.g. the sweeps between two scene changes; default: the chunk); blocks are
    cut by :func:`~mitsar.model.geometry.visibility.visibility_blocks` at
    ``config.visibility_feature``.
    """
    count = scatterers.count
    sweep_arrays = backscatter_sweep_arrays(geometry, frames, radar, chosen,
                                            setup.plane_normals, setup.channel_receivers)
    sweep_arrays.beams = setup.channel_beams
    sweep_arrays.receiver_visibility = bool(config.receiver_visibility)
    shadowing = 1 + len(sweep_arrays.shadowing_receivers)  # antennas casting shadow rays
    receivers = len(sweep_arrays.receivers)
    # how far a receiver's half path may differ from the transmitter's range [m]
    apart = max((0.5 * float(np.linalg.norm(rx[chosen] - geometry.position[chosen],
                                            axis=1).max())
                 for rx in setup.channel_receivers or () if rx is not None), default=0.0)
    chunk = {**chunk_bounds(geometry, frames, radar, chosen, target_speed),
             "first": 0, "sweeps": len(chosen)}
    motion = sight_line_motion(geometry.position[chosen], geometry.slow_time[chosen],
                               target_speed)
    # The block kernel (a lane per candidate over the chunk, docs/integrator.md §"Performance")
    # serves static 3D scatterer sets with shared shadow rays; moving sets, the 2D mode and a
    # ray per sweep keep the lane kernels. Its probes share the rays at block boundaries unless
    # the caller caps the blocks (e.g. at scene changes).
    # Elements with their own beams (setup.channel_beams: receive elements, or a transmit
    # element traced with its own beam) take the lane kernels: the block kernel's amplitude
    # polynomial is the traced antenna's two-way pattern, one for all.
    blocked = (block_kernel_applies(config, scatterers.static, sweep_arrays.planar)
               and len(chosen) <= MAX_CHUNK_SWEEPS and setup.channel_beams is None)
    shared = blocked and visibility_block is None
    blocks = visibility_blocks(motion, float(config.visibility_feature),
                               len(chosen) if visibility_block is None
                               else max(1, int(visibility_block)), shared_ends=shared)
    reuse = int(blocks[-1]) + 1 < len(chosen)  # else: a ray per sweep, no probe needed
    if reuse:
        sweep_arrays.blocks = visibility_block_arrays(blocks)
        block_sizes = np.bincount(blocks)
        if shared:
            probe_sweeps, probe_first, probe_end = shared_probe_sweeps(
                motion, blocks, float(config.visibility_feature))
            sweep_arrays.probes = shared_probe_arrays(probe_sweeps, probe_first, probe_end)
    block_count = int(blocks[-1]) + 1
    constants = acquisition.replace(**chunk, blocks=block_count)
    with order_independent():  # dr.compress returns the indices in increasing order
        found, nearest, farthest = candidates(scatterers, constants, count)
        dr.eval(found, nearest, farthest)
    width_found = dr.width(found)
    block = max(1, config.chunk_lanes // len(chosen))
    statistics["pairs"] += count * len(chosen)
    statistics["candidate_pairs"] += width_found * len(chosen)
    exact = deterministic()  # integer packets: the same bits on any number of threads
    packets = None
    if blocked and reuse:
        steps, uniform, half_span = chunk_step_arrays(geometry, frames, chosen)
        # The packets cover the bins the candidates can reach (their ranges at the middle
        # sweep, the antenna's excursion, the Doppler shift and two bins of float32 slack).
        bin_lo, bin_width = packet_window(float(nearest[0]), float(farthest[0]),
                                          half_span + apart, constants)
        constants = constants.replace(bin_lo=bin_lo, bin_width=bin_width)
        packets = packet_buffer(receivers * len(chosen), bin_width, exact)
    if packets is not None:
        sweep_arrays.step = steps
        polynomial = uniform and amplitude_polynomial_holds(half_span, float(nearest[0]),
                                                            radar)
        # receivers away from the transmitter: offsets from its deposit as polynomials where
        # their bound holds (receivers.py), else the exact half path per sweep
        position = geometry.position[chosen]
        receiver_polynomial = uniform and apart > 0.0 and receiver_polynomial_holds(
            0.5 * float(np.linalg.norm(position[-1] - position[0])),
            float(nearest[0]) - half_span, float(farthest[0]) + half_span, 2.0 * apart,
            float(np.linalg.norm(geometry.velocity[chosen], axis=1).max()), constants)
        units = fixed_point_scale(scatterers, constants) if exact else None
    for m0 in range(0, width_found, block):
        width = min(block, width_found - m0)
        constants = constants.replace(first=m0, width=width)
        statistics["launches"] += 1
        if packets is not None:
            with order_independent():  # shadow rays and integer packets: any thread count
                if shared:
                    visibility = shared_probe(scene, scatterers, sweep_arrays, constants,
                                              found, width, len(probe_sweeps), block_count)
                    statistics["visibility_rays"] += shadowing * width * len(probe_sweeps)
                else:
                    visibility = probe(scene, scatterers, sweep_arrays, constants, found,
                                       width, block_count)
                    statistics["visibility_rays"] += shadowing * width * int(
                        np.sum(np.minimum(block_sizes, 2)))
                dr.eval(visibility)
                first, end, irregular = deposit_runs(sweep_arrays.blocks, constants,
                                                     visibility, width)
                dr.eval(first, end, irregular)
                runs = None if dr.any(irregular)[0] else (first, end)
                contributions = block_trace(scatterers, sweep_arrays, constants, found,
                                            visibility, width, packets, uniform, polynomial,
                                            units, runs, receiver_polynomial)
                dr.eval(packets, contributions)
                # Every contribution is counted by the block kernel, the split pairs' too.
                statistics["shadow_rays"] += int(dr.sum(contributions)[0])
                split = dr.compress(visibility == 1)  # in order: any thread count
            statistics["visibility_split"] += dr.width(split)
            if dr.width(split):
                split_trace(scene, scatterers, sweep_arrays, constants, found, split,
                            len(chosen), re, im)
            dr.eval(re, im)
            continue
        lanes = cull(scatterers, sweep_arrays, constants, found, len(chosen) * width)
        statistics["shadow_rays"] += dr.width(lanes)
        if dr.width(lanes):
            visibility = None
            if reuse:
                visibility = probe(scene, scatterers, sweep_arrays, constants, found, width,
                                   block_count)
                dr.eval(visibility)
                statistics["visibility_rays"] += shadowing * width * int(
                    np.sum(np.minimum(block_sizes, 2)))
                statistics["visibility_split"] += int(dr.count(visibility == 1)[0])
            trace(scene, scatterers, sweep_arrays, constants, found, lanes, re, im, visibility)
        dr.eval(re, im)
    if packets is not None:
        with order_independent():  # one add per bin (no conflicts): any thread count
            add_packets(packets, constants, len(chosen), constants.value("bin_width"), re, im,
                        units, receivers)
            dr.eval(re, im)


def _split_lanes(blocks: VisibilityBlocks, constants: Constants, found: Any, split: Any,
                 lanes: Any) -> tuple[Any, Any, Any]:
    """Lane -> (sweep, scatterer, inside its block) for :func:`split_trace`:
    ``constants["sweeps"]`` lanes per split pair ``split[lane // sweeps]`` (a :func:`probe`
    index), the ``j``-th sweep of the pair's block."""
    u32 = mi.UInt32
    pair_slot = lanes // constants["sweeps"]
    j = lanes - pair_slot * constants["sweeps"]
    pair = dr.gather(u32, split, pair_slot)
    local = pair // constants["blocks"]
    block = pair - local * constants["blocks"]
    s = dr.gather(u32, blocks.first_sweep, block) + j
    m = dr.gather(u32, found, local + constants["first"])
    return s, m, s <= dr.gather(u32, blocks.last_sweep, block)


def split_trace(scene: Any, scatterers: ScattererArrays, sweep_arrays: SweepArrays,
                constants: Constants, found: Any, split: Any, sweeps: int, re: Any, im: Any
                ) -> int:
    """Trace the sweeps of the (candidate, block) pairs whose block ends disagree (``split``:
    their :func:`probe` indices) as :func:`cull` + :func:`trace` do, a shadow ray per lane
    in the beam and the bin grid. ``sweeps`` (the chunk's length, ``constants["sweeps"]``)
    lanes per pair bound its block. Returns the number of lanes in the beam and the bin
    grid."""
    idx, valid = padded_lanes(dr.width(split) * sweeps)
    s, m, inside = _split_lanes(sweep_arrays.blocks, constants, found, split, idx)
    kept = dr.compress(valid & inside & _in_beam(constants, scatterers, sweep_arrays, s, m))
    count = dr.width(kept)
    if count:
        position, valid = padded_lanes(count)
        if dr.width(position) != count:
            kept = dr.gather(mi.UInt32, kept, position)
        s, m, _ = _split_lanes(sweep_arrays.blocks, constants, found, split, kept)
        _contribute(scene, scatterers, sweep_arrays, constants, s, m, valid, None, re, im)
    return count
