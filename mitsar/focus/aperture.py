"""The processed aperture: which sweeps and which Doppler band contribute to a pixel.

The processed azimuth band is set by the azimuth resolution rho: direction sines
``u = v_hat . (x - p_k) / R`` within ``h = lambda / (4 rho)`` of the Doppler centroid
``u_c = v_hat . l_hat``, an angular span ``lambda / (2 rho)`` (rectangular spectrum:
IRW = 0.886 rho; :func:`aperture_half_width`). Two ways to select it (``focus_bpa``):

* ``"doppler"`` (straight tracks): :func:`doppler_bandpass` band-passes every range bin in
  azimuth frequency, ``|f_eta - f_DC| <= v / (2 rho)``, with the azimuth window across the band;
  :func:`band_coverage` is the fraction of a pixel's band the track holds.
* ``"pixel"`` (any trajectory): each sweep is weighted by the window at the *pixel's* direction
  sine (:func:`doppler_geometry`); :func:`normalise_image` divides by the weight a complete
  aperture would have (:func:`full_aperture_weight`).

:func:`sweep_window` bounds the sweeps a pixel's aperture spans on a straight track (the
kernel's loop range); :func:`aperture_resolution` is the nominal resolution of a recorded
aperture seen from a point.

On a curved track the direction sine along each sweep's *own* velocity also turns with the
heading, so a window on it processes an angular span of the line of sight that follows the
turn rate, not ``lambda / (2 rho)``. :func:`aspect_frames` gives every pixel one fixed
direction, the (interpolated) *mean-track* direction at its beam-centre crossing, and the sine
of its line of sight there: the window on ``l_hat . d_pixel - u_pixel`` then spans exactly the
line-of-sight (aspect) angle the resolution asks for, on any track (docs/focusing.md, "Curved
tracks"). The mean track (:func:`mitsar.model.geometry.aperture.mean_track_velocity`: the
velocity averaged over three passes of a 1 s boxcar) follows turns but not a cross-track wander of
a few centimetres, which swings the instantaneous velocity by up to +-25 deg but moves no line
of sight (docs/focusing.md, "An aperture that ignores the wander"). On a straight track the
frame is the track's and nothing changes.
"""

from __future__ import annotations

import math

import numpy as np
import scipy.fft as sp_fft
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.focus.windows import evaluate_window
from mitsar.model.geometry.aperture import MEAN_TRACK_TIME, mean_track_velocity
from mitsar.model.radar import SPEED_OF_LIGHT, Radar

__all__ = [
    "MAX_AZIMUTH_RESOLUTION",
    "aperture_half_width",
    "aperture_resolution",
    "aspect_frames",
    "band_coverage",
    "doppler_bandpass",
    "doppler_geometry",
    "full_aperture_weight",
    "is_uniform_straight_track",
    "mean_track_frame",
    "median_sweep_interval",
    "normalise_image",
    "sweep_window",
    "track_coordinates",
]


MAX_AZIMUTH_RESOLUTION = 1000.0
"""Coarsest processed azimuth resolution accepted [m] (focus and the TOML ``[focus]`` table),
far beyond any indoor scene: its band would hold no sweep."""


def doppler_geometry(pixels: NDArray, positions: NDArray, velocities: NDArray
                     ) -> tuple[NDArray, NDArray, NDArray]:
    """Range, direction sine along the velocity, and delay rate for pixels x sweeps.

    Parameters
    ----------
    pixels : ndarray, shape (P, 3)
    positions, velocities : ndarray, shape (S, 3)

    Returns
    -------
    slant_range : ndarray, shape (S, P) [m]
    direction_sine : ndarray, shape (S, P)
        ``v_hat . (x - p) / R``.
    delay_rate : ndarray, shape (S, P)
        ``dtau/dt = -(2/c) v . (x - p) / R`` [s/s].
    """
    offset = pixels[None, :, :] - positions[:, None, :]
    slant_range = np.linalg.norm(offset, axis=-1)
    speed = np.linalg.norm(velocities, axis=-1)
    radial_speed = np.einsum("spi,si->sp", offset, velocities) / slant_range
    direction_sine = radial_speed / np.where(speed > 0, speed, 1.0)[:, None]
    return slant_range, direction_sine, -2.0 * radial_speed / SPEED_OF_LIGHT


