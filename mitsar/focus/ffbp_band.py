"""FFBP's final stage for a band narrower than the beam on a curved track: each pixel sums
its own band of sweeps from the sub-apertures of every stage and single sweeps at its edges
(:mod:`mitsar.focus.ffbp`, "A chosen resolution on curved tracks"; the stage kernels:
:mod:`mitsar.focus.ffbp_stages`).

- :func:`merge_band`: the band of every pixel by bisection on its aspect offset, the whole
  sub-apertures inside it (segment-tree fashion) and BPA's per-pulse sum at its two ends;
- :func:`_windowed_piece`: a tapered window over a whole sub-aperture, one shifted read of its
  image per harmonic, and for a bistatic channel :func:`_receiver_read` (where that read goes).
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.backend import drjit as dr  # imported when a kernel runs (LazyModule)
from mitsar.backend import namespace_of
from mitsar.focus.backprojection import carrier_turns, derotate, jit_array, pixel_pulse
from mitsar.focus.ffbp_stages import Stage, merge_lanes, stage_columns, tap_rows

__all__ = ["merge_band"]


def merge_band(stages: list[Stage], points: NDArray, frame: tuple[NDArray, NDArray],
               sweep_range: tuple[NDArray, NDArray], tables: tuple, half_width: float,
               window: NDArray, wavenumber: float, normal: NDArray | None = None
               ) -> tuple[Any, Any, Any]:
    """Each point's sum over the sweeps of its own processed band (aspect-angle window).

    The band of point x is the sweeps k with ``|g_k| <= h``, ``g_k = d . l_k - u`` (its
    aspect frame ``(d, u)``, :func:`mitsar.focus.aperture.aspect_frames`; ``l_k`` the unit
    line of sight from sweep k to x), with BPA's edge fractions: a sweep within half a
    sweep's step of ``|g| = h`` counts by the part of its stretch inside
    (:func:`mitsar.focus.backprojection.edge_fraction`). Along a pass ``g_k`` falls
    monotonically (the line of sight turns one way), so the band is one run of sweeps
    ``[k_1, k_2)`` (``|g_k| <= h``), found by bisection inside ``sweep_range`` (float64). The
    run is summed from pieces that are whole sub-apertures of any stage (the sub-aperture
    images, interpolated at x and re-phased as in :func:`merge_points`; the largest aligned
    sub-aperture that fits, then the next, as in a segment tree: at most ``2 (factor - 1)``
    per stage) between the first-stage boundaries ``b_1 = ceil((k_1 + 1) / n_0) n_0`` and
    ``b_2 = floor((k_2 - 1) / n_0) n_0``, and at its two ends (``[k_1 - 1, b_1)``,
    ``[b_2, k_2 + 1)``: the sweeps whose edge fraction may lie between 0 and 1, the first
    and last of the run and one outside either end) from single sweeps by BPA's own
    per-pulse sum (:func:`pixel_pulse <mitsar.focus.backprojection.pixel_pulse>`, which
    applies the window and the edge fraction itself, so the edges are BPA's to the sweep;
    the pieces hold sweeps at least one step inside, whose fraction is 1). With a window other
    than rect each piece's sweeps are weighted by :func:`_windowed_piece` (one more read of
    its image per harmonic of the window).

    Parameters
    ----------
    stages : list of Stage
        Every stage, first to last, with its images (``values``).
    points : ndarray, shape (P, 3)
        Points [m] in the stages' local frame.
    frame : (ndarray (P, 3), ndarray (P,))
        Aspect frame ``(d, u)`` of every point.
    sweep_range : (ndarray (P,), ndarray (P,))
        First and end sweep that can hold the band (a safe bound,
        :func:`mitsar.focus.bpa.curved_sweep_range`).
    tables : tuple
        :func:`mitsar.focus.backprojection.kernel_tables` (sweep positions in the local frame).
    half_width : float
        Band half width h in direction sine.
    window : ndarray
        Cosine-series coefficients of the azimuth window.
    wavenumber : float
        Two-way carrier wavenumber ``2 f_c / c`` [cycles/m].
    normal : ndarray, shape (3,), optional
        Unit normal of the image plane (the polar grids'); needed for a bistatic channel's
        windowed pieces (:func:`_windowed_piece`).

    Returns
    -------
    real, imag, total : Dr.Jit arrays, launched
        The BPA sum of every point and the sum of its sweeps' window weights.
    """
    constants, sweep_arrays, pairs = tables
    jit = namespace_of(pairs)
    Float32, Float64, UInt32 = jit.Float32, jit.Float64, jit.UInt32
    sweeps = int(stages[0].end[-1])
    count = len(points)
    coordinates = [jit_array(Float64, points[:, i], np.float64) for i in range(3)]
    direction = [jit_array(Float32, frame[0][:, i], np.float32) for i in range(3)]
    centre = jit_array(Float32, frame[1], np.float32)
    low = jit_array(UInt32, sweep_range[0], np.uint32)
    high = jit_array(UInt32, np.maximum(sweep_range[1], sweep_range[0]), np.uint32)
    coefficients = np.zeros(4)
    coefficients[: len(window)] = window
    edge_constants = {**constants, "half_width": dr.opaque(Float32, half_width),
                      "coefficients": [float(c) for c in coefficients],
                      "fractional_edges": True}  # a band narrower than the beam

    # The band [k1, k2): bisection on g (falling along the pass), float64.
    d64 = [Float64(v) for v in direction]

    def offset(k: Any, active: Any) -> Any:
        ox, oy, oz = (coordinates[i] - dr.gather(Float64, sweep_arrays[i], k, active)
                      for i in range(3))
        distance = dr.sqrt(ox * ox + oy * oy + oz * oz)
        return (ox * d64[0] + oy * d64[1] + oz * d64[2]) / distance - Float64(centre)

    def bisect(threshold: float, strict: bool) -> Any:
        lo, hi = UInt32(low), UInt32(high)
        for _ in range(max(1, int(sweeps).bit_length())):
            active = lo < hi
            mid = (lo + hi) >> 1
            g = offset(dr.select(active, mid, 0), active)
            left = (g < threshold) if strict else (g <= threshold)
            hi = dr.select(active & left, mid, hi)
            lo = dr.select(active & ~left, mid + 1, lo)
        return lo

    k1 = bisect(half_width, strict=False)
    k2 = dr.maximum(bisect(-half_width, strict=True), k1)
    size0 = int(stages[0].end[0] - stages[0].first[0])
    # the first and last sweeps of the run go to the edges (their edge fraction may be < 1)
    b1 = (k1 + size0) // size0 * size0
    b2 = dr.select(k2 > 0, k2 - 1, 0) // size0 * size0
    empty = b2 <= b1
    stop = dr.minimum(k2 + 1, sweeps)
    b1 = dr.select(empty, stop, b1)
    b2 = dr.select(empty, stop, b2)

    # Pieces: whole sub-apertures of any stage between b1 and b2.
    sizes = [int(s.end[0] - s.first[0]) for s in stages]
    counts = [len(s.first) for s in stages]
    nodes = [len(s.first) * s.shape[0] * s.shape[1] for s in stages]
    node_offset = np.concatenate([[0], np.cumsum(nodes)[:-1]]).astype(np.int64)
    sub_offset = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    node_base = np.concatenate([offset + np.arange(len(s.first)) * (s.shape[0] * s.shape[1])
                                for offset, s in zip(node_offset, stages, strict=True)])
    child = stage_columns(stages, Float32)
    spacing = jit_array(Float32, np.concatenate([_sweep_spacing(s) for s in stages]),
                        np.float32)
    bases = jit_array(UInt32, node_base, np.uint32)
    level_arrays = {
        "alpha_step": jit_array(Float32, [s.alpha_step for s in stages], np.float32),
        "n_rho": jit_array(UInt32, [s.shape[0] for s in stages], np.uint32),
        "n_alpha": jit_array(UInt32, [s.shape[1] for s in stages], np.uint32),
    }
    rows = dr.concat([tap_rows(s.values) for s in stages]) if len(stages) > 1 else tap_rows(
        stages[0].values)
    dr.eval(rows)
    point = [Float32(v) for v in coordinates]
    zero = dr.zeros(Float32, count)
    point_data = point + [zero] * (3 if stages[0].receiver is None else 6)
    rho_step = dr.opaque(Float32, stages[0].rho_step)
    wave = dr.opaque(Float32, wavenumber)
    n_sweeps = dr.opaque(UInt32, sweeps)
    rect = not np.any(coefficients[1:])
    harmonics = [(m, float(coefficients[m])) for m in range(len(coefficients))]
    wavelength = 2.0 / wavenumber

    def piece_condition(cursor: Any, *_: Any) -> Any:
        return cursor < b2

    def piece_body(cursor: Any, acc_real: Any, acc_imag: Any, acc_total: Any) -> tuple:
        # The largest stage whose sub-aperture starts at the cursor and ends by b2 (sizes
        # are Python constants: no division by a gathered, possibly masked, value).
        level, piece, size = UInt32(0), cursor // sizes[0], UInt32(sizes[0])
        for index in range(1, len(stages)):
            fits = ((cursor % sizes[index]) == 0) & (
                dr.minimum(cursor + sizes[index], n_sweeps) <= b2)
            level = dr.select(fits, index, level)
            piece = dr.select(fits, int(sub_offset[index]) + cursor // sizes[index], piece)
            size = dr.select(fits, sizes[index], size)
        piece_end = dr.minimum(cursor + size, n_sweeps)
        scalars = {"rho_step": rho_step, "wavenumber": wave,
                   "alpha_step": dr.gather(Float32, level_arrays["alpha_step"], level),
                   "n_rho": dr.gather(UInt32, level_arrays["n_rho"], level),
                   "n_alpha": dr.gather(UInt32, level_arrays["n_alpha"], level)}
        base = dr.gather(UInt32, bases, piece)
        part_real, part_imag, _ = merge_lanes(piece, point_data, child, rows, None,
                                               scalars, False, base)
        weight = Float32(piece_end - cursor)
        if not rect:
            part_real, part_imag, weight = _windowed_piece(
                piece, point_data, (child, spacing), rows, scalars, base,
                (part_real, part_imag), weight, direction, centre, harmonics, half_width,
                wavelength, normal)
        return piece_end, acc_real + part_real, acc_imag + part_imag, acc_total + weight

    state = (UInt32(b1), *[dr.zeros(Float32, count) for _ in range(3)])
    real, imag, total = dr.while_loop(state, piece_condition, piece_body)[1:]
    distance = dr.sqrt(sum(v * v for v in coordinates))
    turns = carrier_turns(distance, dr.opaque(Float64, wavenumber), dr.floor)
    sin_phase, cos_phase = dr.sincos(Float32(2 * np.pi) * Float32(turns))
    real, imag = derotate(real, imag, sin_phase, cos_phase)

    # Edges: single sweeps [k1 - 1, b1) and [b2, k2 + 1), BPA's per-pulse sum, window and
    # edge fraction.
    start = dr.select(k1 > 0, k1 - 1, k1)
    left = b1 - dr.minimum(start, b1)
    length = left + (stop - dr.minimum(b2, stop))
    pixel = (*coordinates, UInt32(0), dr.opaque(UInt32, sweeps), *direction, centre)

    def edge_condition(t: Any, *_: Any) -> Any:
        return t < length

    def edge_body(t: Any, acc_real: Any, acc_imag: Any, acc_total: Any) -> tuple:
        k = dr.select(t < left, start + t, b2 + (t - left))
        sweep = tuple(dr.gather(type(a), a, k) for a in sweep_arrays)
        part = pixel_pulse(k, pixel, sweep, pairs, edge_constants)
        return t + 1, acc_real + part[0], acc_imag + part[1], acc_total + part[2]

    state = (UInt32(0), real, imag, total)
    real, imag, total = dr.while_loop(state, edge_condition, edge_body)[1:]
    dr.eval(real, imag, total)  # launched: the caller may work while it runs
    return real, imag, total


def _windowed_piece(piece: Any, point_data: list, children: tuple[list, Any], rows: Any,
                    scalars: dict, base: Any, plain: tuple[Any, Any], count: Any, direction: list,
                    centre: Any, harmonics: list, half_width: float, wavelength: float,
                    normal: NDArray | None = None) -> tuple[Any, Any, Any]:
    """A whole sub-aperture's image at the point, each sweep weighted by the window.

    The window is a cosine series in the aspect offset, ``W(g) = sum_m a_m cos(pi m g / h)``
    (:func:`mitsar.focus.windows.cosine_series` at ``g / 2h``). Across a sub-aperture ``g``
    is linear in the sweep's offset s along the axis, ``g = g_c + gamma s`` with ``gamma =
    (-d.a + (d.l)(a.l)) / rho`` (l, rho: line of sight and range from the centre to the
    point), and the demodulated polar image holds sweep s with the phase ``2 pi (2 /
    lambda) s alpha`` (step 3 of :mod:`mitsar.focus.ffbp`): the weight ``exp(j pi m g / h)``
    of every sweep is therefore the image read at ``alpha + m gamma lambda / (4 h)`` times
    ``exp(j pi m g_c / h)``. Each harmonic costs one more interpolation; the sum of the
    weights is ``sum_m a_m cos(pi m g_c / h) D_m`` with the Dirichlet kernel ``D_m`` of the
    n sweeps' phase steps.

    A bistatic channel's image holds sweep s with the phase ``2 pi (2 / lambda) s (a.l +
    a'.l') / 2`` (its half path, :func:`first_stage`), which moves by ``(1 + kappa) / 2`` per
    step of alpha along the polar grid's circle, and that step also moves half its path,
    hence its compressed pulse (:func:`_receiver_read`): the reads are shifted by ``2 / (1 +
    kappa)`` times the monostatic shift in alpha and in range so that half the path stays.
    Measured on the 20-degree turn with a Hamming window and a receiver at (0.3, 0.2, 0.4) m
    in the body frame: -35.5 dB from BPA reading at the monostatic shift, -41.1 dB with the
    range shift, -41.6 dB with both (the monostatic channel: -41.8 dB).
    """
    jit = namespace_of(piece)
    Float32 = jit.Float32
    child, spacing = children  # (_child_data, each sub-aperture's sweep spacing)
    x, y, z = point_data[:3]
    cx, cy, cz, ax, ay, az = (dr.gather(Float32, c, piece) for c in child[:6])
    ox, oy, oz = x - cx, y - cy, z - cz
    rho = dr.sqrt(ox * ox + oy * oy + oz * oz)
    lx, ly, lz = ox / rho, oy / rho, oz / rho
    along_d = direction[0] * lx + direction[1] * ly + direction[2] * lz
    along_a = ax * lx + ay * ly + az * lz
    g_centre = along_d - centre
    gamma = (-(direction[0] * ax + direction[1] * ay + direction[2] * az)
             + along_d * along_a) / rho
    step = dr.opaque(Float32, math.pi / half_width)
    reading = dr.opaque(Float32, wavelength / (4 * half_width))  # image shift per gamma
    radial = None  # a bistatic channel: the range shift per shift of alpha
    if len(child) > 8:
        rate, radial = _receiver_read(point_data[:3], *([dr.gather(Float32, c, piece)
                                                         for c in child[i:i + 3]]
                                                        for i in (8, 11)),
                                      (lx, ly, lz), rho, (ax, ay, az), normal)
        reading = reading * 2.0 / (1.0 + rate)
    real, imag = harmonics[0][1] * plain[0], harmonics[0][1] * plain[1]
    # per-sweep phase step of harmonic 1 (sweeps evenly spaced along the chord)
    theta = step * gamma * dr.gather(Float32, spacing, piece)
    total = harmonics[0][1] * count
    for m, a_m in harmonics[1:]:
        if a_m == 0.0:
            continue
        sin_c, cos_c = dr.sincos(m * step * g_centre)
        for sign in (1.0, -1.0):
            shift = sign * m * gamma * reading
            v_real, v_imag, _ = merge_lanes(piece, point_data, child, rows, None, scalars,
                                             False, base, shift,
                                             None if radial is None else shift * radial)
            # times a_m / 2 exp(sign j pi m g_c / h)
            rotated_real = v_real * cos_c - sign * v_imag * sin_c
            rotated_imag = v_imag * cos_c + sign * v_real * sin_c
            real += 0.5 * a_m * rotated_real
            imag += 0.5 * a_m * rotated_imag
        half = 0.5 * m * theta
        small = dr.abs(dr.sin(half)) < 1e-6
        dirichlet = dr.select(small, count, dr.sin(count * half)
                              / dr.select(small, 1.0, dr.sin(half)))
        total += a_m * cos_c * dirichlet
    return real, imag, total


def _receiver_read(point: list, receiver: list, receiver_axis: list, line: tuple,
                   rho: Any, axis: tuple, normal: NDArray) -> tuple[Any, Any]:
    """Where a bistatic channel's windowed piece reads its image (:func:`_windowed_piece`):
    ``kappa`` and the range shift per shift of ``alpha``.

    Sweep s moves the transmitter by ``s a`` and the receiver by ``s a'`` (``a'``: the
    receiver's chord per unit of the transmitter's, ``Stage.receiver_axis``: not ``a`` where
    the attitude turns a horizontal offset), so its phase ramps are ``s a.l`` and ``s a'.l'``
    (l, l': unit lines of sight from the centres c and d, ranges rho and rho'). Along the
    polar grid's circle (fixed rho, in the image plane of normal n: ``e = n x l``, ``dx /
    d alpha = rho e / (a.e)``), ``grad (a.l) . e = a.e / rho`` and ``grad (a'.l') . e = (a'.e -
    (a'.l')(l'.e)) / rho'``: ``kappa`` is their ratio. The same step moves the receiver's
    range by ``rho (l'.e) / (a.e)``, hence half the path (the compressed pulse's position in
    the image) by half that: the read moves in range by ``-rho (l'.e) / (a.e) / (1 + l.l')``
    per unit of alpha to keep it (half the path grows by ``(1 + l.l') / 2`` per metre of
    range). Where the circle runs across the axis (``a.e`` ~ 0): 1 and 0.
    """
    n = [float(v) for v in normal]
    e = (n[1] * line[2] - n[2] * line[1], n[2] * line[0] - n[0] * line[2],
         n[0] * line[1] - n[1] * line[0])
    q = [p - r for p, r in zip(point, receiver, strict=True)]
    rho_receiver = dr.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])
    ramp = sum(a * v for a, v in zip(receiver_axis, q, strict=True)) / rho_receiver
    across = sum(v * w for v, w in zip(q, e, strict=True)) / rho_receiver
    along = sum(a * w for a, w in zip(axis, e, strict=True))
    along_receiver = sum(a * w for a, w in zip(receiver_axis, e, strict=True))
    flat = dr.abs(along) < 1e-6
    safe = dr.select(flat, 1.0, along)
    kappa = dr.select(flat, 1.0, (rho / rho_receiver) * (along_receiver - ramp * across) / safe)
    # half the path from the centres along e per unit alpha, over its radial rate
    facing = sum(v * w for v, w in zip(q, line, strict=True)) / rho_receiver
    radial = dr.select(flat, 0.0, -(rho * across / safe) / (1.0 + facing))
    return kappa, radial


def _sweep_spacing(stage: Stage) -> NDArray:
    """Mean spacing [m] of every sub-aperture's sweeps along its axis (0 for one sweep)."""
    return stage.length / np.maximum(stage.end - stage.first - 1, 1)
