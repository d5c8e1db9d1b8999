"""Back-projection (BPA) of dechirped FMCW data, with the continuous-motion range shift.

Steps of :func:`focus_bpa`:

1. choose how the processed azimuth band is selected (:mod:`mitsar.focus.aperture`):
   ``"doppler"`` on straight uniform tracks whose band is narrower than the beam, where every
   range bin is band-passed in azimuth frequency by the *echo's* Doppler, as RDA/WDA/FSA do, so
   a point focuses to a clean sinc with no phase curvature across the image; ``"pixel"``
   otherwise, where each sweep is weighted by the window at the *pixel's* direction sine (the
   point response then carries a quadratic phase ``2 pi d^2 / (lambda R)`` in the azimuth offset
   d, so the image must be sampled finely);
2. range-compress the sweeps on a 16x zero-padded, sweep-centred FFT
   (:func:`mitsar.focus.compression.range_spectrum`; paper eq. 1) and keep the bins the pixels
   can be looked up in (:func:`crop_to_pixels`);
3. back-project (:mod:`mitsar.focus.backprojection`: the profile is read at the beat frequency
   ``K tau + f_c dtau/dt`` of every pixel, Meta 2007 §II-B, and de-rotated by
   ``exp(-j 2 pi f_c tau)``), in pixel chunks, with the Dr.Jit kernel limited per pixel to the
   sweeps of its aperture on straight tracks (:func:`mitsar.focus.aperture.sweep_window`), or
   with the NumPy reference;
4. normalise by the weight a full aperture would have
   (:func:`mitsar.focus.aperture.full_aperture_weight`), so a point of amplitude a focuses to a
   peak of about a, and pixels whose aperture runs off the end of the track fade instead of
   being amplified.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.errors import ParameterError
from mitsar.focus.aperture import (
    aperture_half_width,
    band_coverage,
    doppler_bandpass,
    full_aperture_weight,
    is_uniform_straight_track,
    normalise_image,
    sweep_window,
)
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
from mitsar.focus.compression import range_spectrum
from mitsar.focus.grid import track_frame
from mitsar.focus.windows import window_coefficients
from mitsar.model.radar import Radar
from mitsar.model.signal import fast_time
from mitsar.raw.product import radar_of

__all__ = ["crop_to_pixels", "focus_bpa"]


def crop_to_pixels(frequency: NDArray, profile: NDArray, radar: Radar, pixels: NDArray,
                   positions: NDArray, max_speed: float) -> tuple[NDArray, NDArray]:
    """Keep only the profile bins that the pixels can be looked up in.

    Slant ranges between the pixels' bounding box and the antenna positions bound the beat
    frequencies (nearest point of the box, farthest corner), widened by the largest Doppler
    shift ``f_c v / K`` (in range) and half a metre.
    """
    low_corner, high_corner = pixels.min(axis=0), pixels.max(axis=0)
    nearest = np.clip(positions, low_corner, high_corner)
    corners = np.array(np.meshgrid(*zip(low_corner, high_corner, strict=True),
                                   indexing="ij")).reshape(3, -1).T
    low = np.linalg.norm(positions - nearest, axis=-1).min()
    high = np.linalg.norm(positions[:, None, :] - corners[None], axis=-1).max()
    margin = 0.5 + radar.carrier_frequency * max_speed / radar.chirp_rate
    keep = np.flatnonzero((frequency >= radar.beat_frequency(max(low - margin, 0.0)))
                          & (frequency <= radar.beat_frequency(high + margin)))
    if len(keep) < 2:
        return frequency, profile
    return frequency[keep[0]:keep[-1] + 1], profile[:, keep[0]:keep[-1] + 1]


def focus_bpa(raw: xr.Dataset, pixels: NDArray, *, half_width: float, window: str,
              range_window: str, remove_rvp: bool, motion_correction: bool, backend: str,
              range_upsample: int, pixel_chunk: int, band_selection: str | None = None,
              progress: bool = False) -> tuple[NDArray, NDArray, dict]:
    """Back-project a raw product onto pixels (see the module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product.
    pixels : ndarray, shape (P, 3)
        Pixel world positions [m].
    half_width : float
        Processed half width in direction sine, ``lambda / (4 rho)``.
    band_selection : {"doppler", "pixel"} or None
        How the processed band is selected; default "doppler" for straight tracks with a
        processed band narrower than the beam, "pixel" otherwise.
    progress : bool
        Show a progress bar over pixel chunks.

    Returns
    -------
    values : ndarray, shape (P,), complex
    coverage : ndarray, shape (P,)
    extra : dict
        Processing attributes for the image product.
    """
    # 1. band selection
    radar = radar_of(raw)
    beam_half_width = aperture_half_width(radar, None)
    straight = is_uniform_straight_track(raw)
    if band_selection is None:
        band_selection = "doppler" if straight and half_width < beam_half_width else "pixel"
    if band_selection == "doppler" and not straight:
        raise ParameterError("focus", "band_selection",
                             "'pixel' for a curved track or a varying speed", band_selection)
    positions = raw["platform_position"].values
    velocities = raw["platform_velocity"].values
    speed = np.linalg.norm(velocities, axis=-1)
    centroid = np.einsum("si,si->s", raw["boresight"].values, velocities) / np.where(
        speed > 0, speed, 1.0)
    coefficients = window_coefficients(window)
    mean_speed, mean_centroid = float(speed.mean()), float(centroid.mean())
    samples = raw["raw"].values
    if band_selection == "doppler":
        bandwidth = 4 * mean_speed * half_width / radar.wavelength  # B_a = v / rho
        rf_frequency = radar.carrier_frequency + radar.chirp_rate * fast_time(radar)
        pad = int(np.ceil(4 * radar.prf / bandwidth))
        samples = doppler_bandpass(samples, radar.prf, mean_centroid, half_width, mean_speed,
                                   rf_frequency, coefficients, pad)
        kernel_half_width, kernel_window = beam_half_width, window_coefficients("rect")
    else:
        kernel_half_width, kernel_window = half_width, coefficients
    # 2. range compression, cropped to the pixels
    frequency, profile = range_spectrum(
        samples, radar, window=range_window, remove_rvp=remove_rvp, upsample=range_upsample,
        rvp_present=bool(raw.attrs.get("rvp", 1)))
    frequency, profile = crop_to_pixels(frequency, profile, radar, pixels, positions,
                                        float(speed.max()))
    # 3. back-projection in pixel chunks
    origin, direction, _ = track_frame(raw)
    chunks = tqdm([slice(start, start + pixel_chunk)
                   for start in range(0, len(pixels), pixel_chunk)],
                  disable=not progress, desc="back-projection", unit="chunk")
    arguments = (profile, frequency, radar)
    common = (positions, velocities, centroid, kernel_half_width, kernel_window,
              motion_correction)
    if backend == "numpy":
        results = [backproject_numpy(*arguments, pixels[c], *common) for c in chunks]
    else:
        ranges = None
        if straight:
            ranges = sweep_window(pixels, origin, direction, mean_speed / radar.prf,
                                  len(positions), mean_centroid, kernel_half_width)
        results = [backproject_drjit(*arguments, pixels[c], *common, sweep_range=None
                                     if ranges is None else (ranges[0][c], ranges[1][c]))
                   for c in chunks]
    # 4. normalisation by the full-aperture weight
    sums, totals = zip(*results, strict=True)
    geometry = (pixels, origin, direction, mean_speed, radar.prf, mean_centroid)
    signal_weight = full_aperture_weight(*geometry, half_width, float(coefficients[0]))
    total = np.concatenate(totals)
    if band_selection == "doppler":
        track_length = float((positions[-1] - origin) @ direction)
        coverage = band_coverage(pixels, origin, direction, track_length, mean_centroid,
                                 half_width)
        values = np.concatenate(sums) / np.where(signal_weight > 0, signal_weight, 1.0)
    else:
        values, coverage = normalise_image(np.concatenate(sums), total, signal_weight)
    return values, coverage, {"band_selection": band_selection}