def aperture_half_width(radar: Radar, azimuth_resolution: float | None) -> float:
    """Half width of the processed aperture in direction sine, ``lambda / (4 rho)``.

    ``None`` processes the whole beam to its first nulls (direction sine ``lambda / l_AZ``),
    capped at 1.
    """
    if azimuth_resolution is None:
        return min(radar.azimuth_beamwidth, 1.0)
    return min(radar.wavelength / (4.0 * azimuth_resolution), 1.0)


def is_uniform_straight_track(raw: xr.Dataset, tolerance: float = 1e-6) -> bool:
    """Whether all sweeps share one velocity (straight track at constant speed)."""
    velocities = raw["platform_velocity"].values
    speed = np.linalg.norm(velocities, axis=-1).max()
    return bool(np.ptp(velocities, axis=0).max() <= tolerance * max(speed, 1e-12))


def track_coordinates(pixels: NDArray, origin: NDArray, direction: NDArray
                       ) -> tuple[NDArray, NDArray]:
    """Along-track coordinate [m] of every pixel and its distance [m] from the track line.

    ``a = (x - o).d`` and ``r = sqrt(|x - o|^2 - a^2)``, with ``|x - o|^2`` expanded so that no
    (P, 3) temporary is made (3x faster on a million pixels; the expansion loses ~1e-16 of
    ``|x|^2`` in ``r^2``: 1e-14 m at 10 m).
    """
    pixels = np.asarray(pixels, dtype=float)
    along = pixels @ direction - float(origin @ direction)
    square = (np.einsum("ij,ij->i", pixels, pixels) - 2.0 * (pixels @ origin)
              + float(origin @ origin))
    return along, np.sqrt(np.maximum(square - along**2, 0.0))


def full_aperture_weight(pixels: NDArray, origin: NDArray, direction: NDArray, speed: float,
                         prf: float, centroid_sine: float, half_width: float,
                         window_mean: float, coordinates: tuple[NDArray, NDArray] | None = None
                         ) -> NDArray:
    """Sum of azimuth weights a pixel would get from a complete processed aperture.

    Along a straight track the direction sine changes per metre by ``(1 - u^2)^(3/2) / r``
    (r: distance of the pixel from the track), so the aperture ``|u - u_c| <= h`` holds
    ``2 h r PRF / (v (1 - u_c^2)^(3/2))`` sweeps, each weighted on average by the window mean.
    For curved tracks this uses the mean track line (an approximation). ``coordinates``:
    :func:`track_coordinates` of the pixels if already computed.
    """
    along, distance = coordinates or track_coordinates(pixels, origin, direction)
    return (window_mean * 2 * half_width * distance * prf
            / (speed * (1 - centroid_sine**2) ** 1.5))


def sweep_window(pixels: NDArray, origin: NDArray, direction: NDArray, sweep_spacing: float,
                 sweeps: int, centroid_sine: float, half_width: float,
                 coordinates: tuple[NDArray, NDArray] | None = None
                 ) -> tuple[NDArray, NDArray]:
    """First and end sweep index that see each pixel within ``|u - u_c| <= h`` (straight track).

    The antenna sees direction sine u from along-track ``a - r u / sqrt(1 - u^2)`` (a, r: the
    pixel's along-track coordinate and distance from the track); sweep k sits at
    ``k * sweep_spacing`` along the track. One sweep of margin either side. ``coordinates``:
    :func:`track_coordinates` of the pixels if already computed.
    """
    along, distance = coordinates or track_coordinates(pixels, origin, direction)
    limits = np.clip([centroid_sine - half_width, centroid_sine + half_width], -0.999, 0.999)
    slope = limits / np.sqrt(1 - limits**2)
    earliest = (along - distance * slope[1]) / sweep_spacing
    latest = (along - distance * slope[0]) / sweep_spacing
    first = np.clip(np.floor(earliest) - 1, 0, sweeps).astype(np.uint32)
    end = np.clip(np.ceil(latest) + 2, 0, sweeps).astype(np.uint32)
    return first, np.maximum(end, first)


