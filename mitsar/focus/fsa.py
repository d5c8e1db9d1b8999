"""Frequency-scaling algorithm (FSA) for dechirped FMCW data (Mittermayer, Moreira & Loffeld
1999; FMCW form after Jiang et al. 2007 and docs/design.md §5.6).

After the common front end (:mod:`mitsar.focus.spectral`: RVP removal, azimuth FFT, ``H_cm``,
azimuth weighting) and a bulk secondary range compression, a target at closest range ``R0`` is,
in the azimuth-frequency bin with ``D = sqrt(1 - (k_x / k_c)^2)``, a tone of beat frequency
``f0 = 2 K R0 / (c D)``: its range migration ``R0 / D`` grows with range. The frequency scaling

``x exp(-j pi K alpha t^2)``; FFT; ``x exp(-j pi f^2 / (K (1 + alpha)))``; IFFT;
``x exp(+j pi K alpha (1 + alpha) t^2)``

maps ``exp(j 2 pi f0 t)`` to ``exp{j 2 pi (1 + alpha) f0 t - j pi f0^2 / K}`` with no
interpolation. With ``1 + alpha = D / D_ref`` every bin's tone lands at ``2 K R0 / (c D_ref)``:
the range-variant migration is removed for all ranges at once, and the bulk ``D_ref`` (the
squint of the processed band, the midpoint of its D range) is absorbed in the output range
axis, which is evaluated by a chirp-z transform at ``f = 2 K r / (c D_ref)``. Then the residual
phase ``exp(+j 4 pi K (r / D)^2 / c^2)`` and the azimuth matched filter ``exp(-j k_c D r)`` are
applied and the azimuth transform is evaluated on the output along-track axis.

Aliasing
--------
The chirp ``exp(-j pi K alpha t^2)`` spreads the beat spectrum by ``K |alpha| T``; the scaled
signal fits the fast-time sampling only while ``K |alpha| T + f_b,max <= f_s``. At the paper's
10 cm azimuth resolution broadside this holds (``|alpha| ~ 3e-5``, 48 kHz); for a wide
processed band or a squinted one it does not (``|alpha| ~ 3e-3`` for the full 9 deg beam,
4.6 MHz against 165 kHz). The fast time is then upsampled (by zero-padding the beat spectrum)
by the smallest integer factor that satisfies the bound, and padded in time against the
circular wrap of the chirp convolution. ``upsample`` fixes the factor instead; with
``check_aliasing=False`` a too small factor is used anyway (the aliasing ablation).
"""

from __future__ import annotations

import numpy as np
from scipy import fft as sp_fft

from mitsar.errors import ParameterError
from mitsar.focus.spectral import Spectrum, evaluate_dtft, secondary_range_compression
from mitsar.model.radar import SPEED_OF_LIGHT

GUARD_SAMPLES = 8
"""Extra zero samples (at the original rate) either side of the sweep against wrap-around."""


def aliasing_requirement(spectrum: Spectrum) -> dict:
    """Terms of the FSA aliasing bound for a front-end spectrum.

    Returns
    -------
    dict
        ``alpha_max`` (largest |alpha|), ``chirp_spread`` (``K |alpha| (T + 2 g)`` [Hz], with
        the time guard ``g``), ``beat_max`` (largest beat frequency of the data after range
        migration [Hz]), ``guard`` (guard samples at the original rate), ``upsample`` (the
        smallest factor meeting the bound) and ``reference_cosine`` ``D_ref``.
    """
    radar = spectrum.radar
    d = spectrum.cosine_factor()
    d_ref = 0.5 * (d.min() + d.max())
    alpha_max = float(np.max(np.abs(d / d_ref - 1.0)))
    max_range = max(radar.max_range, float(spectrum.slant_range.max()))
    beat_max = 2 * radar.chirp_rate * max_range / (SPEED_OF_LIGHT * d.min())
    duration = radar.sweep_duration
    guard_time = alpha_max * duration / 2 + beat_max / radar.chirp_rate
    guard = int(np.ceil(guard_time * radar.sampling_frequency)) + GUARD_SAMPLES
    chirp_spread = radar.chirp_rate * alpha_max * (duration + 2 * guard
                                                   / radar.sampling_frequency)
    needed = (chirp_spread + beat_max) / radar.sampling_frequency
    return {"alpha_max": alpha_max, "chirp_spread": chirp_spread, "beat_max": beat_max,
            "guard": guard, "upsample": max(1, int(np.ceil(needed * 1.02))),
            "reference_cosine": float(d_ref)}


