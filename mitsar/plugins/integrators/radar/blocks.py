"""Mechanism 1's block kernel: one lane per candidate scatterer of a chunk of sweeps, advanced
in float32 from the chunk's middle sweep, deposited as packets (docs/integrator.md
§"Performance").

:func:`block_trace` is the kernel; :func:`packet_buffer` and :func:`add_packets` hold and fold its
deposits into the histogram. :func:`~.backscatter.backscatter_chunk` runs it for static 3-D
scatterer sets whose shadow rays are shared by visibility blocks (the probes, and the lanes of
blocks whose ends disagree, stay in :mod:`.backscatter`).
"""

from __future__ import annotations

import importlib
import math
import platform
from collections.abc import Callable
from types import SimpleNamespace
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np

from mitsar.model import histogram as hg
from mitsar.model.doublelobe import TABLE_SIZE, interp_theta_table
from mitsar.model.geometry.antenna import field_pattern
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import half_path
from mitsar.plugins.integrators.radar.config import histogram_buffer_length
from mitsar.plugins.integrators.radar.constants import (
    MAX_HALF_SPAN,
    Constants,
    ScattererArrays,
    SweepArrays,
    VisibilityBlocks,
    padded_lanes,
)
from mitsar.plugins.integrators.radar.receivers import horner, receiver_offsets
from mitsar.plugins.ops import DRJIT_OPS, sincos_turns


def _packet_type(integer: bool) -> type:
    """Four int64 (fixed point) or four float32 per lane in the active variant's Dr.Jit
    namespace (e.g. ``drjit.llvm.ad``): the packet of :func:`block_trace` (resolved at call
    time: a variant must be set)."""
    namespace = importlib.import_module(type(mi.Float()).__module__)
    return namespace.Array4i64 if integer else namespace.Array4f


FIXED_POINT_BITS = 40
"""Fixed-point units per amplitude bound (:func:`fixed_point_scale`): 2^40, so a bin may sum
2^22 deposits at the bound before an int64 overflows."""


_ROUNDING_MAGIC = 1.5 * 2.0**52
_MAGIC_BITS = 0x4338000000000000
"""The bits of :data:`_ROUNDING_MAGIC` as an int64: ``bits(x + magic) - bits(magic)`` is
``round(x)`` for |x| < 2^51."""


def direct_rounding() -> bool:
    """Whether the packets may round a float32 deposit straight to int64 (``Int64(round(x))``)
    on the active variant's CPU instead of through :data:`_ROUNDING_MAGIC`: on the LLVM backend
    where the host converts float32 to int64 in one vector instruction (x86 with AVX-512DQ,
    ``vcvttps2qq``; any other architecture LLVM targets), not on x86 without it, where LLVM
    would convert lane by lane (NumPy's CPU dispatch names the host's features; Dr.Jit's LLVM
    backend compiles for the same host). Both round half to even, so the packets, hence the
    traces, are the same bits either way (``tests/test_block_kernel.py``); the CUDA variants
    keep the magic number (not re-measured on a GPU)."""
    if not mi.variant().startswith("llvm"):
        return False
    if platform.machine().lower() not in ("x86_64", "amd64", "i386", "i686"):
        return True
    try:  # NumPy >= 2 (numpy._core), else 1.26 (numpy.core)
        from numpy._core._multiarray_umath import __cpu_features__ as features
    except ImportError:
        try:
            from numpy.core._multiarray_umath import __cpu_features__ as features
        except ImportError:   # no dispatch table: keep the portable magic number
            return False
    return bool(features.get("AVX512DQ"))


def fixed_point_scale(scatterers: ScattererArrays, constants: Constants) -> float:
    """Fixed-point units per amplitude unit for the packets of :func:`block_trace`.

    Integer sums do not depend on the order of their terms, so the packets sum to the same
    bits on any number of threads (docs/integrator.md §"Determinism"). The amplitude of a
    deposit is at most ``sqrt(max sigma0 table x max area share)`` (pattern <= 1) times, unless
    normalised, the radar equation's ``radar_const / R^2`` at the nearest range a deposit can
    have: a deposit lies in the bin grid, so its range is at least the grid's first range less
    the Doppler shift of the apparent range (a fraction of a metre); half the first range,
    and no less than 5 cm, bounds it. The bound maps to 2^:data:`FIXED_POINT_BITS` units: one
    unit is ~1e-12 of the bound, below the float32 rounding of the deposits themselves.
    """
    if scatterers.sigma_bound is None:  # a property of the scatterer set: reduced once
        scatterers.sigma_bound = (float(dr.max(scatterers.tables)[0])
                                  * float(dr.max(scatterers.weight)[0]))
    bound = math.sqrt(max(scatterers.sigma_bound, 1e-300))
    if constants.value("normalized") <= 0.0:
        nearest = max(0.5 * float(constants.value("first_range")), 0.05)
        bound *= float(constants.value("radar_const")) / nearest**2
    return 2.0**FIXED_POINT_BITS / bound


