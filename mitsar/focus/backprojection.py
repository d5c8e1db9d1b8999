"""The back-projection sum, written once for NumPy and for the Dr.Jit kernel.

For every pixel x and sweep (or pulse) k with two-way delay ``tau`` (and delay rate
``dtau/dt`` for continuous motion):

1. the echo of x sits in the range profile at the beat frequency ``f = K tau + f_c dtau/dt``
   (:func:`mitsar.model.signal.beat_frequency`; Meta 2007 §II-B): the Doppler term removes the
   FMCW range shift of continuous motion;
2. the profile, on its ascending uniform beat-frequency axis, is interpolated there
   (:func:`profile_position`; :mod:`mitsar.focus.interpolation`: 4-tap Lagrange cubic by
   default, or linear);
3. the value is de-rotated by ``exp(-j 2 pi f_c tau)``, the carrier phase the sweep-centred
   range FFT leaves (paper eq. 1; :func:`carrier_turns`, :func:`derotate`);
4. it is weighted by the azimuth window at the sweep's window offset g (direction sine less
   the centroid, or the pixel's aspect offset) times the part of the sweep's stretch of
   aperture inside ``|g| <= h`` (:func:`edge_fraction`: 1 inside, a fraction for the edge
   sweeps, so the aperture is not cut at whole sweeps; for a band narrower than the beam,
   :func:`fractional_edges`), and accumulated, with the sum of the weights for the
   normalisation.

Steps 1-3 are small pure functions of operators (and a ``floor``), called by the NumPy sum
(:func:`pulse_sum`, behind :func:`backproject_numpy` and :func:`backproject_referenced`) and by
the Dr.Jit loop (:func:`backproject_drjit`), so the reference and the kernel evaluate the same
expressions. The kernel is one symbolic loop over sweeps, compiled once and cached
(per-acquisition values are opaque): each lane takes a few pixels that share their sweep range
and gathers a sweep's geometry once for all of them; range, profile bin and carrier phase are
float64, the rest float32 (docs/focusing.md, kernel speed).

Recorded data referenced to a scene point (:mod:`mitsar.raw.recorded`) use the same sum with
``tau = 2 (R - R_ref,k) / c``, no delay rate, and a profile that is periodic in beat frequency.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.backend import array_namespace, namespace_of, safe_width
from mitsar.backend import drjit as dr  # imported when a kernel runs (LazyModule)
from mitsar.focus.aperture import aperture_half_width, doppler_geometry, median_sweep_interval
from mitsar.focus.interpolation import (
    DEFAULT_INTERPOLATION,
    coefficient_table,
    horner,
    jit_packets,
    lookup,
    numpy_fma,
)
from mitsar.focus.windows import cosine_series, evaluate_window
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import beat_frequency, half_path

__all__ = [
    "backproject_drjit",
    "backproject_numpy",
    "backproject_referenced",
    "carrier_turns",
    "derotate",
    "edge_fraction",
    "fractional_edges",
    "interpolate",
    "inverse_window_step",
    "jit_array",
    "kernel_tables",
    "pixel_pulse",
    "pulse_loop",
    "profile_position",
    "pulse_sum",
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
    """Linear interpolation between two neighbouring values (FFBP's weight images; the range
    profiles go through :mod:`mitsar.focus.interpolation`)."""
    return low * (1 - fraction) + high * fraction


def carrier_turns(delay: Any, carrier_frequency: Any, floor: Callable[[Any], Any]) -> Any:
    """Carrier phase ``f_c tau`` in turns, wrapped to [0, 1) in the caller's precision."""
    cycles = carrier_frequency * delay
    return cycles - floor(cycles)


def derotate(real: Any, imag: Any, sin_phase: Any, cos_phase: Any) -> tuple[Any, Any]:
    """Real and imaginary parts of ``(real + j imag) exp(-j phase)``."""
    return real * cos_phase + imag * sin_phase, imag * cos_phase - real * sin_phase