def band_coverage(pixels: NDArray, origin: NDArray, direction: NDArray, track_length: float,
                  centroid_sine: float, half_width: float,
                  coordinates: tuple[NDArray, NDArray] | None = None) -> NDArray:
    """Fraction of a pixel's processed aperture that lies on a straight track, in [0, 1].

    The aperture of the band ``|u - u_c| <= h`` is centred where ``u = u_c``, at along-track
    ``a - u_c r / sqrt(1 - u_c^2)``, and is ``2 h r / (1 - u_c^2)^(3/2)`` long (r: distance of
    the pixel from the track); the track runs from 0 to ``track_length``. ``coordinates``:
    :func:`track_coordinates` of the pixels if already computed.
    """
    along, distance = coordinates or track_coordinates(pixels, origin, direction)
    centre = along - centroid_sine * distance / np.sqrt(1 - centroid_sine**2)
    half_length = half_width * distance / (1 - centroid_sine**2) ** 1.5
    overlap = (np.minimum(centre + half_length, track_length)
               - np.maximum(centre - half_length, 0.0))
    return np.clip(overlap / np.where(half_length > 0, 2 * half_length, 1.0), 0.0, 1.0)


def normalise_image(weighted_sum: NDArray, total_weight: NDArray,
                    full_weight: NDArray) -> tuple[NDArray, NDArray]:
    """Divide by the larger of the actual and the full-aperture weight.

    Returns
    -------
    image : ndarray
        Focused values; a complete aperture gives the echo amplitude.
    coverage : ndarray
        Fraction of the full aperture that contributed, in [0, 1].
    """
    norm = np.maximum(total_weight, full_weight)
    image = weighted_sum / np.where(norm > 0, norm, 1.0)
    coverage = np.clip(total_weight / np.where(full_weight > 0, full_weight, 1.0), 0.0, 1.0)
    return image, coverage


def doppler_bandpass(samples: NDArray, prf: float, centroid_sine: float, half_width: float,
                     speed: float, rf_frequency: NDArray, window: NDArray,
                     pad_sweeps: int) -> NDArray:
    """Keep the echoes whose direction sine lies in the processed band, by azimuth filtering.

    At fast-time sample n the dechirped echo is ``exp(j 2 pi f_n tau(eta))`` with the RF
    frequency ``f_n = f_c + K t_n`` (paper eq. 1), so its azimuth frequency is
    ``-2 v u f_n / c`` for direction sine u (minus the Doppler frequency in our convention).
    The band ``|u - u_c| <= h`` is therefore ``|f_eta + 2 v u_c f_n / c| <= 2 v h f_n / c``,
    selected per sample: an exact angular selection with no range-migration coupling. The
    window is applied across the band; the two edge bins are weighted by the fraction of them
    inside it, so the band is exact however coarse the bins. Zero-padding by ``pad_sweeps`` on
    both ends keeps the filter from wrapping the track's ends onto each other.

    Parameters
    ----------
    samples : ndarray, shape (S, N)
        Dechirped raw samples.
    prf : float
        Sweep rate [Hz].
    centroid_sine, half_width : float
        Band centre u_c and half width h in direction sine.
    speed : float
        Platform speed [m/s].
    rf_frequency : ndarray, shape (N,)
        RF frequency of every fast-time sample [Hz].
    window : ndarray
        Cosine-series window coefficients.
    pad_sweeps : int
    """
    sweeps = samples.shape[0]
    # At least pad_sweeps of zeros on both ends, rounded up to a fast FFT length (a length
    # with a large prime factor costs 3x: 4496 = 16 x 281 for 4096 sweeps).
    size = sp_fft.next_fast_len(sweeps + 2 * pad_sweeps)
    padded = np.zeros((size, samples.shape[1]), dtype=complex)
    padded[pad_sweeps:pad_sweeps + sweeps] = samples
    all_frequencies = np.fft.fftfreq(size, 1.0 / prf)
    scale = 2 * speed * np.asarray(rf_frequency)[None, :] / SPEED_OF_LIGHT
    bandwidth = 2 * half_width * scale
    step = prf / size
    # Only the rows within a bin of the band for some sample can pass (a few per cent of
    # them for a narrow band): the gain is evaluated there, the other rows are zeroed.
    centre = -centroid_sine * scale
    middle = 0.5 * (centre.min() + centre.max())
    reach = 0.5 * (centre.max() - centre.min()) + 0.5 * bandwidth.max() + step
    rows = np.abs((all_frequencies - middle + prf / 2) % prf - prf / 2) <= reach
    frequency = all_frequencies[rows][:, None]
    offset = (frequency + centroid_sine * scale + prf / 2) % prf - prf / 2
    low = np.maximum(offset - step / 2, -bandwidth / 2)
    high = np.minimum(offset + step / 2, bandwidth / 2)
    inside = np.clip((high - low) / step, 0.0, 1.0)
    # -offset: the band's upper azimuth frequencies are its lower direction sines.
    position = np.clip(-(low + high) / 2 / bandwidth + 0.5, 0.0, 1.0)
    gain = inside * evaluate_window(window, position)
    spectrum = sp_fft.fft(padded, axis=0, workers=-1)
    spectrum[~rows] = 0.0
    spectrum[rows] *= gain
    return sp_fft.ifft(spectrum, axis=0, workers=-1)[pad_sweeps:pad_sweeps + sweeps]


