"""The back-projection sum, written once for NumPy and for the Dr.Jit kernel.

For every pixel x and sweep (or pulse) k with two-way delay ``tau`` (and delay rate
``dtau/dt`` for continuous motion):

1. the echo of x sits in the range profile at the beat frequency ``f = K tau + f_c dtau/dt``
   (:func:`mitsar.model.signal.beat_frequency`; Meta 2007 §II-B): the Doppler term removes the
   FMCW range shift of continuous motion;
2. the profile, on its ascending uniform beat-frequency axis, is interpolated linearly there
   (:func:`profile_position`, :func:`interpolate`);
3. the value is de-rotated by ``exp(-j 2 pi f_c tau)``, the carrier phase the sweep-centred
   range FFT leaves (paper eq. 1; :func:`carrier_turns`, :func:`derotate`);
4. it is weighted and accumulated, with the sum of the weights for the normalisation.

Steps 1-3 are small pure functions of operators (and a ``floor``), called by the NumPy sum
(:func:`pulse_sum`, behind :func:`backproject_numpy` and :func:`backproject_referenced`) and by
the Dr.Jit loop (:func:`backproject_drjit`), so the reference and the kernel evaluate the same
expressions. The kernel is one symbolic loop over sweeps with one lane per pixel (float64
phases), compiled once and cached: per-acquisition values are opaque. A float32 variant
(``precision="single"``) keeps the phase with float64 per-block tables (:func:`block_tables`,
:func:`range_offset`; docs/focusing.md, kernel speed).

Recorded data referenced to a scene point (:mod:`mitsar.raw.recorded`) use the same sum with
``tau = 2 (R - R_ref,k) / c``, no delay rate, and a profile that is periodic in beat frequency.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import drjit as dr
import numpy as np
from drjit.llvm import Float32, Float64, UInt32
from numpy.typing import NDArray

from mitsar.backend import require_llvm
from mitsar.errors import ParameterError
from mitsar.focus.aperture import doppler_geometry
from mitsar.focus.windows import cosine_series, evaluate_window
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import beat_frequency

__all__ = [
    "backproject_drjit",
    "block_tables",
    "backproject_numpy",
    "backproject_referenced",
    "carrier_turns",
    "derotate",
    "interpolate",
    "jit_array",
    "profile_position",
    "pulse_sum",
    "range_offset",
]


# --------------------------------------------------------------------------------------------
# The per-pulse physics (NumPy and Dr.Jit alike)
# --------------------------------------------------------------------------------------------
def profile_position(beat: Any, first_frequency: Any, frequency_step: Any,
                     floor: Callable[[Any], Any]) -> tuple[Any, Any]:
    """Lower bin and fraction of a beat frequency on the profile axis ``f_0 + i df``.

    Returns
    -------
    lower : array_like
        ``floor((f - f_0) / df)`` (float values).
    fraction : array_like
        Position between bin ``lower`` and ``lower + 1``, in [0, 1).
    """
    index = (beat - first_frequency) / frequency_step
    lower = floor(index)
    return lower, index - lower


def interpolate(low: Any, high: Any, fraction: Any) -> Any:
    """Linear interpolation between two neighbouring profile values."""
    return low * (1 - fraction) + high * fraction


def carrier_turns(delay: Any, carrier_frequency: Any, floor: Callable[[Any], Any]) -> Any:
    """Carrier phase ``f_c tau`` in turns, wrapped to [0, 1) in the caller's precision."""
    cycles = carrier_frequency * delay
    return cycles - floor(cycles)


def derotate(real: Any, imag: Any, sin_phase: Any, cos_phase: Any) -> tuple[Any, Any]:
    """Real and imaginary parts of ``(real + j imag) exp(-j phase)``."""
    return real * cos_phase + imag * sin_phase, imag * cos_phase - real * sin_phase