SMALLEST_WINDOW_STEP = 1e-30
"""Floor of the window step (a platform at rest, a pixel dead ahead): the edge fraction is
then the hard cut ``|g| <= h``."""


def inverse_window_step(rate: Any, spacing_over_range: Any, maximum: Callable) -> Any:
    """``1 / delta``: the window offset's change from one sweep to the next, inverted.

    Moving the antenna by ``s = |v| T`` along its unit velocity v (T the sweep interval)
    turns the unit line of sight l to a pixel at range R by ``-(s / R) (v - (v . l) l)``,
    so the window offset ``g = d . l - u`` changes by ``delta = (s / R) |d . v - (d . l)(l .
    v)|`` per sweep: ``rate = d . v - (d . l)(l . v)`` with the aspect frame's direction d
    (:func:`mitsar.focus.aperture.aspect_frames`), ``1 - (l . v)^2`` on the sweep's own
    velocity (d = v; a centroid that changes along a turn is neglected there). Floored at
    :data:`SMALLEST_WINDOW_STEP`.

    Parameters
    ----------
    rate : array_like
        ``d . v - (d . l)(l . v)`` (any sign).
    spacing_over_range : array_like
        ``|v| T / R`` [1].
    maximum : callable
        Element-wise maximum of the caller's array library.
    """
    return 1.0 / maximum(abs(rate) * spacing_over_range, SMALLEST_WINDOW_STEP)


def edge_fraction(offset: Any, inverse_step: Any, half_width: Any, clip: Callable) -> Any:
    """Part of a sweep's stretch of aperture that lies inside the window ``|g| <= h``.

    Sweep k stands for the aperture half-way to its neighbours, over which the window offset
    moves across ``[g_k - delta / 2, g_k + delta / 2]`` (:func:`inverse_window_step`); the
    part of it inside ``[-h, h]`` is ``clip(1/2 + (h - |g_k|) / delta, 0, 1)`` (for
    ``delta <= 2 h``): 1 well inside, 0 beyond ``h + delta / 2``, a fraction for the one
    or two sweeps at each edge. The processed aperture then spans ``2 h`` of window offset
    whatever the sampling, as the Doppler band-pass weights its edge bins
    (:func:`mitsar.focus.aperture.doppler_bandpass`); cut at whole sweeps it would jump by
    a sweep from pixel to pixel (64 or 65 sweeps at 10 cm, a 0.35 dB swing of the PSLR;
    docs/focusing.md, "An aperture that ignores the wander").
    """
    return clip(0.5 + (half_width - abs(offset)) * inverse_step, 0.0, 1.0)


def fractional_edges(radar: Radar, half_width: float) -> bool:
    """Whether the window's edges get :func:`edge_fraction` (else the cut ``|g| <= h``).

    Only a band narrower than the beam: the whole beam ends at the antenna pattern's first
    nulls (:func:`mitsar.focus.aperture.aperture_half_width`), where the echo vanishes and
    the part of an edge sweep inside changes nothing (nor does it cost the kernels' time, in
    the Doppler band selection's whole-beam sum, the default on straight tracks).
    """
    return bool(half_width < aperture_half_width(radar, None))


