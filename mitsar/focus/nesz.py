"""Noise floor and NESZ of every pixel of a back-projected image (docs/metrics.md §Noise).

The closed forms are those of :mod:`mitsar.model.noise` (eqs. N1, N2); this module evaluates
their geometry per pixel for the BP focusers' normalisation (:mod:`mitsar.focus.bp_setup`):

- ``M``, the sweeps of the pixel's full processed aperture ``|u - u_c| <= h``
  (:func:`mitsar.focus.aperture.full_aperture_weight` with a unit window mean);
- ``|h_0|``, the focused peak of a 1 m^2 point at the pixel: the azimuth-window-weighted mean,
  over that aperture, of the radar-equation amplitude with the two-way pattern
  (:func:`mitsar.model.signal.radar_equation_amplitude`), the antenna placed on the flown track
  where it sees the pixel at direction sine ``u``;
- the incidence angle on a horizontal surface (z up) seen from mid-aperture.

A pixel whose aperture runs off the track (coverage ``c < 1``) keeps a fraction ``c`` of the
noise power and of the peak amplitude, so its noise power is ``c P_img`` and its NESZ
``NESZ / c`` (infinite where ``c = 0``).
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.focus.aperture import full_aperture_weight
from mitsar.focus.grid import track_frame
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.model.geometry.antenna import two_way_pattern
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.model.noise import focused_noise_power, noise_equivalent_sigma0, window_noise_bandwidth
from mitsar.model.signal import radar_equation_amplitude
from mitsar.products.raw import look_of, radar_of, sweep_rate

__all__ = ["APERTURE_NODES", "noise_variables", "unit_peak_amplitude"]

APERTURE_NODES = 33
"""Direction sines at which the aperture's mean amplitude is evaluated (midpoint rule; the
pattern varies smoothly over the processed band, so the mean converges far below 0.1 %)."""

_PIXEL_BLOCK = 8192
"""Pixels per block of the aperture evaluation (memory: block x nodes x 3 x 3 floats)."""


def _aperture_sampling(raw: xr.Dataset) -> tuple[NDArray, NDArray, NDArray, float, float]:
    """Track frame, along-track coordinate of each sweep, mean speed and mean centroid sine."""
    origin, direction, _ = track_frame(raw)
    velocity = raw["platform_velocity"].values
    speed = np.linalg.norm(velocity, axis=-1)
    centroid = np.einsum("si,si->s", raw["boresight"].values, velocity) / np.where(
        speed > 0, speed, 1.0)
    along = (raw["platform_position"].values - origin) @ direction
    return origin, direction, along, float(speed.mean()), float(centroid.mean())


def unit_peak_amplitude(raw: xr.Dataset, pixels: NDArray, half_width: float,
                        window: str) -> tuple[NDArray, NDArray]:
    """Focused peak ``|h_0|`` of a 1 m^2 point at each pixel [sqrt(W)] and the sine of the
    incidence angle on a horizontal surface from mid-aperture (module docstring)."""
    radar, look = radar_of(raw), look_of(raw)
    origin, direction, along_sweeps, _, centroid = _aperture_sampling(raw)
    positions = raw["platform_position"].values
    frames = antenna_frame(look, *raw["attitude"].values.T)
    order = np.argsort(along_sweeps)
    nodes = (np.arange(APERTURE_NODES) + 0.5) / APERTURE_NODES  # window coordinate in [0, 1]
    sines = np.clip(centroid + half_width * (2 * nodes - 1), -0.999, 0.999)
    weights = evaluate_window(window_coefficients(window), nodes)
    peak = np.empty(len(pixels))
    sin_incidence = np.empty(len(pixels))
    for start in range(0, len(pixels), _PIXEL_BLOCK):
        block = pixels[start:start + _PIXEL_BLOCK]
        offset = block - origin
        along = offset @ direction
        distance = np.linalg.norm(offset - along[:, None] * direction, axis=-1)
        antenna_along = along[:, None] - distance[:, None] * sines / np.sqrt(1 - sines**2)
        antenna = np.stack([np.interp(antenna_along, along_sweeps[order], positions[order, axis])
                            for axis in range(3)], axis=-1)
        nearest = order[np.clip(np.searchsorted(along_sweeps[order], antenna_along), 0,
                                len(order) - 1)]
        line = block[:, None, :] - antenna
        slant = np.linalg.norm(line, axis=-1)
        pattern = two_way_pattern(line / slant[..., None], frames[nearest],
                                  radar.azimuth_beamwidth, radar.elevation_beamwidth)
        amplitude = radar_equation_amplitude(radar, 1.0, slant, two_way_pattern=pattern)
        peak[start:start + len(block)] = amplitude @ weights / weights.sum()
        middle = line[:, APERTURE_NODES // 2]
        cos_incidence = np.abs(middle[:, 2]) / slant[:, APERTURE_NODES // 2]
        sin_incidence[start:start + len(block)] = np.sqrt(np.clip(1 - cos_incidence**2,
                                                                  1e-6, 1.0))
    return peak, sin_incidence


def noise_variables(raw: xr.Dataset, pixels: NDArray, coverage: NDArray, half_width: float,
                    window: str, range_window: str) -> dict[str, tuple] | None:
    """``noise_power`` [W] and ``nesz_db`` [dB] of each pixel, as image-product variables
    (values flat, shape (P,)); None when the radar has no noise figure or the echoes are
    normalised (no watts to compare with).

    Parameters
    ----------
    raw : xarray.Dataset
        The raw product that was focused.
    pixels : ndarray, shape (P, 3)
        Pixel world positions [m].
    coverage : ndarray, shape (P,)
        Fraction of each pixel's processed aperture on the track.
    half_width : float
        Processed half width in direction sine ``h``.
    window, range_window : str
        Azimuth and range windows.
    """
    radar = radar_of(raw)
    if radar.noise_figure_db is None or int(raw.attrs.get("normalized", 0)):
        return None
    origin, direction, _, speed, centroid = _aperture_sampling(raw)
    sweeps = full_aperture_weight(pixels, origin, direction, speed, sweep_rate(raw, radar),
                                  centroid, half_width, 1.0)
    coverage = np.clip(np.asarray(coverage, dtype=float).ravel(), 0.0, 1.0)
    noise = coverage * focused_noise_power(
        radar.noise_power, radar.samples_per_sweep, sweeps,
        window_noise_bandwidth(window_coefficients(range_window)),
        window_noise_bandwidth(window_coefficients(window)))
    peak, sin_incidence = unit_peak_amplitude(raw, pixels, half_width, window)
    nesz = noise_equivalent_sigma0(radar.noise_power, radar.samples_per_sweep, sweeps,
                                   peak**2, radar.range_resolution,
                                   radar.wavelength / (4 * half_width), sin_incidence)
    with np.errstate(divide="ignore"):
        nesz_db = 10 * np.log10(nesz) - 10 * np.log10(coverage)
    return {"noise_power": (noise, {"units": "W", "long_name": "thermal noise power of the "
                                    "pixel (docs/metrics.md §Noise)"}),
            "nesz_db": (nesz_db, {"units": "dB", "long_name": "noise-equivalent sigma0 on a "
                                  "horizontal surface (docs/metrics.md §Noise)"})}
