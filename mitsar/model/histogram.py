"""Range histograms of the ray tracer and their synthesis into raw sweeps (docs/design.md §5.5).

A contribution with two-way delay ``tau_0`` at mid-sweep, delay rate ``dtau/dt`` and amplitude
``a`` is, to first order in fast time, a tone at the beat frequency ``f = K tau_0 + f_c dtau/dt``
(:func:`mitsar.model.signal.apparent_beat_frequency`) with phase
``2 pi (f_c tau_0 - K tau_0^2 / 2)``.
The tracer deposits ``a exp{j 2 pi (f_c tau_0 - K tau_0^2 / 2)}`` at the *apparent range*
``c f / (2K)`` into a complex histogram whose bins are ``1 / bins_per_cell`` of a range cell,
splitting each deposit linearly between its two neighbouring bins. One inverse FFT per sweep,
with ``exp(-j pi f T)`` for the sweep-centred time origin, then gives the raw samples.

Bin grid
--------
Bin ``j`` of a histogram sits at the apparent range ``r_j = (k_0 + j) dr`` with an integer
``k_0`` (possibly negative) and ``dr = c df / (2K)``, ``df = f_s / (bins_per_cell N_s)``: the
frequencies of the bins are exactly the frequencies of an ``bins_per_cell N_s``-point DFT of the
sweep, so the synthesis is exact (no resampling) and apparent ranges beyond the Nyquist range
alias exactly as the sampled signal does. When ``f_s T`` is an integer (Table 1: 660) ``dr`` is
the range cell ``c / (2B)`` divided by ``bins_per_cell``.

Everything here is pure NumPy; the Dr.Jit kernel of the ``radar`` integrator evaluates the same
formulas (:func:`apparent_range`, :func:`deposit_cycles` and :func:`split_weights` are written
with plain arithmetic so that they accept Dr.Jit arrays too).
"""

from __future__ import annotations

import math
import os
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.radar import SPEED_OF_LIGHT, Radar

DEFAULT_BINS_PER_CELL = 16
"""Histogram bins per range cell (docs/design.md §5.5: -54 dB synthesis error with linear
splitting)."""


# --- the bin grid ---------------------------------------------------------------------------

def frequency_step(radar: Radar, bins_per_cell: int = DEFAULT_BINS_PER_CELL) -> float:
    """Beat-frequency width of one histogram bin, ``f_s / (bins_per_cell N_s)`` [Hz]."""
    return radar.sampling_frequency / (_check_bins_per_cell(bins_per_cell)
                                       * radar.samples_per_sweep)


def range_step(radar: Radar, bins_per_cell: int = DEFAULT_BINS_PER_CELL) -> float:
    """Apparent-range width of one histogram bin, ``c df / (2K)`` [m]."""
    return SPEED_OF_LIGHT * frequency_step(radar, bins_per_cell) / (2.0 * radar.chirp_rate)


def bin_grid(radar: Radar, min_range: float, max_range: float,
             bins_per_cell: int = DEFAULT_BINS_PER_CELL) -> tuple[int, int]:
    """Integer bin grid covering apparent ranges ``[min_range, max_range]``.

    Returns
    -------
    first_index, count : int
        ``k_0`` and the number of bins; bin ``j`` sits at ``(k_0 + j) * range_step``.
    """
    if not (math.isfinite(min_range) and math.isfinite(max_range) and max_range > min_range):
        raise ParameterError("bin_grid", "max_range", f"a finite range > min_range "
                             f"({min_range!r} m)", max_range)
    step = range_step(radar, bins_per_cell)
    first = int(math.floor(min_range / step)) - 1
    last = int(math.ceil(max_range / step)) + 1
    return first, last - first + 1


def bin_ranges(radar: Radar, first_index: int, count: int,
               bins_per_cell: int = DEFAULT_BINS_PER_CELL) -> NDArray[np.float64]:
    """Apparent range of each bin of a grid, ``(k_0 + j) * range_step`` [m]."""
    return (first_index + np.arange(count)) * range_step(radar, bins_per_cell)