def pulse_sum(profile: NDArray, frequency: NDArray, delay: NDArray, beat: NDArray,
              weight: NDArray, carrier_frequency: float, periodic: bool = False,
              interpolation: str = DEFAULT_INTERPOLATION, table: NDArray | None = None
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
    interpolation : {"cubic", "linear"}
        Interpolation of the profile (:mod:`mitsar.focus.interpolation`).
    table : ndarray, shape (S, F, terms), optional
        The profile's :func:`mitsar.focus.interpolation.coefficient_table` if already made.

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
        lower %= bins
    else:
        weight = np.where((lower >= 0) & (lower < bins - 1), weight, 0.0)
        lower = np.clip(lower, 0, bins - 2)
    if table is None:
        table = coefficient_table(profile, interpolation, periodic)
    rows = np.arange(profile.shape[0])[:, None]
    value = horner(tuple(np.moveaxis(table[rows, lower], -1, 0)), fraction, numpy_fma)
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
                      motion_correction: bool = True,
                      aspect: tuple[NDArray, NDArray] | None = None,
                      receivers: NDArray | None = None,
                      interpolation: str = DEFAULT_INTERPOLATION,
                      table: NDArray | None = None) -> tuple[NDArray, NDArray]:
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
    aspect : (ndarray (P, 3), ndarray (P,)), optional
        Per-pixel window frame (:func:`mitsar.focus.aperture.aspect_frames`): the window is
        then evaluated at ``d_pixel . l_hat - u_pixel`` instead of ``v_hat . l_hat - u_c``.
    receivers : ndarray, shape (S, 3), optional
        A bistatic channel's receive phase centre per sweep [m] (``positions`` is then its
        transmitter): the delay is the exact path ``(|t - x| + |x - r|) / c``
        (:func:`mitsar.model.signal.bistatic_delay`), looked up as a "range" of half the path
        (:func:`half_path`); direction sine and delay rate stay the transmitter's (a receiver
        centimetres away changes them by ~1e-5).
    interpolation : {"cubic", "linear"}
        Interpolation of the profiles (:mod:`mitsar.focus.interpolation`).
    table : ndarray, optional
        The profile's :func:`mitsar.focus.interpolation.coefficient_table` if already made
        (a focus by pixel chunks makes it once).

    Returns
    -------
    weighted_sum : ndarray, shape (P,), complex
        Sum of the weighted, de-rotated profile values.
    total_weight : ndarray, shape (P,)
        Sum of the weights (see :func:`mitsar.focus.aperture.normalise_image`).
    """
    slant_range, sine, delay_rate = doppler_geometry(pixels, positions, velocities)
    path = slant_range   # the "range" looked up: half the exact path of a bistatic channel
    if receivers is not None:
        path = half_path(slant_range, np.linalg.norm(pixels[None] - receivers[:, None],
                                                     axis=-1))
    delay = 2.0 * path / SPEED_OF_LIGHT
    beat = beat_frequency(delay, delay_rate if motion_correction else 0.0, radar.chirp_rate,
                          radar.carrier_frequency)
    offset = sine - centroid_sine[:, None]
    speed = np.linalg.norm(velocities, axis=-1)
    spacing_over_range = (speed * median_sweep_interval(positions, velocities))[:, None] \
        / slant_range
    if aspect is None:
        rate = 1.0 - sine * sine
    else:
        offset = (np.einsum("spi,pi->sp", pixels[None] - positions[:, None], aspect[0])
                  / slant_range - aspect[1][None])
        along = velocities @ aspect[0].T / np.where(speed > 0, speed, 1.0)[:, None]  # d . v
        rate = along - (offset + aspect[1][None]) * sine
    fraction = (edge_fraction(offset, inverse_window_step(rate, spacing_over_range, np.maximum),
                              half_width, np.clip) if fractional_edges(radar, half_width)
                else (np.abs(offset) <= half_width).astype(float))
    inside = np.clip(offset, -half_width, half_width) / (2 * half_width) + 0.5
    weight = np.where(fraction > 0, evaluate_window(window, inside) * fraction, 0.0)
    return pulse_sum(profile, frequency, delay, beat, weight, radar.carrier_frequency,
                     interpolation=interpolation, table=table)


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


def backproject_drjit(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray, motion_correction: bool = True,
                      sweep_range: tuple[NDArray, NDArray] | None = None,
                      aspect: tuple[NDArray, NDArray] | None = None,
                      receivers: NDArray | None = None,
                      interpolation: str = DEFAULT_INTERPOLATION, packets: Any = None
                      ) -> tuple[NDArray, NDArray]:
    """Back-projection as one Dr.Jit kernel (parameters as :func:`backproject_numpy`;
    ``packets``: the profile's :func:`mitsar.focus.interpolation.jit_packets` if already on
    the device, e.g. from an earlier pixel chunk).

    ``sweep_range``, optional per-pixel first and end sweep indices, limits each pixel to the
    sweeps that can see it inside the processed window
    (:func:`mitsar.focus.aperture.sweep_window`); by default every pixel takes every sweep.
    ``aspect``, optional per-pixel window frame (:func:`mitsar.focus.aperture.aspect_frames`),
    windows on the pixel's aspect angle as in :func:`backproject_numpy`.

    Range, profile bin and carrier phase are evaluated in float64, the rest (direction sine,
    Doppler shift of the lookup, interpolation, sin/cos, de-rotation, window, sums) in
    float32; each lane takes :data:`LANE_PIXELS` pixels of similar sweep range and gathers a
    sweep's geometry once for all of them (docs/focusing.md, kernel speed). Agrees with
    :func:`backproject_numpy` to 1e-6 of the peak (about -120 dB over an image). Runs on the
    backend of :func:`mitsar.backend.array_namespace` (LLVM on the CPU or CUDA; docs/gpu.md).
    """
    jit = array_namespace()
    Float32, Float64, UInt32 = jit.Float32, jit.Float64, jit.UInt32  # Dr.Jit type names
    if len(pixels) == 0:
        return np.zeros(0, dtype=complex), np.zeros(0)
    sweeps = profile.shape[0]
    sweep_range = _kernel_inputs(pixels, sweeps, velocities, window, sweep_range)[0]
    first, end = (np.asarray(r, dtype=np.int64) for r in sweep_range)
    groups = _lane_groups(first, LANE_PIXELS)
    lanes = len(groups)
    constants, sweep_arrays, pairs = kernel_tables(profile, frequency, radar, positions,
                                                   velocities, centroid_sine, half_width,
                                                   window, motion_correction, receivers,
                                                   interpolation, packets)
    index = groups.ravel()
    count = len(pixels)
    natural = bool(np.array_equal(index[:count], np.arange(count)))

    def lane_order(array: NDArray, pad: Any) -> NDArray:
        """``array`` in the lanes' order, padding (index -1) filled with ``pad``."""
        rest = array.shape[1:]
        if natural:  # pixels already in order: pad the end, no gather
            padding = np.broadcast_to(pad, (len(index) - count, *rest))
            return np.concatenate([array, padding]).reshape(lanes, LANE_PIXELS, *rest)
        return np.concatenate([array, np.broadcast_to(pad, (1, *rest))])[groups]

    padded_first = lane_order(first, 0)  # padding gets an empty range
    padded_end = lane_order(end, 0)
    grouped = lane_order(pixels, pixels[:1])  # (L, LANE_PIXELS, 3)
    frames = (None if aspect is None else  # (L, LANE_PIXELS, 4): direction, centre sine
              lane_order(np.column_stack([aspect[0], aspect[1]]), np.zeros(4)))
    lane_pixels = [tuple(jit_array(Float64, grouped[:, g, i], np.float64) for i in range(3))
                   + (jit_array(UInt32, padded_first[:, g], np.uint32),
                      jit_array(UInt32, padded_end[:, g], np.uint32))
                   + (() if frames is None else
                      tuple(jit_array(Float32, frames[:, g, i], np.float32) for i in range(4)))
                   for g in range(LANE_PIXELS)]
    lane_first = jit_array(UInt32, padded_first.min(axis=1, initial=sweeps,
                                                    where=padded_end > padded_first), np.uint32)
    lane_end = jit_array(UInt32, padded_end.max(axis=1), np.uint32)
    result = pulse_loop(lane_pixels, lane_first, lane_end, sweep_arrays, pairs, constants,
                       lanes)
    dr.eval(*result)
    # (3 G, L) accumulators -> per part, values in the order of groups.ravel().
    parts = np.stack([np.asarray(r, dtype=float) for r in result]).reshape(
        LANE_PIXELS, 3, lanes).transpose(1, 2, 0).reshape(3, -1)
    if natural:
        return parts[0, :count] + 1j * parts[1, :count], parts[2, :count]
    keep = index >= 0
    weighted_sum = np.zeros(count, dtype=complex)
    total = np.zeros(count)
    weighted_sum[index[keep]] = parts[0, keep] + 1j * parts[1, keep]
    total[index[keep]] = parts[2, keep]
    return weighted_sum, total


