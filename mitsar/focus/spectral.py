"""Shared machinery of the frequency-domain focusing algorithms (RDA, WDA, FSA).

Signal model (docs/design.md §5.6, docs/design.md §4)
-------------------------------------------------
After residual-video-phase removal, dechirped FMCW samples are samples of the scene's frequency
response: sample ``n`` of a sweep is at the RF frequency ``f_c + K t_n`` (two-way wavenumber
``k_r = 4 pi (f_c + K t_n) / c``), and a point target at along-track ``x0`` and distance
``y0`` from the track gives ``exp(+j k_r R)`` with ``R`` its range. After the azimuth Fourier
transform over the along-track position ``X`` (kernel ``exp(-j k_x X)``, ``k_x = 2 pi f_eta / v``)
and the continuous-motion correction (:mod:`mitsar.focus.motion`), stationary phase gives

``S(k_r, k_x) = A exp{ j [ y0 sqrt(k_r^2 - k_x^2) - k_x x0 + pi/4 ] }``,
``|A|^2 = (2 pi / dX^2) y0 / (k_r cos^3 theta)``,  ``sin theta = -k_x / k_r``

(``dX`` the sweep spacing, ``theta`` the squint of the ray, ``u = sin theta`` its direction sine).
The three algorithms differ only in how they evaluate the matched filter
``I(x, y) = sum S conj(S_model(x, y))`` over the processed band.

What is shared here
-------------------
:func:`prepare_spectrum` (the front end): RVP removal, range window, the azimuth transform
evaluated by a chirp-z transform directly on a fine grid of azimuth frequencies around the
Doppler centroid (no wrapping, any squint), ``H_cm``, and the azimuth weighting. The weighting is
the one back-projection applies, so that the images agree pixel for pixel: the window over the
direction sine ``u = -k_x / k_r`` within ``u_c +- lambda / (4 rho)`` (per RF frequency, as BPA's
aperture is fixed in angle), the stationary-phase amplitude of the matched filter, and the
normalisation by the sum of weights. :func:`chirp_z` evaluates DFTs on arbitrary uniform grids
(per-row start and step), which the algorithms use to land exactly on the requested image grid
without interpolation.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy import fft as sp_fft

from mitsar.errors import ParameterError
from mitsar.focus.motion import TrackGeometry, motion_correction_phase, straight_track
from mitsar.focus.windows import evaluate_window, window_coefficients, window_samples
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import fast_time
from mitsar.products.raw import sweep_rate

CHANNEL_DIRECTION_ERROR = "channel_direction_error"
"""The variable of a compensated receive channel (:data:`mitsar.focus.channels.DIRECTION_ERROR`)
that :func:`prepare_spectrum` removes per direction sine."""

MIN_BAND_BINS = 256
"""Fewest azimuth-frequency bins across the processed band (the band edges fall between bins
and get fractional weights, so this only sets how smoothly the band is sampled)."""


# --------------------------------------------------------------------------------------------
# Chirp-z transform and DTFT evaluation
# --------------------------------------------------------------------------------------------
def chirp_z(x: NDArray, start: ArrayLike, step: ArrayLike, count: int) -> NDArray:
    """DTFT of the rows of ``x`` on uniform grids: ``X[..., j] = sum_n x[..., n] e^{-i w_j n}``.

    ``w_j = start + step * j`` (radians per sample), with ``start`` and ``step`` scalars or one
    value per row (shape ``x.shape[:-1]``). Bluestein's algorithm: three FFTs of length
    ``>= N + count - 1``, exact up to rounding (Rabiner, Schafer & Rader 1969).
    """
    x = np.asarray(x)
    length = x.shape[-1]
    start = np.asarray(start, dtype=float)[..., None]
    step = np.asarray(step, dtype=float)[..., None]
    n = np.arange(length)
    j = np.arange(count)
    size = sp_fft.next_fast_len(length + count - 1)
    a = x * np.exp(-1j * (start * n + 0.5 * step * n.astype(float) ** 2))
    lags = np.concatenate([np.arange(count), np.arange(-(length - 1), 0)]).astype(float)
    kernel = np.zeros(step.shape[:-1] + (size,), dtype=complex)
    kernel[..., : count] = np.exp(0.5j * step * lags[:count] ** 2)
    if length > 1:
        kernel[..., size - (length - 1):] = np.exp(0.5j * step * lags[count:] ** 2)
    spectrum = sp_fft.fft(a, size, axis=-1) * sp_fft.fft(kernel, axis=-1)
    out = sp_fft.ifft(spectrum, axis=-1)[..., :count]
    return out * np.exp(-0.5j * step * j.astype(float) ** 2)


def uniform_axis(values: ArrayLike) -> tuple[float, float] | None:
    """``(first, step)`` of an evenly spaced axis, or None."""
    values = np.asarray(values, dtype=float)
    if len(values) < 2:
        return (float(values[0]), 1.0) if len(values) else None
    step = (values[-1] - values[0]) / (len(values) - 1)
    if np.allclose(values, values[0] + step * np.arange(len(values)), rtol=0,
                   atol=1e-9 * max(abs(step) * len(values), 1e-12)):
        return float(values[0]), float(step)
    return None


def evaluate_dtft(x: NDArray, scale: ArrayLike, points: ArrayLike, offset: ArrayLike = 0.0
                  ) -> NDArray:
    """``X[..., j] = sum_n x[..., n] exp(-i scale (points_j - offset) n)`` along the last axis.

    ``scale`` (radians per sample per unit of ``points``) and ``offset`` may be per row.
    A chirp-z transform when ``points`` are evenly spaced, a direct sum otherwise.
    """
    points = np.asarray(points, dtype=float)
    scale = np.asarray(scale, dtype=float)
    offset = np.asarray(offset, dtype=float)
    axis = uniform_axis(points)
    if axis is not None:
        first, step = axis
        return chirp_z(x, scale * (first - offset), scale * step, len(points))
    n = np.arange(x.shape[-1])
    phase = (scale[..., None, None] * (points[:, None] - offset[..., None, None])) * n
    return np.einsum("...n,...jn->...j", x, np.exp(-1j * phase))


# --------------------------------------------------------------------------------------------
# The front end
# --------------------------------------------------------------------------------------------
@dataclass
class Spectrum:
    """Data in the (RF frequency, azimuth wavenumber) domain, ready for an algorithm."""

    data: NDArray[np.complex128]
    """``S(k_x[q], k_r[n])``, shape (Q, N), after RVP removal, range window, azimuth transform,
    ``H_cm`` and the azimuth weighting (window, matched-filter amplitude, normalisation,
    ``exp(-j pi/4)``); rows outside the processed band are dropped."""
    k_r: NDArray[np.float64]
    """Two-way wavenumber of each fast-time sample [rad/m], shape (N,)."""
    k_x: NDArray[np.float64]
    """Along-track wavenumber of each row, evenly spaced and ascending [rad/m], shape (Q,)."""
    k_c: float
    """``4 pi f_c / c`` [rad/m]."""
    radar: Radar
    """The radar of the raw product."""
    track: TrackGeometry
    """The straight track (:func:`mitsar.focus.motion.straight_track`)."""
    azimuth: NDArray[np.float64]
    """Output along-track coordinates from the first sweep [m]."""
    slant_range: NDArray[np.float64]
    """Output distances from the track [m]."""
    reference_range: float
    """Centre of the output range span [m] (reference of RFM / SRC)."""

    @property
    def sample_wavenumber_step(self) -> float:
        """``dk_r`` between fast-time samples [rad/m]."""
        return 4 * np.pi * self.radar.chirp_rate / (SPEED_OF_LIGHT
                                                     * self.radar.sampling_frequency)

    def cosine_factor(self) -> NDArray[np.float64]:
        """``D(k_x) = sqrt(1 - (k_x / k_c)^2)`` per row (Meta 2007's D(f_eta))."""
        return np.sqrt(1.0 - (self.k_x / self.k_c) ** 2)

    def finish(self, range_compressed: NDArray) -> NDArray[np.complex128]:
        """Azimuth amplitude per range and the azimuth transform to the output along-track axis.

        ``range_compressed`` has shape (Q, len(slant_range)) and already holds the azimuth
        matched-filter phase; returns the image, shape (len(azimuth), len(slant_range)).
        """
        amplitude = np.sqrt(2.0) * self.track.spacing / np.sqrt(self.slant_range)
        columns = (range_compressed * amplitude).T  # (range, q)
        dk = self.k_x[1] - self.k_x[0] if len(self.k_x) > 1 else 1.0
        # sum_q c_q exp(+j k_x[q] a) = exp(+j k_x[0] a) * DTFT(-dk a)
        values = evaluate_dtft(columns, -dk, self.azimuth)
        return (values * np.exp(1j * self.k_x[0] * self.azimuth)).T


def remove_rvp(samples: NDArray, radar: Radar) -> NDArray[np.complex128]:
    """Residual-video-phase (and skew) removal in the fast-time domain.

    FFT over fast time, ``H_RVP(f) = exp(+j pi f^2 / K)`` on the beat frequency
    (Carrara 1995 App. C in our sign convention), inverse FFT.
    """
    count = samples.shape[-1]
    frequency = sp_fft.fftfreq(count, 1.0 / radar.sampling_frequency)
    spectrum = sp_fft.fft(samples, axis=-1)
    spectrum *= np.exp(1j * np.pi * frequency**2 / radar.chirp_rate)
    return sp_fft.ifft(spectrum, axis=-1)


def _coverage(centre: NDArray, width: NDArray, low: float, high: float) -> NDArray:
    """Fraction of each interval ``centre +- width/2`` inside ``[low, high]``."""
    lo = np.maximum(centre - 0.5 * width, low)
    hi = np.minimum(centre + 0.5 * width, high)
    return np.clip((hi - lo) / width, 0.0, 1.0)


def prepare_spectrum(raw: xr.Dataset, radar: Radar, layout: dict, *, half_width: float,
                     window: str, range_window: str, remove_rvp_flag: bool,
                     motion_correction: bool, where: str) -> Spectrum:
    """The common front end of RDA, WDA and FSA (module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product (straight track, constant velocity).
    radar : Radar
    layout : dict
        A resolved :class:`~mitsar.focus.grid.SlantGrid` (``grid.resolve``).
    half_width : float
        Processed aperture half width in direction sine, ``lambda / (4 rho)``.
    window, range_window : str
        Azimuth and range windows.
    remove_rvp_flag : bool
        Remove the residual video phase (when the data hold it).
    motion_correction : bool
        Apply ``H_cm``.
    where : str
        Algorithm name for error messages.
    """
    if layout.get("attrs", {}).get("grid_kind") != "slant":
        raise ParameterError(
            where, "grid", "a SlantGrid (the frequency-domain algorithms form the image in "
            "along-track / slant-range coordinates; use algorithm='bpa' for plane and point "
            "grids)", layout.get("attrs", {}).get("grid_kind"))
    if "reference_range" in raw:
        raise ParameterError(where, "raw", "dechirped FMCW data (real data referenced to a "
                             "scene point are focused by algorithm='bpa')", "referenced data")
    track = straight_track(raw, radar, half_width)
    azimuth = np.asarray(layout["coords"]["azimuth"], dtype=float)
    slant_range = np.asarray(layout["coords"]["range"], dtype=float)
    if np.any(slant_range <= 0):
        raise ParameterError(where, "grid.slant_range", "distances from the track > 0 m",
                             float(slant_range.min()))
    samples = np.asarray(raw["raw"].values, dtype=complex)
    if remove_rvp_flag and bool(raw.attrs.get("rvp", 1)):
        samples = remove_rvp(samples, radar)
    times = fast_time(radar)
    weights = window_samples(range_window, len(times))
    samples = samples * (weights / weights.sum())

    k_c = 4 * np.pi * radar.carrier_frequency / SPEED_OF_LIGHT
    k_r = 4 * np.pi * (radar.carrier_frequency + radar.chirp_rate * times) / SPEED_OF_LIGHT
    u_c = track.centroid_sine
    low, high = u_c - half_width, u_c + half_width
    if low < -1 or high > 1:
        raise ParameterError(where, "azimuth_resolution",
                             "a processed aperture within +-90 deg of broadside (direction sines "
                             "in [-1, 1])", f"[{low:.3f}, {high:.3f}]")
    # The processed band in k_x = -k_r u, over all RF frequencies.
    k_x_low = -high * k_r.max() if high > 0 else -high * k_r.min()
    k_x_high = -low * k_r.max() if low < 0 else -low * k_r.min()
    sample_rate = 2 * np.pi / track.spacing  # along-track sampling wavenumber
    if k_x_high - k_x_low >= sample_rate:
        rate = sweep_rate(raw, radar)  # the PRF; PRF / N_tx for one TDM-MIMO channel
        band = (k_x_high - k_x_low) / sample_rate * rate
        raise ParameterError(where, "azimuth_resolution", f"a processed Doppler band narrower "
                             f"than the sweep rate ({rate:g} Hz)", f"{band:.4g} Hz")
    # Bin spacing: fine enough across the band, and a period in X longer than data + apertures.
    g_low = low / np.sqrt(1 - low**2)
    g_high = high / np.sqrt(1 - high**2)
    ends = [azimuth.min() - slant_range.max() * g_high, azimuth.min() - slant_range.min() * g_high,
            azimuth.max() - slant_range.max() * g_low, azimuth.max() - slant_range.min() * g_low,
            0.0, (track.sweeps - 1) * track.spacing]
    extent = max(ends) - min(ends) + 4 * track.spacing
    step = min((k_x_high - k_x_low) / MIN_BAND_BINS, 2 * np.pi / extent)
    first = k_x_low - step
    count = int(np.ceil((k_x_high + step - first) / step)) + 1
    k_x = first + step * np.arange(count)

    # Azimuth DTFT over sweeps at k_x (X_k = k dX), rows = k_x.
    data = chirp_z(samples.T, first * track.spacing, step * track.spacing, count).T  # (Q, N)
    if motion_correction:
        azimuth_frequency = track.speed * k_x / (2 * np.pi)
        data *= motion_correction_phase(times[None, :], azimuth_frequency[:, None])
    sine = -k_x[:, None] / k_r[None, :]
    if CHANNEL_DIRECTION_ERROR in raw.variables:
        # A compensated receive channel (mitsar.focus.channels.compensate_channel): the rest
        # of its path error with the direction sine, removed where each direction is seen.
        table = raw[CHANNEL_DIRECTION_ERROR]
        residual = np.interp(sine, np.asarray(table["direction_sine"].values, dtype=float),
                             np.asarray(table.values, dtype=float))
        data *= np.exp(-1j * k_r[None, :] * residual)
    # Azimuth weighting: window over the direction sine, matched-filter amplitude, normalisation.
    width = step / k_r[None, :]
    coverage = _coverage(sine, width, low, high)
    position = (sine - low) / (2 * half_width)
    window_values = evaluate_window(window_coefficients(window), np.clip(position, 0.0, 1.0))
    weight = window_values * coverage
    cos3 = np.clip(1 - sine**2, 1e-12, None) ** 1.5
    wavelength = 2 * np.pi / (k_r / 2)
    density = wavelength[None, :] / cos3
    total = (weight * density).sum(axis=0)
    amplitude = weight * np.sqrt(density) / np.where(total > 0, total, 1.0)[None, :]
    data *= amplitude * np.exp(-0.25j * np.pi)
    keep = np.flatnonzero(weight.max(axis=1) > 0)
    keep = np.arange(keep.min(), keep.max() + 1)
    return Spectrum(data=data[keep], k_r=k_r, k_x=k_x[keep], k_c=k_c, radar=radar, track=track,
                    azimuth=azimuth, slant_range=slant_range,
                    reference_range=0.5 * (slant_range.min() + slant_range.max()))


def secondary_range_compression(spectrum: Spectrum) -> NDArray[np.complex128]:
    """Bulk SRC filter at the reference range, shape (Q, N).

    ``exp{-j r_ref [sqrt(k_r^2 - k_x^2) - D k_c - (k_r - k_c) / D]}``: the part of the 2-D
    spectrum phase that is neither the azimuth phase ``D k_c`` nor the range migration
    ``(k_r - k_c)/D``, exact at the reference range (Cumming & Wong 2005 §6.3 option 2).
    """
    k_r = spectrum.k_r[None, :]
    k_x = spectrum.k_x[:, None]
    d = spectrum.cosine_factor()[:, None]
    residual = (np.sqrt(k_r**2 - k_x**2) - d * spectrum.k_c - (k_r - spectrum.k_c) / d)
    return np.exp(-1j * spectrum.reference_range * residual)