def frame_sines(direction: Any, frame: Callable[[int, int], Any]) -> tuple[Any, Any, Any]:
    """Direction sines of ``direction`` (a Vector3f, world frame) along the axes of an antenna
    frame: ``direction . column j`` for ``j`` = 0, 1, 2 (azimuth, elevation, boresight), the
    entries ``(i, j)`` of the antenna-to-world rotation given by ``frame(i, j)``."""
    return tuple(direction.x * frame(0, j) + direction.y * frame(1, j)
                 + direction.z * frame(2, j) for j in range(3))


AMPLITUDE_DEGREE = 6
"""Degree of the amplitude's polynomial in the sweep index over a chunk."""

AMPLITUDE_NODES = tuple(math.cos(math.pi * (2 * i + 1) / (2 * AMPLITUDE_DEGREE + 2))
                        for i in range(AMPLITUDE_DEGREE + 1))
"""Chebyshev nodes of the amplitude's polynomial over a chunk, on [-1, 1]."""

_MONOMIAL = np.linalg.inv(np.vander(AMPLITUDE_NODES, AMPLITUDE_DEGREE + 1,
                                    increasing=True)).tolist()
"""``coefficient[p] = sum_i _MONOMIAL[p][i] a_i``: the polynomial in ``t`` through the values
``a_i`` at :data:`AMPLITUDE_NODES` (inverse Vandermonde matrix)."""

AMPLITUDE_SPAN_LIMIT = 0.4
"""Largest antenna displacement from the anchor sweep over a chunk, in beamwidths times the
nearest candidate's range, for the amplitude polynomial: there the degree-6 Chebyshev
interpolant holds the two-way field pattern sinc²(u/β) to -86 dB of its peak at any position
in the beam cull (tests/test_block_kernel.py); nearer chunks evaluate the amplitude exactly per
sweep (docs/integrator.md §"Performance")."""

def block_kernel_applies(config: Any, static: bool, planar: bool) -> bool:
    """Whether the block kernel traces direct backscatter (docs/integrator.md §"Performance"):
    asked for (``config.block_kernel``), a static scatterer set, the 3-D mode and shadow rays
    shared by blocks of sweeps (``config.visibility_feature > 0``)."""
    return bool(config.block_kernel and static and not planar
                and config.visibility_feature > 0.0)


def block_chunk_sweeps(sweeps: int, bins: int, positions: Any) -> int:
    """Sweeps per chunk for the block kernel, at most ``sweeps``.

    Shorter where the packets of a chunk would overflow :data:`PACKET_BUFFER_LIMIT` (wide bin
    grids, down to :data:`MIN_PACKET_SWEEPS`; beyond that the lane kernels trace the chunk) and
    where the antenna moves more than :data:`MAX_HALF_SPAN` from the anchor (``positions``: the
    antenna at the traced sweeps [m]; a chunk of ``n`` sweeps spans ``n // 2`` steps).
    """
    fitting = PACKET_BUFFER_LIMIT // (4 * max(int(bins), 1))
    if MIN_PACKET_SWEEPS <= fitting < sweeps:
        sweeps = fitting
    positions = np.asarray(positions, dtype=float)
    if len(positions) > 1:
        step = float(np.linalg.norm(np.diff(positions, axis=0), axis=1).max())
        if step > 0.0:
            sweeps = max(1, min(sweeps, 2 * int(MAX_HALF_SPAN / step) + 1))
    return sweeps


def amplitude_polynomial_holds(half_span: float, nearest: float, radar: Any) -> bool:
    """Whether the amplitude polynomial serves a chunk (:data:`AMPLITUDE_SPAN_LIMIT`).

    Parameters
    ----------
    half_span : float
        Largest antenna displacement from the anchor sweep over the chunk [m].
    nearest : float
        Smallest range of a candidate scatterer from the antenna at the anchor sweep [m].
    radar : Radar
        Its beamwidths [rad] (the narrower counts).
    """
    beamwidth = min(radar.azimuth_beamwidth, radar.elevation_beamwidth)
    closest = nearest - half_span  # no candidate comes nearer during the chunk
    return closest > 0.0 and half_span <= AMPLITUDE_SPAN_LIMIT * beamwidth * closest


def beam_sweeps(sines: tuple, steps: tuple, reach_az: Any, reach_el: Any) -> tuple[Any, Any]:
    """The interval ``(lo, hi)`` of sweep offsets ``j`` where a scatterer can be in the beam.

    The unnormalised direction sines along the antenna axes are linear in ``j`` on a uniform
    chunk, ``s(j) = s_0 - j d`` (:func:`block_trace`); the beam test needs ``s_b > 0``,
    ``|s_az| < reach_az`` and ``|s_el| < reach_el`` (the cull's beamwidths times a bound on the
    range over the chunk). Each is an interval (or half-line) of ``j``; their intersection is
    returned, empty when ``lo > hi``.
    """
    big = 1e30
    lo, hi = -big, big
    for s0, d, reach in zip(sines[:2], steps[:2], (reach_az, reach_el), strict=True):
        flat = dr.abs(d) < 1e-30
        a = (s0 - reach) / dr.select(flat, 1.0, d)
        b = (s0 + reach) / dr.select(flat, 1.0, d)
        inside = dr.abs(s0) < reach
        lo = dr.maximum(lo, dr.select(flat, dr.select(inside, -big, big), dr.minimum(a, b)))
        hi = dr.minimum(hi, dr.select(flat, dr.select(inside, big, -big), dr.maximum(a, b)))
    s0, d = sines[2], steps[2]  # boresight component: s0 - j d > 0
    flat = dr.abs(d) < 1e-30
    edge = s0 / dr.select(flat, 1.0, d)
    lo = dr.maximum(lo, dr.select(flat | (d > 0.0), dr.select(flat & (s0 <= 0.0), big, -big),
                                  edge))
    hi = dr.minimum(hi, dr.select(flat | (d < 0.0), dr.select(flat & (s0 <= 0.0), -big, big),
                                  edge))
    return lo, hi


