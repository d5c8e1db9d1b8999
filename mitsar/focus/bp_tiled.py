"""Exact back-projection by groups of neighbouring pixels: float64 once per group and sweep.

The sum is that of :mod:`mitsar.focus.backprojection` (beat frequency ``K tau + f_c dtau/dt``,
Meta 2007 §II-B; interpolation of the zero-padded range profile,
:mod:`mitsar.focus.interpolation`; de-rotation by
``exp(-j 2 pi f_c tau)``, paper eq. 1; window on the direction sine), evaluated differently:

1. the pixels are cut into *lanes* of ``G`` neighbours (a row segment of a grid, or ``G``
   consecutive points), and each lane gets a centre ``c`` (float64) and the offsets
   ``d = x - c`` of its pixels (float32);
2. per lane and sweep, in float64: ``w = c - p_k``, ``r = |w|``, the profile position of
   ``K 2 r / c`` (split into an integer bin and a float32 fraction) and the carrier turns
   ``f_c 2 r / c`` wrapped to one turn; the unit vector ``u = w / r`` and ``1 / r`` go to
   float32;
3. per pixel, in float32, the range offset to third order in ``d`` (FastSAR 0.1.8,
   ``fastsar.exact`` module docstring):

   ``|w + d| - |w| = a + b / (2 r) - a b / (2 r^2) + e``, ``a = d . u``,
   ``b = |d|^2 - a^2``,                                                                (1)

   whose remainder is bounded by ``|e| <= h^4 / (2 r^3)`` for ``|d| <= h`` (the next terms
   of the series of ``sqrt((r + a)^2 + b)``: ``(a^2 b / 2 - b^2 / 8) / r^3``, each at most
   ``h^4 / 8``, with a factor 2 of margin for the higher ones and ``r`` taken as the smallest
   lane-to-antenna distance less ``h``); the direction sine ``v . (w + d) / (r + delta)``
   (window and Doppler term) is evaluated with that range. On a regular row (slot g at
   ``d = m A``, ``m = g - (G - 1) / 2``, one step vector A for all the rows) (1) is a cubic in
   m and the sine a quadratic,

   ``s(m) = s_c + m (beta - s_c alpha) + m^2 (s_c (3 alpha^2 / 2 - gamma / 2) - alpha beta)``,
   ``alpha = A . u / r``, ``beta = A . v / r``, ``gamma = |A|^2 / r^2``, ``s_c = v . u``,   (2)

   with a remainder of order ``(m |A| / r)^3``, so the lookup position, the phase and the
   window offset of a pixel are each one polynomial in m whose coefficients are computed once
   per lane and sweep, and so is the inverse window step of the edge fraction
   (:func:`mitsar.focus.backprojection.edge_fraction`), ``R / (|v| T (1 - s^2))``, to first
   order in m: ``R`` grows by ``m A . u`` and ``s`` by ``m (beta - s_c alpha)``;
4. the lookup position is the centre's fraction plus ``delta`` times bins per metre plus the
   Doppler shift, the phase the centre's wrapped turns plus ``2 f_c delta / c``; one 32-byte
   (cubic) or 16-byte (linear) packet per lookup holds the bin's interpolation coefficients
   (complex64, :func:`mitsar.focus.interpolation.kernel_packets`), and sin/cos of
   the phase come from polynomials of the half angle (:func:`sincos_half_turns`,
   error 1.2e-6).

5. on a regular row without an aspect window, S neighbouring slots (:data:`SHARED_SLOTS`,
   :func:`shared_slots`) share one packet: that of the bin ``b`` below the lookup position
   of their middle, each pixel evaluating the cubic at its own ``t = position - b``. Where
   every slot's position is within half a bin of the middle's (``(S - 1) sigma <= 1``),
   ``t`` stays in [-1/2, 3/2), on which the Lagrange remainder is at most 5/3 of the one on
   [0, 1) (:func:`mitsar.focus.interpolation.error_bound` with ``shared``: -60.6 dB instead
   of -65.1 dB at 8x for a component at the band edge; measured on the benchmark image
   -71.1 dB against an interpolation-free float64 sum, as without sharing); the slots a
   window leaves out are cleared (the group's packet is not theirs). At S = 16 (rows along
   the track at 1000 x 512^2) a sixteenth of the packet loads, which dominated the kernel
   on the CPU: kernel 283 -> 155-175 ms. Cubic only (a shared linear lookup would triple its
   bound), and only where every lookup is known to lie inside the profile (no bounds test).

6. a bistatic channel (receiver at ``r_k``, away from the transmitter ``p_k``) looks up half
   its exact path ``P = (|c + d - p_k| + |c + d - r_k|) / 2``
   (:func:`mitsar.model.signal.half_path`): per lane and sweep both legs in float64, the
   profile position and carrier turns of ``P`` at the centre, and (1) for each leg with its
   own unit vector and range, the lookup position and phase following the mean of the two
   offsets (on a regular row the mean of two cubics in m, still one cubic). The direction
   sine, the window and the Doppler term stay the transmitter's, as in
   :func:`mitsar.focus.backprojection.pixel_pulse`. The bounds hold with both phase centres:
   the expansion error (each leg's remainder is at most (1)'s bound at the nearer of the
   two) and the lookups inside the profile (``P`` lies between the two ranges) over both
   sets of positions, and :func:`shared_slots` widens its spread by the baseline over R.

A lane is used only where the phase error of (1), ``4 pi f_max / c * h^4 / (2 r^3)``, stays
below :data:`PHASE_LIMIT`; the lane size G is the largest of :data:`LANE_SIZES` for which all
lanes pass, and lanes that fail even at the smallest size go to the exact kernel
(:func:`mitsar.focus.backprojection.backproject_drjit`, float64 range per pixel). Error budget
(docs/focusing.md, "Exact BPA by pixel groups"): expansion <= 1e-4 rad of phase per term,
float32 offsets and phase ~1e-5 rad, sin/cos ~1e-6, float32 sums as the exact kernel:
-100 to -130 dB against the float64 sum of the same profiles. The interpolation of the
profiles dominates the error against an interpolation-free float64 sum, as in the exact kernel
(cubic: about -71 dB at 8x zero-padding, focus()'s default; linear: -48 dB at 16x, -61 dB at
32x; docs/focusing.md, error budget).
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.backend import array_namespace, namespace_of, safe_width
from mitsar.backend import drjit as dr  # imported when a kernel runs (LazyModule)
from mitsar.focus.backprojection import (
    SMALLEST_WINDOW_STEP,
    backproject_drjit,
    carrier_turns,
    edge_fraction,
    fractional_edges,
    inverse_window_step,
    jit_array,
    kernel_tables,
    profile_position,
)
from mitsar.focus.bp_lanes import (
    LANE_SIZES,
    PHASE_LIMIT,
    SHARED_SLOTS,
    column_order,
    lane_layout,
    lanes_of,
    lookups_inside,
    nearest_range,
    row_step,
    shared_slots,
    slab_transpose,
)
from mitsar.focus.interpolation import DEFAULT_INTERPOLATION, evaluate, jit_packets, lookup, packet
from mitsar.focus.windows import cosine_series
from mitsar.model.geometry.bounds import bounding_box
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import half_path

__all__ = ["LANE_SIZES", "SHARED_SLOTS", "SWEEP_PARTS", "PHASE_LIMIT", "backproject_tiled",
           "column_order", "lane_layout", "nearest_range", "row_step", "shared_slots",
           "sincos_half_turns", "sincos_turns", "slab_transpose"]

# sin(2 pi y) = y S(y^2), cos(2 pi y) = C(y^2) on |y| <= 1/4: least squares on Chebyshev
# nodes; sin and cos of 2 y then by the double angle, largest error 1.2e-6 (sin) and 4.1e-7
# (cos) over a whole turn, evaluated in float32.
_SIN = (6.283163946270893, -41.33712966619642, 81.34035740333923, -70.98962650011296)
_COS = (0.9999999532360555, -19.739171315085024, 64.93458093602057, -85.24007915837323,
        56.24034662338018)


def _horner(coefficients: tuple[Any, ...], x: Any) -> Any:
    """``sum_i c_i x^i`` by Horner's rule (fused multiply-adds)."""
    value = coefficients[-1]
    for c in coefficients[-2::-1]:
        value = dr.fma(value, x, c)
    return value