def grid_of(ranges: ArrayLike, radar: Radar) -> tuple[int, int, int]:
    """Recover ``(first_index, count, bins_per_cell)`` from the bin ranges of a histogram.

    Raises
    ------
    ParameterError
        If the ranges are not a uniform grid of :func:`range_step` for an integer number of bins
        per cell, starting at an integer multiple of the step.
    """
    ranges = np.asarray(ranges, dtype=float)
    if ranges.ndim != 1 or len(ranges) < 2:
        raise ParameterError("histogram_to_raw", "bin_ranges", "at least two bin ranges",
                             ranges.shape)
    spacing = (ranges[-1] - ranges[0]) / (len(ranges) - 1)
    cell = range_step(radar, 1)
    bins_per_cell = int(round(cell / spacing))
    expected = f"a uniform grid of (c/2K) f_s/(n N_s) = {cell:.6g}/n m for an integer n"
    if bins_per_cell < 1 or abs(cell / bins_per_cell - spacing) > 1e-6 * spacing:
        raise ParameterError("histogram_to_raw", "bin_ranges", expected, f"spacing {spacing!r}")
    step = cell / bins_per_cell
    first = int(round(ranges[0] / step))
    if (abs(first * step - ranges[0]) > 1e-3 * step
            or np.max(np.abs(np.diff(ranges) - step)) > 1e-3 * step):
        raise ParameterError("histogram_to_raw", "bin_ranges",
                             f"{expected}, starting at a multiple of the step",
                             f"first {ranges[0]!r}")
    return first, len(ranges), bins_per_cell


# --- what one contribution deposits (ops-agnostic formulas) ------------------------------------

def apparent_range(slant_range: Any, range_rate: Any, radar: Radar) -> Any:
    """Apparent range ``c f / (2K)`` of an echo [m] (docs/design.md §5.5).

    With ``tau_0 = 2R/c`` and ``dtau/dt = 2 dR/dt / c`` the beat frequency
    ``f = K tau_0 + f_c dtau/dt`` (:func:`mitsar.model.signal.apparent_beat_frequency`) maps to
    ``R + (f_c / K) dR/dt``. Plain arithmetic: accepts NumPy and Dr.Jit arrays.

    Parameters
    ----------
    slant_range : array_like
        One-way range at mid-sweep [m] (monostatic; for a bistatic path, half the path length).
    range_rate : array_like
        Its time derivative [m/s] (positive receding).
    radar : Radar
        Or any object with ``carrier_frequency`` and ``chirp_rate`` (a kernel's constants).
    """
    return slant_range + (radar.carrier_frequency / radar.chirp_rate) * range_rate


def deposit_cycles(delay: Any, radar: Radar, rvp: Any = 1.0) -> Any:
    """Phase of a deposit in cycles, ``f_c tau_0 - K tau_0^2 / 2`` (float64!).

    :func:`mitsar.model.signal.dechirped_phase_cycles` at ``t = 0``; plain arithmetic so that a
    Dr.Jit ``Float64`` works too. Wrap with ``x - floor(x)`` before multiplying by 2 pi.

    Parameters
    ----------
    delay : array_like
        Two-way delay at mid-sweep tau_0 [s].
    radar : Radar
        Or any object with ``carrier_frequency`` [Hz] and ``chirp_rate`` [Hz/s] (a kernel passes
        its packed constants).
    rvp : float or array_like
        1 keeps the residual video phase ``-K tau_0^2 / 2``, 0 drops it (paper eq. 1).
    """
    return radar.carrier_frequency * delay - rvp * (0.5 * radar.chirp_rate) * delay * delay


def carrier_cycles_per_metre(radar: Radar) -> Any:
    """``2 f_c / c`` [cycles/m]: the carrier term ``f_c tau_0`` of :func:`deposit_cycles` (paper
    eq. 1, docs/design.md §5.5) per metre of one-way range, ``tau_0 = 2R/c`` (the linear part
    of :func:`deposit_cycles_change`)."""
    return (2.0 / SPEED_OF_LIGHT) * radar.carrier_frequency


def rvp_cycles_change(range_change: Any, slant_range: Any, radar: Radar) -> Any:
    """``-(2K / c^2)(2R + d) d`` [cycles]: the residual video phase's part of
    :func:`deposit_cycles_change` (``-K tau_0^2/2`` with ``tau_0 = 2R/c``, paper eq. 1)."""
    return -(2.0 / SPEED_OF_LIGHT**2) * radar.chirp_rate * (2.0 * slant_range
                                                           + range_change) * range_change