def pulse_sum(profile: NDArray, frequency: NDArray, delay: NDArray, beat: NDArray,
              weight: NDArray, carrier_frequency: float, periodic: bool = False
              ) -> tuple[NDArray, NDArray]:
    """Weighted sum over sweeps of the de-rotated profile values (NumPy, steps 2-4).

    Parameters
    ----------
    profile : ndarray, shape (S, F)
        Range profiles on the ascending, uniform beat-frequency axis ``frequency`` [Hz].
    delay, beat : ndarray, shape (S, P)
        Two-way delay [s] and beat frequency [Hz] of every pixel in every sweep.
    weight : ndarray, shape (S, P) or (S, 1)
        Azimuth weight.
    carrier_frequency : float
        ``f_c`` [Hz].
    periodic : bool
        The profile is periodic in beat frequency (a DFT, not zero-padded beyond the band):
        positions wrap around; otherwise positions off the axis get weight 0.

    Returns
    -------
    weighted_sum : ndarray, shape (P,), complex
    total_weight : ndarray, shape (P,)
    """
    bins = profile.shape[1]
    lower, fraction = profile_position(beat, frequency[0], frequency[1] - frequency[0],
                                       np.floor)
    lower = lower.astype(np.int64)
    if periodic:
        upper = (lower + 1) % bins
        lower %= bins
    else:
        weight = np.where((lower >= 0) & (lower < bins - 1), weight, 0.0)
        lower = np.clip(lower, 0, bins - 2)
        upper = lower + 1
    rows = np.arange(profile.shape[0])[:, None]
    value = interpolate(profile[rows, lower], profile[rows, upper], fraction)
    phase = 2 * np.pi * carrier_turns(delay, carrier_frequency, np.floor)
    real, imag = derotate(value.real, value.imag, np.sin(phase), np.cos(phase))
    weight = np.broadcast_to(weight, real.shape)
    return (weight * real).sum(axis=0) + 1j * (weight * imag).sum(axis=0), weight.sum(axis=0)


# --------------------------------------------------------------------------------------------
# Dechirped FMCW data (absolute range, continuous motion)
# --------------------------------------------------------------------------------------------
def backproject_numpy(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray,
                      motion_correction: bool = True) -> tuple[NDArray, NDArray]:
    """Reference back-projection in NumPy (same sum as the Dr.Jit kernel, all in memory).

    Parameters
    ----------
    profile : ndarray, shape (S, F)
        Range profiles on the ascending, uniform beat-frequency axis ``frequency`` [Hz].
    radar : Radar
    pixels : ndarray, shape (P, 3)
    positions, velocities : ndarray, shape (S, 3)
        Antenna position [m] and velocity [m/s] at mid-sweep.
    centroid_sine : ndarray, shape (S,)
        Doppler-centroid direction sine per sweep.
    half_width : float
        Processed aperture half width in direction sine.
    window : ndarray
        Cosine-series coefficients of the azimuth window.
    motion_correction : bool
        Shift the range lookup by the Doppler term ``f_c dtau/dt``.

    Returns
    -------
    weighted_sum : ndarray, shape (P,), complex
        Sum of the weighted, de-rotated profile values.
    total_weight : ndarray, shape (P,)
        Sum of the weights (see :func:`mitsar.focus.aperture.normalise_image`).
    """
    slant_range, sine, delay_rate = doppler_geometry(pixels, positions, velocities)
    delay = 2.0 * slant_range / SPEED_OF_LIGHT
    beat = beat_frequency(delay, delay_rate if motion_correction else 0.0, radar.chirp_rate,
                          radar.carrier_frequency)
    offset = sine - centroid_sine[:, None]
    weight = np.where(np.abs(offset) <= half_width,
                      evaluate_window(window, offset / (2 * half_width) + 0.5), 0.0)
    return pulse_sum(profile, frequency, delay, beat, weight, radar.carrier_frequency)


def _kernel_inputs(pixels: NDArray, sweeps: int, velocities: NDArray, window: NDArray,
                   sweep_range: tuple[NDArray, NDArray] | None) -> tuple:
    """Per-pixel sweep ranges (default all), speed and unit direction per sweep, and the
    window's cosine series padded to the kernels' four coefficients."""
    if sweep_range is None:
        sweep_range = (np.zeros(len(pixels), dtype=np.uint32),
                       np.full(len(pixels), sweeps, dtype=np.uint32))
    speed = np.linalg.norm(velocities, axis=-1)
    direction = velocities / np.where(speed > 0, speed, 1.0)[:, None]
    coefficients = np.zeros(4)
    coefficients[: len(window)] = window
    return sweep_range, speed, direction, coefficients