def aperture_resolution(raw: xr.Dataset, point: ArrayLike) -> float:
    """Nominal azimuth resolution ``lambda_c / (2 dtheta)`` of the whole aperture seen from
    ``point`` (``dtheta`` the angle between the first and last lines of sight) [m]."""
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    point = np.asarray(point, dtype=float)
    first = positions[0] - point
    last = positions[-1] - point
    cosine = first @ last / (np.linalg.norm(first) * np.linalg.norm(last))
    angle = float(np.arccos(np.clip(cosine, -1.0, 1.0)))
    wavelength = SPEED_OF_LIGHT / float(raw.attrs["radar_carrier_frequency"])
    return wavelength / (2 * angle) if angle > 0 else math.inf


def aspect_frames(pixels: NDArray, positions: NDArray, velocities: NDArray,
                  centroid_sine: NDArray, *, samples: int = 256, chunk: int = 32768,
                  smoothing_time: float = MEAN_TRACK_TIME, sweep_interval: float | None = None
                  ) -> tuple[NDArray, NDArray]:
    """Per-pixel window frame of the aspect-angle window for curved tracks (module docstring).

    The frame is the **mean track**'s: velocities ``v_bar`` averaged over a smooth window
    (:func:`mitsar.model.geometry.aperture.mean_track_velocity`, boxcars of
    ``smoothing_time``), and the Doppler-centroid sine in that frame
    ``u_bar = <|v| u_c> / |v_bar|`` (the same average), which is exactly ``b_hat . v_bar_hat``
    wherever the boresight b is constant over the window (u_c = b . v_hat: a multirotor holding
    its heading while it wanders). The beam-centre crossing of a pixel is where
    ``v_bar_hat_k . l_hat_k = u_bar_k``. It is found on ``samples`` evenly spaced sweeps (the
    crossing nearest the track if the pixel is seen more than once, e.g. before and after a
    U-turn; the closest approach to the beam centre if it never crosses), refined by a secant
    step between the two sweeps around it, with positions and mean velocities interpolated
    linearly there.

    Parameters
    ----------
    pixels : ndarray, shape (P, 3)
        Pixel positions [m].
    positions, velocities : ndarray, shape (S, 3)
        Mid-sweep antenna positions [m] and velocities [m/s].
    centroid_sine : ndarray, shape (S,)
        Doppler-centroid direction sine of every sweep (along its own velocity).
    samples : int
        Sweeps sampled in the coarse search.
    chunk : int
        Pixels per NumPy block (memory ~ 60 bytes x samples x chunk).
    smoothing_time : float
        Boxcar length of the mean track [s]; 0 uses each sweep's own velocity (the frame of
        earlier versions, which follows the wander).
    sweep_interval : float, optional
        Time between sweeps [s]; default: the median of ``|p_k+1 - p_k| / |v_k|``.

    Returns
    -------
    direction : ndarray, shape (P, 3)
        Unit mean-track direction at the crossing.
    centre_sine : ndarray, shape (P,)
        ``d_hat . l_hat`` at the crossing (l_hat: antenna to pixel).
    """
    direction, centre, _ = _aspect_crossings(pixels, positions, velocities, centroid_sine,
                                             samples, chunk, smoothing_time, sweep_interval)
    return direction, centre