def deposit_runs(blocks: VisibilityBlocks, constants: Constants, visibility: Any, width: int
                 ) -> tuple[Any, Any, Any]:
    """Per candidate of the launch, the sweeps its blocks seen at both ends (probe code 2)
    cover when they are one run: ``(first, end)`` (``first == end``: none), and whether they
    are not (``irregular``: seen blocks separated by hidden or split ones). A launch without
    irregular candidates lets :func:`block_trace` test the run with two 32-bit compares."""
    u32 = mi.UInt32
    local, _ = padded_lanes(width)  # the extra lanes repeat the last (block_trace's width)
    lanes = dr.width(local)

    def body(b: Any, first: Any, end: Any, before: Any, irregular: Any) -> tuple:
        seen = dr.gather(u32, visibility, local * constants["blocks"] + b) == 2
        starts = seen & ~before
        irregular |= starts & (end > 0)
        first = dr.select(starts & (end == 0), dr.gather(u32, blocks.first_sweep, b), first)
        end = dr.select(seen, dr.gather(u32, blocks.last_sweep, b) + 1, end)
        return b + 1, first, end, seen, irregular

    state = (dr.zeros(u32, lanes), dr.zeros(u32, lanes), dr.zeros(u32, lanes),
             dr.full(mi.Bool, False, lanes), dr.full(mi.Bool, False, lanes))
    _, first, end, _, irregular = dr.while_loop(
        state, lambda b, *rest: b < constants["blocks"], body)
    return first, end, irregular


