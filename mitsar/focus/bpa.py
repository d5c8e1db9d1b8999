"""Back-projection (BPA) of dechirped FMCW data, with the continuous-motion range shift.

For every pixel x and sweep k (antenna at ``p_k``, velocity ``v_k`` at mid-sweep):

1. ``R = |x - p_k|``, ``tau = 2R/c`` and ``dtau/dt = -(2/c) v_k . (x - p_k) / R``;
2. the echo of x sits in the range profile at the beat frequency
   ``f = K tau + f_c dtau/dt`` (Meta 2007 §II-B; fmcw3's ``v_corr``): the Doppler part removes
   the FMCW range shift of continuous motion, so no stop-and-go error remains to first order;
3. the profile is interpolated there (linear, on a 16x zero-padded FFT) and de-rotated by
   ``exp(-j 2 pi f_c tau)``, the phase the sweep-centred range FFT leaves (paper eq. 1);
4. it is weighted by an azimuth window over the processed aperture and summed.

The processed azimuth band is set by the azimuth resolution rho: direction sines
``u = v_hat . (x - p_k) / R`` within ``h = lambda / (4 rho)`` of the Doppler centroid
``u_c = v_hat . l_hat``, an angular span ``lambda / (2 rho)`` (rectangular spectrum:
IRW = 0.886 rho). Two ways to select it:

* ``"doppler"`` (straight tracks, the default there): band-pass every range bin in azimuth
  frequency, ``|f_eta - f_DC| <= v / (2 rho)`` with the azimuth window across the band, then
  back-project every sweep that sees the pixel inside the beam. The band is then selected by
  the *echo's* Doppler, as RDA/WDA/FSA do, and a point focuses to a clean sinc with no phase
  curvature across the image.
* ``"pixel"`` (any trajectory): weight each sweep by the window at the *pixel's* direction sine.
  The magnitude of a point response is the same sinc, but its phase carries a quadratic term
  ``2 pi d^2 / (lambda R)`` in the azimuth offset d (the aperture slides with the pixel), so
  the image is not band-limited to 1/rho and must be sampled finely.

The result is normalised by the weight a full aperture would have (:func:`normalise_image`),
so a point of amplitude a focuses to a peak of about a, and pixels whose aperture runs off the
end of the track fade instead of being amplified.

The kernel is one Dr.Jit loop over sweeps with one lane per pixel (float64 phases), compiled once
and cached: per-acquisition values are opaque. A NumPy reference (:func:`backproject_numpy`)
implements the same sum for tests and benchmarks.
"""

from __future__ import annotations

import drjit as dr
import numpy as np
import xarray as xr
from drjit.llvm import Float32, Float64, UInt32
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.backend import require_llvm
from mitsar.errors import ParameterError
from mitsar.focus.compression import range_spectrum
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.focus.grid import track_frame
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.raw.product import radar_of
from mitsar.model.signal import fast_time


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