def _kernel_constants(opaque: Any, frequency: NDArray, radar: Radar, motion_correction: bool,
                      half_width: float, bins: int, coefficients: NDArray) -> dict:
    """The opaque scalars both kernels read (``opaque`` makes them in the kernel's precision)."""
    return {"frequency_step": opaque(frequency[1] - frequency[0]),
            "chirp_rate": opaque(radar.chirp_rate),
            "carrier": opaque(radar.carrier_frequency),
            "motion": opaque(1.0 if motion_correction else 0.0),
            "half_width": opaque(half_width),
            "bins": dr.opaque(UInt32, bins),
            "coefficients": [float(c) for c in coefficients]}


def _backproject_double(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                        positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                        half_width: float, window: NDArray, motion_correction: bool,
                        sweep_range: tuple[NDArray, NDArray] | None
                        ) -> tuple[NDArray, NDArray]:
    """The float64 kernel: geometry and phase in float64, sin/cos of the wrapped phase in
    float32 (1e-6 of the peak from :func:`backproject_numpy`)."""
    sweeps, bins = profile.shape
    sweep_range, speed, direction, coefficients = _kernel_inputs(pixels, sweeps, velocities,
                                                                 window, sweep_range)

    def opaque(value: float) -> Float64:
        return dr.opaque(Float64, float(value))

    sweep_arrays = [Float64(np.ascontiguousarray(a)) for a in (
        positions[:, 0], positions[:, 1], positions[:, 2],
        direction[:, 0], direction[:, 1], direction[:, 2], speed, centroid_sine)]
    constants = {"first_frequency": opaque(frequency[0]),
                 **_kernel_constants(opaque, frequency, radar, motion_correction, half_width,
                                     bins, coefficients)}
    # Profiles are read at random: float32 halves the memory traffic (1e-7 relative error).
    real = Float32(np.ascontiguousarray(profile.real, dtype=np.float32).ravel())
    imag = Float32(np.ascontiguousarray(profile.imag, dtype=np.float32).ravel())
    result_real, result_imag, total = _bpa_kernel(
        Float64(pixels[:, 0]), Float64(pixels[:, 1]), Float64(pixels[:, 2]),
        sweep_arrays, real, imag, UInt32(sweep_range[0]), UInt32(sweep_range[1]), constants)
    return np.asarray(result_real) + 1j * np.asarray(result_imag), np.asarray(total)


BLOCK = 64
"""Pixels per block of :func:`block_tables` (neighbours in the caller's order)."""

_TABLE_COLUMNS = ("to_x", "to_y", "to_z", "range", "turns", "bin", "fraction")


