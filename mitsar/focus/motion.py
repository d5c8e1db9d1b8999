"""Platform motion for frequency-domain focusing: straight-track check, Doppler centroid and the
continuous-motion correction of dechirped FMCW data.

Continuous motion (Meta et al. 2007, §II-B; docs/design.md §5.6)
--------------------------------------------------------------------
An FMCW radar keeps moving while it sweeps, so the sample at fast time ``t`` of the sweep whose
middle is at slow time ``eta`` sees the platform at ``eta + t``: ``s(t, eta) = g(t, eta + t)``
with ``g`` the stop-and-go signal. For a straight track at constant speed, the azimuth Fourier
transform turns the time shift into a phase, ``S(t, f_eta) = G(t, f_eta) exp(+j 2 pi f_eta t)``,
so the exact correction is

``H_cm(t, f_eta) = exp(-j 2 pi f_eta t)``                      (:func:`motion_correction_phase`)

applied after the azimuth FFT. Left uncorrected, the Doppler frequency moves the beat frequency
(``f = K tau + f_c dtau/dt``, :func:`mitsar.model.signal.apparent_beat_frequency`) and the target
appears displaced along the line of sight by ``-c f_D / (2K)`` (:func:`doppler_range_shift`).

Signs: our dechirped data carry ``exp(+j 2 pi f_c tau)``, so the azimuth frequency of the data is
``f_eta = f_c dtau/dt = -f_D`` with the physical Doppler ``f_D = 2 v u / lambda`` (``u`` the
direction sine of the target along the velocity: positive ahead, approaching).

The frequency-domain algorithms (RDA, WDA, FSA) need a straight track flown at constant velocity;
:func:`straight_track` checks that and refuses anything else with a
:class:`~mitsar.errors.ParameterError` that points to back-projection.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.products.raw import sweep_rate

POSITION_TOLERANCE_WAVELENGTHS = 1.0 / 16.0
"""Largest deviation of the antenna from the fitted straight, uniform track, in wavelengths
(a two-way phase error of pi/4)."""

VELOCITY_TOLERANCE = 1e-3
"""Largest relative deviation of any sweep's velocity from the mean velocity."""

CENTROID_TOLERANCE = 0.1
"""Largest spread of the Doppler-centroid direction sine, as a fraction of the processed
aperture half width."""


@dataclass(frozen=True)
class TrackGeometry:
    """A straight track flown at constant velocity, as the frequency-domain algorithms see it."""

    origin: NDArray[np.float64]
    """Antenna position of the first sweep (mid-sweep) [m], shape (3,); the slant grid's origin."""
    along: NDArray[np.float64]
    """Unit vector along the track (mean velocity), shape (3,)."""
    look: NDArray[np.float64]
    """Unit vector normal to the track toward the mean boresight (the slant grid's range
    direction), shape (3,)."""
    speed: float
    """Platform speed from the sweep positions [m/s]."""
    spacing: float
    """Along-track distance between sweeps [m] (``speed / PRF``)."""
    sweeps: int
    """Number of sweeps."""
    centroid_sine: float
    """Mean Doppler-centroid direction sine ``u_c = v_hat . l_hat`` (positive: looking ahead)."""


def _refuse(name: str, expected: str, found: object) -> ParameterError:
    return ParameterError(
        "focus", name, f"{expected} (RDA, WDA and FSA need a straight track flown at constant "
        "velocity; use algorithm='bpa', which focuses any trajectory)", found)