def kernel_tables(profile: NDArray, frequency: NDArray, radar: Radar, positions: NDArray,
                  velocities: NDArray, centroid_sine: NDArray, half_width: float,
                  window: NDArray, motion_correction: bool = True,
                  receivers: NDArray | None = None,
                  interpolation: str = DEFAULT_INTERPOLATION,
                  packets: Any = None) -> tuple[dict, list, Any]:
    """Constants, per-sweep geometry and packed profiles that :func:`pixel_pulse` reads.

    Parameters as :func:`backproject_numpy` (``packets``: the packed profiles if already made,
    returned as they are). Returns the kernel constants (opaque scalars:
    profile position of ``K tau`` and of the Doppler term, carrier turns per metre, bins,
    half width, window coefficients, sweep interval
    (:func:`mitsar.focus.aperture.median_sweep_interval`) for the edge fractions, and
    whether they apply, :func:`fractional_edges`), the sweep arrays (position float64; unit
    direction, speed and centroid sine float32; a bistatic channel's receiver position
    float64) and the profiles as packets of interpolation coefficients, float32
    (:func:`mitsar.focus.interpolation.kernel_packets`; ``constants["interpolation"]`` names
    the kind), all on the backend of :func:`mitsar.backend.array_namespace`.
    """
    jit = array_namespace()
    Float32, Float64, UInt32 = jit.Float32, jit.Float64, jit.UInt32
    sweeps, bins = profile.shape
    _, speed, direction, coefficients = _kernel_inputs(positions[:0], sweeps, velocities,
                                                       window, None)
    step = frequency[1] - frequency[0]
    two_over_c = 2.0 / SPEED_OF_LIGHT
    constants = {
        # index = (K 2R/c - f_0) / df + f_c dtau/dt / df (beat_frequency, profile_position)
        "range_scale": dr.opaque(Float64, radar.chirp_rate * two_over_c / step),
        "index_offset": dr.opaque(Float64, -frequency[0] / step),
        "doppler_scale": dr.opaque(Float32, -radar.carrier_frequency * two_over_c / step
                                   if motion_correction else 0.0),
        "carrier_scale": dr.opaque(Float64, radar.carrier_frequency * two_over_c),
        "bins": dr.opaque(UInt32, bins),
        "half_width": dr.opaque(Float32, half_width),
        "sweep_interval": dr.opaque(Float32, median_sweep_interval(positions, velocities)),
        "fractional_edges": fractional_edges(radar, half_width),
        "coefficients": [float(c) for c in coefficients],
        "interpolation": interpolation}
    sweep_arrays = ([jit_array(Float64, positions[:, i], np.float64) for i in range(3)]
                    + [jit_array(Float32, a, np.float32) for a in (
                        direction[:, 0], direction[:, 1], direction[:, 2], speed,
                        centroid_sine)]
                    + ([] if receivers is None else
                       [jit_array(Float64, receivers[:, i], np.float64) for i in range(3)]))
    # Profiles are read at random: one packet of coefficients per lookup.
    pairs = jit_packets(profile, interpolation, jit_array) if packets is None else packets
    return constants, sweep_arrays, pairs