def centre_of_aperture_sight(pixels: NDArray, positions: NDArray, velocities: NDArray,
                             centroid_sine: NDArray, **options) -> NDArray:
    """Unit line of sight (antenna to pixel) at every pixel's beam-centre crossing in the
    mean-track frame (:func:`aspect_frames`, whose keyword ``options`` it takes): the centre
    of the pixel's processed aperture, whose spatial frequency ``-k l . e`` along a grid axis
    e the pixels' spectrum is centred on (``exp(-j 2 pi k l . x)``, k = 2 f_c / c;
    docs/conventions.md, BPA de-rotation). Shape (P, 3)."""
    return _aspect_crossings(pixels, positions, velocities, centroid_sine, **options)[2]


def _aspect_crossings(pixels: NDArray, positions: NDArray, velocities: NDArray,
                      centroid_sine: NDArray, samples: int = 256, chunk: int = 32768,
                      smoothing_time: float = MEAN_TRACK_TIME,
                      sweep_interval: float | None = None) -> tuple[NDArray, NDArray, NDArray]:
    """Direction, centre sine and unit line of sight at each pixel's crossing
    (:func:`aspect_frames`)."""
    velocities, centroid_sine = mean_track_frame(positions, velocities, centroid_sine,
                                                 smoothing_time, sweep_interval)
    sweeps = len(positions)
    coarse = np.unique(np.linspace(0, sweeps - 1, min(samples, sweeps)).round().astype(int))
    direction = np.empty_like(pixels, dtype=float)
    line_of_sight = np.empty_like(pixels, dtype=float)
    centre = np.empty(len(pixels))
    for start in range(0, len(pixels), chunk):
        block = pixels[start:start + chunk]
        crossing = _crossing(block, positions, velocities, centroid_sine, coarse)
        # refine between the two whole sweeps around the coarse crossing (secant step)
        low = np.clip(np.floor(crossing).astype(int), 0, max(sweeps - 2, 0))
        high = np.minimum(low + 1, sweeps - 1)
        off_low, off_high = (_centroid_offset(block, positions[k], velocities[k],
                                              centroid_sine[k]) for k in (low, high))
        step = off_low - off_high
        fraction = np.clip(np.where(np.abs(step) > 0, off_low / np.where(step != 0, step, 1),
                                    crossing - low), 0.0, 1.0)[:, None]
        position = positions[low] + fraction * (positions[high] - positions[low])
        velocity = velocities[low] + fraction * (velocities[high] - velocities[low])
        unit = velocity / np.linalg.norm(velocity, axis=-1, keepdims=True)
        sight = block - position
        sight /= np.linalg.norm(sight, axis=-1, keepdims=True)
        direction[start:start + chunk] = unit
        line_of_sight[start:start + chunk] = sight
        centre[start:start + chunk] = np.einsum("pi,pi->p", sight, unit)
    return direction, centre, line_of_sight


def median_sweep_interval(positions: ArrayLike, velocities: ArrayLike) -> float:
    """Time between sweeps [s] from their mid-sweep positions and velocities.

    The median over neighbouring sweeps of ``|p_k+1 - p_k| / ((|v_k| + |v_k+1|) / 2)``
    (sweeps that move); 0 when fewer than two sweeps move. Back-projection turns it into the
    stretch of aperture a sweep stands for, ``|v_k| T``
    (:func:`mitsar.focus.backprojection.inverse_window_step`).
    """
    positions = np.asarray(positions, dtype=float)
    speed = np.linalg.norm(np.asarray(velocities, dtype=float), axis=-1)
    if len(positions) < 2:
        return 0.0
    step = np.linalg.norm(np.diff(positions, axis=0), axis=-1)
    moving = 0.5 * (speed[1:] + speed[:-1])
    ratio = step[moving > 0] / moving[moving > 0]
    return float(np.median(ratio)) if len(ratio) else 0.0


