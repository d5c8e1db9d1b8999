"""Trajectory refuses absurd values through the Python API as the experiment files do
(issue 27 item 1; bounds in mitsar.checks, docs/reliability.md §1)."""

from __future__ import annotations

import math

import numpy as np
import pytest

from mitsar import ParameterError, Trajectory
from mitsar.checks import MAX_DURATION, MAX_LENGTH, MAX_SPEED

KNOTS = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]]

REFUSED = {
    "linear start 1e300": (lambda: Trajectory.linear([1e300, 0, 1], [1, 0, 0], 2), "start"),
    "linear velocity 1e300": (lambda: Trajectory.linear([0, 0, 1], [1e300, 0, 0], 2),
                              "velocity"),
    "linear duration 1e300": (lambda: Trajectory.linear([0, 0, 1], [1, 0, 0], 1e300),
                              "duration"),
    "linear end beyond 10 km": (lambda: Trajectory.linear([0, 0, 1], [1, 0, 0], 2e4),
                                "duration"),
    "waypoints 1e300": (lambda: Trajectory.waypoints([[0, 0, 1], [1e300, 0, 1]], 1), "points"),
    "waypoints text": (lambda: Trajectory.waypoints("abc", 1), "points"),
    "waypoints speed 1e300": (lambda: Trajectory.waypoints(KNOTS[:2], 1e300), "speed"),
    "waypoints speed 1e-300": (lambda: Trajectory.waypoints(KNOTS[:2], 1e-300), "speed"),
    "navigation NaN time": (lambda: Trajectory.navigation([0, math.nan, 2], KNOTS), "times"),
    "navigation inf time": (lambda: Trajectory.navigation([0, 1, math.inf], KNOTS), "times"),
    "navigation 1e300 time": (lambda: Trajectory.navigation([0, 1, 1e300], KNOTS), "times"),
    "navigation unsorted": (lambda: Trajectory.navigation([0, 2, 1], KNOTS), "times"),
    "navigation repeated": (lambda: Trajectory.navigation([0, 1, 1], KNOTS), "times"),
    "navigation text times": (lambda: Trajectory.navigation("abc", KNOTS), "times"),
    "navigation ragged": (lambda: Trajectory.navigation([0, 1, 2], [[0, 0, 1], [1, 0], [2, 0, 1]]),
                          "positions"),
    "navigation 1e300 position": (lambda: Trajectory.navigation(
        [0, 1, 2], [[0, 0, 1], [1e300, 0, 1], [2, 0, 1]]), "positions"),
    "navigation 1e300 velocity": (lambda: Trajectory.navigation(
        [0, 1, 2], KNOTS, [[1e300, 0, 0]] * 3), "velocities"),
    "navigation samples a nanosecond apart": (lambda: Trajectory.navigation(
        [0, 1e-9, 2e-9], KNOTS), "positions"),
    "navigation 1e300 attitude": (lambda: Trajectory.navigation(
        [0, 1, 2], KNOTS, attitude_deg=[[1e300, 0, 0]] * 3), "attitude_deg"),
    "navigation heading_smoothing text": (lambda: Trajectory.navigation(
        [0, 1, 2], KNOTS, heading_smoothing="x"), "heading_smoothing"),
    "navigation heading_smoothing 1e300": (lambda: Trajectory.navigation(
        [0, 1, 2], KNOTS, heading_smoothing=1e300), "heading_smoothing"),
    "flight 1e300": (lambda: Trajectory.flight([[0, 0, 1], [1e300, 0, 1]], 0.5), "points"),
    "flight speed 1e300": (lambda: Trajectory.flight(KNOTS[:2], 1e300), "speed"),
    "flight sample_rate 1e300": (lambda: Trajectory.flight(KNOTS[:2], 0.5, sample_rate=1e300),
                                 "sample_rate"),
    "flight hover 1e300": (lambda: Trajectory.flight(KNOTS[:2], 0.5, acceleration=1,
                                                     hover=1e300), "hover"),
    "flight acceleration 1e-300": (lambda: Trajectory.flight(KNOTS[:2], 0.5,
                                                             acceleration=1e-300),
                                   "acceleration"),
    "flight turn_radius text": (lambda: Trajectory.flight(KNOTS, 0.5, turn_radius="x"),
                                "turn_radius"),
}


@pytest.mark.parametrize("case", sorted(REFUSED))
def test_absurd_trajectory_refused_by_name(case: str) -> None:
    call, name = REFUSED[case]
    with pytest.raises(ParameterError) as info:
        call()
    assert info.value.name == name
    assert "expected" in str(info.value)


@pytest.mark.parametrize("bad", [math.nan, [0.1, math.nan], math.inf, "x", None])
def test_evaluation_refuses_times_that_are_not_finite_numbers(bad: object) -> None:
    track = Trajectory.linear([0, 0, 1], [1, 0, 0], 2)
    for method in (track.position, track.velocity, track.attitude_at):
        with pytest.raises(ParameterError, match="'time'"):
            method(bad)


def test_bounds_are_inclusive_and_values_inside_them_fly() -> None:
    # a 1 km/s pass of 10 s from -5 km ends at +5 km: every bound met with equality or inside
    track = Trajectory.linear([-5e3, 0, 1], [MAX_SPEED, 0, 0], 10.0)
    assert np.allclose(track.position(10.0), [5e3, 0, 1])
    assert abs(track.position(10.0)[0]) <= MAX_LENGTH
    long = Trajectory.waypoints([[0, 0, 1], [1, 0, 1]], 1.0 / MAX_DURATION)
    assert long.duration == pytest.approx(MAX_DURATION)
    nav = Trajectory.navigation([10.0, 11.0, 12.0], KNOTS, attitude_deg=[[720.0, 0, 0]] * 3)
    assert nav.duration == 2.0
