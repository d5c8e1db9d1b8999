"""Band-limited pixels from a per-pixel aperture (issue 25): a wider aperture, then a band-pass.

A per-pixel processed band (``"pixel"`` band selection, the one a track that is not straight and
uniform gets: :mod:`mitsar.focus.aperture`) slides with the pixel, so a point's response is
``sinc(B d) exp(j pi k d^2 / R)`` (d the azimuth offset, B = 1/rho, k = 2 f_c / c): not
band-limited to B. With the paper's rho = 0.1 m at 8 m its Fresnel number ``B^2 R / k`` is 1.3
and 15 % of the column energy lies outside the band (docs/products.md, "Band-limited pixels on
any track"), which SICD's ``DeltaK1/2`` (NGA.STND.0024-1 Vol. 1 §4.2) cannot declare while
``ImpRespBW`` stays 1/rho. On a straight track the ``"doppler"`` selection band-passes the echoes
instead; on any other track :func:`band_limit_image` does the same in the image:

1. back-project with a per-pixel aperture :data:`WIDENING` times wider, weighted by the
   maximally flat window :data:`FLAT_TOP` (flat to 0.3 % over the middle quarter, smooth to its
   ends): each sweep then reaches every pixel around a point whose line of sight lies in the
   processed band, and no sharp aperture edge is left near it;
2. band-pass every pixel's azimuth spectrum to B about its own centre of aperture, the spatial
   frequency ``-k l(COA) . e`` of the line of sight at its beam-centre crossing along the grid's
   azimuth axis e (:func:`mitsar.focus.aperture.centre_of_aperture_sight`, the frame SICD's
   ``DeltaKCOAPoly`` is computed in), with the azimuth window across the band. The centre moves
   over the image on a curved track (-10 to +6 cyc/m on the test flight), so the filter is
   chosen by the *input* pixel: the image is split by a partition of unity in the centre
   frequency (hat functions on nodes :data:`NODE_STEP` B apart), each part filtered about its
   node, the parts summed (:func:`azimuth_bandpass`).

By stationary phase the wide image's spectrum at spatial frequency f carries the flat window at
the direction sine f / k, so the band-pass divides by it (a gain within 0.3 % of 1) and scales by
``mean(FLAT_TOP) WIDENING / mean(window)``: a point of amplitude a keeps a peak of about a.
The result is the response of the fixed band of sweeps around the point's own centre of
aperture, as ``"doppler"`` gives on a straight track.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import scipy.fft as sp_fft
import xarray as xr
from numpy.typing import NDArray

from mitsar.focus.aperture import (
    aperture_half_width,
    centre_of_aperture_sight,
    is_uniform_straight_track,
)
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.products.raw import sweep_rate

__all__ = ["BLOCK_SAMPLES", "FLAT_TOP", "NODE_STEP", "WIDENING", "azimuth_bandpass",
           "band_limit_image", "band_limited_focus", "wide_half_width"]

WIDENING = 4.0
"""Width of the back-projected per-pixel aperture in units of the processed band. The flat
part of :data:`FLAT_TOP` (the middle quarter) then holds the band however the line of sight
turns across the image (the curve of the test flight stretches the mapping of band to image
frequency by up to 30 %)."""

FLAT_TOP = np.array([22.0, 15.0, -6.0, 1.0]) / 32.0
"""Cosine-series coefficients (:mod:`mitsar.focus.windows`) of the maximally flat window of
four terms: ``w(0) = 1``, ``w''(0) = w''''(0) = 0``, ``w(+-1/2) = 0`` at the offset from the
centre; 1 - 0.3 % at +-1/8, 0.875 at +-1/4, smooth (no sharp edge to leak)."""

BLOCK_SAMPLES = 1 << 22
"""Samples (padded rows x columns) per FFT of :func:`azimuth_bandpass`: 64 MiB of complex128."""

NODE_STEP = 1.0 / 16.0
"""Spacing of the centre-frequency nodes of :func:`azimuth_bandpass` in units of the band
(0.6 cyc/m at rho = 0.1 m): a pixel between two nodes is filtered by a mix of the two bands,
which blurs the band's edges by at most this much."""


def wide_half_width(raw: xr.Dataset, radar: Radar, half_width: float,
                    positions: NDArray) -> float | None:
    """Half width in direction sine of the wider aperture that :func:`band_limit_image` needs
    on the grid ``positions`` (shape (A, B, 3) [m]), or None where the band is left to the
    focuser: a grid that is not 2-D, a straight uniform track (``"doppler"`` selects the band
    without a sliding aperture), or no room for a wider aperture. The widening is
    :data:`WIDENING`, less where the pixels sample it too coarsely (the wide band ``W B`` about
    the centre must not fold into the kept band ``B``: ``W <= 2 / (B dy) - 1``, dy the azimuth
    spacing; below 2 no widening), and None where it would exceed the beam's
    ``lambda / l_AZ`` or a band ``4 v h / lambda`` beyond the sweep rate (which would alias in
    slow time), or where the grid's azimuth axis turns from the mean track by more than
    ``sin(theta) = NODE_STEP B c / (2 B_rf)`` (3.6 deg at the paper's radar and rho = 0.1 m:
    the range band would spill across the azimuth band)."""
    positions = np.asarray(positions, dtype=float)
    if positions.ndim != 3 or min(positions.shape[:2]) < 2 or is_uniform_straight_track(raw):
        return None
    step = _azimuth_step(positions, raw)[0]
    spacing = float(np.linalg.norm(step))
    heading = np.asarray(raw["platform_velocity"].values, dtype=float).mean(axis=0)
    heading /= max(float(np.linalg.norm(heading)), 1e-300)
    across = float(np.linalg.norm(step - (step @ heading) * heading)) / spacing
    bandwidth = 4.0 * half_width / radar.wavelength  # B = 1 / rho [cyc/m]
    widening = min(WIDENING, 2.0 / (bandwidth * spacing) - 1.0)
    wide = widening * half_width
    if widening < 2.0 or wide >= aperture_half_width(radar, None):
        return None
    # an azimuth axis turned by theta from the track sees the range band 2 B_rf / c spread by
    # sin(theta): beyond a node step of the band, a band-pass along it would cut range content
    if 2 * radar.bandwidth / SPEED_OF_LIGHT * across > NODE_STEP * bandwidth:
        return None
    speed = float(np.linalg.norm(raw["platform_velocity"].values, axis=-1).max())
    if 4 * speed * wide / radar.wavelength > sweep_rate(raw, radar):
        return None
    return wide


def _azimuth_step(positions: NDArray, raw: xr.Dataset) -> tuple[NDArray, int]:
    """Step between neighbouring pixels [m] along the grid axis nearer the mean velocity (the
    azimuth axis), and that axis (0 or 1)."""
    heading = np.asarray(raw["platform_velocity"].values, dtype=float).mean(axis=0)
    steps = [positions[1, 0] - positions[0, 0], positions[0, 1] - positions[0, 0]]
    axis = int(np.argmax([abs(s @ heading) / max(float(np.linalg.norm(s)), 1e-300)
                          for s in steps]))
    return steps[axis], axis


def azimuth_bandpass(image: NDArray, centre: NDArray, spacing: float, bandwidth: float,
                     window: NDArray, kernel_window: NDArray, kernel_bandwidth: float
                     ) -> NDArray:
    """Band-pass every pixel's azimuth spectrum (axis 0) to ``bandwidth`` about its own centre.

    The filter is chosen by the input pixel: ``out(y) = sum_y' h(y - y'; centre(y')) in(y')``,
    ``h(.; f)`` the band ``|nu - f| <= bandwidth / 2`` (frequencies modulo ``1 / spacing``)
    with gain ``window(p) / kernel_window(q)``, ``p = (nu - f) / bandwidth + 1/2`` and
    ``q = (nu - f) / kernel_bandwidth + 1/2``, scaled by ``mean(kernel_window)
    kernel_bandwidth / (mean(window) bandwidth)``; evaluated on nodes :data:`NODE_STEP`
    bandwidths apart with hat-function weights (linear in the centre), on a spectrum
    zero-padded to three times the image (no wrap of the filter's tails), by blocks of
    columns (:data:`BLOCK_SAMPLES`).

    Parameters
    ----------
    image : ndarray, shape (A, R), complex
        Image with its azimuth along axis 0.
    centre : ndarray, shape (A, R)
        Centre of every pixel's band [cyc/m], in NumPy's DFT convention (``exp(-j 2 pi nu y)``).
    spacing : float
        Pixel spacing along axis 0 [m].
    bandwidth, kernel_bandwidth : float
        Band kept, and the band the image was back-projected with [cyc/m].
    window, kernel_window : ndarray
        Cosine-series coefficients of the window across the kept band and of the one the
        image was back-projected with.

    Returns
    -------
    ndarray, shape (A, R), complex
    """
    image = np.asarray(image)
    centre = np.asarray(centre, dtype=float)
    rows = image.shape[0]
    period = 1.0 / spacing
    if bandwidth >= period or rows < 2:  # nothing to take away: the band fills the sampling
        return image.copy()
    size = sp_fft.next_fast_len(3 * rows)
    frequency = np.fft.fftfreq(size, spacing)
    scale = (float(kernel_window[0]) * kernel_bandwidth) / (float(window[0]) * bandwidth)
    step = NODE_STEP * bandwidth
    nodes = np.arange(np.floor(centre.min() / step), np.ceil(centre.max() / step) + 1) * step
    gains = []
    for node in nodes:  # the band about each centre-frequency node, with its window gain
        offset = (frequency - node + period / 2) % period - period / 2
        inside = np.abs(offset) <= bandwidth / 2
        gain = np.zeros(size)
        gain[inside] = scale * (
            evaluate_window(window, np.clip(offset[inside] / bandwidth + 0.5, 0.0, 1.0))
            / evaluate_window(kernel_window,
                              np.clip(offset[inside] / kernel_bandwidth + 0.5, 0.0, 1.0)))
        gains.append(gain)
    out = np.zeros(image.shape, dtype=np.result_type(image.dtype, np.complex64))
    block = max(1, BLOCK_SAMPLES // size)  # columns per FFT: bounded memory on large images
    for start in range(0, image.shape[1], block):
        columns = slice(start, start + block)
        for node, gain in zip(nodes, gains, strict=True):  # one FFT pair per node it touches
            weight = np.clip(1.0 - np.abs(centre[:, columns] - node) / step, 0.0, None)
            if not weight.any():
                continue
            spectrum = sp_fft.fft(weight * image[:, columns], n=size, axis=0, workers=-1)
            out[:, columns] += sp_fft.ifft(spectrum * gain[:, None], axis=0,
                                           workers=-1)[:rows]
    return out


def band_limit_image(values: NDArray, positions: NDArray, raw: xr.Dataset, half_width: float,
               wide: float, window: str) -> NDArray:
    """Band-limit an image back-projected with the wider aperture ``wide`` and window
    :data:`FLAT_TOP` to the processed band ``half_width`` (module docstring).

    Parameters
    ----------
    values : ndarray, shape (A, B), complex
        The image on a 2-D grid.
    positions : ndarray, shape (A, B, 3)
        Its pixel positions [m].
    raw : xarray.Dataset
        The raw product (track, velocities, boresights, carrier).
    half_width, wide : float
        Processed and back-projected half widths in direction sine.
    window : str
        Azimuth window across the processed band.

    Returns
    -------
    ndarray, shape (A, B), complex
        The band along the grid axis nearer the mean track (the azimuth axis).
    """
    radar = Radar.from_attrs(raw.attrs)
    track = np.asarray(raw["platform_position"].values, dtype=float)
    velocities = np.asarray(raw["platform_velocity"].values, dtype=float)
    speed = np.linalg.norm(velocities, axis=-1)
    centroid = np.einsum("si,si->s", np.asarray(raw["boresight"].values, dtype=float),
                         velocities) / np.where(speed > 0, speed, 1.0)
    step, axis = _azimuth_step(positions, raw)
    image = np.moveaxis(values, axis, 0)
    spacing = float(np.linalg.norm(step))
    unit = step / spacing
    sight = centre_of_aperture_sight(np.moveaxis(positions, axis, 0).reshape(-1, 3), track,
                                     velocities, centroid)
    wavenumber = 2.0 * radar.carrier_frequency / SPEED_OF_LIGHT
    centre = (-wavenumber * sight @ unit).reshape(image.shape)
    result = azimuth_bandpass(image, centre, spacing, 2 * wavenumber * half_width,
                              window_coefficients(window), FLAT_TOP,
                              2 * wavenumber * wide)
    return np.moveaxis(result, 0, axis)


def band_limited_focus(focuser: Callable[[float, str | NDArray], tuple[NDArray, NDArray, dict]],
                       raw: xr.Dataset, radar: Radar, positions: NDArray, half_width: float,
                       window: str, enabled: bool = True) -> tuple[NDArray, NDArray, dict]:
    """Run a back-projection ``focuser(half_width, window) -> (values, coverage, extra)`` onto
    the grid ``positions`` and band-limit its image (module docstring) where
    :func:`wide_half_width` finds it needed and ``enabled``; ``extra`` then gets
    ``band_limit = "image"`` and ``coverage`` is the wider aperture's fraction."""
    wide = wide_half_width(raw, radar, half_width, positions) if enabled else None
    if wide is None:
        return focuser(half_width, window)
    values, coverage, extra = focuser(wide, FLAT_TOP)
    values = band_limit_image(np.reshape(values, np.shape(positions)[:-1]), positions, raw,
                              half_width, wide, window)
    return values, coverage, {**extra, "band_limit": "image"}
