"""Platform trajectories: position, velocity and attitude as functions of time.

Three ways to make one: :meth:`Trajectory.linear` (constant velocity), :meth:`Trajectory.waypoints`
(straight legs at constant speed) and :meth:`Trajectory.navigation` (sampled navigation data,
cubic Hermite interpolation). All are evaluated vectorised on arrays of times [s].
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.budget import require_memory
from mitsar.checks import (
    MAGNITUDE_BOUNDS,
    MAX_DURATION,
    MAX_LENGTH,
    MAX_SPEED,
    bounded,
    finite,
    is_real,
    positive,
    vector,
)
from mitsar.errors import MitsarWarning, ParameterError
from mitsar.lazy import LazyModule
from mitsar.model.geometry.aperture import MEAN_TRACK_TIME, mean_track_velocity
from mitsar.model.geometry.flight import sample_flight

if TYPE_CHECKING:
    from scipy.interpolate import CubicHermiteSpline

interpolate = LazyModule("scipy.interpolate")
"""SciPy's splines, imported when a sampled track is made (reading a linear one needs none)."""

_VECTOR = "3 finite numbers [m or m/s]"
"""Expectation of the 3-vector arguments (start, velocity) in error messages."""

_WHERE = "Trajectory"

MAX_SAMPLE_RATE = 1.0e6
"""Largest ``sample_rate`` of :meth:`Trajectory.flight` [Hz]: a sample every microsecond, far
finer than any motion of a drone between two sweeps."""

FLIGHT_SAMPLE_BYTES = 256
"""Peak bytes per time sample of :func:`~mitsar.model.geometry.flight.sample_flight` (times,
arc, speed, positions, tangents, velocities and their temporaries, float64) and of the spline
built on them; and per path node (arc, speed, time, pieces)."""


def _array(name: str, value: ArrayLike, expected: str, where: str = _WHERE) -> NDArray:
    """``value`` as a float array, or a ParameterError naming ``name`` (not NumPy's own
    ValueError or TypeError for text, ragged lists or objects)."""
    try:
        return np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        raise ParameterError(where, name, expected, _shown(value)) from None


def _shown(value: object) -> object:
    """A refused value as shown in an error message: itself, or its repr cut to 120
    characters (a long array)."""
    text = repr(value)
    return value if len(text) <= 120 else text[:117] + "..."


def _speed_rows(velocities: NDArray[np.float64]) -> NDArray[np.float64]:
    """Speed of each row [m/s], +inf where an entry exceeds :data:`MAX_SPEED` (so that squares
    of 1e300 never overflow)."""
    velocities = np.atleast_2d(velocities)
    big = np.any(np.abs(velocities) > MAX_SPEED, axis=-1)
    speed = np.linalg.norm(np.where(big[:, None], 0.0, velocities), axis=-1)
    return np.where(big, np.inf, speed)


def _check_speeds(name: str, velocities: NDArray[np.float64], where: str = _WHERE) -> None:
    """Refuse velocities [m/s] whose speed exceeds :data:`MAX_SPEED`."""
    speed = _speed_rows(velocities)
    if not np.all(speed <= MAX_SPEED):
        worst = int(np.argmax(speed))
        found = (velocities.tolist() if velocities.ndim == 1 else
                 f"{np.atleast_2d(velocities)[worst].tolist()} at sample {worst}")
        raise ParameterError(where, name, f"speeds <= {MAX_SPEED:g} m/s (drone flights)",
                             found)


def _check_positions(name: str, positions: NDArray[np.float64], expected: str,
                     where: str = _WHERE) -> None:
    """Refuse positions [m] beyond :data:`~mitsar.checks.MAX_LENGTH` from the origin."""
    if not np.all(np.abs(positions) <= MAX_LENGTH):
        far = np.atleast_2d(positions)
        worst = int(np.argmax(np.abs(far).max(axis=-1)))
        found = (positions.tolist() if positions.ndim == 1 else
                 f"{far[worst].tolist()} at sample {worst}")
        raise ParameterError(where, name, f"{expected} within ±{MAX_LENGTH:g} m (indoor "
                             "scenes)", found)