def block_trace(scatterers: ScattererArrays, sweep_arrays: SweepArrays, constants: Constants,
                found: Any, visibility: Any, width: int,
                packets: Any, uniform: bool, polynomial: bool, units: float | None,
                runs: tuple[Any, Any] | None = None, receiver_polynomial: bool = False) -> Any:
    """Trace every sweep of the chunk for ``width`` candidates: a lane per candidate, a symbolic
    loop over sweeps.

    Lanes are the candidates ``first ..`` of the launch; all run the chunk's ``constants["sweeps"]``
    (<= :data:`MAX_CHUNK_SWEEPS`) sweeps, so the lanes of a SIMD packet share their trip count
    and every sweep datum. ``visibility`` holds the probe codes of the (candidate, block) pairs
    (:func:`~.backscatter.probe` layout): a lane deposits without a shadow ray in the sweeps of
    its blocks seen at both ends (code 2; docs/integrator.md §"Visibility reuse"), given as
    ``runs`` (:func:`deposit_runs`, when every lane's are one run) or else ORed from the sweep
    bits ``sweep_arrays.blocks.sweep_bits`` into a two-word mask; blocks hidden at both ends
    (0) deposit nothing, and those whose ends disagree (1) are traced sweep by sweep by
    :func:`~.backscatter.split_trace`.

    A lane gathers its scatterer once and evaluates in float64, at the chunk's middle sweep
    ``a`` (the anchor), the range ``R_a``, the wrapped deposit phase ``f_c tau_a - K tau_a^2/2 +
    phi`` and the bin position (docs/design.md §5.5). Per sweep ``j`` (counted from the anchor,
    |j| <= 64) it evaluates in float32 what :func:`~.backscatter.trace` evaluates per
    (scatterer, sweep) lane of a static 3-D set:

    - geometry: with ``uniform`` (the antenna moves by one step ``s`` per sweep over the chunk
      with one frame and velocity, :func:`~.constants.chunk_step_arrays`),
      ``R_j^2 - R_a^2 = j (j |s|^2 - 2 o_a.s)`` and ``d_j = R_j - R_a`` from it, no gather
      (and not beyond :data:`MAX_HALF_SPAN` from the anchor);
      otherwise the antenna position, velocity and frame are gathered per sweep and ``R_j``
      taken in float64;
    - beam test on the direction sines, as :func:`~.backscatter.cull`;
    - amplitude (two-way pattern, σ⁰ table, radar equation ``1/R^2``): with ``polynomial``
      (a uniform chunk far enough from every candidate, :func:`amplitude_polynomial_holds`),
      the polynomial of degree :data:`AMPLITUDE_DEGREE` in ``j`` through its exact values at
      Chebyshev nodes of the chunk (:data:`AMPLITUDE_NODES`; docs/integrator.md
      §"Performance" states the error); otherwise exact per sweep;
    - bin: ``x_j = x_a + (d_j + (f_c/K) dR/dt) / dr`` (:func:`mitsar.model.histogram.
      apparent_range`), split linearly;
    - phase: ``cycles_a + deposit_cycles_change(d_j)`` (exact change of the quadratic phase):
      on uniform chunks its carrier term's linear ramp ``-j g (2 f_c/c)``, ``g = o_a.s / R_a``,
      exactly (wrapped in float64 per lane, the product's rounding recovered by an fma), and
      the small rest ``j (j |s|^2 + g d_j) / (R_j + R_a)`` and the residual video phase in
      float32 (chunks span at most :data:`MAX_HALF_SPAN` from the anchor); otherwise the
      change in float64; then :func:`~mitsar.plugins.ops.sincos_turns` in float32;
    - receivers (``sweep_arrays.receivers``): each receiver of the transmitter gets its own
      packet rows ``k sweeps + s``; one at the transmitter deposits as above, one elsewhere at
      half its exact path ``P_j = (R_j + R'_j)/2`` (:func:`mitsar.model.signal.half_path`):
      with ``receiver_polynomial`` (a uniform chunk, :func:`~.receivers.
      receiver_polynomial_holds`) the transmitter's bin and phase plus the receiver's offsets
      from them as polynomials in ``j`` (:func:`~.receivers.receiver_offsets`, the error
      bounded below 1e-6 cycles and bins); otherwise ``R'_j`` its own range advanced as
      ``R_j`` is from its own anchor vector (a rigid body offset moves by the same step ``s``
      over a uniform chunk), ``P``'s ramp from ``(g + g')/2`` and its rest, Doppler and
      residual video phase as the half sums; the beam, visibility and amplitude are the
      transmitter's, shared by all its receivers;
    - deposit: one packet of four values (re, im of the lower and of the upper bin) added at
      ``4 (s bins + lower)`` of ``packets``, non-atomically (``ReduceMode.Expand``: a copy per
      thread, summed afterwards): int64 in fixed-point units (``units`` per amplitude unit,
      :func:`fixed_point_scale`) for deterministic traces, since integer sums do not depend
      on which thread took which lanes; float32 with ``units=None`` (the last bits vary with
      the threads); :func:`add_packets` folds them into the float64 histogram.

    docs/integrator.md §"Performance" gives the measured error against the lane kernels.

    Returns
    -------
    mi.UInt32
        Per lane, the number of its sweeps in the beam and the bin grid (contributions,
        whatever their visibility).
    """
    f64, f32, u32, i32, u64 = mi.Float64, mi.Float, mi.UInt32, mi.Int32, mi.UInt64
    packet = _packet_type(units is not None)
    local, valid = padded_lanes(width)  # the extra lanes run no sweep
    padded, width = dr.width(local) != width, dr.width(local)
    m = dr.gather(u32, found, local + constants["first"])

    # 1. The sweeps the lane deposits: one run (runs given) or a two-word mask of its blocks
    # seen at both ends.
    if runs is None:
        bits = sweep_arrays.blocks.sweep_bits

        def mask_body(b: Any, seen0: Any, seen1: Any) -> tuple[Any, Any, Any]:
            seen = dr.gather(u32, visibility, local * constants["blocks"] + b) == 2
            return (b + 1, seen0 | dr.select(seen, dr.gather(u64, bits[0], b), 0),
                    seen1 | dr.select(seen, dr.gather(u64, bits[1], b), 0))

        _, seen0, seen1 = dr.while_loop(
            (dr.zeros(u32, width), dr.zeros(u64, width), dr.zeros(u64, width)),
            lambda b, seen0, seen1: b < constants["blocks"], mask_body)
    sweeps = constants["sweeps"]
    anchor = sweeps // 2

    # 2. Once per lane, float64: the scatterer and its geometry at the anchor sweep.
    q = [dr.gather(f64, c, m) for c in scatterers.position]
    o0 = [qi - dr.gather(f64, c, anchor)
          for qi, c in zip(q, sweep_arrays.position, strict=True)]
    r0 = dr.sqrt(o0[0] * o0[0] + o0[1] * o0[1] + o0[2] * o0[2])
    cycles0_64 = (hg.deposit_cycles(r0 * (2.0 / SPEED_OF_LIGHT), constants, constants["rvp"])
                  + dr.gather(f64, scatterers.phase, m))
    cycles0_64 = cycles0_64 - dr.floor(cycles0_64)
    cycles0 = f32(cycles0_64)
    position0 = (r0 - constants["first_range"]) * constants["inv_step"]
    bin0 = dr.floor(position0)
    fraction0 = f32(position0 - bin0)
    bin0 = i32(bin0)
    n = mi.Vector3f(*(dr.gather(f32, c, m) for c in scatterers.normal))
    weight = dr.gather(f32, scatterers.weight, m)
    offset = f32(dr.gather(u32, scatterers.table_row, m) * TABLE_SIZE)
    r0f = f32(r0)
    # Receivers elsewhere than the transmitter: their anchor vector, half path and its phase
    # and bin at the anchor (float64 once per lane, as the transmitter's above).
    legs: list[Any] = []
    for receiver in sweep_arrays.receivers:
        if receiver is None:
            legs.append(None)
            continue
        leg = SimpleNamespace(receiver=receiver)
        leg.o0 = [qi - dr.gather(f64, c, anchor) for qi, c in zip(q, receiver, strict=True)]
        leg.r0 = dr.sqrt(leg.o0[0] * leg.o0[0] + leg.o0[1] * leg.o0[1] + leg.o0[2] * leg.o0[2])
        leg.path0 = half_path(r0, leg.r0)
        cycles = (hg.deposit_cycles(leg.path0 * (2.0 / SPEED_OF_LIGHT), constants,
                                    constants["rvp"]) + dr.gather(f64, scatterers.phase, m))
        leg.cycles0_64 = cycles - dr.floor(cycles)
        leg.cycles0 = f32(leg.cycles0_64)
        position = (leg.path0 - constants["first_range"]) * constants["inv_step"]
        leg.bin0 = dr.floor(position)
        leg.fraction0 = f32(position - leg.bin0)
        leg.bin0 = i32(leg.bin0)
        leg.r0f, leg.path0f = f32(leg.r0), f32(leg.path0)
        legs.append(leg)
    radar32 = SimpleNamespace(carrier_frequency=constants.f32("fc"),
                              chirp_rate=constants.f32("chirp_rate"))
    rvp, inv_step = constants.f32("rvp"), constants.f32("inv_step")
    # apparent range per unit range rate [s]
    doppler = constants.f32("fc") / constants.f32("chirp_rate")
    scale = dr.select(constants["normalized"] > 0.0, 0.0, constants.f32("radar_const"))
    last_lower = i32(constants["last_lower"])
    beta_az, beta_el = constants.f32("beta_az"), constants.f32("beta_el")

    def amplitude(o: Any, frame: Any) -> Any:
        """What :func:`~.backscatter.trace` deposits along ``o`` before the phase: two-way pattern,
        sqrt(σ⁰(θ_i) × area share) and the radar equation's ``1/R^2`` (or 1, normalised)."""
        inv = dr.rsqrt(dr.squared_norm(o))
        d = o * inv
        u_az, u_el, _ = frame_sines(d, frame)
        one_way = dr.square(field_pattern(u_az, u_el, beta_az, beta_el, DRJIT_OPS))
        sigma = interp_theta_table(scatterers.tables, TABLE_SIZE, dr.abs(dr.dot(n, d)),
                                   DRJIT_OPS,
                                   offset=offset) * weight
        return one_way * dr.sqrt(sigma) * dr.select(scale > 0.0, scale * inv * inv, 1.0)

    carrier = hg.carrier_cycles_per_metre(radar32)  # [cycles/m]
    if uniform:
        o0f = mi.Vector3f(*(f32(c) for c in o0))
        step64 = [dr.gather(f64, c, 0) for c in sweep_arrays.step]
        step = mi.Vector3f(*(f32(c) for c in step64))
        # g: the range's first-order decrease per sweep, o_a.s / R_a [m]; its carrier phase
        # -j g (2 f_c/c) is the exact ramp j (w_hi + w_lo) [cycles], w wrapped to half a turn.
        g64 = (o0[0] * step64[0] + o0[1] * step64[1] + o0[2] * step64[2]) / r0
        lin, g = f32(2.0 * g64 * r0), f32(g64)
        ramp64 = -g64 * hg.carrier_cycles_per_metre(constants)
        ramp64 = ramp64 - dr.round(ramp64)
        ramp_hi = f32(ramp64)
        ramp_lo = f32(ramp64 - f64(ramp_hi))
        quad = dr.squared_norm(step)
        fixed_frame = tuple(tuple(dr.gather(f32, entry, anchor) for entry in row)
                            for row in sweep_arrays.frame)

        def fixed(i: int, j: int) -> Any:
            return fixed_frame[i][j]

        velocity = mi.Vector3f(*(f32(dr.gather(f64, c, anchor))
                                 for c in sweep_arrays.velocity))
        # o_j = o_a - j s: the direction sines (unnormalised) and o.v are linear in j.
        sines0 = frame_sines(o0f, fixed)
        sines_step = frame_sines(step, fixed)
        along0, along_step = dr.dot(o0f, velocity), dr.dot(step, velocity)
        # t = (j - centre) / half in [-1, 1] over the chunk's sweeps [-anchor, sweeps - 1 -
        # anchor]: the variable of the amplitude's and the receivers' polynomials.
        centre = f32(sweeps - 1) * 0.5 - f32(anchor)
        half = dr.maximum(f32(sweeps - 1) * 0.5, 0.5)
        inv_half = 1.0 / half
        for leg in legs:
            if leg is None:
                continue
            if receiver_polynomial:
                velocity64 = [dr.gather(f64, c, anchor) for c in sweep_arrays.velocity]
                leg.offsets = receiver_offsets(o0, leg.o0, step64, velocity64, f64(centre),
                                               f64(half), constants, AMPLITUDE_NODES,
                                               _MONOMIAL)
                continue
            g_rx64 = (leg.o0[0] * step64[0] + leg.o0[1] * step64[1]
                      + leg.o0[2] * step64[2]) / leg.r0
            leg.lin, leg.g = f32(2.0 * g_rx64 * leg.r0), f32(g_rx64)
            # the half path's carrier ramp, -j (g + g')/2 (2 f_c/c), exactly as above
            ramp64 = -0.5 * (g64 + g_rx64) * hg.carrier_cycles_per_metre(constants)
            ramp64 = ramp64 - dr.round(ramp64)
            leg.ramp_hi = f32(ramp64)
            leg.ramp_lo = f32(ramp64 - f64(leg.ramp_hi))
            leg.along0 = dr.dot(mi.Vector3f(*(f32(c) for c in leg.o0)), velocity)
    if polynomial:
        # 5. The amplitude as a polynomial in t over the chunk's sweeps, through its values at
        # the Chebyshev nodes.
        values = [amplitude(o0f - (centre + half * t) * step, fixed)
                  for t in AMPLITUDE_NODES]
        coefficients = [sum(row[i] * values[i] for i in range(len(values)))
                        for row in _MONOMIAL]
        lit = values[0] > 0.0
        for value in values[1:]:
            lit |= value > 0.0
    else:
        lit = mi.Bool(True)
    # Constants read once, outside the loop (gathers inside it are not hoisted past the
    # scatter into ``packets``).
    cull_az, cull_el = constants.f32("cull_az"), constants.f32("cull_el")
    bin_lo, window = i32(constants["bin_lo"]), i32(constants["bin_width"])  # the packets' bins
    first, end = dr.zeros(u32, width), sweeps
    if uniform:
        # 3. The sweeps a lane can be in the beam: the direction sines are linear in j, so each
        # beam test holds on an interval of j (with R_j <= R_a + |j| |s|, one sweep of slack).
        reach = r0f + f32(dr.maximum(anchor, sweeps - 1 - anchor)) * dr.norm(step)
        lo, hi = beam_sweeps(sines0, sines_step, cull_az * reach, cull_el * reach)
        first = u32(dr.clip(dr.floor(lo) - 1.0 + f32(anchor), 0.0, f32(sweeps)))
        end = u32(dr.clip(dr.ceil(hi) + 2.0 + f32(anchor), 0.0, f32(sweeps)))
    per_unit = dr.opaque(f32, 1.0 if units is None else units)  # per amplitude unit
    if padded:
        end = dr.select(valid, end, 0)

    direct = direct_rounding()

    def stored(value: Any) -> Any:
        """A deposit as the packets hold it: float32 as it is, or rounded to an int64, straight
        where the CPU converts in one instruction (:func:`direct_rounding`: 2.5-7 ms less of
        the block kernel's 38-70 ms on the benchmark room), else by the float64 magic number
        1.5 x 2^52 (exact for |x| < 2^51; AVX2 has no float-to-int64 conversion, which costs
        a quarter of the kernel)."""
        if units is None:
            return value
        if direct:  # float32 values >= 2^24 are integers already: round is exact below
            return mi.Int64(dr.round(value))
        shifted = mi.Float64(value) + _ROUNDING_MAGIC
        return dr.reinterpret_array(mi.Int64, shifted) - _MAGIC_BITS

    def receiver_leg(leg: Any, s: Any, j: Any, tx: SimpleNamespace) -> tuple[Any, Any]:
        """Bin position (relative to ``leg.bin0``) and wrapped phase [cycles] of sweep ``s``
        for a receiver away from the transmitter: half the exact path and its rate, from the
        transmitter's range change ``tx`` and the receiver's own (uniform chunks: advanced as
        the transmitter's range; otherwise float64 from the gathered phase centre)."""
        if uniform:
            change = j * (j * quad - leg.lin)  # R'_j^2 - R'_a^2 [m^2]
            r = dr.sqrt(leg.r0f * leg.r0f + change)
            inv = 1.0 / (r * (r + leg.r0f))
            own = change * r * inv  # R'_j - R'_a [m]
            delta = half_path(tx.delta, own)
            rdot = half_path(tx.rdot, -dr.fma(-j, along_step, leg.along0) * (r + leg.r0f) * inv)
            rest = half_path(tx.rest, j * dr.fma(leg.g, own, j * quad) * (r * inv))
            turns = j * leg.ramp_hi
            ramp = (turns - dr.round(turns)) + dr.fma(j, leg.ramp_lo,
                                                      dr.fma(j, leg.ramp_hi, -turns))
            cycles = (leg.cycles0 + ramp + carrier * rest
                      + rvp * hg.rvp_cycles_change(delta, leg.path0f, radar32))
        else:
            b64 = [qi - dr.gather(f64, c, s) for qi, c in zip(q, leg.receiver, strict=True)]
            rb64 = dr.sqrt(b64[0] * b64[0] + b64[1] * b64[1] + b64[2] * b64[2])
            change64 = half_path(tx.r64, rb64) - leg.path0
            cycles64 = leg.cycles0_64 + hg.deposit_cycles_change(change64, leg.path0,
                                                                 constants, constants["rvp"])
            cycles = f32(cycles64 - dr.floor(cycles64))
            b = mi.Vector3f(*(f32(c) for c in b64))
            delta = f32(change64)
            rdot = half_path(tx.rdot, -dr.dot(b, tx.v) / f32(rb64))
        return leg.fraction0 + (delta + doppler * rdot) * inv_step, cycles

    def body(s: Any, count: Any) -> tuple[Any, Any]:
        """4.-6. One sweep: geometry, beam and bin, amplitude, phase, deposit."""
        j = f32(i32(s) - i32(anchor))
        if uniform:
            change = j * (j * quad - lin)  # R_j^2 - R_a^2 [m^2]
            r = dr.sqrt(r0f * r0f + change)
            inv = 1.0 / (r * (r + r0f))  # one division for d_j and dR/dt
            delta = change * r * inv
            rdot = -dr.fma(-j, along_step, along0) * (r + r0f) * inv
            # Phase: the carrier's linear ramp exactly (its product's rounding error recovered
            # by the fma, whole turns dropped), then the small rest d_j + j g =
            # j (j |s|^2 + g d_j) / (R_j + R_a) and the residual video phase.
            turns = j * ramp_hi
            ramp = (turns - dr.round(turns)) + dr.fma(j, ramp_lo, dr.fma(j, ramp_hi, -turns))
            rest = j * dr.fma(g, delta, j * quad) * (r * inv)
            cycles = (cycles0 + ramp + carrier * rest
                      + rvp * hg.rvp_cycles_change(delta, r0f, radar32))
            s_az, s_el, s_b = (dr.fma(-j, d, s0) for s0, d in zip(sines0, sines_step,
                                                                  strict=True))
            t = (j - centre) * inv_half
            if polynomial:
                amp = horner(coefficients, t)
            else:  # near the antenna: exact per sweep
                amp = amplitude(o0f - j * step, fixed)
        else:
            o64 = [qi - dr.gather(f64, c, s)
                   for qi, c in zip(q, sweep_arrays.position, strict=True)]
            r64 = dr.sqrt(o64[0] * o64[0] + o64[1] * o64[1] + o64[2] * o64[2])
            delta, r = f32(r64 - r0), f32(r64)
            cycles64 = cycles0_64 + hg.deposit_cycles_change(r64 - r0, r0, constants,
                                                             constants["rvp"])
            cycles = f32(cycles64 - dr.floor(cycles64))  # float64: any range change
            o = mi.Vector3f(*(f32(c) for c in o64))
            v = mi.Vector3f(*(f32(dr.gather(f64, c, s)) for c in sweep_arrays.velocity))
            rdot = -dr.dot(o, v) / r

            def frame(i: int, j: int) -> Any:
                return dr.gather(f32, sweep_arrays.frame[i][j], s)

            s_az, s_el, s_b = frame_sines(o, frame)
            amp = amplitude(o, frame)  # a turning frame moves the pattern: exact per sweep
        tx = (SimpleNamespace(delta=delta, rdot=rdot, rest=rest) if uniform
              else SimpleNamespace(r64=r64, rdot=rdot, v=v))
        # Beam test on the unnormalised direction: |u| < cull <=> |f.o| < cull R.
        in_beam = (s_b > 0.0) & (dr.abs(s_az) < cull_az * r) & (dr.abs(s_el) < cull_el * r)
        if runs is None:
            seen = (dr.select(s < 64, seen0, seen1) >> u64(s & 63)) & 1
            shared = in_beam & (seen != 0) & lit
        else:  # 32-bit compares: a tenth of the kernel less than the 64-bit mask test
            shared = in_beam & (s >= runs[0]) & (s < runs[1]) & lit
        counted = None
        # the transmitter's bin position relative to bin0 and its phase
        tx_x = fraction0 + (delta + doppler * rdot) * inv_step
        for k, leg in enumerate(legs):
            if leg is None:  # at the transmitter: its range
                path_x, path_bin0, path_cycles = tx_x, bin0, cycles
            elif receiver_polynomial:  # the transmitter's plus the leg's offsets
                path_x = tx_x + horner(leg.offsets.bins, t)
                path_bin0, path_cycles = bin0, cycles + horner(leg.offsets.phase, t)
            else:  # elsewhere: half the exact path, its rate and phase
                path_x, path_cycles = receiver_leg(leg, s, j, tx)
                path_bin0 = leg.bin0
            # Bin: apparent range P_j + (f_c/K) dP/dt (hg.apparent_range) relative to bin0,
            # with dR/dt = -(o.v)/R (o points from the antenna to the static scatterer).
            lower, w_lo, w_hi = hg.split_weights(path_x, dr.floor)
            lower = path_bin0 + i32(lower)
            in_grid = (lower >= 0) & (lower < last_lower)
            if counted is None:  # contributions counted on the first receiver
                counted = in_beam & in_grid
            slot = lower - bin_lo  # in the chunk's packet window (packet_window: always)
            active = shared & in_grid & (slot >= 0) & (slot < window)
            sin_p, cos_p = sincos_turns(path_cycles)
            v_re, v_im = (amp * per_unit) * cos_p, (amp * per_unit) * sin_p
            value = packet(*(stored(v) for v in (v_re * w_lo, v_im * w_lo, v_re * w_hi,
                                                 v_im * w_hi)))
            row = s if k == 0 else s + u32(k) * u32(sweeps)
            index = row * u32(window) + u32(dr.select(active, slot, 0))
            dr.scatter_reduce(dr.ReduceOp.Add, packets, value, index, active,
                              mode=dr.ReduceMode.Expand)
        return s + 1, count + dr.select(counted, 1, 0)

    return dr.while_loop((first, dr.zeros(u32, width)), lambda s, count: s < end, body)[1]