def backproject_drjit(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray, motion_correction: bool = True,
                      sweep_range: tuple[NDArray, NDArray] | None = None,
                      precision: str = "double", block: int = BLOCK
                      ) -> tuple[NDArray, NDArray]:
    """Back-projection as one Dr.Jit kernel (parameters as :func:`backproject_numpy`).

    ``sweep_range``, optional per-pixel first and end sweep indices, limits each lane's loop
    to the sweeps that can see the pixel inside the processed window
    (:func:`mitsar.focus.aperture.sweep_window`); by default every lane visits every sweep.

    ``precision="double"`` (default) evaluates geometry and phase in float64 (agrees with
    :func:`backproject_numpy` to 1e-6 of the peak). ``precision="single"`` runs in float32
    with float64 accuracy where it matters (:func:`block_tables`): pixels are grouped in
    blocks of ``block`` neighbours; per block and sweep the range of the block centre, its
    carrier phase (wrapped in float64) and its profile bin are tabulated, and each pixel adds
    its offset from the centre in the cancellation-free form of :func:`range_offset` (about
    -90 dB from the float64 reference for blocks a few decimetres across; docs/focusing.md,
    kernel speed).
    """
    require_llvm()
    if precision not in ("double", "single"):
        raise ParameterError("backproject_drjit", "precision", "'double' or 'single'",
                             precision)
    if precision == "double":
        return _backproject_double(profile, frequency, radar, pixels, positions, velocities,
                                   centroid_sine, half_width, window, motion_correction,
                                   sweep_range)
    sweeps, bins = profile.shape
    sweep_range, speed, direction, coefficients = _kernel_inputs(pixels, sweeps, velocities,
                                                                 window, sweep_range)
    first, end = (np.asarray(r, dtype=np.int64) for r in sweep_range)
    order, tables = block_tables(pixels, positions, first, end, radar, frequency, block)

    def opaque(value: float) -> Float32:
        return dr.opaque(Float32, float(value))

    def f32(array: NDArray) -> Float32:
        return jit_array(Float32, array, np.float32)

    # One interleaved buffer per kind of row (fewer, cache-friendly gather sources).
    sweep_rows = f32(np.column_stack([direction, speed, centroid_sine]).ravel())
    table_rows = f32(np.column_stack([tables[name] for name in _TABLE_COLUMNS]).ravel())
    # Profiles are read at random: float32 halves the memory traffic (1e-7 relative error).
    profile_pairs = f32(np.stack([profile.real, profile.imag], axis=-1).ravel())
    constants = _kernel_constants(opaque, frequency, radar, motion_correction, half_width, bins,
                                  coefficients)
    lanes = [f32(tables["offset"][:, i]) for i in range(3)]
    result = _bpa_loop(*lanes, jit_array(UInt32, tables["entry"], np.uint32),
                       jit_array(UInt32, first[order], np.uint32),
                       jit_array(UInt32, end[order], np.uint32), table_rows, sweep_rows,
                       profile_pairs, constants)
    dr.eval(*result)
    weighted_sum = np.empty(len(pixels), dtype=complex)
    total = np.empty(len(pixels))
    weighted_sum[order] = (np.asarray(result[0], dtype=float)
                           + 1j * np.asarray(result[1], dtype=float))
    total[order] = np.asarray(result[2], dtype=float)
    return weighted_sum, total


def range_offset(offset: Any, to_pixel: Any, centre_range: Any, sqrt: Callable[[Any], Any]
                 ) -> Any:
    """``|w + d| - |w|`` for the centre-to-pixel offset d and the sweep-to-centre vector w.

    Written ``(2 d.w + |d|^2) / (|w + d| + |w|)`` so that it keeps its relative accuracy in
    float32 however large ``|w|`` is (no cancellation): the range from sweep to pixel is
    ``|w| + range_offset`` with ``|w|`` (and its carrier phase) from a float64 table.

    Parameters
    ----------
    offset, to_pixel : sequence of three array_like
        d = pixel - block centre and w = block centre - antenna [m].
    centre_range : array_like
        ``|w|`` [m].
    sqrt : callable
    """
    dw = offset[0] * to_pixel[0] + offset[1] * to_pixel[1] + offset[2] * to_pixel[2]
    dd = offset[0] * offset[0] + offset[1] * offset[1] + offset[2] * offset[2]
    numerator = 2 * dw + dd
    return numerator / (sqrt(centre_range * centre_range + numerator) + centre_range)


