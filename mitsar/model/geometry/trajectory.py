"""Platform trajectories: position, velocity and attitude as functions of time.

Three ways to make one: :meth:`Trajectory.linear` (constant velocity), :meth:`Trajectory.waypoints`
(straight legs at constant speed) and :meth:`Trajectory.navigation` (sampled navigation data,
cubic Hermite interpolation). All are evaluated vectorised on arrays of times [s].
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.interpolate import CubicHermiteSpline, CubicSpline

from mitsar.checks import positive, vector
from mitsar.errors import MitsarWarning, ParameterError
from mitsar.model.geometry.aperture import MEAN_TRACK_TIME, mean_track_velocity
from mitsar.model.geometry.flight import sample_flight

_VECTOR = "3 finite numbers [m or m/s]"
"""Expectation of the 3-vector arguments (start, velocity) in error messages."""


VERTICAL_WARNING = ("Trajectory: a vertical track or leg has no horizontal velocity, so its "
                    "heading is undefined and taken as 0 (the antenna frame faces +x); give the "
                    "attitude explicitly (kind = 'navigation' with attitude_deg) if that is not "
                    "meant")
"""Warning of :meth:`Trajectory.linear` and :meth:`Trajectory.waypoints` for vertical motion."""


def is_vertical(steps: NDArray[np.float64]) -> bool:
    """True if any non-zero row of ``steps`` (n, 3) (velocities or leg vectors) has no
    horizontal component (below 1e-6 of its length): the velocity-aligned heading is undefined
    there. Zero rows are left to the callers' own checks."""
    steps = np.asarray(steps, dtype=float)
    length = np.linalg.norm(steps, axis=1)
    return bool(np.any((length > 0) & ~(np.hypot(steps[:, 0], steps[:, 1]) > 1e-6 * length)))


HEADINGS = ("mean", "velocity")
"""Named headings of :meth:`Trajectory.navigation` for data without attitude."""


def _default_attitude(times: NDArray, spline: CubicHermiteSpline, heading: str | ArrayLike,
                      smoothing: float) -> NDArray[np.float64] | None:
    """Attitude [rad] at the knots of navigation data without attitude (None: velocity-aligned,
    evaluated wherever asked); see :meth:`Trajectory.navigation`."""
    if not isinstance(heading, str):
        try:
            values = np.asarray(heading, dtype=float)
        except (TypeError, ValueError):
            values = None
        if values is None or values.shape != times.shape or not np.all(np.isfinite(values)):
            raise ParameterError("Trajectory", "heading", f"one of {list(HEADINGS)} or "
                                 f"{len(times)} finite headings [deg] (one per knot)",
                                 heading if values is None else values.shape)
        return np.column_stack([np.radians(values), np.zeros((len(times), 2))])
    if heading not in HEADINGS:
        raise ParameterError("Trajectory", "heading", f"one of {list(HEADINGS)} or "
                             "an array of headings [deg]", heading)
    if not (np.isfinite(smoothing) and smoothing >= 0):
        raise ParameterError("Trajectory", "heading_smoothing", "a finite time >= 0 s",
                             smoothing)
    if heading == "velocity" or smoothing == 0:
        return None
    # the mean track on a uniform grid fine against T (21 samples per boxcar), read at the knots
    duration = float(times[-1])
    interval = min(smoothing / 21.0, duration)
    grid = np.linspace(0.0, duration, int(math.ceil(duration / interval)) + 1)
    mean = mean_track_velocity(spline(grid, 1), grid[1] - grid[0], smoothing)
    horizontal = np.hypot(mean[:, 0], mean[:, 1])
    moving = horizontal > 1e-6 * max(float(np.linalg.norm(mean, axis=1).max()), 1e-300)
    if not np.any(moving):  # a vertical or still track: no horizontal direction anywhere
        warnings.warn(VERTICAL_WARNING, MitsarWarning, stacklevel=3)
        return np.zeros((len(times), 3))
    angle = np.unwrap(np.arctan2(mean[moving, 1], mean[moving, 0]))
    # where the mean track has no horizontal motion, the heading is held from its neighbours
    held = np.interp(grid, grid[moving], angle)
    return np.column_stack([np.interp(times, grid, held), np.zeros((len(times), 2))])


