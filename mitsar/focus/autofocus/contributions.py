"""Per-sweep contributions of back-projection, ``c_k(x)``, for autofocus.

Back-projection (:mod:`mitsar.focus.backprojection`) forms a pixel x as the weighted sum over
sweeps k of the range profile read at x's beat frequency and de-rotated by x's carrier phase,
``I(x) = sum_k w_k(x) c_k(x)``. Autofocus needs the terms of that sum before they are added:
an unknown phase ``phi_k`` per sweep (a line-of-sight error ``d_k``: ``phi_k = 4 pi d_k /
lambda``, the same for every pixel of a small scene) multiplies every ``c_k(x)`` by
``exp(j phi_k)``, so ``I(x; phi) = sum_k w_k(x) c_k(x) exp(-j phi_k)`` after a correction.

The terms are computed here with the same pure functions as the BP sum (:func:`beat_frequency`,
:func:`profile_position`, :func:`carrier_turns`, :func:`derotate`), the focuser's interpolation
of the profile (:mod:`mitsar.focus.interpolation`: the same taps, coefficients and edge
extrapolation, ``range_interpolation``), on the same range profiles
(:func:`mitsar.focus.compression.range_spectrum`) and with the same azimuth weights as "pixel"
band selection (:func:`mitsar.focus.aperture.doppler_geometry`): for any track, straight or
curved, and for recordings referenced to a scene point (:mod:`mitsar.focus.referenced`:
``tau = 2 (R - R_ref,k) / c``, no delay rate, periodic profile).
They are the estimation model only; the corrected image is formed by the focuser itself
(:mod:`mitsar.focus.autofocus.driver`).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.focus.aperture import aperture_half_width, doppler_geometry
from mitsar.focus.backprojection import (
    carrier_turns,
    derotate,
    profile_position,
)
from mitsar.focus.compression import range_spectrum
from mitsar.focus.interpolation import DEFAULT_INTERPOLATION, coefficients, horner, numpy_fma
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import beat_frequency
from mitsar.products.raw import radar_of

__all__ = ["PulseData", "PulseSettings", "aperture_weights", "azimuth_directions",
           "carrier_phase", "contributions", "pulse_data"]


@dataclass(frozen=True)
class PulseSettings:
    """How the focuser forms its sum (the keywords of :func:`mitsar.focus.focus`).

    Attributes
    ----------
    half_width : float or None
        Half width of the aperture in direction sine over which a pixel's sweeps are taken
        (``lambda / (4 rho)``, :func:`mitsar.focus.aperture.aperture_half_width`); ``None``: the
        whole beam.
    window : str
        Azimuth window across that aperture.
    range_window : str
        Range window of the range compression.
    remove_rvp, motion_correction : bool
        As :func:`mitsar.focus.focus`.
    range_upsample : int
        Zero-padding factor of the range FFT.
    range_interpolation : {"linear", "cubic"}
        Interpolation of the range profiles (:mod:`mitsar.focus.interpolation`).
    """

    half_width: float | None = None
    window: str = "rect"
    range_window: str = "rect"
    remove_rvp: bool = True
    motion_correction: bool = True
    range_upsample: int = 8
    range_interpolation: str = DEFAULT_INTERPOLATION


@dataclass(frozen=True)
class PulseData:
    """Range profiles and sweep geometry of a raw product, ready for pixel look-ups.

    Attributes
    ----------
    profile : ndarray, shape (S, F), complex
        Range profiles on the ascending uniform beat-frequency axis ``frequency`` [Hz].
    radar : Radar
    positions, velocities : ndarray, shape (S, 3)
        Antenna position [m] and velocity [m/s] per sweep.
    centroid : ndarray, shape (S,)
        Doppler-centroid direction sine per sweep.
    reference_range : ndarray, shape (S,) or None
        Reference range of a referenced recording [m]; ``None`` for dechirped FMCW data.
    settings : PulseSettings
    """

    profile: NDArray
    frequency: NDArray
    radar: Radar
    positions: NDArray
    velocities: NDArray
    centroid: NDArray
    reference_range: NDArray | None
    settings: PulseSettings


def pulse_data(raw: xr.Dataset, settings: PulseSettings) -> PulseData:
    """Range-compress a raw product as the focuser does and collect its sweep geometry.

    Dechirped products are compressed with RVP removal as requested; referenced recordings
    without it, as :func:`mitsar.focus.referenced.focus_referenced` does.
    """
    radar = radar_of(raw)
    referenced = "reference_range" in raw.variables
    frequency, profile = range_spectrum(
        raw["raw"].values, radar, window=settings.range_window,
        remove_rvp=settings.remove_rvp and not referenced, upsample=settings.range_upsample,
        rvp_present=bool(raw.attrs.get("rvp", 1)) and not referenced)
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    velocities = np.asarray(raw["platform_velocity"].values, dtype=float)
    speed = np.linalg.norm(velocities, axis=-1)
    centroid = np.einsum("si,si->s", raw["boresight"].values, velocities) / np.where(
        speed > 0, speed, 1.0)
    return PulseData(profile, frequency, radar, positions, velocities, centroid,
                     np.asarray(raw["reference_range"].values, float) if referenced else None,
                     settings)


def _delays(data: PulseData, points: NDArray, sweeps: NDArray | slice = slice(None)
            ) -> tuple[NDArray, NDArray]:
    """Two-way delay [s] and beat frequency [Hz] of points in the sweeps, shape (S, P).

    Dechirped data: ``tau = 2 R / c`` and ``f = K tau + f_c dtau/dt`` (Meta 2007 §II-B);
    referenced data: ``tau = 2 (R - R_ref,k) / c`` and ``f = K tau``.
    """
    radar = data.radar
    positions = data.positions[sweeps]
    if data.reference_range is not None:
        distance = np.linalg.norm(points[None, :, :] - positions[:, None, :], axis=-1)
        delay = 2.0 * (distance - data.reference_range[sweeps, None]) / SPEED_OF_LIGHT
        return delay, beat_frequency(delay, 0.0, radar.chirp_rate, radar.carrier_frequency)
    slant_range, _, delay_rate = doppler_geometry(points, positions, data.velocities[sweeps])
    delay = 2.0 * slant_range / SPEED_OF_LIGHT
    rate = delay_rate if data.settings.motion_correction else 0.0
    return delay, beat_frequency(delay, rate, radar.chirp_rate, radar.carrier_frequency)


def carrier_phase(data: PulseData, points: NDArray) -> NDArray:
    """Carrier phase ``2 pi f_c tau_k(x)`` wrapped to one turn [rad], shape (S, P)."""
    delay, _ = _delays(data, points)
    return 2 * np.pi * carrier_turns(delay, data.radar.carrier_frequency, np.floor)


def contributions(data: PulseData, points: NDArray, sweeps: NDArray | slice = slice(None)
                  ) -> NDArray:
    """De-rotated profile values ``c_k(x)`` of points x in sweeps k, shape (S, P), complex.

    Steps 1-3 of :mod:`mitsar.focus.backprojection`: the profile is read at the point's beat
    frequency with the focuser's ``range_interpolation``
    (:func:`mitsar.focus.interpolation.coefficients`; taps past a dechirped profile's ends
    extrapolated linearly, as :func:`mitsar.focus.interpolation.coefficient_table` does) and
    de-rotated by ``exp(-j 2 pi f_c tau)``. Positions off the profile axis give 0 (dechirped
    data) or wrap round (referenced data, periodic profile).
    ``sweeps`` (indices or a slice) limits the rows to those sweeps (default all).
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    delay, beat = _delays(data, points, sweeps)
    profile, frequency = data.profile, data.frequency
    bins = profile.shape[1]
    lower, fraction = profile_position(beat, frequency[0], frequency[1] - frequency[0],
                                       np.floor)
    lower = lower.astype(np.int64)
    inside = np.ones(lower.shape, dtype=bool)
    rows = np.arange(profile.shape[0])[sweeps][:, None]
    if data.reference_range is not None:
        taps = [profile[rows, (lower + offset) % bins] for offset in (-1, 0, 1, 2)]
    else:
        inside = (lower >= 0) & (lower < bins - 1)
        lower = np.clip(lower, 0, bins - 2)
        taps = [profile[rows, lower], profile[rows, lower + 1]]
        before = np.where(lower > 0, profile[rows, np.maximum(lower - 1, 0)],
                          2 * taps[0] - taps[1])
        after = np.where(lower < bins - 2, profile[rows, np.minimum(lower + 2, bins - 1)],
                         2 * taps[1] - taps[0])
        taps = [before, *taps, after]
    value = horner(coefficients(*taps, data.settings.range_interpolation), fraction, numpy_fma)
    phase = 2 * np.pi * carrier_turns(delay, data.radar.carrier_frequency, np.floor)
    real, imag = derotate(value.real, value.imag, np.sin(phase), np.cos(phase))
    return np.where(inside, real + 1j * imag, 0.0)