def focus_fsa(spectrum: Spectrum, *, upsample: int | str = "auto", check_aliasing: bool = True,
              src: bool = True, chunk_elements: int = 1 << 22) -> tuple[np.ndarray, dict]:
    """Form the image from the front-end spectrum (module docstring).

    Parameters
    ----------
    spectrum : Spectrum
        From :func:`mitsar.focus.spectral.prepare_spectrum`.
    upsample : int or "auto"
        Fast-time upsampling factor of the frequency scaling; "auto" picks the smallest one
        meeting the aliasing bound.
    check_aliasing : bool
        Refuse a given ``upsample`` that violates the bound (ParameterError).
    src : bool
        Apply the bulk secondary range compression.
    chunk_elements : int
        Bound on rows x upsampled samples processed at once (memory).

    Returns
    -------
    image : ndarray, shape (len(azimuth), len(slant_range))
    processing : dict
    """
    radar = spectrum.radar
    need = aliasing_requirement(spectrum)
    if upsample == "auto":
        factor = need["upsample"]
    else:
        if isinstance(upsample, bool) or not isinstance(upsample, int | np.integer) \
                or upsample < 1:
            raise ParameterError("fsa", "upsample", "'auto' or an integer >= 1", upsample)
        factor = int(upsample)
        if check_aliasing and factor < need["upsample"]:
            raise ParameterError(
                "fsa", "upsample",
                f">= {need['upsample']}: the frequency-scaling aliasing bound "
                f"K|alpha|T + f_b,max <= f_s * upsample needs "
                f"{need['chirp_spread']:.4g} Hz + {need['beat_max']:.4g} Hz <= "
                f"{radar.sampling_frequency:g} Hz * upsample (|alpha| = "
                f"{need['alpha_max']:.3g}); use upsample='auto', a narrower processed band "
                "(larger azimuth_resolution), or check_aliasing=False to see the aliasing",
                factor)
    data = spectrum.data
    if src:
        data = data * secondary_range_compression(spectrum)
    d = spectrum.cosine_factor()
    d_ref = need["reference_cosine"]
    alpha = d / d_ref - 1.0
    rows, count = data.shape
    chirp_rate = radar.chirp_rate
    rate = radar.sampling_frequency * factor
    guard = need["guard"] * factor
    length = sp_fft.next_fast_len(count * factor + 2 * guard)
    t_first = -radar.sweep_duration / 2 - guard / rate
    time = t_first + np.arange(length) / rate
    frequency = sp_fft.fftfreq(length, 1.0 / rate)
    low = -chirp_rate * need["alpha_max"] * (radar.sweep_duration / 2 + guard / rate) \
        - 0.01 * rate
    frequency = low + np.mod(frequency - low, rate)
    coarse = sp_fft.fftfreq(count, 1.0 / radar.sampling_frequency)
    placement = np.round(coarse / radar.sampling_frequency * count).astype(int) % (count * factor)
    r = spectrum.slant_range
    beat_scale = 2 * chirp_rate / (SPEED_OF_LIGHT * d_ref)  # Hz per metre of output range
    out = np.empty((rows, len(r)), dtype=complex)
    step = max(1, chunk_elements // length)
    for first in range(0, rows, step):
        block = slice(first, first + step)
        a = alpha[block, None]
        # Upsample the sweep (zero-padded beat spectrum) and pad it with zeros in time.
        fine = np.zeros((a.shape[0], count * factor), dtype=complex)
        fine[:, placement] = sp_fft.fft(data[block], axis=-1)
        signal = np.zeros((a.shape[0], length), dtype=complex)
        signal[:, guard:guard + count * factor] = sp_fft.ifft(fine, axis=-1) * factor
        # Frequency scaling.
        signal *= np.exp(-1j * np.pi * chirp_rate * a * time**2)
        signal = sp_fft.fft(signal, axis=-1)
        signal *= np.exp(-1j * np.pi * frequency**2 / (chirp_rate * (1 + a)))
        signal = sp_fft.ifft(signal, axis=-1)
        signal *= np.exp(1j * np.pi * chirp_rate * a * (1 + a) * time**2)
        # Range compression on the output axis: sum_p y_p exp(-j 2 pi f t_p), f = beat_scale r.
        values = evaluate_dtft(signal, 2 * np.pi * beat_scale / rate, r)
        values *= np.exp(-2j * np.pi * beat_scale * r * t_first)[None, :]
        out[block] = values * (np.sqrt(1 + a) / factor)
    # Residual phase of the scaling, then the azimuth matched filter.
    out *= np.exp(1j * 4 * np.pi * chirp_rate * (r[None, :] / d[:, None]) ** 2
                  / SPEED_OF_LIGHT**2)
    out *= np.exp(-1j * spectrum.k_c * d[:, None] * r[None, :])
    return spectrum.finish(out), {"reference_range": spectrum.reference_range,
                                  "fsa_upsample": factor,
                                  "fsa_required_upsample": need["upsample"],
                                  "fsa_alpha_max": need["alpha_max"],
                                  "fsa_src": int(src)}