@dataclass(frozen=True)
class Trajectory:
    """A platform path over ``[0, duration]`` seconds.

    Use the constructors :meth:`linear`, :meth:`waypoints` and :meth:`navigation`.

    Attributes
    ----------
    kind : {"linear", "waypoints", "navigation"}
    times : ndarray, shape (n,)
        Knot times [s], starting at 0.
    positions, velocities : ndarray, shape (n, 3)
        Knot positions [m] and velocities [m/s].
    attitude : ndarray, shape (n, 3) or None
        Heading, pitch, roll [rad] at the knots; ``None`` means velocity-aligned flight
        (heading along the horizontal velocity, zero pitch and roll): linear and waypoint
        tracks, and navigation data read with ``heading="velocity"``.
    """

    kind: Literal["linear", "waypoints", "navigation", "flight"]
    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    attitude: NDArray[np.float64] | None = None
    _spline: object = field(default=None, repr=False, compare=False)

    # --- constructors ---------------------------------------------------------------------
    @classmethod
    def linear(cls, start: ArrayLike, velocity: ArrayLike, duration: float) -> Trajectory:
        """Straight flight at constant velocity.

        Parameters
        ----------
        start : array_like, shape (3,)
            Position at t = 0 [m].
        velocity : array_like, shape (3,)
            Constant velocity [m/s].
        duration : float
            Flight time [s].

        Examples
        --------
        >>> Trajectory.linear([0, 0, 1], [0.5, 0, 0], 2.0).position(1.0)
        array([0.5, 0. , 1. ])
        """
        start, velocity = (vector("Trajectory", name, value, expected=_VECTOR)
                           for name, value in (("start", start), ("velocity", velocity)))
        duration = positive("Trajectory", "duration", duration, "a finite time > 0 s")
        if not np.linalg.norm(velocity) > 0:
            raise ParameterError("Trajectory", "velocity", "a non-zero velocity [m/s]",
                                 velocity.tolist())
        if is_vertical(velocity[None]):
            warnings.warn(VERTICAL_WARNING, MitsarWarning, stacklevel=2)
        times = np.array([0.0, float(duration)])
        positions = np.stack([start, start + velocity * duration])
        return cls("linear", times, positions, np.stack([velocity, velocity]))

    @classmethod
    def waypoints(cls, points: ArrayLike, speed: float) -> Trajectory:
        """Straight legs between waypoints flown at constant ``speed`` [m/s]."""
        try:
            points = np.asarray(points, dtype=float)
        except (TypeError, ValueError):
            raise ParameterError("Trajectory", "points", "at least 2 waypoints of 3 numbers "
                                 "[m] (a list of [x, y, z])", points) from None
        if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
            raise ParameterError("Trajectory", "points", "at least 2 waypoints of 3 numbers",
                                 points.tolist())
        speed = positive("Trajectory", "speed", speed, "a finite speed > 0 m/s")
        if not np.all(np.isfinite(points)):
            raise ParameterError("Trajectory", "points", "finite coordinates [m]",
                                 points.tolist())
        legs = np.linalg.norm(np.diff(points, axis=0), axis=1)
        if np.any(legs <= 0):
            raise ParameterError("Trajectory", "points", "distinct consecutive waypoints",
                                 points.tolist())
        if is_vertical(np.diff(points, axis=0)):
            warnings.warn(VERTICAL_WARNING, MitsarWarning, stacklevel=2)
        times = np.concatenate([[0.0], np.cumsum(legs) / speed])
        leg_velocity = np.diff(points, axis=0) / np.diff(times)[:, None]
        velocities = np.vstack([leg_velocity, leg_velocity[-1:]])
        return cls("waypoints", times, points, velocities)

    @classmethod
    def navigation(cls, times: ArrayLike, positions: ArrayLike,
                   velocities: ArrayLike | None = None,
                   attitude_deg: ArrayLike | None = None, *,
                   heading: str | ArrayLike = "mean",
                   heading_smoothing: float = MEAN_TRACK_TIME) -> Trajectory:
        """Sampled navigation data, interpolated by cubic Hermite splines.

        Parameters
        ----------
        times : array_like, shape (n,)
            Strictly increasing sample times [s]; shifted so the first is 0.
        positions : array_like, shape (n, 3)
            Positions [m].
        velocities : array_like, shape (n, 3), optional
            Velocities [m/s]; estimated by a cubic spline when omitted.
        attitude_deg : array_like, shape (n, 3), optional
            Heading, pitch, roll [deg]. When omitted, level flight with the heading chosen by
            ``heading``.
        heading : {"mean", "velocity"} or array_like, shape (n,)
            Heading of data without attitude (docs/navigation.md, "Heading without attitude
            data"). ``"mean"`` (default): along the horizontal **mean track**, the velocity
            averaged over three passes of a boxcar of ``heading_smoothing`` seconds
            (:func:`mitsar.model.geometry.aperture.mean_track_velocity`), as a multirotor
            holds its heading along its path while its position loop corrects a cross-track
            wander (a 3 cm, 0.8 s wander at 0.5 m/s swings the velocity by +-25 deg, this
            heading by 0.15 deg); evaluated at the knots and interpolated linearly between them.
            ``"velocity"``: along the instantaneous horizontal velocity (a fixed-wing platform,
            or mitsar before 2026-11). An array: the heading [deg] at every knot.
        heading_smoothing : float
            Boxcar length T [s] of the mean track (>= 0).

        Raises
        ------
        ParameterError
            Bad samples; an unknown ``heading``; a heading array together with
            ``attitude_deg``.
        """
        times = np.asarray(times, dtype=float)
        positions = np.asarray(positions, dtype=float)
        if times.ndim != 1 or len(times) < 2 or np.any(np.diff(times) <= 0):
            raise ParameterError("Trajectory", "times", "at least 2 strictly increasing times",
                                 times.tolist())
        if positions.shape != (len(times), 3):
            raise ParameterError("Trajectory", "positions", f"shape ({len(times)}, 3)",
                                 positions.shape)
        if not (np.all(np.isfinite(times)) and np.all(np.isfinite(positions))):
            raise ParameterError("Trajectory", "positions", "finite times and positions",
                                 "NaN or infinite values")
        times = times - times[0]
        if velocities is None:
            velocities = CubicSpline(times, positions, axis=0)(times, 1)
        velocities = np.asarray(velocities, dtype=float)
        if velocities.shape != positions.shape or not np.all(np.isfinite(velocities)):
            raise ParameterError("Trajectory", "velocities",
                                 f"finite values of shape {positions.shape}", velocities.shape)
        spline = CubicHermiteSpline(times, positions, velocities, axis=0)
        attitude = None
        if attitude_deg is not None:
            if not (isinstance(heading, str) and heading == "mean"):
                raise ParameterError("Trajectory", "heading", "the default ('mean') when "
                                     "attitude_deg is given (the attitude holds the heading)",
                                     heading if isinstance(heading, str) else "an array")
            attitude = np.radians(np.asarray(attitude_deg, dtype=float))
            if attitude.shape != positions.shape or not np.all(np.isfinite(attitude)):
                raise ParameterError("Trajectory", "attitude_deg",
                                     f"finite values of shape {positions.shape}", attitude.shape)
        else:
            attitude = _default_attitude(times, spline, heading, heading_smoothing)
        if attitude is not None:
            attitude[:, 0] = np.unwrap(attitude[:, 0])
        return cls("navigation", times, positions, velocities, attitude, spline)

    @classmethod
    def flight(cls, points: ArrayLike, speed: float | ArrayLike, *, turn_radius: float = 0.0,
               acceleration: float | None = None, hover: float = 0.0,
               sample_rate: float = 1000.0) -> Trajectory:
        """A drone flight: legs joined by circular turns, speed changes, an initial hover.

        The path and its timing are :func:`mitsar.model.geometry.flight.sample_flight`'s
        (module docstring there); the result is evaluated like navigation data (cubic Hermite
        on the samples, with their exact velocities), heading along the path, level flight.

        Parameters
        ----------
        points : array_like, shape (n, 3)
            Waypoints [m].
        speed : float or array_like, shape (n - 1,)
            Speed per leg [m/s].
        turn_radius : float
            Radius of the turns [m] (0: sharp corners).
        acceleration : float, optional
            Rate of speed changes [m/s^2]; required with ``hover``.
        hover : float
            Time at rest at the first waypoint [s].
        sample_rate : float
            Samples per second of the path [Hz].

        Examples
        --------
        A lawn-mower U-turn of radius 1 m at 0.5 m/s:

        >>> track = Trajectory.flight([[0, 0, 4], [3, 0, 4], [3, 2, 4], [0, 2, 4]], 0.5,
        ...                           turn_radius=1.0)
        """
        flown = sample_flight(points, speed, turn_radius=turn_radius,
                              acceleration=acceleration, hover=hover, sample_rate=sample_rate)
        attitude = np.zeros((len(flown.times), 3))
        attitude[:, 0] = np.degrees(flown.heading)
        made = cls.navigation(flown.times, flown.positions, flown.velocities, attitude)
        return cls("flight", made.times, made.positions, made.velocities, made.attitude,
                   made._spline)

    # --- evaluation -----------------------------------------------------------------------
    @property
    def duration(self) -> float:
        """Flight time [s]."""
        return float(self.times[-1])

    @property
    def is_straight(self) -> bool:
        """True for a straight track at constant velocity (what FFT focusing needs)."""
        if self.kind == "linear":
            return True
        spread = np.ptp(self.velocities, axis=0)
        speed = np.linalg.norm(self.velocities, axis=1).max()
        return bool(np.all(spread <= 1e-9 * max(speed, 1.0)))

    def _check_times(self, t: NDArray) -> None:
        tolerance = 1e-9 * max(self.duration, 1.0)
        if np.any(t < -tolerance) or np.any(t > self.duration + tolerance):
            raise ParameterError("Trajectory", "time", f"times within [0, {self.duration:g}] s",
                                 f"[{t.min():g}, {t.max():g}]")

    def position(self, t: ArrayLike) -> NDArray[np.float64]:
        """Platform position at times ``t`` [s]; shape ``t.shape + (3,)`` [m]."""
        t = np.asarray(t, dtype=float)
        self._check_times(t)
        if self.kind == "linear":
            return self.positions[0] + t[..., None] * self.velocities[0]
        if self.kind == "waypoints":
            return np.stack([np.interp(t, self.times, self.positions[:, i]) for i in range(3)],
                            axis=-1)
        return self._spline(t)

    def velocity(self, t: ArrayLike) -> NDArray[np.float64]:
        """Platform velocity at times ``t`` [s]; shape ``t.shape + (3,)`` [m/s]."""
        t = np.asarray(t, dtype=float)
        self._check_times(t)
        if self.kind == "linear":
            return np.broadcast_to(self.velocities[0], t.shape + (3,)).copy()
        if self.kind == "waypoints":
            leg = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0,
                          len(self.times) - 2)
            return self.velocities[leg]
        return self._spline(t, 1)

    def attitude_at(self, t: ArrayLike) -> NDArray[np.float64]:
        """Heading, pitch, roll [rad] at times ``t``; shape ``t.shape + (3,)``.

        Velocity-aligned unless attitude samples were given: heading = atan2(v_y, v_x),
        pitch = roll = 0.
        """
        t = np.asarray(t, dtype=float)
        if self.attitude is None:
            velocity = self.velocity(t)
            heading = np.arctan2(velocity[..., 1], velocity[..., 0])
            return np.stack([heading, np.zeros_like(heading), np.zeros_like(heading)], -1)
        self._check_times(t)
        return np.stack([np.interp(t, self.times, self.attitude[:, i]) for i in range(3)], -1)

    def max_speed(self) -> float:
        """Largest speed over the knots [m/s]."""
        return float(np.linalg.norm(self.velocities, axis=1).max())

    def describe(self) -> dict:
        """A JSON-serialisable description (for provenance attributes)."""
        out = {"kind": self.kind, "times": self.times.tolist(),
               "positions": self.positions.tolist(), "velocities": self.velocities.tolist()}
        if self.attitude is not None:
            out["attitude_deg"] = np.degrees(self.attitude).tolist()
        return out
