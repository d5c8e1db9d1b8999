"""Back-projection (BPA) of dechirped FMCW data, with the continuous-motion range shift.

For every pixel x and sweep k (antenna at ``p_k``, velocity ``v_k`` at mid-sweep):

1. ``R = |x - p_k|``, ``tau = 2R/c`` and ``dtau/dt = -(2/c) v_k . (x - p_k) / R``;
2. the echo of x sits in the range profile at the beat frequency
   ``f = K tau + f_c dtau/dt`` (Meta 2007 §II-B; fmcw3's ``v_corr``): the Doppler part removes
   the FMCW range shift of continuous motion, so no stop-and-go error remains to first order;
3. the profile is interpolated there (linear, on a 16x zero-padded FFT) and de-rotated by
   ``exp(-j 2 pi f_c tau)``, the phase the sweep-centred range FFT leaves (paper eq. 1);
4. it is weighted by an azimuth window over the processed aperture and summed.

The processed aperture is set by the azimuth resolution rho: sweeps whose direction sine
``u = v_hat . (x - p_k) / R`` lies within ``lambda / (4 rho)`` of the Doppler centroid
``u_c = v_hat . l_hat`` contribute, an angular span ``lambda / (2 rho)`` (rectangular spectrum:
IRW = 0.886 rho). The result is normalised by the sum of weights, so a point of amplitude a
focuses to a peak of about a.

The kernel is one Dr.Jit loop over sweeps with one lane per pixel (float64 phases), compiled once
and cached: per-acquisition values are opaque. A NumPy reference (:func:`backproject_numpy`)
implements the same sum for tests and benchmarks.
"""

from __future__ import annotations

import drjit as dr
import numpy as np
from drjit.llvm import Float32, Float64, UInt32
from numpy.typing import NDArray

from mitsar.backend import require_llvm
from mitsar.focus.windows import evaluate_window
from mitsar.radar import SPEED_OF_LIGHT, Radar


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

    ``None`` processes the whole beam to its first nulls (``lambda / l_AZ``), capped at 1.
    """
    if azimuth_resolution is None:
        return min(np.sin(radar.azimuth_beamwidth), 1.0)
    return min(radar.wavelength / (4.0 * azimuth_resolution), 1.0)


def backproject_numpy(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray,
                      motion_correction: bool = True) -> NDArray[np.complex128]:
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
    ndarray, shape (P,)
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
    total = weight.sum(axis=0)
    return (weight * value).sum(axis=0) / np.where(total > 0, total, 1.0)


def backproject_drjit(profile: NDArray, frequency: NDArray, radar: Radar, pixels: NDArray,
                      positions: NDArray, velocities: NDArray, centroid_sine: NDArray,
                      half_width: float, window: NDArray,
                      motion_correction: bool = True) -> NDArray[np.complex128]:
    """Back-projection as one Dr.Jit kernel (parameters as :func:`backproject_numpy`)."""
    require_llvm()
    sweeps, bins = profile.shape
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
    real = Float64(np.ascontiguousarray(profile.real).ravel())
    imag = Float64(np.ascontiguousarray(profile.imag).ravel())
    result_real, result_imag, total = _bpa_kernel(
        Float64(pixels[:, 0]), Float64(pixels[:, 1]), Float64(pixels[:, 2]),
        sweep_arrays, real, imag, dr.opaque(UInt32, sweeps), constants)
    total_np = np.asarray(total)
    image = np.asarray(result_real) + 1j * np.asarray(result_imag)
    return image / np.where(total_np > 0, total_np, 1.0)


def _bpa_kernel(x: Float64, y: Float64, z: Float64, sweep_arrays: list, real: Float64,
                imag: Float64, sweeps: UInt32, constants: dict) -> tuple:
    """Launch the back-projection loop and evaluate its three accumulators."""
    result = _bpa_loop(x, y, z, *sweep_arrays, real, imag, sweeps, constants["chirp_rate"],
                       constants["carrier"], constants["motion"], constants["first_frequency"],
                       constants["frequency_step"], constants["bins"], constants["half_width"],
                       constants["coefficients"])
    dr.eval(*result)
    return result


@dr.syntax
def _bpa_loop(x, y, z, px, py, pz, dx_v, dy_v, dz_v, speed_all, centroid_all, real, imag,  # noqa: ANN001, ANN202, PLR0913
              sweeps, chirp_rate, carrier, motion, first_frequency, frequency_step, bins,
              half_width, coefficients):
    """One lane per pixel, a symbolic loop over sweeps (see the module docstring)."""
    two_over_c = 2.0 / SPEED_OF_LIGHT
    k = UInt32(0)
    acc_real = dr.zeros(Float64, dr.width(x))
    acc_imag = dr.zeros(Float64, dr.width(x))
    total = dr.zeros(Float64, dr.width(x))
    while k < sweeps:
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
        v_real = (dr.gather(Float64, real, flat, active) * (1 - fraction)
                  + dr.gather(Float64, real, flat + 1, active) * fraction)
        v_imag = (dr.gather(Float64, imag, flat, active) * (1 - fraction)
                  + dr.gather(Float64, imag, flat + 1, active) * fraction)
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