def mean_track_frame(positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                     smoothing_time: float = MEAN_TRACK_TIME,
                     sweep_interval: float | None = None) -> tuple[NDArray, NDArray]:
    """Mean-track velocity ``v_bar`` [m/s] and centroid sine ``u_bar`` of every sweep.

    ``v_bar = <v>`` and ``u_bar = <|v| u_c> / |v_bar|``, ``<.>`` the mean-track average of
    :func:`mitsar.model.geometry.aperture.mean_track_velocity`; since ``|v| u_c = b . v``
    (b the boresight), ``u_bar = b . v_bar / |v_bar|`` wherever b is constant over the window.
    Where the mean track stands still (``|v_bar| = 0``, a hover) the sweep's own velocity and
    centroid are kept. See :func:`aspect_frames` for the parameters.
    """
    positions = np.asarray(positions, dtype=float)
    velocities = np.asarray(velocities, dtype=float)
    centroid_sine = np.asarray(centroid_sine, dtype=float)
    speed = np.linalg.norm(velocities, axis=-1)
    if len(positions) < 2 or smoothing_time <= 0:
        return velocities, centroid_sine
    if sweep_interval is None:
        sweep_interval = median_sweep_interval(positions, velocities)
    if not sweep_interval > 0:
        return velocities, centroid_sine
    mean = mean_track_velocity(np.column_stack([velocities, speed * centroid_sine]),
                               sweep_interval, smoothing_time)
    mean_velocity = mean[:, :3]
    mean_speed = np.linalg.norm(mean_velocity, axis=-1)
    still = ~(mean_speed > 1e-9 * max(float(speed.max()), 1e-300))
    mean_centroid = mean[:, 3] / np.where(still, 1.0, mean_speed)
    mean_velocity[still] = velocities[still]
    mean_centroid[still] = centroid_sine[still]
    return mean_velocity, np.clip(mean_centroid, -1.0, 1.0)


def _centroid_offset(pixels: NDArray, position: NDArray, velocity: NDArray,
                     centroid_sine: NDArray) -> NDArray:
    """``v_hat . l_hat - u_c`` of pixel i seen from its own sweep i (rows paired)."""
    sight = pixels - position
    unit = velocity / np.linalg.norm(velocity, axis=-1, keepdims=True)
    return (np.einsum("pi,pi->p", sight, unit) / np.linalg.norm(sight, axis=-1)
            - centroid_sine)


def _crossing(pixels: NDArray, positions: NDArray, velocities: NDArray,
              centroid_sine: NDArray, coarse: NDArray) -> NDArray:
    """Fractional sweep index of each pixel's beam-centre crossing on the coarse sweeps."""
    slant_range, sine, _ = doppler_geometry(pixels, positions[coarse], velocities[coarse])
    offset = sine - centroid_sine[coarse][:, None]
    if len(coarse) == 1:
        return np.zeros(len(pixels))
    before, after = offset[:-1], offset[1:]
    crosses = (before * after <= 0) & (before != after)
    # among crossings, the one nearest the track; otherwise the closest approach in sine
    score = np.where(crosses, slant_range[:-1], np.inf)
    pick = score.argmin(axis=0)
    columns = np.arange(len(pixels))
    found = np.isfinite(score[pick, columns])
    a, b = before[pick, columns], after[pick, columns]
    fraction = np.where(found, a / np.where(a != b, a - b, 1.0), 0.0)
    index = np.where(found, coarse[pick] + fraction * (coarse[pick + 1] - coarse[pick]),
                     coarse[np.abs(offset).argmin(axis=0)])
    return index.astype(float)