def _check_time(name: str, value: object, minimum: float, where: str = _WHERE,
                expected: str | None = None) -> float:
    """A time [s] in [``minimum``, :data:`MAX_DURATION`] (> 0 when ``minimum`` is 0 and
    ``expected`` says so)."""
    expected = expected or f"a finite time >= {minimum:g} s and <= {MAX_DURATION:g} s"
    if not is_real(value) or not minimum <= float(value) <= MAX_DURATION:
        raise ParameterError(where, name, expected, _shown(value))
    return float(value)


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
        if values is None or values.shape != times.shape or not np.all(np.isfinite(values)) \
                or not np.all(np.abs(values) <= MAGNITUDE_BOUNDS["deg"]):
            raise ParameterError("Trajectory", "heading", f"one of {list(HEADINGS)} or "
                                 f"{len(times)} finite headings [deg] (one per knot)",
                                 heading if values is None else values.shape)
        return np.column_stack([np.radians(values), np.zeros((len(times), 2))])
    if heading not in HEADINGS:
        raise ParameterError("Trajectory", "heading", f"one of {list(HEADINGS)} or "
                             "an array of headings [deg]", heading)
    smoothing = _check_time("heading_smoothing", smoothing, 0.0)
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


def _check_flight(points: ArrayLike, speed: float | ArrayLike, turn_radius: object,
                  acceleration: object, hover: object, sample_rate: object) -> None:
    """Refuse the arguments of :meth:`Trajectory.flight` that are not numbers, are beyond the
    bounds of :mod:`mitsar.checks`, or would sample more than memory holds, before
    :func:`~mitsar.model.geometry.flight.sample_flight` allocates anything.

    The flight time is bounded above by the hover, the speed ramps (each at most
    |Δv|/acceleration) and the path flown at the slowest leg speed, so its samples
    (duration x ``sample_rate``) are budgeted before they are made."""
    where = "Trajectory.flight"
    points = _array("points", points, "at least 2 waypoints of 3 numbers [m]", where)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2 \
            or not np.all(np.isfinite(points)):
        raise ParameterError(where, "points", "at least 2 waypoints of 3 finite numbers [m]",
                             _shown(points.tolist()))
    _check_positions("points", points, "waypoints [m]", where)
    if isinstance(speed, bool | np.bool_):
        raise ParameterError(where, "speed", "a speed > 0 m/s or one per leg (a number, not a "
                             "bool)", speed)
    speeds = _array("speed", speed, "a speed > 0 m/s or one per leg", where)
    speeds = np.broadcast_to(speeds, (len(points) - 1,)) if speeds.ndim == 0 else speeds
    if speeds.shape != (len(points) - 1,) or not np.all((speeds > 0) & (speeds <= MAX_SPEED)):
        raise ParameterError(where, "speed", f"a speed > 0 m/s and <= {MAX_SPEED:g} m/s or "
                             f"one per leg ({len(points) - 1})", _shown(speeds.tolist()))
    radius = finite(where, "turn_radius", turn_radius, "a finite radius >= 0 m")
    if not 0 <= radius <= MAX_LENGTH:
        raise ParameterError(where, "turn_radius", f"a radius >= 0 m and <= {MAX_LENGTH:g} m",
                             radius)
    ramps = 0.0
    if acceleration is not None:
        limit = MAGNITUDE_BOUNDS["m/s^2"]
        accel = positive(where, "acceleration", acceleration, "None or a finite acceleration "
                         f"> 0 m/s^2 and <= {limit:g} m/s^2")
        if accel > limit:
            raise ParameterError(where, "acceleration", "None or a finite acceleration > 0 "
                                 f"m/s^2 and <= {limit:g} m/s^2", accel)
        ramps = float(speeds[0] + np.sum(np.abs(np.diff(speeds)))) / accel
    hover = _check_time("hover", hover, 0.0, where)
    rate = positive(where, "sample_rate", sample_rate, "a finite rate > 0 Hz and <= "
                    f"{MAX_SAMPLE_RATE:g} Hz")
    if rate > MAX_SAMPLE_RATE:
        raise ParameterError(where, "sample_rate", f"a finite rate > 0 Hz and <= "
                             f"{MAX_SAMPLE_RATE:g} Hz", rate)
    length = float(np.sum(np.linalg.norm(np.diff(points, axis=0), axis=1)))
    duration = hover + ramps + length / float(speeds.min())
    if not duration <= MAX_DURATION:
        name, value = max((hover, "hover", hover), (ramps, "acceleration", acceleration),
                          (duration - hover - ramps, "speed", speeds.tolist()))[1:]
        raise ParameterError(where, name, f"a flight of at most {MAX_DURATION:g} s (hover + "
                             "speed ramps + path / slowest speed)",
                             f"up to {duration:g} s with {name} = {_shown(value)}")
    nodes = max(1e4, length / 1e-3)  # sample_flight's path nodes: 1 mm or 1e-4 of the path
    require_memory(where, "sample_rate", FLIGHT_SAMPLE_BYTES * (duration * rate + nodes),
                   f"{duration:g} s at {rate:g} Hz and {nodes:.3g} path nodes: a lower "
                   "sample_rate, a shorter hover or fewer legs")


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
        _check_positions("start", start, "a start position [m]")
        _check_speeds("velocity", velocity)
        duration = positive("Trajectory", "duration", duration,
                            f"a finite time > 0 s and <= {MAX_DURATION:g} s")
        if duration > MAX_DURATION:
            raise ParameterError(_WHERE, "duration", f"a finite time > 0 s and <= "
                                 f"{MAX_DURATION:g} s", duration)
        end = start + velocity * duration
        if not np.all(np.abs(end) <= MAX_LENGTH):
            raise ParameterError(_WHERE, "duration", "a duration whose end position "
                                 f"start + velocity x duration lies within ±{MAX_LENGTH:g} m "
                                 "(indoor scenes)", f"{duration:g} s (ends at {end.tolist()})")
        if not np.linalg.norm(velocity) > 0:
            raise ParameterError("Trajectory", "velocity", "a non-zero velocity [m/s]",
                                 velocity.tolist())
        if is_vertical(velocity[None]):
            warnings.warn(VERTICAL_WARNING, MitsarWarning, stacklevel=2)
        times = np.array([0.0, float(duration)])
        positions = np.stack([start, end])
        return cls("linear", times, positions, np.stack([velocity, velocity]))

    @classmethod
    def waypoints(cls, points: ArrayLike, speed: float) -> Trajectory:
        """Straight legs between waypoints flown at constant ``speed`` [m/s]."""
        points = _array("points", points, "at least 2 waypoints of 3 numbers [m] (a list of "
                        "[x, y, z])")
        if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2:
            raise ParameterError("Trajectory", "points", "at least 2 waypoints of 3 numbers",
                                 _shown(points.tolist()))
        speed = positive("Trajectory", "speed", speed,
                         f"a finite speed > 0 m/s and <= {MAX_SPEED:g} m/s")
        if speed > MAX_SPEED:
            raise ParameterError(_WHERE, "speed", f"a finite speed > 0 m/s and <= "
                                 f"{MAX_SPEED:g} m/s", speed)
        if not np.all(np.isfinite(points)):
            raise ParameterError("Trajectory", "points", "finite coordinates [m]",
                                 _shown(points.tolist()))
        _check_positions("points", points, "waypoints [m]")
        legs = np.linalg.norm(np.diff(points, axis=0), axis=1)
        if np.any(legs <= 0):
            raise ParameterError("Trajectory", "points", "distinct consecutive waypoints",
                                 points.tolist())
        if is_vertical(np.diff(points, axis=0)):
            warnings.warn(VERTICAL_WARNING, MitsarWarning, stacklevel=2)
        times = np.concatenate([[0.0], np.cumsum(legs) / speed])
        if not times[-1] <= MAX_DURATION:
            raise ParameterError(_WHERE, "speed", f"a speed that flies the waypoints within "
                                 f"{MAX_DURATION:g} s ({float(np.sum(legs)):g} m of legs)",
                                 speed)
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
        times = _array("times", times, "an array of at least 2 strictly increasing times [s]")
        positions = _array("positions", positions, "an (n, 3) array of positions [m]")
        if times.ndim != 1 or len(times) < 2:
            raise ParameterError("Trajectory", "times", "at least 2 strictly increasing times",
                                 _shown(times.tolist()))
        if not np.all(np.isfinite(times)):
            bad = int(np.flatnonzero(~np.isfinite(times))[0])
            raise ParameterError(_WHERE, "times", "finite times [s] (no NaN or infinity)",
                                 f"{times[bad]} at sample {bad}")
        if np.any(np.diff(times) <= 0):
            bad = int(np.flatnonzero(np.diff(times) <= 0)[0])
            raise ParameterError("Trajectory", "times", "at least 2 strictly increasing times "
                                 "(sort the samples and drop repeated ones)",
                                 f"{times[bad]} then {times[bad + 1]} at samples {bad}, "
                                 f"{bad + 1}")
        if not times[-1] - times[0] <= MAX_DURATION:
            raise ParameterError(_WHERE, "times", f"samples spanning <= {MAX_DURATION:g} s",
                                 f"{times[0]:g} to {times[-1]:g} s")
        if positions.shape != (len(times), 3):
            raise ParameterError("Trajectory", "positions", f"shape ({len(times)}, 3)",
                                 positions.shape)
        if not np.all(np.isfinite(positions)):
            raise ParameterError("Trajectory", "positions", "finite positions [m]",
                                 "NaN or infinite values")
        _check_positions("positions", positions, "positions [m]")
        times = times - times[0]
        if velocities is None:
            velocities = interpolate.CubicSpline(times, positions, axis=0)(times, 1)
            if not np.all(_speed_rows(velocities) <= MAX_SPEED):
                raise ParameterError(_WHERE, "positions", "positions whose speed between "
                                     f"samples (spline estimate) stays <= {MAX_SPEED:g} m/s "
                                     "(check the times' unit: seconds)",
                                     f"{float(np.max(_speed_rows(velocities))):g} m/s")
        velocities = _array("velocities", velocities, f"finite values of shape "
                            f"{positions.shape} [m/s]")
        if velocities.shape != positions.shape or not np.all(np.isfinite(velocities)):
            raise ParameterError("Trajectory", "velocities",
                                 f"finite values of shape {positions.shape}", velocities.shape)
        _check_speeds("velocities", velocities)
        spline = interpolate.CubicHermiteSpline(times, positions, velocities, axis=0)
        attitude = None
        if attitude_deg is not None:
            if not (isinstance(heading, str) and heading == "mean"):
                raise ParameterError("Trajectory", "heading", "the default ('mean') when "
                                     "attitude_deg is given (the attitude holds the heading)",
                                     heading if isinstance(heading, str) else "an array")
            attitude = _array("attitude_deg", attitude_deg, f"finite values of shape "
                              f"{positions.shape} [deg]")
            if attitude.shape != positions.shape or not np.all(np.isfinite(attitude)):
                raise ParameterError("Trajectory", "attitude_deg",
                                     f"finite values of shape {positions.shape}", attitude.shape)
            bounded(_WHERE, "attitude_deg", attitude, "deg", "heading, pitch and roll [deg]")
            attitude = np.radians(attitude)
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
        _check_flight(points, speed, turn_radius, acceleration, hover, sample_rate)
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

    def _times(self, t: ArrayLike) -> NDArray[np.float64]:
        """``t`` as checked times [s] (numbers within the flight; NaN refused)."""
        t = _array("time", t, f"times [s] within [0, {self.duration:g}] (numbers)")
        self._check_times(t)
        return t

    def _check_times(self, t: NDArray) -> None:
        tolerance = 1e-9 * max(self.duration, 1.0)
        if not np.all(np.isfinite(t)):
            raise ParameterError("Trajectory", "time", f"finite times within "
                                 f"[0, {self.duration:g}] s", "NaN or infinite times")
        if np.any(t < -tolerance) or np.any(t > self.duration + tolerance):
            raise ParameterError("Trajectory", "time", f"times within [0, {self.duration:g}] s",
                                 f"[{t.min():g}, {t.max():g}]")

    def position(self, t: ArrayLike) -> NDArray[np.float64]:
        """Platform position at times ``t`` [s]; shape ``t.shape + (3,)`` [m]."""
        t = self._times(t)
        if self.kind == "linear":
            return self.positions[0] + t[..., None] * self.velocities[0]
        if self.kind == "waypoints":
            return np.stack([np.interp(t, self.times, self.positions[:, i]) for i in range(3)],
                            axis=-1)
        return self._spline(t)

    def velocity(self, t: ArrayLike) -> NDArray[np.float64]:
        """Platform velocity at times ``t`` [s]; shape ``t.shape + (3,)`` [m/s]."""
        t = self._times(t)
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
        t = self._times(t)
        if self.attitude is None:
            velocity = self.velocity(t)
            heading = np.arctan2(velocity[..., 1], velocity[..., 0])
            return np.stack([heading, np.zeros_like(heading), np.zeros_like(heading)], -1)
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
