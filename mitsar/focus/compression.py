"""Range compression of dechirped FMCW data and residual-video-phase removal.

After dechirping, fast time is range frequency: a range FFT turns each echo into a peak at its
beat frequency ``f = K tau`` (paper eq. 1). With fast time centred on the sweep,

``S(f) = sum_n s(t_n) exp(-j 2 pi f t_n) = exp(+j pi f T) * DFT[s]``

keeps the phase referenced to the sweep centre, where the carrier is f_c (torchbp's
``fc_choice`` trap). The residual video phase ``-pi K tau^2`` is removed by
``H_RVP(f) = exp(+j pi f^2 / K)`` (Carrara 1995 App. C, in our sign convention).
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy import fft as sp_fft

from mitsar.errors import ParameterError
from mitsar.focus.windows import window_samples
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.raw.product import radar_of


def range_spectrum(samples: NDArray, radar: Radar, *, window: str = "rect",
                   remove_rvp: bool = True, upsample: int = 1,
                   rvp_present: bool = True) -> tuple[NDArray, NDArray]:
    """Range-compress dechirped sweeps: windowed, zero-padded, sweep-centred FFT.

    Parameters
    ----------
    samples : ndarray, shape (sweeps, N_s)
        Dechirped samples.
    radar : Radar
    window : str
        Range window (see :mod:`mitsar.focus.windows`).
    remove_rvp : bool
        Multiply by ``exp(+j pi f^2 / K)`` when the data hold the RVP.
    upsample : int
        Zero-padding factor of the FFT (interpolates the profile).
    rvp_present : bool
        Whether the samples carry the residual video phase.

    Returns
    -------
    beat_frequency : ndarray, shape (N_fft,)
        Ascending beat frequencies [Hz].
    profile : ndarray, shape (sweeps, N_fft)
        Range profiles; a tone of amplitude a gives a peak of amplitude a.
    """
    count = samples.shape[-1]
    size = count * int(upsample)
    weights = window_samples(window, count)
    spectrum = sp_fft.fft(samples * (weights / weights.sum()), n=size, axis=-1, workers=-1)
    frequency = np.fft.fftfreq(size, 1.0 / radar.sampling_frequency)
    phase = np.pi * frequency * radar.sweep_duration
    if remove_rvp and rvp_present:
        phase = phase + np.pi * frequency**2 / radar.chirp_rate
    factor = np.exp(1j * phase)
    # Ascending frequencies are a rotation of the FFT's order (negative ones from bin
    # ceil(N/2) on): reorder and apply the phase in one pass over the spectrum.
    split = (size + 1) // 2
    out = np.empty_like(spectrum)
    np.multiply(spectrum[..., split:], factor[split:], out=out[..., :size - split])
    np.multiply(spectrum[..., :split], factor[:split], out=out[..., size - split:])
    return np.concatenate([frequency[split:], frequency[:split]]), out


def range_compress(raw: xr.Dataset, window: str = "rect", remove_rvp: bool = True,
                   upsample: int = 1) -> xr.Dataset:
    """Range-compressed product: ``profile`` (sweep, range) with ``range = c f / (2K)`` [m].

    See :func:`range_spectrum` for the parameters.
    """
    if not isinstance(raw, xr.Dataset) or "raw" not in raw:
        raise ParameterError("range_compress", "raw", "a raw product (xarray.Dataset with a "
                             "'raw' variable, e.g. from mitsar.load)", type(raw).__name__)
    radar = radar_of(raw)
    frequency, profile = range_spectrum(
        raw["raw"].values, radar, window=window, remove_rvp=remove_rvp, upsample=upsample,
        rvp_present=bool(raw.attrs.get("rvp", 1)))
    slant_range = SPEED_OF_LIGHT * frequency / (2 * radar.chirp_rate)
    product = xr.Dataset(
        {"profile": (("sweep", "range"), profile, {"long_name": "range-compressed sweeps"})},
        coords={"sweep": raw["sweep"].values, "slow_time": ("sweep", raw["slow_time"].values,
                                                          {"units": "s"}),
                "range": ("range", slant_range, {"units": "m"}),
                "beat_frequency": ("range", frequency, {"units": "Hz"})})
    product.attrs.update(raw.attrs)
    product.attrs.update(product="range_compressed", range_window=window,
                         rvp_removed=int(remove_rvp and bool(raw.attrs.get("rvp", 1))))
    return product