LANE_PIXELS = 4
"""Pixels per lane of the float64 kernel: the per-sweep geometry is gathered once for all."""


def _lane_groups(first: NDArray, group: int) -> NDArray:
    """Pixel indices of every lane, shape (L, group), -1 for padding.

    Pixels are taken in order of their first sweep (stable: the caller's order among equal
    ones), so that the pixels of a lane share their sweep range. L is padded past the widths
    at which Dr.Jit 1.5's LLVM backend crashes (:func:`mitsar.backend.safe_width`, at most 15
    lanes of padding only: empty sweep ranges, their results dropped).
    """
    sorted_already = len(first) < 2 or bool(np.all(first[1:] >= first[:-1]))
    order = np.arange(len(first)) if sorted_already else np.argsort(first, kind="stable")
    lanes = safe_width(-(-len(order) // group))
    padded = np.full(lanes * group, -1, dtype=np.int64)
    padded[: len(order)] = order
    return padded.reshape(lanes, group)


def jit_array(kind: type, array: NDArray, dtype: type) -> Any:
    """A Dr.Jit array that owns an aligned copy of ``array``.

    Built straight from NumPy, an array may wrap NumPy's memory, whose alignment varies from
    call to call; the LLVM backend writes the alignment into the kernel, which then misses
    the kernel cache and recompiles. A copy made by Dr.Jit is always aligned.
    """
    value = kind(np.ascontiguousarray(array, dtype=dtype)) * dr.opaque(kind, 1)
    dr.eval(value)
    return value


def _cos32(angle: Any) -> Any:
    return dr.cos(angle)


def pixel_pulse(k: Any, pixel: tuple, sweep: tuple, pairs: Any, constants: dict
                 ) -> tuple[Any, Any, Any]:
    """Weighted, de-rotated profile value of one pixel for sweep k (steps 1-4 of the module).

    Range, profile position and carrier turns in float64 (:func:`carrier_turns`,
    :func:`profile_position`); the direction sine, the Doppler shift of the lookup
    (:func:`mitsar.model.signal.beat_frequency`, Meta 2007 §II-B), the interpolation, the
    de-rotation and the window in float32. Array types from ``k``'s backend.
    """
    jit = namespace_of(k)
    Float32, Int32, UInt32 = jit.Float32, jit.Int32, jit.UInt32
    x, y, z, first, end = pixel[:5]
    gx, gy, gz, ux, uy, uz, speed, centroid = sweep[:8]
    bins, half_width = constants["bins"], constants["half_width"]
    ox, oy, oz = x - gx, y - gy, z - gz
    slant_range = dr.sqrt(ox * ox + oy * oy + oz * oz)
    inverse_range = dr.rcp(Float32(slant_range))
    if len(sweep) > 8:  # a bistatic channel: half its exact path (half_path)
        ex, ey, ez = x - sweep[8], y - sweep[9], z - sweep[10]
        slant_range = half_path(slant_range, dr.sqrt(ex * ex + ey * ey + ez * ez))
    sine = (Float32(ox) * ux + Float32(oy) * uy + Float32(oz) * uz) * inverse_range
    # Bin of K tau (float64), then the Doppler term f_c dtau/dt (float32, a few bins at most).
    lower, fraction = profile_position(slant_range * constants["range_scale"],
                                       -constants["index_offset"], 1.0, dr.floor)
    shift, fraction = profile_position(Float32(fraction)
                                       + constants["doppler_scale"] * speed * sine,
                                       0.0, 1.0, dr.floor)
    bin_index = Int32(lower) + Int32(shift)
    offset = sine - centroid
    rate = 1.0 - sine * sine
    if len(pixel) > 5:  # aspect-angle window (curved tracks): the pixel's own frame
        dx, dy, dz, centre = pixel[5:]
        offset = (Float32(ox) * dx + Float32(oy) * dy + Float32(oz) * dz) * inverse_range - centre
        rate = ux * dx + uy * dy + uz * dz - (offset + centre) * sine
    if constants["fractional_edges"]:  # a band narrower than the beam
        part = edge_fraction(offset, inverse_window_step(
            rate, speed * constants["sweep_interval"] * inverse_range, dr.maximum),
            half_width, dr.clip)
    else:
        part = dr.select(dr.abs(offset) <= half_width, Float32(1.0), Float32(0.0))
    active = ((k >= first) & (k < end) & (bin_index >= 0) & (bin_index < Int32(bins - 1))
              & (part > 0))
    flat = k * bins + UInt32(dr.select(active, bin_index, 0))
    v_real, v_imag = lookup(pairs, flat, fraction, active, constants["interpolation"])
    # Carrier phase wrapped to one turn in float64, sin/cos in float32 (error < 1e-6 rad).
    turns = carrier_turns(slant_range, constants["carrier_scale"], dr.floor)
    sin_phase, cos_phase = dr.sincos(Float32(2 * math.pi) * Float32(turns))
    inside = dr.clip(offset, -half_width, half_width)
    weight = dr.select(active, part * cosine_series(constants["coefficients"],
                                                    inside / (2 * half_width), _cos32), 0.0)
    part_real, part_imag = derotate(v_real, v_imag, sin_phase, cos_phase)
    return weight * part_real, weight * part_imag, weight


def pulse_loop(lane_pixels: list, first: Any, end: Any, sweep_arrays: list, pairs: Any,
               constants: dict, lanes: int) -> list:
    """A symbolic loop over sweeps, ``len(lane_pixels)`` pixels (or FFBP nodes) per lane: the
    sweep's geometry is gathered once per lane and sweep; three float32 accumulators (real,
    imaginary, weight) per pixel, in that order (:func:`pixel_pulse`); on ``first``'s backend."""
    jit = namespace_of(first)

    def condition(k: Any, *_: Any) -> Any:
        return k < end

    def body(k: Any, *accumulators: Any) -> tuple:
        sweep = tuple(dr.gather(type(a), a, k) for a in sweep_arrays)
        out = []
        for g, pixel in enumerate(lane_pixels):
            parts = pixel_pulse(k, pixel, sweep, pairs, constants)
            out += [accumulators[3 * g + i] + parts[i] for i in range(3)]
        return (k + 1, *out)

    state = (jit.UInt32(first),
             *[dr.zeros(jit.Float32, lanes) for _ in range(3 * len(lane_pixels))])
    return list(dr.while_loop(state, condition, body)[1:])


# --------------------------------------------------------------------------------------------
# Recorded data referenced to a scene point
# --------------------------------------------------------------------------------------------
def backproject_referenced(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                           positions: NDArray, reference_range: NDArray,
                           sweep_weight: NDArray | None = None, chunk: int = 1 << 22,
                           interpolation: str = DEFAULT_INTERPOLATION
                           ) -> tuple[NDArray, float]:
    """Back-projection of range profiles referenced to ``reference_range`` (NumPy, chunked).

    Pixel x, row k: ``dR = |x - p_k| - R_ref,k`` and ``tau = 2 dR / c``; the profile is
    interpolated (``interpolation``, :mod:`mitsar.focus.interpolation`, on its zero-padded
    axis) at the beat frequency ``K tau``, wrapped
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
    interpolation : {"cubic", "linear"}
        Interpolation of the profiles.

    Returns
    -------
    weighted_sum : ndarray, shape (P,), complex
    total_weight : float
    """
    sweeps = profile.shape[0]
    weight = np.ones(sweeps) if sweep_weight is None else np.asarray(sweep_weight, float)
    out = np.zeros(len(pixels), dtype=complex)
    per = max(1, chunk // sweeps)
    table = coefficient_table(profile, interpolation, periodic=True)
    for start in range(0, len(pixels), per):
        block = pixels[start:start + per]
        distance = np.linalg.norm(block[None, :, :] - positions[:, None, :], axis=-1)
        delay = 2.0 * (distance - reference_range[:, None]) / SPEED_OF_LIGHT
        beat = beat_frequency(delay, 0.0, radar.chirp_rate, radar.carrier_frequency)
        out[start:start + per] = pulse_sum(profile, frequency, delay, beat, weight[:, None],
                                           radar.carrier_frequency, periodic=True,
                                           table=table)[0]
    return out, float(weight.sum())