def aperture_weights(data: PulseData, points: NDArray, half_width: float | None = None,
                     window: str | None = None) -> NDArray:
    """Azimuth weight of every sweep for every point, shape (S, P) ("pixel" band selection).

    The window over ``|u - u_c| <= h`` of the direction sine u of the point along the velocity
    (:mod:`mitsar.focus.aperture`); referenced recordings: the window over all rows.

    Parameters
    ----------
    half_width : float, optional
        h; default the settings' (or the whole beam).
    window : str, optional
        Default the settings' window.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    coefficients = window_coefficients(window or data.settings.window)
    sweeps = len(data.positions)
    if data.reference_range is not None:
        weight = evaluate_window(coefficients, (np.arange(sweeps) + 0.5) / sweeps)
        return np.broadcast_to(weight[:, None], (sweeps, len(points))).copy()
    if half_width is None:
        half_width = data.settings.half_width
    if half_width is None:
        half_width = aperture_half_width(data.radar, None)
    _, sine, _ = doppler_geometry(points, data.positions, data.velocities)
    offset = sine - data.centroid[:, None]
    return np.where(np.abs(offset) <= half_width,
                    evaluate_window(coefficients, offset / (2 * half_width) + 0.5), 0.0)


def azimuth_directions(data: PulseData, points: NDArray, weight: NDArray) -> NDArray:
    """Unit azimuth direction of every point, shape (P, 3).

    The direction in which the sweeps' lines of sight turn as the platform moves: the weighted
    mean over sweeps of the velocity's component normal to the line of sight ``l_k(x)``,
    ``sum_k w_k (v_k - (v_k . l_k) l_k)``, for any track.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    sight = points[None, :, :] - data.positions[:, None, :]
    sight /= np.linalg.norm(sight, axis=-1, keepdims=True)
    velocity = data.velocities[:, None, :]
    normal = velocity - np.sum(velocity * sight, axis=-1, keepdims=True) * sight
    direction = np.einsum("sp,spi->pi", weight, normal)
    norm = np.linalg.norm(direction, axis=-1, keepdims=True)
    return direction / np.where(norm > 0, norm, 1.0)