def deposit_cycles_change(range_change: Any, slant_range: Any, radar: Radar,
                          rvp: Any = 1.0) -> Any:
    """Change of :func:`deposit_cycles` when the one-way range goes from ``R`` to ``R + d``.

    ``deposit_cycles`` is a quadratic in ``tau_0 = 2R/c``, so the change is exactly
    ``(2 f_c / c) d - rvp (2K / c^2)(2R + d) d`` [cycles]
    (:func:`carrier_cycles_per_metre`, :func:`rvp_cycles_change`). The block kernel of the
    ``radar`` integrator evaluates the carrier term's linear ramp over a chunk exactly and the
    rest in float32 (docs/integrator.md §"Performance"). Plain arithmetic: accepts NumPy and
    Dr.Jit arrays.

    Parameters
    ----------
    range_change : array_like
        ``d`` [m].
    slant_range : array_like
        ``R`` [m].
    radar : Radar
        Or any object with ``carrier_frequency`` [Hz] and ``chirp_rate`` [Hz/s].
    rvp : float or array_like
        1 keeps the residual video phase, 0 drops it (as :func:`deposit_cycles`).
    """
    return (range_change * carrier_cycles_per_metre(radar)
            + rvp * rvp_cycles_change(range_change, slant_range, radar))


def split_weights(position: Any, floor: Any = np.floor) -> tuple[Any, Any, Any]:
    """Linear splitting of a deposit at fractional bin ``position``.

    Returns
    -------
    lower, weight_lower, weight_upper
        The deposit goes ``weight_lower`` into bin ``lower`` and ``weight_upper`` into
        ``lower + 1`` (``lower`` as a float; weights sum to 1).
    """
    lower = floor(position)
    upper_weight = position - lower
    return lower, 1.0 - upper_weight, upper_weight


def deposit_values(amplitude: ArrayLike, delay: ArrayLike, radar: Radar,
                   phase_cycles: ArrayLike = 0.0) -> NDArray[np.complex128]:
    """Complex deposits ``a exp{j 2 pi (f_c tau_0 - K tau_0^2/2 + phi)}``.

    Parameters
    ----------
    amplitude : array_like
        Real (or complex) amplitude a [sqrt(W)].
    delay : array_like
        Two-way delay at mid-sweep tau_0 [s].
    phase_cycles : array_like
        Extra phase phi [cycles] (e.g. a fixed speckle phase).
    """
    cycles = deposit_cycles(np.asarray(delay, dtype=np.float64), radar) + np.asarray(phase_cycles)
    return np.asarray(amplitude) * np.exp(2j * np.pi * (cycles - np.floor(cycles)))


def deposit(histogram: NDArray, index: ArrayLike | tuple, value: ArrayLike,
            apparent_ranges: ArrayLike, first_range: float, step: float) -> NDArray:
    """Add complex ``value`` at ``apparent_ranges`` into ``histogram``, split linearly.

    Parameters
    ----------
    histogram : ndarray, shape (..., bins), complex
        Updated in place (and returned).
    index : array_like or tuple of array_like
        Leading indices (e.g. ``(sweep, order)``) of each deposit, broadcast with ``value``.
    value : array_like, complex
        Deposits.
    apparent_ranges : array_like
        Apparent range of each deposit [m].
    first_range, step : float
        Range of bin 0 and the bin width [m]. Deposit halves outside the grid are dropped.
    """
    bins = histogram.shape[-1]
    index = index if isinstance(index, tuple) else (index,)
    lower, w_lo, w_hi = split_weights((np.asarray(apparent_ranges, dtype=np.float64)
                                       - first_range) / step)
    lower = lower.astype(np.int64)
    value = np.asarray(value)
    arrays = np.broadcast_arrays(*index, value, lower, w_lo, w_hi)
    *lead, value, lower, w_lo, w_hi = arrays
    for offset, weight in ((0, w_lo), (1, w_hi)):
        target = lower + offset
        ok = (target >= 0) & (target < bins)
        np.add.at(histogram, tuple(i[ok] for i in lead) + (target[ok],), value[ok] * weight[ok])
    return histogram


# --- synthesis ----------------------------------------------------------------------------------