def block_tables(pixels: NDArray, positions: NDArray, first: NDArray, end: NDArray,
                 radar: Radar, frequency: NDArray, block: int = BLOCK) -> tuple[NDArray, dict]:
    """Per-block, per-sweep float64 geometry for the float32 kernel.

    Pixels are taken in blocks of ``block`` (in their given order, or in a spatial order when
    the given one puts pixels more than a metre from their block's centre). For every block b
    and sweep k in the union of its pixels' sweep ranges: ``w = c_b - p_k``, ``|w|``, the carrier
    turns ``f_c 2 |w| / c`` wrapped to [0, 1) in float64 (:func:`carrier_turns`), and the
    position of the centre's beat frequency ``K 2 |w| / c`` on the profile axis ``frequency``
    split into its bin and the fraction (:func:`profile_position`), so that float32 lanes
    only add small offsets to exact values.

    Returns
    -------
    order : ndarray, shape (P,)
        Pixel order of the lanes.
    tables : dict
        ``offset`` (P, 3): pixel minus block centre [m] (lane order); ``entry`` (P,): index of
        the lane's block's row for sweep 0, so that sweep k is at ``entry + k``; ``to_x``,
        ``to_y``, ``to_z``, ``range`` [m], ``turns``, ``bin`` and ``fraction`` per
        (block, sweep) row.
    """
    count = len(pixels)
    order = np.arange(count)
    for attempt in range(2):
        blocks = np.arange(count) // block
        ordered = pixels[order]
        sums = np.zeros((blocks[-1] + 1 if count else 0, 3))
        np.add.at(sums, blocks, ordered)
        sizes = np.bincount(blocks)
        centre = sums / sizes[:, None]
        offset = ordered - centre[blocks]
        if attempt or count == 0 or np.abs(offset).max() <= 1.0:
            break
        # Neighbours first, among pixels that share a sweep range (keeps the tables short).
        cell = np.floor((pixels - pixels.min(axis=0)) / 0.25).astype(np.int64)
        order = np.lexsort((cell[:, 2], cell[:, 1], cell[:, 0], end, first))
    lane_first, lane_end = first[order], end[order]
    low = np.minimum.reduceat(lane_first, np.arange(0, count, block)) if count else first
    high = np.maximum.reduceat(lane_end, np.arange(0, count, block)) if count else end
    high = np.maximum(high, low)
    lengths = high - low
    starts = np.concatenate([[0], np.cumsum(lengths)[:-1]])
    total = int(lengths.sum())
    row_block = np.repeat(np.arange(len(lengths)), lengths)
    sweep = low[row_block] + (np.arange(total) - starts[row_block])
    to_pixel = centre[row_block] - positions[sweep]
    centre_range = np.linalg.norm(to_pixel, axis=-1)
    delay = 2.0 * centre_range / SPEED_OF_LIGHT
    turns = carrier_turns(delay, radar.carrier_frequency, np.floor)
    beat = beat_frequency(delay, 0.0, radar.chirp_rate, radar.carrier_frequency)
    lower, fraction = profile_position(beat, frequency[0], frequency[1] - frequency[0],
                                       np.floor)
    entry = (starts - low)[blocks]  # may be negative; entry + k >= 0 for k in range
    tables = {"offset": offset, "entry": entry, "to_x": to_pixel[:, 0],
              "to_y": to_pixel[:, 1], "to_z": to_pixel[:, 2], "range": centre_range,
              "turns": turns, "bin": lower, "fraction": fraction}
    return order, tables


def jit_array(kind: type, array: NDArray, dtype: type) -> Any:
    """A Dr.Jit array that owns an aligned copy of ``array``.

    Built straight from NumPy, an array may wrap NumPy's memory, whose alignment varies from
    call to call; the LLVM backend writes the alignment into the kernel, which then misses
    the kernel cache and recompiles. A copy made by Dr.Jit is always aligned.
    """
    value = kind(np.ascontiguousarray(array, dtype=dtype)) * dr.opaque(kind, 1)
    dr.eval(value)
    return value


def _bpa_kernel(x: Float64, y: Float64, z: Float64, sweep_arrays: list, real: Float64,
                imag: Float64, first: UInt32, end: UInt32, constants: dict) -> tuple:
    """Launch the back-projection loop and evaluate its three accumulators."""
    result = _bpa_loop64(x, y, z, *sweep_arrays, real, imag, first, end, constants["chirp_rate"],
                       constants["carrier"], constants["motion"], constants["first_frequency"],
                       constants["frequency_step"], constants["bins"], constants["half_width"],
                       constants["coefficients"])
    dr.eval(*result)
    return result


def _cos64(angle: Float32) -> Float64:
    return Float64(dr.cos(angle))