def packet_window(nearest: float, farthest: float, half_span: float, constants: Constants
                  ) -> tuple[int, int]:
    """First bin and number of bins of a chunk's packet rows: the ``lower`` bins a deposit of
    the chunk can have, from the candidates' nearest and farthest range at the middle sweep
    [m], the antenna's largest displacement from it [m] and the Doppler shift of the apparent
    range (``doppler_bins``), with two bins of slack for float32 rounding; within
    ``[0, bins - 1)``. The paper's room reaches ~30 % of its bin grid: the packets, their
    per-thread copies and the fold shrink with it."""
    last = int(constants.value("bins")) - 1
    if not nearest <= farthest:  # no candidate
        return 0, 1
    step = 1.0 / constants.value("inv_step")
    first_range, doppler_bins = constants.value("first_range"), constants.value("doppler_bins")
    lo = math.floor((nearest - half_span - first_range) / step - doppler_bins) - 2
    hi = math.ceil((farthest + half_span - first_range) / step + doppler_bins) + 3
    lo, hi = min(max(lo, 0), last - 1), min(max(hi, 1), last)
    return lo, max(hi - lo, 1)


def packet_buffer(sweeps: int, bins: int, integer: bool) -> Any:
    """A zeroed buffer for the packets of :func:`block_trace` (4 values per bin of ``sweeps``
    histograms: the chunk's sweeps times its receivers;
    :func:`~.config.histogram_buffer_length`: few lengths, few compilations), or None beyond
    :data:`PACKET_BUFFER_LIMIT`."""
    size = histogram_buffer_length(4 * sweeps * bins)
    kind = mi.Int64 if integer else mi.Float
    return None if size > PACKET_BUFFER_LIMIT else dr.zeros(kind, size)