def backproject_numpy(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray,
                      motion_correction: bool = True) -> tuple[NDArray, NDArray]:
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

    Returns
    -------
    weighted_sum : ndarray, shape (P,), complex
        Sum of the weighted, de-rotated profile values.
    total_weight : ndarray, shape (P,)
        Sum of the weights (see :func:`normalise_image`).
    """
    slant_range, sine, delay_rate = doppler_geometry(pixels, positions, velocities)
    delay = 2.0 * slant_range / SPEED_OF_LIGHT
    beat = radar.chirp_rate * delay
    if motion_correction:
        beat = beat + radar.carrier_frequency * delay_rate
    index = (beat - frequency[0]) / (frequency[1] - frequency[0])
    lower = np.floor(index).astype(int)
    valid = (lower >= 0) & (lower < len(frequency) - 1)
    lower = np.clip(lower, 0, len(frequency) - 2)
    fraction = index - lower
    rows = np.arange(profile.shape[0])[:, None]
    value = profile[rows, lower] * (1 - fraction) + profile[rows, lower + 1] * fraction
    cycles = radar.carrier_frequency * delay
    value = value * np.exp(-2j * np.pi * (cycles - np.floor(cycles)))
    offset = sine - centroid_sine[:, None]
    weight = np.where(valid & (np.abs(offset) <= half_width),
                      evaluate_window(window, offset / (2 * half_width) + 0.5), 0.0)
    return (weight * value).sum(axis=0), weight.sum(axis=0)


def backproject_drjit(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray, motion_correction: bool = True,
                      sweep_range: tuple[NDArray, NDArray] | None = None
                      ) -> tuple[NDArray, NDArray]:
    """Back-projection as one Dr.Jit kernel (parameters as :func:`backproject_numpy`).

    ``sweep_range``, optional per-pixel first and end sweep indices, limits each lane's loop
    to the sweeps that can see the pixel inside the processed window (:func:`sweep_window`);
    by default every lane visits every sweep.
    """
    require_llvm()
    sweeps, bins = profile.shape
    if sweep_range is None:
        sweep_range = (np.zeros(len(pixels), dtype=np.uint32),
                       np.full(len(pixels), sweeps, dtype=np.uint32))
    speed = np.linalg.norm(velocities, axis=-1)
    direction = velocities / np.where(speed > 0, speed, 1.0)[:, None]
    coefficients = np.zeros(4)
    coefficients[: len(window)] = window

    def opaque(value: float) -> Float64:
        return dr.opaque(Float64, float(value))

    sweep_arrays = [Float64(np.ascontiguousarray(a)) for a in (
        positions[:, 0], positions[:, 1], positions[:, 2],
        direction[:, 0], direction[:, 1], direction[:, 2], speed, centroid_sine)]
    constants = {
        "first_frequency": opaque(frequency[0]),
        "frequency_step": opaque(frequency[1] - frequency[0]),
        "chirp_rate": opaque(radar.chirp_rate),
        "carrier": opaque(radar.carrier_frequency),
        "motion": opaque(1.0 if motion_correction else 0.0),
        "half_width": opaque(half_width),
        "bins": dr.opaque(UInt32, bins),
        "coefficients": [float(c) for c in coefficients],
    }
    # Profiles are read at random: float32 halves the memory traffic (1e-7 relative error).
    real = Float32(np.ascontiguousarray(profile.real, dtype=np.float32).ravel())
    imag = Float32(np.ascontiguousarray(profile.imag, dtype=np.float32).ravel())
    result_real, result_imag, total = _bpa_kernel(
        Float64(pixels[:, 0]), Float64(pixels[:, 1]), Float64(pixels[:, 2]),
        sweep_arrays, real, imag, UInt32(sweep_range[0]), UInt32(sweep_range[1]), constants)
    return np.asarray(result_real) + 1j * np.asarray(result_imag), np.asarray(total)


def _bpa_kernel(x: Float64, y: Float64, z: Float64, sweep_arrays: list, real: Float64,
                imag: Float64, first: UInt32, end: UInt32, constants: dict) -> tuple:
    """Launch the back-projection loop and evaluate its three accumulators."""
    result = _bpa_loop(x, y, z, *sweep_arrays, real, imag, first, end, constants["chirp_rate"],
                       constants["carrier"], constants["motion"], constants["first_frequency"],
                       constants["frequency_step"], constants["bins"], constants["half_width"],
                       constants["coefficients"])
    dr.eval(*result)
    return result


@dr.syntax
def _bpa_loop(x, y, z, px, py, pz, dx_v, dy_v, dz_v, speed_all, centroid_all, real, imag,  # noqa: ANN001, ANN202, PLR0913
              first, end, chirp_rate, carrier, motion, first_frequency, frequency_step, bins,
              half_width, coefficients):
    """One lane per pixel, a symbolic loop over its sweeps (see the module docstring)."""
    two_over_c = 2.0 / SPEED_OF_LIGHT
    k = UInt32(first)
    acc_real = dr.zeros(Float64, dr.width(x))
    acc_imag = dr.zeros(Float64, dr.width(x))
    total = dr.zeros(Float64, dr.width(x))
    while k < end:
        ox = x - dr.gather(Float64, px, k)
        oy = y - dr.gather(Float64, py, k)
        oz = z - dr.gather(Float64, pz, k)
        slant_range = dr.sqrt(ox * ox + oy * oy + oz * oz)
        sine = (ox * dr.gather(Float64, dx_v, k) + oy * dr.gather(Float64, dy_v, k)
                + oz * dr.gather(Float64, dz_v, k)) / slant_range
        delay = two_over_c * slant_range
        delay_rate = -two_over_c * dr.gather(Float64, speed_all, k) * sine
        beat = chirp_rate * delay + motion * carrier * delay_rate
        index = (beat - first_frequency) / frequency_step
        lower = dr.floor(index)
        fraction = index - lower
        offset = sine - dr.gather(Float64, centroid_all, k)
        active = (lower >= 0) & (lower < Float64(bins - 1)) & (dr.abs(offset) <= half_width)
        flat = k * bins + UInt32(dr.select(active, lower, 0))
        v_real = (Float64(dr.gather(Float32, real, flat, active)) * (1 - fraction)
                  + Float64(dr.gather(Float32, real, flat + 1, active)) * fraction)
        v_imag = (Float64(dr.gather(Float32, imag, flat, active)) * (1 - fraction)
                  + Float64(dr.gather(Float32, imag, flat + 1, active)) * fraction)
        # Phase wrapped to one cycle in float64, then evaluated in float32 (error < 1e-6 rad).
        cycles = carrier * delay
        sin_phase, cos_phase = dr.sincos(Float32(2 * dr.pi * (cycles - dr.floor(cycles))))
        sin_phase, cos_phase = Float64(sin_phase), Float64(cos_phase)
        # Azimuth window: cosine series at xi = offset / (2 half_width) (centre 0). The
        # coefficients are literals, so a rectangular window costs nothing.
        xi = Float32(offset / (2 * half_width))
        weight = Float64(coefficients[0])
        for harmonic in range(1, len(coefficients)):
            if coefficients[harmonic] != 0.0:
                weight += coefficients[harmonic] * Float64(dr.cos(2 * dr.pi * harmonic * xi))
        weight = dr.select(active, weight, 0.0)
        # value * exp(-j phase)
        acc_real += weight * (v_real * cos_phase + v_imag * sin_phase)
        acc_imag += weight * (v_imag * cos_phase - v_real * sin_phase)
        total += weight
        k += 1
    return acc_real, acc_imag, total


def full_aperture_weight(pixels: NDArray, origin: NDArray, direction: NDArray, speed: float,
                         prf: float, centroid_sine: float, half_width: float,
                         window_mean: float) -> NDArray:
    """Sum of azimuth weights a pixel would get from a complete processed aperture.

    Along a straight track the direction sine changes per metre by ``(1 - u^2)^(3/2) / r``
    (r: distance of the pixel from the track), so the aperture ``|u - u_c| <= h`` holds
    ``2 h r PRF / (v (1 - u_c^2)^(3/2))`` sweeps, each weighted on average by the window mean.
    For curved tracks this uses the mean track line (an approximation).
    """
    offset = pixels - origin
    along = offset @ direction
    distance = np.linalg.norm(offset - along[:, None] * direction, axis=-1)
    return (window_mean * 2 * half_width * distance * prf
            / (speed * (1 - centroid_sine**2) ** 1.5))


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


def sweep_window(pixels: NDArray, origin: NDArray, direction: NDArray, sweep_spacing: float,
                 sweeps: int, centroid_sine: float, half_width: float
                 ) -> tuple[NDArray, NDArray]:
    """First and end sweep index that see each pixel within ``|u - u_c| <= h`` (straight track).

    The antenna sees direction sine u from along-track ``a - r u / sqrt(1 - u^2)`` (a, r: the
    pixel's along-track coordinate and distance from the track); sweep k sits at
    ``k * sweep_spacing`` along the track. One sweep of margin either side.
    """
    offset = pixels - origin
    along = offset @ direction
    distance = np.linalg.norm(offset - along[:, None] * direction, axis=-1)
    limits = np.clip([centroid_sine - half_width, centroid_sine + half_width], -0.999, 0.999)
    slope = limits / np.sqrt(1 - limits**2)
    earliest = (along - distance * slope[1]) / sweep_spacing
    latest = (along - distance * slope[0]) / sweep_spacing
    first = np.clip(np.floor(earliest) - 1, 0, sweeps).astype(np.uint32)
    end = np.clip(np.ceil(latest) + 2, 0, sweeps).astype(np.uint32)
    return first, np.maximum(end, first)


def band_coverage(pixels: NDArray, origin: NDArray, direction: NDArray, track_length: float,
                  centroid_sine: float, half_width: float) -> NDArray:
    """Fraction of a pixel's processed aperture that lies on a straight track, in [0, 1].

    The aperture of the band ``|u - u_c| <= h`` is centred where ``u = u_c``, at along-track
    ``a - u_c r / sqrt(1 - u_c^2)``, and is ``2 h r / (1 - u_c^2)^(3/2)`` long (r: distance of
    the pixel from the track); the track runs from 0 to ``track_length``.
    """
    offset = pixels - origin
    along = offset @ direction
    distance = np.linalg.norm(offset - along[:, None] * direction, axis=-1)
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
    size = sweeps + 2 * pad_sweeps
    padded = np.zeros((size, samples.shape[1]), dtype=complex)
    padded[pad_sweeps:pad_sweeps + sweeps] = samples
    frequency = np.fft.fftfreq(size, 1.0 / prf)[:, None]
    scale = 2 * speed * np.asarray(rf_frequency)[None, :] / SPEED_OF_LIGHT
    bandwidth = 2 * half_width * scale
    offset = (frequency + centroid_sine * scale + prf / 2) % prf - prf / 2
    step = prf / size
    low = np.maximum(offset - step / 2, -bandwidth / 2)
    high = np.minimum(offset + step / 2, bandwidth / 2)
    inside = np.clip((high - low) / step, 0.0, 1.0)
    # -offset: the band's upper azimuth frequencies are its lower direction sines.
    position = np.clip(-(low + high) / 2 / bandwidth + 0.5, 0.0, 1.0)
    gain = inside * evaluate_window(window, position)
    filtered = np.fft.ifft(np.fft.fft(padded, axis=0) * gain, axis=0)
    return filtered[pad_sweeps:pad_sweeps + sweeps]


def is_uniform_straight_track(raw: xr.Dataset, tolerance: float = 1e-6) -> bool:
    """Whether all sweeps share one velocity (straight track at constant speed)."""
    velocities = raw["platform_velocity"].values
    speed = np.linalg.norm(velocities, axis=-1).max()
    return bool(np.ptp(velocities, axis=0).max() <= tolerance * max(speed, 1e-12))


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
    frequency, profile = range_spectrum(
        samples, radar, window=range_window, remove_rvp=remove_rvp, upsample=range_upsample,
        rvp_present=bool(raw.attrs.get("rvp", 1)))
    frequency, profile = crop_to_pixels(frequency, profile, radar, pixels, positions,
                                        float(speed.max()))
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
