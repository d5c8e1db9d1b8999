"""Wavenumber-domain algorithm (WDA, omega-k) for dechirped FMCW data (Wang et al. 2010).

After residual-video-phase removal the fast time of dechirped data already is range frequency,
so the azimuth FFT alone gives the 2-D spectrum ``S(k_r, k_x)`` (common front end,
:mod:`mitsar.focus.spectral`, including the continuous-motion correction ``H_cm``). Then:

1. reference function multiply (bulk focusing at the reference range ``r_ref``, the centre of
   the output range span): ``exp{-j r_ref sqrt(k_r^2 - k_x^2)}``;
2. range gating: the data are band-limited to the output range span plus ``gate_cells``
   resolution cells either side (one FFT over ``k_r``), and upsampled in ``k_r`` so that the
   residual phase varies slowly from sample to sample;
3. Stolt mapping ``k_y = sqrt(k_r^2 - k_x^2)``: the data are interpolated (Keys cubic) from the
   uniform ``k_r`` grid onto a uniform ``k_y`` grid, with the Jacobian ``dk_r/dk_y = k_y/k_r``,
   which makes the focusing exact at every range (differential focusing);
4. 2-D inverse transform, evaluated directly on the output grid by chirp-z transforms:
   ``sum exp{-j k_y (r - r_ref)}`` over ``k_y`` (our data carry ``exp(+j k_r R)``, so the
   range transform has the forward sign) and ``sum exp{+j k_x a}`` over ``k_x``.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray
from scipy import fft as sp_fft

from mitsar.focus.spectral import Spectrum, evaluate_dtft

MAX_CYCLES_PER_SAMPLE = 0.02
"""Largest residual phase rate (cycles per k_r sample) the Stolt interpolator sees."""


def keys_cubic(data: NDArray, position: NDArray) -> NDArray:
    """Keys (a = -1/2) cubic interpolation of the rows of ``data`` at fractional ``position``.

    ``data`` (Q, M), ``position`` (Q, P) in samples; positions are clamped to ``[0, M-1]`` and
    the neighbours to the row (edge samples repeated).
    """
    size = data.shape[-1]
    position = np.clip(position, 0.0, size - 1.0)
    base = np.floor(position).astype(np.int64)
    t = position - base
    t2, t3 = t * t, t * t * t
    weights = (-0.5 * t3 + t2 - 0.5 * t,
               1.5 * t3 - 2.5 * t2 + 1.0,
               -1.5 * t3 + 2.0 * t2 + 0.5 * t,
               0.5 * t3 - 0.5 * t2)
    out = np.zeros(position.shape, dtype=complex)
    for offset, weight in zip((-1, 0, 1, 2), weights, strict=True):
        index = np.clip(base + offset, 0, size - 1)
        out += weight * np.take_along_axis(data, index, axis=-1)
    return out


def gate_and_upsample(data: NDArray, bins_kept: NDArray, factor: int) -> NDArray:
    """Keep the range bins ``bins_kept`` (FFT-ordered indices) of each row and upsample by
    ``factor`` along the rows (FFT zero-padding; the kept bins are at most half the band)."""
    size = data.shape[-1]
    spectrum = sp_fft.fft(data, axis=-1)
    out = np.zeros(data.shape[:-1] + (size * factor,), dtype=complex)
    frequency = np.where(bins_kept < (size + 1) // 2, bins_kept, bins_kept - size)
    out[..., frequency % (size * factor)] = spectrum[..., bins_kept]
    return sp_fft.ifft(out, axis=-1) * factor


def focus_wda(spectrum: Spectrum, *, gate_cells: float = 16.0) -> tuple[np.ndarray, dict]:
    """Form the image from the front-end spectrum (module docstring).

    Parameters
    ----------
    spectrum : Spectrum
        From :func:`mitsar.focus.spectral.prepare_spectrum`.
    gate_cells : float
        Range gate margin beyond the output span, in range resolution cells.

    Returns
    -------
    image : ndarray, shape (len(azimuth), len(slant_range))
    processing : dict
    """
    k_r, k_x = spectrum.k_r, spectrum.k_x
    r = spectrum.slant_range
    r_ref = spectrum.reference_range
    dk = spectrum.sample_wavenumber_step
    count = len(k_r)
    data = spectrum.data * np.exp(-1j * r_ref * np.sqrt(k_r[None, :] ** 2 - k_x[:, None] ** 2))

    # Range gate: after the reference multiply a target at distance y from the track is a tone
    # of about (y - r_ref) / D rad per unit k_r, i.e. range bin (y - r_ref) / D / (2 pi / (N dk)).
    d_min = float(np.sqrt(1 - (np.abs(k_x).max() / k_r.min()) ** 2))
    half_span = max(r.max() - r_ref, r_ref - r.min()) / d_min
    cell = spectrum.radar.range_resolution
    reach = half_span + gate_cells * cell
    bin_size = 2 * np.pi / (count * dk)  # metres per range bin of the k_r DFT
    bins = np.arange(count)
    signed = np.where(bins < (count + 1) // 2, bins, bins - count) * bin_size
    kept = bins[np.abs(signed) <= reach] if reach < 0.5 * count * bin_size else bins
    cycles = reach * dk / (2 * np.pi)  # cycles per k_r sample at the gate edge
    factor = max(1, int(np.ceil(cycles / MAX_CYCLES_PER_SAMPLE)))
    if len(kept) < count:
        data = gate_and_upsample(data, kept, factor)
    elif factor > 1:
        data = gate_and_upsample(data, bins, factor)

    # Stolt mapping onto a uniform k_y grid (spacing dk).
    k_low, k_high = k_r[0] - 0.5 * dk, k_r[-1] + 0.5 * dk
    k_y_low = np.sqrt(max(k_low**2 - np.max(k_x**2), 0.0))
    k_y_high = np.sqrt(k_high**2 - np.min(k_x**2))
    k_y = k_y_low + dk * np.arange(int(np.ceil((k_y_high - k_y_low) / dk)) + 1)
    k_source = np.sqrt(k_y[None, :] ** 2 + k_x[:, None] ** 2)
    index = (k_source - k_r[0]) / dk
    inside = (index >= -0.5) & (index <= count - 0.5)
    # Samples past the last original one are the periodic wrap of the upsampling: drop them
    # (the half sample at either band edge repeats the edge value).
    data = data[:, : (count - 1) * factor + 1]
    stolt = keys_cubic(data, np.clip(index, 0.0, count - 1.0) * factor)
    stolt *= np.where(inside, k_y[None, :] / k_source, 0.0)

    # Range: sum_m G exp(-j k_y[m] (r - r_ref)).
    compressed = evaluate_dtft(stolt, dk, r, r_ref)
    compressed *= np.exp(-1j * k_y[0] * (r - r_ref))[None, :]
    return spectrum.finish(compressed), {"reference_range": r_ref,
                                         "wda_upsample": factor,
                                         "wda_gate_cells": float(gate_cells)}