def straight_track(raw: xr.Dataset, radar: Radar,
                   half_width: float | None = None) -> TrackGeometry:
    """Check that a raw product was acquired on a straight track at constant velocity.

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product.
    radar : Radar
    half_width : float, optional
        Processed aperture half width in direction sine; when given, the Doppler centroid
        (boresight along the velocity) must not vary by more than
        ``CENTROID_TOLERANCE * half_width`` over the acquisition.

    Returns
    -------
    TrackGeometry

    Raises
    ------
    ParameterError
        If the product says the trajectory is not straight (``trajectory_straight = 0``), the
        antenna leaves the fitted straight, uniformly sampled line by more than
        ``lambda / 16``, the velocity varies by more than 0.1 %, the velocities disagree with
        the positions, or the Doppler centroid varies.
    """
    if int(raw.attrs.get("trajectory_straight", 1)) == 0:
        kind = raw.attrs.get("trajectory_kind", "?")
        raise _refuse("raw.trajectory_straight", "a straight, constant-velocity trajectory",
                      f"trajectory_straight=0 (trajectory kind {kind!r})")
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    velocities = np.asarray(raw["platform_velocity"].values, dtype=float)
    sweeps = len(positions)
    if sweeps < 8:
        raise _refuse("raw.sweep", "at least 8 sweeps", sweeps)
    mean_velocity = velocities.mean(axis=0)
    speed_mean = float(np.linalg.norm(mean_velocity))
    if not speed_mean > 0:
        raise _refuse("raw.platform_velocity", "a moving platform", mean_velocity.tolist())
    deviation = np.linalg.norm(velocities - mean_velocity, axis=1).max() / speed_mean
    if deviation > VELOCITY_TOLERANCE:
        raise _refuse("raw.platform_velocity",
                      f"a constant velocity (deviations <= {VELOCITY_TOLERANCE:g} of the speed)",
                      f"velocity varies by {deviation:.3g} of the speed (turns or "
                      "speed changes)")
    along = mean_velocity / speed_mean
    origin = positions[0]
    offset = positions - origin
    coordinate = offset @ along
    index = np.arange(sweeps)
    slope, intercept = np.polyfit(index, coordinate, 1)
    tolerance = POSITION_TOLERANCE_WAVELENGTHS * radar.wavelength
    along_error = np.abs(coordinate - (intercept + slope * index)).max()
    cross_error = np.linalg.norm(offset - coordinate[:, None] * along, axis=1).max()
    if cross_error > tolerance:
        raise _refuse("raw.platform_position", f"positions on a straight line (within "
                      f"lambda/16 = {tolerance * 1e3:.3g} mm)",
                      f"{cross_error * 1e3:.3g} mm off the line (a curved track)")
    if along_error > tolerance:
        raise _refuse("raw.platform_position", f"uniformly spaced sweeps (within lambda/16 = "
                      f"{tolerance * 1e3:.3g} mm)", f"spacing errors up to "
                      f"{along_error * 1e3:.3g} mm (a varying speed)")
    speed = float(slope * sweep_rate(raw, radar))
    if abs(speed - speed_mean) > VELOCITY_TOLERANCE * speed_mean:
        raise _refuse("raw.platform_velocity", f"velocities consistent with the sweep positions "
                      f"({speed:.6g} m/s at PRF {radar.prf:g} Hz)", f"{speed_mean:.6g} m/s")
    sines = centroid_sines(raw)
    if half_width is not None and np.ptp(sines) > CENTROID_TOLERANCE * half_width:
        raise _refuse("raw.boresight", f"a constant Doppler centroid (spread <= "
                      f"{CENTROID_TOLERANCE:g} of the aperture half width {half_width:.3g})",
                      f"direction-sine spread {np.ptp(sines):.3g} (attitude changes)")
    look = np.asarray(raw["boresight"].values, dtype=float).mean(axis=0)
    look = look - (look @ along) * along
    norm = np.linalg.norm(look)
    if not norm > 1e-9:
        raise _refuse("raw.boresight", "a boresight with a component normal to the track",
                      "a boresight along the track")
    return TrackGeometry(origin=origin, along=along, look=look / norm, speed=speed,
                         spacing=float(slope), sweeps=sweeps,
                         centroid_sine=float(np.mean(sines)))


def is_straight_track(raw: xr.Dataset, radar: Radar) -> tuple[bool, str]:
    """Whether :func:`straight_track` accepts a product, and why not."""
    try:
        straight_track(raw, radar)
    except ParameterError as error:
        return False, str(error)
    return True, ""


def centroid_sines(raw: xr.Dataset) -> NDArray[np.float64]:
    """Doppler-centroid direction sine per sweep, ``u_c = v_hat . l_hat`` (boresight ``l_hat``).

    The same quantity back-projection uses to centre its processed aperture.
    """
    velocities = np.asarray(raw["platform_velocity"].values, dtype=float)
    speed = np.linalg.norm(velocities, axis=-1)
    boresight = np.asarray(raw["boresight"].values, dtype=float)
    return np.einsum("si,si->s", boresight, velocities) / np.where(speed > 0, speed, 1.0)


def doppler_centroid(raw: xr.Dataset, radar: Radar) -> NDArray[np.float64]:
    """Physical Doppler centroid per sweep, ``f_Dc = 2 v u_c / lambda`` [Hz].

    Positive when the antenna looks ahead (approaching scatterers). The azimuth frequency of our
    dechirped data is ``-f_Dc`` (module docstring).
    """
    speed = np.linalg.norm(np.asarray(raw["platform_velocity"].values, dtype=float), axis=-1)
    return 2.0 * speed * centroid_sines(raw) / radar.wavelength


def motion_correction_phase(fast_time: ArrayLike, azimuth_frequency: ArrayLike) -> NDArray:
    """The exact continuous-motion correction ``H_cm = exp(-j 2 pi f_eta t)``.

    Parameters
    ----------
    fast_time : array_like
        Sweep-centred fast time t [s].
    azimuth_frequency : array_like
        Azimuth frequency of the data f_eta [Hz] (``-f_D``); broadcast against ``fast_time``.
    """
    return np.exp(-2j * np.pi * np.asarray(azimuth_frequency) * np.asarray(fast_time))


def doppler_range_shift(radar: Radar, doppler_frequency: ArrayLike) -> NDArray:
    """Apparent line-of-sight displacement of a target without motion correction [m].

    ``delta = -c f_D / (2K)``: from the beat frequency ``K tau + f_c dtau/dt = K tau - f_D``
    (:func:`mitsar.model.signal.apparent_beat_frequency`); an approaching target (``f_D > 0``)
    appears nearer. 9.8 mm (0.1 cell) at the edge of the paper's 9 deg beam at 0.5 m/s.
    """
    return -SPEED_OF_LIGHT * np.asarray(doppler_frequency) / (2.0 * radar.chirp_rate)