@dr.syntax
def _bpa_loop64(x, y, z, px, py, pz, dx_v, dy_v, dz_v, speed_all, centroid_all, real, imag,  # noqa: ANN001, ANN202, PLR0913
              first, end, chirp_rate, carrier, motion, first_frequency, frequency_step, bins,
              half_width, coefficients):
    """One lane per pixel, a symbolic loop over its sweeps (steps 1-4 of the module)."""
    two_over_c = 2.0 / SPEED_OF_LIGHT
    k = UInt32(first)
    acc_real = dr.zeros(Float64, dr.width(x))
    acc_imag = dr.zeros(Float64, dr.width(x))
    total = dr.zeros(Float64, dr.width(x))
    while k < end:
        ox = x - dr.gather(Float64, px, k)
        oy = y - dr.gather(Float64, py, k)
        oz = z - dr.gather(Float64, pz, k)
        slant_range = dr.sqrt(ox * ox + oy * oy + oz * oz)
        sine = (ox * dr.gather(Float64, dx_v, k) + oy * dr.gather(Float64, dy_v, k)
                + oz * dr.gather(Float64, dz_v, k)) / slant_range
        delay = two_over_c * slant_range
        delay_rate = -two_over_c * dr.gather(Float64, speed_all, k) * sine
        beat = beat_frequency(delay, motion * delay_rate, chirp_rate, carrier)
        lower, fraction = profile_position(beat, first_frequency, frequency_step, dr.floor)
        offset = sine - dr.gather(Float64, centroid_all, k)
        active = (lower >= 0) & (lower < Float64(bins - 1)) & (dr.abs(offset) <= half_width)
        flat = k * bins + UInt32(dr.select(active, lower, 0))
        v_real = interpolate(Float64(dr.gather(Float32, real, flat, active)),
                             Float64(dr.gather(Float32, real, flat + 1, active)), fraction)
        v_imag = interpolate(Float64(dr.gather(Float32, imag, flat, active)),
                             Float64(dr.gather(Float32, imag, flat + 1, active)), fraction)
        # Phase wrapped to one turn in float64, then evaluated in float32 (error < 1e-6 rad).
        sin_phase, cos_phase = dr.sincos(Float32(2 * dr.pi * carrier_turns(delay, carrier,
                                                                           dr.floor)))
        sin_phase, cos_phase = Float64(sin_phase), Float64(cos_phase)
        # Azimuth window at xi = offset / (2 half_width) (centre 0), in float32.
        weight = dr.select(active, Float64(cosine_series(
            coefficients, Float32(offset / (2 * half_width)), _cos64)), 0.0)
        part_real, part_imag = derotate(v_real, v_imag, sin_phase, cos_phase)
        acc_real += weight * part_real
        acc_imag += weight * part_imag
        total += weight
        k += 1
    return acc_real, acc_imag, total


def _cos32(angle: Float32) -> Float32:
    return dr.cos(angle)