def histogram_to_raw(histogram: ArrayLike, bin_ranges: ArrayLike, radar: Radar) -> NDArray:
    """Raw dechirped sweeps from range histograms: one inverse FFT per sweep (docs/design.md §5.5).

    ``s(t_n) = sum_j H_j exp(j 2 pi f_j t_n)`` with ``f_j = k_j df``, ``t_n = -T/2 + n/f_s``:
    each bin is multiplied by ``exp(-j pi f_j T)`` (centred time origin), placed at DFT index
    ``k_j mod M`` (``M = bins_per_cell N_s``; apparent ranges beyond the Nyquist range alias as
    the sampled signal would) and the first ``N_s`` samples of an ``M``-point inverse DFT kept.

    Parameters
    ----------
    histogram : array_like, shape (..., bins), complex
        Histograms (e.g. (sweep, bins); sum the ``order`` axis first).
    bin_ranges : array_like, shape (bins,)
        Apparent range of each bin [m]: a grid of :func:`bin_ranges`.
    radar : Radar

    Returns
    -------
    ndarray, shape (..., samples_per_sweep), complex128
    """
    import scipy.fft  # here: the module's formulas also run inside Dr.Jit kernels

    histogram = np.asarray(histogram)
    first, count, bins_per_cell = grid_of(bin_ranges, radar)
    if histogram.shape[-1] != count:
        raise ParameterError("histogram_to_raw", "histogram", f"last axis of {count} bins "
                             "(one per bin range)", histogram.shape)
    samples = radar.samples_per_sweep
    size = bins_per_cell * samples
    k = first + np.arange(count)
    centring = np.exp(-1j * np.pi * k * (frequency_step(radar, bins_per_cell)
                                         * radar.sweep_duration))
    slots = np.mod(k, size)
    rows = histogram.reshape(-1, count)
    workers = _fft_workers(len(rows))
    block = SYNTHESIS_ROWS * workers
    out = np.empty((len(rows), samples), dtype=np.complex128)
    buffer = np.empty((min(block, len(rows)), size), dtype=np.complex128)
    # Blocks of rows through one reused buffer: the spectra stay in cache and no M-point
    # array per sweep is allocated (a Python loop over memory blocks, not over sweeps)
    for start in range(0, len(rows), block):
        part = rows[start:start + block]
        spectrum = buffer[:len(part)]
        _place_bins(part, centring, slots, spectrum)
        # SciPy's pocketfft without the 1/M scaling (norm="forward"): the same sum as
        # M ifft(.) without a pass over the spectrum, and faster than numpy.fft on these
        # sizes; one transform per sweep (and channel), so the thread count and the block
        # size do not change the bits
        out[start:start + len(part)] = scipy.fft.ifft(
            spectrum, axis=-1, norm="forward", overwrite_x=True, workers=workers)[:, :samples]
    return out.reshape(histogram.shape[:-1] + (samples,))


SYNTHESIS_ROWS = 32
"""Inverse FFTs per thread and block in :func:`histogram_to_raw` (M-point spectra of 16 x 660
complex128 are 169 kB each: a block of 32 stays within a core's L2/L3 share; 27 -> 17-19 ms for
256 transforms of that size here, bit for bit the same samples)."""


def _place_bins(rows: NDArray, centring: NDArray, slots: NDArray, spectrum: NDArray) -> None:
    """The weighted bins ``rows * centring`` at their DFT slots of ``spectrum`` (rows, M),
    zeros elsewhere: one run of slots, a run that wraps around the M slots, or (a grid wider
    than the band) several bins aliased onto one slot."""
    count, size = len(slots), spectrum.shape[-1]
    first = int(slots[0])
    if count <= size and first + count <= size:  # one run of slots: weighted in place
        spectrum[:, :first] = 0
        spectrum[:, first + count:] = 0
        np.multiply(rows, centring, out=spectrum[:, first:first + count])
    elif count <= size:  # the run wraps around (consecutive bins: no slot twice)
        split = size - first
        spectrum[:, count - split:first] = 0
        np.multiply(rows[:, :split], centring[:split], out=spectrum[:, first:])
        np.multiply(rows[:, split:], centring[split:], out=spectrum[:, :count - split])
    else:  # a grid wider than the band: several bins alias onto one DFT slot
        spectrum[...] = 0
        weighted = rows * centring
        for slot in np.unique(slots):
            spectrum[:, slot] = weighted[:, slots == slot].sum(axis=-1)


def _fft_workers(transforms: int) -> int:
    """Threads for ``transforms`` independent transforms: all cores for many, one for few."""
    return max(1, min(os.cpu_count() or 1, transforms // 64))


def _check_bins_per_cell(bins_per_cell: Any) -> int:
    if isinstance(bins_per_cell, bool) or not isinstance(bins_per_cell, int | np.integer) \
            or bins_per_cell < 1:
        raise ParameterError("histogram", "bins_per_cell", "an integer >= 1", bins_per_cell)
    return int(bins_per_cell)