PACKET_BUFFER_LIMIT = 2**23
"""Largest packet buffer in elements (64 MiB of int64, times the Dr.Jit threads in
``ReduceMode.Expand``): chunks of 128 sweeps up to ~16 000 bins; wider grids get shorter
chunks (down to :data:`MIN_PACKET_SWEEPS`, ~130 000 bins), beyond which the lane kernels trace
them."""

MIN_PACKET_SWEEPS = 16
"""Shortest chunk the integrator shortens its chunks to so that the packets fit
(:data:`PACKET_BUFFER_LIMIT`): about one visibility block at 2 mm per sweep and 3 cm."""


def add_packets(packets: Any, constants: Constants, sweeps: int, width: int, re: Any, im: Any,
                units: float | None, receivers: int = 1) -> None:
    """Fold the packets of :func:`block_trace` into the histogram ``re + j im`` (order 0):
    ``width`` (``constants["bin_width"]``) packets per row from bin ``constants["bin_lo"]``
    (:func:`packet_window`), row ``k sweeps + s`` for receiver ``k`` of ``receivers`` and
    sweep ``s``; bin ``bin_lo + j`` of that sweep and receiver gets the lower half of packet
    ``(row, j)`` and the upper half of packet ``(row, j - 1)`` (no deposit reaches past the
    last bin: ``lower < bins - 1``).

    Integer packets (``units`` fixed-point units per amplitude unit) hold exact sums of the
    deposits, each rounded to one unit (~1e-12 of the amplitude bound; the deposits themselves
    are float32, a relative rounding of ~6e-8); float32 packets (``units=None``) a relative
    rounding of ~6e-8 sqrt(N) for N deposits: both far below the block kernel's other errors
    (docs/integrator.md §"Performance")."""
    f64 = mi.Float64
    packet = _packet_type(units is not None)
    idx, valid = padded_lanes(receivers * sweeps * (width + 1))  # width + 1 bins per row
    row = idx // (constants["bin_width"] + 1)
    j = idx - row * (constants["bin_width"] + 1)
    flat = row * constants["bin_width"] + j  # packet (s, j)
    own = dr.gather(packet, packets, flat, j < constants["bin_width"])  # its lower half: bin j
    below = dr.gather(packet, packets, flat - 1, j > 0)  # packet (s, j - 1): its upper half
    if receivers == 1:
        target = row * constants["sweep_stride"] + constants["bin_lo"] + j
    else:  # row k sweeps + s: sweep s, receiver k
        k = row // constants["sweeps"]
        target = ((row - k * constants["sweeps"]) * constants["sweep_stride"]
                  + k * constants["receiver_stride"] + constants["bin_lo"] + j)
    for part, out in ((0, re), (1, im)):
        if units is None:
            value = f64(own[part]) + f64(below[part + 2])
        else:  # exact integer sum, then one conversion
            value = f64(own[part] + below[part + 2]) * (1.0 / units)
        dr.scatter_reduce(dr.ReduceOp.Add, out, value, target, valid,
                          mode=dr.ReduceMode.NoConflicts)