@dr.syntax
def _bpa_loop(dx, dy, dz, entry, first, end, table_rows, sweep_rows, profile_pairs,  # noqa: ANN001, ANN202, PLR0913
              constants):
    """One lane per pixel, a symbolic loop over its sweeps (steps 1-4 of the module), float32.

    Sweep k of the lane's block: ``w``, ``|w|``, the wrapped carrier turns and the profile
    bin of ``|w|`` from the float64 tables; the pixel's range ``|w| + range_offset``; the
    carrier phase ``turns(|w|) + f_c 2 range_offset / c`` (a few hundred cycles at most:
    float32 keeps it to ~1e-4 rad).
    """
    chirp_rate, carrier, motion = (constants["chirp_rate"], constants["carrier"],
                                   constants["motion"])
    frequency_step = constants["frequency_step"]
    bins, half_width, coefficients = (constants["bins"], constants["half_width"],
                                      constants["coefficients"])
    two_over_c = 2.0 / SPEED_OF_LIGHT
    columns = len(_TABLE_COLUMNS)
    k = UInt32(first)
    acc_real = dr.zeros(Float32, dr.width(dx))
    acc_imag = dr.zeros(Float32, dr.width(dx))
    total = dr.zeros(Float32, dr.width(dx))
    while k < end:
        row = (entry + k) * columns
        wx = dr.gather(Float32, table_rows, row)
        wy = dr.gather(Float32, table_rows, row + 1)
        wz = dr.gather(Float32, table_rows, row + 2)
        centre_range = dr.gather(Float32, table_rows, row + 3)
        extra = range_offset((dx, dy, dz), (wx, wy, wz), centre_range, dr.sqrt)
        slant_range = centre_range + extra
        sweep = k * 5
        sine = ((wx + dx) * dr.gather(Float32, sweep_rows, sweep)
                + (wy + dy) * dr.gather(Float32, sweep_rows, sweep + 1)
                + (wz + dz) * dr.gather(Float32, sweep_rows, sweep + 2)) / slant_range
        delay_rate = -two_over_c * dr.gather(Float32, sweep_rows, sweep + 3) * sine
        # Beat frequency of the offset from the centre, placed after the centre's exact bin.
        beat = beat_frequency(two_over_c * extra, motion * delay_rate, chirp_rate, carrier)
        lower, fraction = profile_position(
            beat, -frequency_step * dr.gather(Float32, table_rows, row + 6), frequency_step,
            dr.floor)
        lower = lower + dr.gather(Float32, table_rows, row + 5)
        offset = sine - dr.gather(Float32, sweep_rows, sweep + 4)
        active = (lower >= 0) & (lower < Float32(bins - 1)) & (dr.abs(offset) <= half_width)
        flat = (k * bins + UInt32(dr.select(active, lower, 0))) * 2
        v_real = interpolate(dr.gather(Float32, profile_pairs, flat, active),
                             dr.gather(Float32, profile_pairs, flat + 2, active), fraction)
        v_imag = interpolate(dr.gather(Float32, profile_pairs, flat + 1, active),
                             dr.gather(Float32, profile_pairs, flat + 3, active), fraction)
        turns = (dr.gather(Float32, table_rows, row + 4)
                 + carrier_turns(two_over_c * extra, carrier, dr.floor))
        sin_phase, cos_phase = dr.sincos(2 * dr.pi * turns)
        # Azimuth window at xi = offset / (2 half_width) (centre 0).
        weight = dr.select(active, cosine_series(coefficients, offset / (2 * half_width),
                                                 _cos32), 0.0)
        part_real, part_imag = derotate(v_real, v_imag, sin_phase, cos_phase)
        acc_real += weight * part_real
        acc_imag += weight * part_imag
        total += weight
        k += 1
    return acc_real, acc_imag, total


# --------------------------------------------------------------------------------------------
# Recorded data referenced to a scene point
# --------------------------------------------------------------------------------------------
def backproject_referenced(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                           positions: NDArray, reference_range: NDArray,
                           sweep_weight: NDArray | None = None, chunk: int = 1 << 22,
                           ) -> tuple[NDArray, float]:
    """Back-projection of range profiles referenced to ``reference_range`` (NumPy, chunked).

    Pixel x, row k: ``dR = |x - p_k| - R_ref,k`` and ``tau = 2 dR / c``; the profile is
    interpolated (linearly, on its zero-padded axis) at the beat frequency ``K tau``, wrapped
    into the unambiguous band, and de-rotated by ``exp(-j 2 pi f_c tau)`` (:func:`pulse_sum`).

    Parameters
    ----------
    profile : ndarray, shape (S, F)
        Range profiles on the ascending uniform beat-frequency axis ``frequency`` [Hz]
        (:func:`mitsar.focus.compression.range_spectrum`).
    radar : Radar
        The equivalent radar.
    pixels : ndarray, shape (P, 3)
    positions : ndarray, shape (S, 3)
    reference_range : ndarray, shape (S,)
    sweep_weight : ndarray, shape (S,), optional
        Azimuth weight of every row (window over the aperture); ones by default.
    chunk : int
        Bound on pixels x rows evaluated at once.

    Returns
    -------
    weighted_sum : ndarray, shape (P,), complex
    total_weight : float
    """
    sweeps = profile.shape[0]
    weight = np.ones(sweeps) if sweep_weight is None else np.asarray(sweep_weight, float)
    out = np.zeros(len(pixels), dtype=complex)
    per = max(1, chunk // sweeps)
    for start in range(0, len(pixels), per):
        block = pixels[start:start + per]
        distance = np.linalg.norm(block[None, :, :] - positions[:, None, :], axis=-1)
        delay = 2.0 * (distance - reference_range[:, None]) / SPEED_OF_LIGHT
        beat = beat_frequency(delay, 0.0, radar.chirp_rate, radar.carrier_frequency)
        out[start:start + per] = pulse_sum(profile, frequency, delay, beat, weight[:, None],
                                           radar.carrier_frequency, periodic=True)[0]
    return out, float(weight.sum())
