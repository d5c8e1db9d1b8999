"""Drone flight paths: straight legs joined by circular turns, with speed changes and hover.

:func:`sample_flight` turns waypoints into a sampled flight that :meth:`Trajectory.flight`
wraps as a navigation-type trajectory:

- **path**: the polyline through the waypoints with every interior corner replaced by the
  circular arc of radius ``turn_radius`` tangent to both legs (tangent length
  ``r tan(phi/2)`` for a turn by ``phi``); a U-turn is two 90-degree corners (a lawn-mower
  pattern). A radius of 0 keeps sharp corners (constant speed through them, as
  :meth:`Trajectory.waypoints`);
- **speed**: one speed per leg (a turn belongs to the leg it leads into); with an
  ``acceleration`` the platform changes speed at that constant rate from the start of the new
  leg, ``v^2 = v_0^2 + 2 a s`` along the path; without one, speeds change at once;
- **hover**: the flight may start with ``hover`` seconds at rest at the first waypoint, then
  accelerate (an ``acceleration`` is then required);
- **attitude**: heading along the path's tangent (defined while hovering too), level flight.

Times follow from ``t(s) = integral ds / v(s)`` on a fine arc-length grid (exact between grid
points for piecewise-constant acceleration), and the flight is
sampled uniformly in time; velocities are the tangent times the speed, exactly.
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.checks import positive
from mitsar.errors import ParameterError

__all__ = ["FlightSamples", "sample_flight"]

_WHERE = "Trajectory.flight"
_MAX_TURN_DEG = 179.0


@dataclass(frozen=True)
class FlightSamples:
    """A flight sampled uniformly in time: ``times`` (n,) [s], ``positions`` and
    ``velocities`` (n, 3) [m, m/s], ``heading`` (n,) [rad]."""

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    heading: NDArray[np.float64]


def _path(points: NDArray, radius: float) -> tuple[NDArray, NDArray, list, NDArray]:
    """Arc-length parametrisation of the rounded polyline.

    Returns ``(starts, kinds, data, leg_of)``: for each piece, its start arc length, kind
    (0 line, 1 arc), the geometry (line: start point and direction; arc: centre, radius vector
    at the start, the in-plane normal, the turn rate 1/r) and the leg whose speed it takes.
    """
    legs = np.diff(points, axis=0)
    lengths = np.linalg.norm(legs, axis=1)
    if np.any(lengths <= 0):
        raise ParameterError(_WHERE, "points", "distinct consecutive waypoints",
                             points.tolist())
    directions = legs / lengths[:, None]
    cut = np.zeros(len(points))  # tangent length removed at each waypoint
    turns = []
    for i in range(1, len(points) - 1):
        cosine = float(np.clip(directions[i - 1] @ directions[i], -1.0, 1.0))
        angle = math.acos(cosine)
        if math.degrees(angle) > _MAX_TURN_DEG:
            raise ParameterError(_WHERE, f"points[{i}]", f"a turn below {_MAX_TURN_DEG:g} deg "
                                 "(make a U-turn of two corners)", f"{math.degrees(angle):.4g} deg")
        cut[i] = radius * math.tan(angle / 2) if radius > 0 else 0.0
        turns.append(angle)
    straight = lengths - cut[:-1] - cut[1:]
    if np.any(straight < -1e-12):
        leg = int(np.argmin(straight))
        raise ParameterError(_WHERE, "turn_radius", f"a radius whose turns fit the legs (leg "
                             f"{leg} is {lengths[leg]:.4g} m long)", radius)
    pieces: list[tuple[float, int, tuple, int]] = []
    s = 0.0
    for i in range(len(legs)):
        start = points[i] + cut[i] * directions[i]
        pieces.append((s, 0, (start, directions[i]), i))
        s += max(straight[i], 0.0)
        if i < len(legs) - 1 and radius > 0 and turns[i] > 1e-12:
            d1, d2 = directions[i], directions[i + 1]
            normal = d2 - (d2 @ d1) * d1
            normal /= np.linalg.norm(normal)
            corner_start = points[i + 1] - cut[i + 1] * d1
            centre = corner_start + radius * normal
            pieces.append((s, 1, (centre, corner_start - centre, d1, 1.0 / radius), i + 1))
            s += radius * turns[i]
    return (np.array([p[0] for p in pieces] + [s]), np.array([p[1] for p in pieces]),
            [p[2] for p in pieces], np.array([p[3] for p in pieces]))


def _evaluate(s: NDArray, starts: NDArray, kinds: NDArray, data: list
              ) -> tuple[NDArray, NDArray]:
    """Position and unit tangent at arc lengths ``s`` (vectorised per piece)."""
    index = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(kinds) - 1)
    position = np.zeros(s.shape + (3,))
    tangent = np.zeros(s.shape + (3,))
    for piece in np.unique(index):
        chosen = index == piece
        local = s[chosen] - starts[piece]
        if kinds[piece] == 0:
            start, direction = data[piece]
            position[chosen] = start + local[:, None] * direction
            tangent[chosen] = direction
        else:
            centre, radial, direction, curvature = data[piece]
            angle = local * curvature
            # Rotate the radius vector in the plane of (radial, direction).
            position[chosen] = (centre + np.cos(angle)[:, None] * radial
                                + np.sin(angle)[:, None] * direction / curvature)
            tangent[chosen] = (-np.sin(angle)[:, None] * radial * curvature
                               + np.cos(angle)[:, None] * direction)
    return position, tangent


def sample_flight(points: ArrayLike, speed: float | ArrayLike, *, turn_radius: float = 0.0,
                  acceleration: float | None = None, hover: float = 0.0,
                  sample_rate: float = 1000.0) -> FlightSamples:
    """Sample a flight through ``points`` (see the module docstring).

    Parameters
    ----------
    points : array_like, shape (n, 3)
        Waypoints [m], n >= 2.
    speed : float or array_like, shape (n - 1,)
        Speed on each leg [m/s].
    turn_radius : float
        Radius of the turns at the interior waypoints [m] (0: sharp corners).
    acceleration : float, optional
        Rate of speed changes [m/s^2] (None: instantaneous).
    hover : float
        Time at rest at the first waypoint before accelerating [s].
    sample_rate : float
        Output samples per second [Hz].
    """
    points = np.asarray(points, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or len(points) < 2 \
            or not np.all(np.isfinite(points)):
        raise ParameterError(_WHERE, "points", "at least 2 waypoints of 3 finite numbers [m]",
                             points.tolist())
    speeds = np.broadcast_to(np.asarray(speed, dtype=float), (len(points) - 1,)).copy() \
        if np.ndim(speed) == 0 else np.asarray(speed, dtype=float)
    if speeds.shape != (len(points) - 1,) or not np.all(np.isfinite(speeds)) \
            or np.any(speeds <= 0):
        raise ParameterError(_WHERE, "speed", f"a speed > 0 m/s or one per leg "
                             f"({len(points) - 1})", np.asarray(speed).tolist())
    radius = float(turn_radius)
    if not (math.isfinite(radius) and radius >= 0):
        raise ParameterError(_WHERE, "turn_radius", "a finite radius >= 0 m", turn_radius)
    if acceleration is not None:
        acceleration = positive(_WHERE, "acceleration", acceleration,
                                "None or a finite acceleration > 0 m/s^2")
    hover = float(hover)
    if not (math.isfinite(hover) and hover >= 0):
        raise ParameterError(_WHERE, "hover", "a finite time >= 0 s", hover)
    if hover > 0 and acceleration is None:
        raise ParameterError(_WHERE, "acceleration", "an acceleration > 0 m/s^2 to start "
                             "from a hover", None)
    rate = positive(_WHERE, "sample_rate", sample_rate, "a finite rate > 0 Hz")

    starts, kinds, data, leg_of = _path(points, radius)
    total = float(starts[-1])
    # Speed along the path: per leg, ramped at the start of each leg from the previous speed.
    step = min(1e-3, total / 1e4)
    s = np.linspace(0.0, total, int(math.ceil(total / step)) + 1)
    piece = np.clip(np.searchsorted(starts, s, side="right") - 1, 0, len(kinds) - 1)
    leg = leg_of[piece]
    target = speeds[leg]
    if acceleration is None:
        v = target
    else:
        previous = np.concatenate([[0.0 if hover > 0 else speeds[0]], speeds[:-1]])[leg]
        leg_start = np.array([starts[np.flatnonzero(leg_of == i)[0]] for i in range(len(speeds))])
        if hover > 0 or len(speeds) > 1:
            travelled = s - leg_start[leg]
            ramp = np.sqrt(np.maximum(previous**2 + 2 * acceleration * travelled
                                      * np.sign(target - previous), 0.0))
            v = np.where(target >= previous, np.minimum(ramp, target), np.maximum(ramp, target))
        else:
            v = target
    # Time along the path: 2 ds / (v1 + v2) is exact for constant acceleration (and for constant
    # speed), so ramps, the start from rest included, integrate without error.
    dt = 2.0 * np.diff(s) / np.maximum(v[1:] + v[:-1], 1e-12)
    time_on_path = np.concatenate([[0.0], np.cumsum(dt)]) + hover
    duration = float(time_on_path[-1])
    times = np.linspace(0.0, duration, max(2, int(math.ceil(duration * rate)) + 1))
    # Between grid points the acceleration is constant: s and v at any time are exact there.
    moving = times >= hover
    interval = np.clip(np.searchsorted(time_on_path, times, side="right") - 1, 0, len(dt) - 1)
    tau = np.clip(times - time_on_path[interval], 0.0, dt[interval])
    accel = (v[interval + 1] ** 2 - v[interval] ** 2) / (2.0 * np.diff(s)[interval])
    arc = np.where(moving, s[interval] + v[interval] * tau + 0.5 * accel * tau**2, 0.0)
    speed_now = np.where(moving, v[interval] + accel * tau, 0.0)
    position, tangent = _evaluate(arc, starts, kinds, data)
    heading = np.unwrap(np.arctan2(tangent[:, 1], tangent[:, 0]))
    return FlightSamples(times=times, positions=position,
                         velocities=tangent * speed_now[:, None], heading=heading)