def sincos_half_turns(half: Any) -> tuple[Any, Any]:
    """``sin(2 pi t)`` and ``cos(2 pi t)`` from ``half = t / 2`` in [-1/4, 1/4] (float32).

    Polynomials for the half angle (``_SIN``, ``_COS``), then ``sin 2y = 2 sin y cos y`` and
    ``cos 2y = 2 cos^2 y - 1``: no folding of the argument, 13 operations.
    """
    square = half * half
    sine = half * _horner(_SIN, square)
    cosine = _horner(_COS, square)
    return (sine + sine) * cosine, dr.fma(cosine + cosine, cosine, -1.0)


def sincos_turns(turns: Any) -> tuple[Any, Any]:
    """``sin(2 pi t)`` and ``cos(2 pi t)`` for any ``t`` [turns] (float32): wrapped to
    [-1/2, 1/2], then :func:`sincos_half_turns`."""
    return sincos_half_turns(0.5 * (turns - dr.round(turns)))


def _cos_turns(angle: Any) -> Any:
    """``cos(angle)`` for the window's cosine series (angle in radians, |angle| <= 3 pi)."""
    turns = angle * (1.0 / (2.0 * math.pi))
    return sincos_turns(turns - dr.round(turns))[1]


def backproject_tiled(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray, motion_correction: bool = True,
                      sweep_range: tuple[NDArray, NDArray] | None = None,
                      aspect: tuple[NDArray, NDArray] | None = None,
                      row_length: int | None = None,
                      interpolation: str = DEFAULT_INTERPOLATION,
                      while_running: Callable[[], Any] | None = None,
                      share_lookups: bool = True, packets: Any = None,
                      nearest: float | None = None, columns: bool | None = None,
                      slab_rows: int | None = None, receivers: NDArray | None = None
                      ) -> tuple[NDArray, NDArray, dict]:
    """Back-projection by lanes of neighbouring pixels (module docstring).

    Parameters as :func:`mitsar.focus.backprojection.backproject_drjit` (``receivers``: a
    bistatic channel's receive phase centre per sweep, step 6 of the module docstring),
    plus ``row_length``: pixels per row of the grid the pixels come from in row-major order
    (the lanes follow rows), None for points in no particular layout, and ``interpolation``
    of the profiles (:mod:`mitsar.focus.interpolation`); ``while_running``, optional host work
    (no Dr.Jit) run while the kernel runs asynchronously, its result in ``info["while_running"]``;
    ``share_lookups``: let neighbouring pixels of a regular row share a cubic lookup (module
    step 5, where :func:`shared_slots` allows it; False: one lookup per pixel, the sum of
    :func:`mitsar.focus.backprojection.backproject_numpy` to float32 rounding); ``packets``:
    the profile's :func:`mitsar.focus.interpolation.jit_packets` if already made (an earlier
    pixel chunk's); ``nearest``: a lower bound [m] of the pixels' range to the track for
    :func:`shared_slots` (the whole grid's, so that its chunks share alike; default and at
    most: that of these pixels' box); ``columns``: lay the lanes along the columns of each
    slab of ``slab_rows`` rows (None: decide by :func:`column_order`; True: wherever the
    columns are regular, as a focus decided for the whole grid; False: rows), e.g. on a
    ``SlantGrid``, whose rows run across the track.

    Returns
    -------
    weighted_sum : ndarray, shape (P,), complex
    total_weight : ndarray, shape (P,)
    info : dict
        ``lane_pixels`` (G used, 0 if none), ``exact_pixels`` (pixels sent to the exact
        kernel), ``row_step`` (1 when the lanes are regular row segments),
        ``shared_lookup`` (pixels per lookup, step 5), ``lanes_along`` ("rows" or "columns")
        and ``predicted_phase_error`` [rad], the
        largest of eq. (1) over the lanes used.
    """
    count = len(pixels)
    info = {"lane_pixels": 0, "exact_pixels": count, "row_step": 0, "shared_lookup": 1,
            "lanes_along": "rows", "predicted_phase_error": 0.0}
    if count == 0:
        info["while_running"] = while_running() if while_running else None
        return np.zeros(0, dtype=complex), np.zeros(0), info
    sweeps = profile.shape[0]
    if sweep_range is None:
        sweep_range = (np.zeros(count, np.uint32), np.full(count, sweeps, np.uint32))
    first, end = (np.asarray(r, dtype=np.int64) for r in sweep_range)
    top_wavenumber = (4 * math.pi * (radar.carrier_frequency + radar.bandwidth / 2)
                      / SPEED_OF_LIGHT)
    if row_length is not None and row_length < min(LANE_SIZES):
        row_length = None  # rows too short to fill a lane: groups of consecutive points
    if columns is None:   # decided here (a focus decides once for all its chunks)
        columns = (aspect is None and share_lookups and interpolation == "cubic"
                   and column_order(pixels, row_length, slab_rows, velocities, centroid_sine,
                                    half_width) is not None)
    if columns and aspect is None and row_length and count % row_length == 0:
        slab_rows = slab_rows or count // row_length
        order = (slab_transpose(count, row_length, slab_rows)
                 if (count // row_length) % slab_rows == 0 else None)
        transposed = None if order is None else pixels[order]
        if transposed is not None and row_step(transposed, slab_rows) is not None:
            # the lanes along the columns: the same sum, transposed
            values, totals, info = backproject_tiled(
                profile, frequency, radar, transposed, positions, velocities, centroid_sine,
                half_width, window, motion_correction, (first[order], end[order]), None,
                slab_rows, interpolation, while_running, share_lookups, packets, nearest,
                columns=False, receivers=receivers)
            weighted_sum, total = np.empty_like(values), np.empty_like(totals)
            weighted_sum[order], total[order] = values, totals
            return weighted_sum, total, {**info, "lanes_along": "columns"}
    step = row_step(pixels, row_length)
    # the phase centres the lanes' bounds hold for: the transmitter's, and a bistatic
    # channel's receiver's too (its half path lies between the two ranges, step 6)
    centres, moving = ((positions, velocities) if receivers is None else
                       (np.concatenate([positions, receivers]),
                        np.concatenate([velocities, velocities])))
    sizes = [s for s in LANE_SIZES if row_length is None or s <= row_length] or [LANE_SIZES[-1]]
    for size in sizes:
        groups, centre, offsets, error = lanes_of(pixels, row_length, size, step, positions,
                                                PHASE_LIMIT / top_wavenumber, receivers)
        good = top_wavenumber * error <= PHASE_LIMIT
        if good.all():
            break
    if not good.any():  # no lane qualifies: the exact kernel for all
        values, totals = backproject_drjit(profile, frequency, radar, pixels, positions,
                                           velocities, centroid_sine, half_width, window,
                                           motion_correction, sweep_range, aspect,
                                           receivers=receivers, interpolation=interpolation,
                                           packets=packets)
        info["while_running"] = while_running() if while_running else None
        return values, totals, info
    weighted_sum = np.zeros(count, dtype=complex)
    total = np.zeros(count)
    lanes = groups[good]
    valid = lanes >= 0
    rows = np.where(valid, lanes, 0)
    lane_first = np.where(valid, first[rows], sweeps).min(axis=1)
    lane_end = np.where(valid, end[rows], 0).max(axis=1)
    lane_first = np.minimum(lane_first, lane_end)
    order = np.argsort(lane_first, kind="stable")  # lanes of a SIMD packet share sweeps
    lanes, valid, rows = lanes[order], valid[order], rows[order]
    frames = None
    if aspect is not None:  # per pixel: window direction (3) and centre sine
        frames = np.column_stack([aspect[0], aspect[1]])[rows]
    # pixel to lane centre [m] (a regular lane: its end slots, (G - 1) / 2 steps away)
    reach = (float(np.linalg.norm(step)) * (groups.shape[1] - 1) / 2 if step is not None
             else float(np.abs(offsets).max(initial=0.0)) * math.sqrt(3))
    checked = not lookups_inside(frequency, radar, centre[good], centres, moving, reach)
    shared = 1
    if share_lookups and step is not None and frames is None and not checked \
            and interpolation == "cubic":
        own = nearest_range(centres, *bounding_box(pixels))
        shared = shared_slots(step, groups.shape[1], frequency, radar,
                              own if nearest is None else min(nearest, own), reach,
                              positions, velocities, centroid_sine, half_width,
                              fractional_edges(radar, half_width),
                              _baseline(positions, receivers))
    sums, totals, done = _run_lanes(profile, frequency, radar, centre[good][order],
                                    offsets[good][order] if step is None else step,
                                    lane_first[order], lane_end[order], frames, positions,
                                    velocities, centroid_sine, half_width, window,
                                    motion_correction, checked, groups.shape[1], interpolation,
                                    while_running, shared, packets, receivers)
    keep = valid.ravel()
    weighted_sum[lanes.ravel()[keep]] = sums.ravel()[keep]
    total[lanes.ravel()[keep]] = totals.ravel()[keep]
    rest = groups[~good]
    rest = np.sort(rest[rest >= 0])
    if len(rest):
        values, totals_rest = backproject_drjit(
            profile, frequency, radar, pixels[rest], positions, velocities, centroid_sine,
            half_width, window, motion_correction, (first[rest], end[rest]),
            None if aspect is None else (aspect[0][rest], aspect[1][rest]),
            receivers=receivers, interpolation=interpolation, packets=packets)
        weighted_sum[rest], total[rest] = values, totals_rest
    return weighted_sum, total, {
        "lane_pixels": int(groups.shape[1]), "exact_pixels": int(len(rest)),
        "row_step": int(step is not None), "shared_lookup": shared, "lanes_along": "rows",
        "predicted_phase_error": float(top_wavenumber * error[good].max()),
        "while_running": done}


def _baseline(positions: NDArray, receivers: NDArray | None) -> float:
    """The largest transmitter-to-receiver distance [m] of a bistatic channel (0 without)."""
    if receivers is None:
        return 0.0
    return float(np.linalg.norm(receivers - positions, axis=-1).max(initial=0.0))


SWEEP_PARTS = 8
"""The sweeps are cut into this many equal parts, and a lane's sum over each part runs in a
kernel lane of its own (summed afterwards in float64): the LLVM backend hands its threads
blocks of 16384 kernel lanes, and a grid of a few hundred pixels a side has too few pixel
groups to keep two cores busy. The parts depend on the sweep count only, so a pixel's sum
does not depend on which other pixels are focused with it (a volume slice equals the plane
image bit for bit)."""


def _run_lanes(profile: NDArray, frequency: NDArray, radar: Radar, centre: NDArray,
               offsets: NDArray, lane_first: NDArray, lane_end: NDArray,
               frames: NDArray | None, positions: NDArray, velocities: NDArray,
               centroid_sine: NDArray, half_width: float, window: NDArray,
               motion_correction: bool, checked: bool, size: int,
               interpolation: str = DEFAULT_INTERPOLATION,
               while_running: Callable[[], Any] | None = None, shared: int = 1,
               packets: Any = None, receivers: NDArray | None = None) -> tuple:
    """The Dr.Jit kernel over lanes: sums (L, G) complex, weight totals (L, G) and the result
    of ``while_running`` (called once the kernel is launched, None if not given).

    ``offsets``: (L, G, 3) pixel offsets, or the row step (3,) of regular lanes. A lane's
    sweeps run in one kernel lane per part of :data:`SWEEP_PARTS` that they touch; the parts
    are summed here. ``checked``: test every lookup against the profile's ends (else
    :func:`lookups_inside` holds); ``shared``: pixels per lookup (step 5, regular lanes);
    ``packets``: the packed profiles if already made; ``receivers``: a bistatic channel's
    receive phase centres (step 6).
    """
    jit = array_namespace()
    Float32, Float64, UInt32 = jit.Float32, jit.Float64, jit.UInt32
    lanes = len(centre)
    regular = offsets.ndim == 1
    # the interpolation coefficients of every bin: one packet (16 or 32 bytes) per lookup
    pairs = jit_packets(profile, interpolation, jit_array) if packets is None else packets
    constants, sweep_arrays, _ = kernel_tables(profile[:, :2], frequency[:2], radar, positions,
                                               velocities, centroid_sine, half_width,
                                               window, motion_correction, receivers,
                                               interpolation=interpolation, packets=pairs)
    constants["bins"] = dr.opaque(UInt32, profile.shape[1])
    sweeps = len(positions)
    span = -(-sweeps // SWEEP_PARTS)          # a part: sweeps [j span, (j + 1) span)
    first_part = lane_first // span
    splits = int(max(1, ((np.maximum(lane_end, lane_first + 1) - 1) // span
                         - first_part).max(initial=0) + 1))
    edges = (first_part[None] + np.arange(splits + 1)[:, None]) * span  # (splits + 1, L)
    bounds = np.clip(edges, lane_first[None], lane_end[None])
    # kernel width past Dr.Jit 1.5's crashing widths (safe_width): extra lanes of empty ranges
    width = safe_width(lanes * splits)
    which = dr.arange(UInt32, width) % dr.opaque(UInt32, lanes)  # split-major

    def per_lane(kind: type, values: NDArray, dtype: type) -> Any:
        # the lanes' values (padded past the crashing widths too; ``which`` reads the first L)
        extra = safe_width(len(values)) - len(values)
        padded = np.concatenate([values, np.repeat(values[-1:], extra)]) if extra else values
        return dr.gather(kind, jit_array(kind, padded, dtype), which)

    lane = {"centre": [per_lane(Float64, centre[:, i], np.float64) for i in range(3)],
            "step": [dr.opaque(Float32, float(v)) for v in offsets] if regular else None,
            "offsets": None if regular else
            [[per_lane(Float32, offsets[:, g, i], np.float32) for i in range(3)]
             for g in range(size)],
            "frames": None if frames is None else
            [[per_lane(Float32, frames[:, g, i], np.float32) for i in range(4)]
             for g in range(frames.shape[1])],
            "size": size, "checked": checked, "shared": shared}
    padding = np.zeros(width - lanes * splits, dtype=np.uint32)
    first = jit_array(UInt32, np.concatenate([bounds[:-1].ravel(), padding]), np.uint32)
    end = jit_array(UInt32, np.concatenate([bounds[1:].ravel(), padding]), np.uint32)
    result = lane_loop(lane, first, end, sweep_arrays, pairs, constants, width)
    dr.eval(*result)  # launched: the LLVM backend runs it while the host goes on
    done = while_running() if while_running else None
    # the parts of every lane summed in float64, one accumulator at a time (no big copies)
    parts = np.stack([np.add.reduce(np.asarray(r)[:lanes * splits].reshape(splits, lanes),
                                    axis=0, dtype=np.float64)
                      for r in result]).reshape(size, 3, lanes)
    return (parts[:, 0] + 1j * parts[:, 1]).T, parts[:, 2].T, done


def lane_loop(lane: dict, first: Any, end: Any, sweep_arrays: list, pairs: Any,
              constants: dict, lanes: int) -> list:
    """Symbolic loop over sweeps for lanes of pixels sharing a centre (module docstring,
    steps 2-4); three float32 accumulators (real, imaginary, weight) per pixel.

    ``lane``: ``centre`` (3 float64 arrays), then either ``step`` (the row step A, 3 opaque
    float32: slot g at ``c + (g - (G - 1) / 2) A``, G = ``size``) or ``offsets`` (per slot,
    3 float32 arrays), optionally ``frames`` (per slot: aspect direction and centre sine),
    and ``checked`` (test the lookups against the profile's ends). ``sweep_arrays`` of
    :func:`mitsar.focus.backprojection.kernel_tables`, with a bistatic channel's receiver
    positions after the first eight (step 6).
    """
    jit = namespace_of(first)
    Float32, Int32, UInt32 = jit.Float32, jit.Int32, jit.UInt32
    cx, cy, cz = lane["centre"]
    step = lane["step"]
    if step is not None:
        size = lane["size"]
        slots = [g - (size - 1) / 2 for g in range(size)]
        step_norm2 = dr.fma(step[0], step[0], dr.fma(step[1], step[1], step[2] * step[2]))
        pixels = [(m, None, m * m * step_norm2) for m in slots]
    else:
        pixels = [(None, (dx, dy, dz), dr.fma(dx, dx, dr.fma(dy, dy, dz * dz)))
                  for dx, dy, dz in lane["offsets"]]
    frames = lane["frames"] or [None] * len(pixels)
    shared = lane.get("shared", 1)  # pixels per lookup (regular rows only)
    bins, half_width = constants["bins"], constants["half_width"]
    bins_per_metre = Float32(constants["range_scale"])
    half_turns_per_metre = 0.5 * Float32(constants["carrier_scale"])
    rectangular = list(constants["coefficients"]) == [1.0, 0.0, 0.0, 0.0]  # weight 1 or 0
    fractional = constants["fractional_edges"]  # edge fractions (a band narrower than the beam)
    coefficients = constants["coefficients"]
    inverse_width = 1.0 / (2.0 * half_width)
    last_bin = Int32(bins - 1)

    bistatic = len(sweep_arrays) > 8  # step 6: the receiver's positions follow
    start_row: list = [None]  # the sweep's first flat index, for the bounds test

    def condition(k: Any, *_: Any) -> Any:
        return k < end

    def body(k: Any, *accumulators: Any) -> tuple:
        gx, gy, gz, vx, vy, vz, speed, centroid = (dr.gather(type(a), a, k)
                                                   for a in sweep_arrays[:8])
        wx, wy, wz = cx - gx, cy - gy, cz - gz                      # float64
        r = dr.sqrt(wx * wx + wy * wy + wz * wz)
        # 1/r and u in float32 (they scale the pixel offsets, |d| <= h, only): no float64
        # division per lane and sweep
        inverse32 = dr.rcp(Float32(r))
        ux, uy, uz = Float32(wx) * inverse32, Float32(wy) * inverse32, Float32(wz) * inverse32
        half_inverse = 0.5 * inverse32
        half_inverse2 = half_inverse * inverse32
        path = r
        if bistatic:  # step 6: the receiver's leg, the same way; half the path looked up
            ex, ey, ez = (cx - dr.gather(type(sweep_arrays[8]), sweep_arrays[8], k),
                          cy - dr.gather(type(sweep_arrays[9]), sweep_arrays[9], k),
                          cz - dr.gather(type(sweep_arrays[10]), sweep_arrays[10], k))
            r_rx = dr.sqrt(ex * ex + ey * ey + ez * ez)
            path = half_path(r, r_rx)
            inverse_rx = dr.rcp(Float32(r_rx))
            qx, qy, qz = (Float32(e) * inverse_rx for e in (ex, ey, ez))
            half_inverse_rx = 0.5 * inverse_rx
            half_inverse2_rx = half_inverse_rx * inverse_rx
        lower, fraction = profile_position(path * constants["range_scale"],
                                           -constants["index_offset"], 1.0, dr.floor)
        base = Int32(lower)
        fraction = Float32(fraction)
        turns = Float32(carrier_turns(path, constants["carrier_scale"], dr.floor))
        fx32, fy32, fz32 = Float32(wx), Float32(wy), Float32(wz)
        along = fx32 * vx + fy32 * vy + fz32 * vz                     # v . w
        doppler = constants["doppler_scale"] * speed
        if fractional:  # |v| T: the stretch of aperture a sweep stands for [m]
            spacing = speed * constants["sweep_interval"]
        if step is not None:  # per lane and sweep: A . u, and the direction sine of slot m
            # s(m) = s_c + m c_1 + m^2 c_2 + O((m |A| / r)^3), from v.(w + m A) / |w + m A|
            # with alpha = A.u / r, beta = A.v / r, gamma = |A|^2 / r^2 (eq. 2)
            step_u = dr.fma(step[0], ux, dr.fma(step[1], uy, step[2] * uz))
            alpha = step_u * inverse32
            beta = dr.fma(step[0], vx, dr.fma(step[1], vy, step[2] * vz)) * inverse32
            gamma = step_norm2 * inverse32 * inverse32
            sine_centre = along * inverse32
            sine_1 = dr.fma(-sine_centre, alpha, beta)
            sine_2 = dr.fma(sine_centre, dr.fma(1.5 * alpha, alpha, -0.5 * gamma),
                            -alpha * beta)
            # eq. (1) on the row: delta(m) = m (d_1 + m (d_2 + m d_3)); the lookup position
            # and the phase are cubics in m, the window offset a quadratic (Horner's rule)
            across = dr.fma(-step_u, step_u, step_norm2)       # |A|^2 - (A.u)^2
            d_1, d_2, d_3 = step_u, across * half_inverse, -step_u * across * half_inverse2
            if bistatic:  # step 6: the mean of the two legs' cubics
                step_q = dr.fma(step[0], qx, dr.fma(step[1], qy, step[2] * qz))
                across_q = dr.fma(-step_q, step_q, step_norm2)
                d_1 = half_path(step_u, step_q)
                d_2 = half_path(d_2, across_q * half_inverse_rx)
                d_3 = half_path(d_3, -step_q * across_q * half_inverse2_rx)
            position = (dr.fma(doppler, sine_centre, fraction),
                        dr.fma(bins_per_metre, d_1, doppler * sine_1),
                        dr.fma(bins_per_metre, d_2, doppler * sine_2), bins_per_metre * d_3)
            cycles = (0.5 * turns, half_turns_per_metre * d_1, half_turns_per_metre * d_2,
                      half_turns_per_metre * d_3)   # half turns (sincos_half_turns)
            window_offset = (sine_centre - centroid, sine_1, sine_2)
            if fractional:  # 1 / delta(m) = R / (|v| T (1 - s^2)), first order in m (step 3)
                across_sine = dr.fma(-sine_centre, sine_centre, 1.0)
                step_0 = inverse_window_step(across_sine, spacing * inverse32, dr.maximum)
                step_1 = step_0 * dr.fma(sine_centre + sine_centre, sine_1 / dr.maximum(
                    across_sine, SMALLEST_WINDOW_STEP), alpha)

                def slot_step(m: float) -> Any:
                    """The first-order inverse step of slot m, kept above half the centre's:
                    near a line of sight along the track (1 - s^2 -> 0) the first order can
                    turn negative or infinite, which would give edge fraction 1 outside the
                    window; the true 1 / delta is large there (a hard cut)."""
                    return dr.maximum(dr.fma(m, step_1, step_0), 0.5 * step_0)
        row = Int32(k * bins)
        start = row + base   # flat index of the lane centre's bin
        start_row[0] = row
        out = []
        if shared > 1:  # regular rows, lookups shared by `shared` neighbours (step 5)
            for first_slot in range(0, len(pixels), shared):
                out += _accumulate_shared([pixels[g][0] for g in range(
                    first_slot, first_slot + shared)], position, cycles, window_offset,
                    slot_step if fractional else None, start,
                    accumulators[3 * first_slot:])
            return (k + 1, *out)
        for g, ((m, offset_xyz, dd), frame) in enumerate(zip(pixels, frames, strict=True)):
            if offset_xyz is None and frame is None:  # a regular row (eqs. 1-2 in m)
                shift, frac = profile_position(_horner(position, m), 0.0, 1.0, dr.floor)
                phase = _horner(cycles, m)
                offset = _horner(window_offset, m)
                out += _accumulate(shift, frac, phase, offset,
                                   slot_step(m) if fractional else None,
                                   start, accumulators[3 * g:])
                continue
            if offset_xyz is None:
                a = m * step_u
                a_rx = m * step_q if bistatic else None
            else:
                dx, dy, dz = offset_xyz
                a = dr.fma(dx, ux, dr.fma(dy, uy, dz * uz))
                a_rx = dr.fma(dx, qx, dr.fma(dy, qy, dz * qz)) if bistatic else None
            b = dr.fma(-a, a, dd)
            delta = dr.fma(b, dr.fma(-a, half_inverse2, half_inverse), a)     # eq. (1)
            path_delta = delta
            if bistatic:  # step 6: eq. (1) for the receiver's leg, half the sum
                b_rx = dr.fma(-a_rx, a_rx, dd)
                path_delta = half_path(delta, dr.fma(
                    b_rx, dr.fma(-a_rx, half_inverse2_rx, half_inverse_rx), a_rx))
            ratio = delta * inverse32   # 1 / (r + delta) to second order in delta / r
            inverse_range = dr.fma(inverse32, dr.fma(ratio, ratio, -ratio), inverse32)
            if offset_xyz is None:
                dx, dy, dz = m * step[0], m * step[1], m * step[2]
            sine = (along + dr.fma(dx, vx, dr.fma(dy, vy, dz * vz))) * inverse_range
            shift, frac = profile_position(dr.fma(path_delta, bins_per_metre,
                                                  dr.fma(doppler, sine, fraction)),
                                           0.0, 1.0, dr.floor)
            rate = None
            if frame is None:
                offset = sine - centroid
                if fractional:
                    rate = dr.fma(-sine, sine, 1.0)
            else:  # aspect-angle window: the pixel's own direction and centre sine
                fx, fy, fz, centre_sine = frame
                offset = (dr.fma(fx32 + dx, fx, dr.fma(fy32 + dy, fy, (fz32 + dz) * fz))
                          * inverse_range - centre_sine)
                if fractional:
                    rate = dr.fma(-(offset + centre_sine), sine,
                                  dr.fma(fx, vx, dr.fma(fy, vy, fz * vz)))
            inverse_step = (inverse_window_step(rate, spacing * inverse_range, dr.maximum)
                            if fractional else None)
            phase = dr.fma(path_delta, half_turns_per_metre, 0.5 * turns)
            out += _accumulate(shift, frac, phase, offset, inverse_step, start,
                               accumulators[3 * g:])
        return (k + 1, *out)

    def _window(offset: Any, inverse_step: Any) -> tuple[Any, Any]:
        """Whether the sweep counts for a pixel, and its edge fraction (None: the whole beam,
        the cut ``|g| <= h``)."""
        if inverse_step is None:  # the whole beam: the cut |g| <= h (fractional_edges)
            return dr.abs(offset) <= half_width, None
        fraction = edge_fraction(offset, inverse_step, half_width, dr.clip)
        return fraction > 0, fraction

    def _accumulate(shift: Any, frac: Any, phase: Any, offset: Any, inverse_step: Any,
                    start: Any, sums: tuple) -> list:
        """Steps 2-4 of :mod:`mitsar.focus.backprojection` for one pixel: window and edge
        fraction, lookup and interpolation (:func:`mitsar.focus.interpolation.lookup`),
        de-rotation, weighted sums (real, imaginary, weight)."""
        active, fraction = _window(offset, inverse_step)
        flat = start + Int32(shift)
        if lane["checked"]:
            local = flat - start_row[0]
            active &= (local >= 0) & (local < last_bin)
            flat = dr.select(active, flat, 0)
        v_real, v_imag = lookup(pairs, flat, frac, active, constants["interpolation"])
        return _derotate(v_real, v_imag, phase, offset, active, fraction, sums)

    def _accumulate_shared(slots: list, position: tuple, cycles: tuple, window_offset: tuple,
                           steps: Callable[[float], Any] | None, start: Any,
                           sums: tuple) -> list:
        """Step 5: the pixels at row offsets ``slots`` read one packet, that of the bin below
        their middle's lookup position, each at its own ``t`` in [-1/2, 3/2) (the span of
        their positions is at most one bin, :func:`shared_slots`)."""
        base = dr.floor(_horner(position, 0.5 * (slots[0] + slots[-1])))
        windows = [_window(_horner(window_offset, m),
                           None if steps is None else steps(m))
                   for m in slots]
        # unmasked: the base bin lies inside the profile (every lookup does, step 5), and a
        # group no slot of which is in the window reads a packet it does not use
        taps = packet(pairs, start + Int32(base), True, constants["interpolation"])
        local = (position[0] - base, *position[1:])   # t = position - b in one Horner
        out = []
        for g, (m, (active, fraction)) in enumerate(zip(slots, windows, strict=True)):
            offset = _horner(window_offset, m)
            v_real, v_imag = evaluate(taps, _horner(local, m))
            if fraction is None and rectangular:  # the packet is the group's: clear it
                v_real, v_imag = dr.select(active, v_real, 0.0), dr.select(active, v_imag, 0.0)
            out += _derotate(v_real, v_imag, _horner(cycles, m), offset, active, fraction,
                             sums[3 * g:])
        return out

    def _derotate(v_real: Any, v_imag: Any, phase: Any, offset: Any, active: Any,
                  fraction: Any, sums: tuple) -> list:
        """Weight, de-rotation by the phase [half turns] and the three sums of one pixel."""
        # phase in half turns (the coefficients carry the 1/2), wrapped to [-1/4, 1/4]
        sin_phase, cos_phase = sincos_half_turns(dr.fma(dr.round(phase + phase), -0.5,
                                                        phase))
        if fraction is None and rectangular:  # inactive lanes gathered zeros
            weight = dr.select(active, 1.0, 0.0)
        elif fraction is None:
            weight = dr.select(active, cosine_series(coefficients, offset * inverse_width,
                                                     _cos_turns), 0.0)
            sin_phase, cos_phase = weight * sin_phase, weight * cos_phase
        else:  # the fraction is 0 where no sweep counts; the bounds test may clear more
            weight = dr.select(active, fraction, 0.0) if lane["checked"] else fraction
            if not rectangular:
                inside = dr.clip(offset, -half_width, half_width)
                weight = weight * cosine_series(coefficients, inside * inverse_width,
                                                _cos_turns)
            sin_phase, cos_phase = weight * sin_phase, weight * cos_phase
        # derotate (backprojection.derotate) and accumulate, fused
        return [dr.fma(v_real, cos_phase, dr.fma(v_imag, sin_phase, sums[0])),
                dr.fma(v_imag, cos_phase, dr.fma(-v_real, sin_phase, sums[1])),
                sums[2] + weight]

    state = (UInt32(first), *[dr.zeros(Float32, lanes) for _ in range(3 * len(pixels))])
    return list(dr.while_loop(state, condition, body)[1:])
