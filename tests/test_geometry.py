"""Attitude, boresight (paper eq. 3 re-derived), antenna pattern and trajectories."""

import math

import numpy as np
import pytest

import mitsar
from mitsar.model.geometry.antenna import one_way_pattern, two_way_pattern
from mitsar.model.geometry.attitude import antenna_frame, body_to_world, boresight


@pytest.mark.parametrize("off_nadir", [0.0, 30.0, 57.0, 90.0])
def test_boresight_zero_squint_and_attitude_is_side_looking(off_nadir):
    theta = math.radians(off_nadir)
    expected = [0.0, math.sin(theta), -math.cos(theta)]
    np.testing.assert_allclose(boresight(mitsar.Look(off_nadir)), expected, atol=1e-15)


def test_positive_squint_looks_back_toward_minus_x():
    look = boresight(mitsar.Look(60.0, squint_deg=15.0))
    assert look[0] < 0 and look[1] > 0
    # The squint turns the horizontal component by 15 deg: x / y = -tan 15.
    assert look[0] / look[1] == pytest.approx(-math.tan(math.radians(15.0)))
    assert np.linalg.norm(look) == pytest.approx(1.0)


def test_heading_rotates_the_look_with_the_platform():
    # Flying along +y (heading 90 deg), the left side is -x.
    look = boresight(mitsar.Look(90.0), heading=math.pi / 2)
    np.testing.assert_allclose(look, [-1.0, 0.0, 0.0], atol=1e-15)


def test_pitch_nose_up_tilts_a_nadir_look_forward_and_roll_raises_the_left_side():
    nadir = boresight(mitsar.Look(0.0), pitch=math.radians(10))
    np.testing.assert_allclose(nadir, [math.sin(math.radians(10)), 0, -math.cos(math.radians(10))],
                               atol=1e-15)
    rolled = boresight(mitsar.Look(60.0), roll=math.radians(10))
    np.testing.assert_allclose(rolled, boresight(mitsar.Look(70.0)), atol=1e-15)


def test_rotations_are_orthonormal():
    rotation = body_to_world([0.3, -1.2], [0.1, 0.2], [-0.4, 0.5])
    np.testing.assert_allclose(rotation @ np.swapaxes(rotation, -1, -2), np.broadcast_to(
        np.eye(3), (2, 3, 3)), atol=1e-14)
    np.testing.assert_allclose(np.linalg.det(rotation), 1.0)


def test_antenna_frame_columns():
    frame = antenna_frame(mitsar.Look(55.0, 10.0), heading=0.4)
    np.testing.assert_allclose(frame.T @ frame, np.eye(3), atol=1e-14)
    np.testing.assert_allclose(frame[:, 2], boresight(mitsar.Look(55.0, 10.0), heading=0.4))


def test_pattern_values_and_first_null():
    beta = 0.16
    assert one_way_pattern(0.0, 0.0, beta, 2 * beta) == pytest.approx(1.0)
    assert one_way_pattern(beta / 2, 0.0, beta, 2 * beta) == pytest.approx((2 / math.pi) ** 2)
    assert one_way_pattern(beta, 0.0, beta, 2 * beta) == pytest.approx(0.0, abs=1e-30)


def test_pattern_solid_angle_matches_aperture_gain():
    """Directivity: the one-way pattern integrates to 4 pi / G (G = 4 pi A / lambda^2).

    Tolerance 2%: G = 4 pi A / lambda^2 is the large-aperture limit; the sinc^2 tails beyond
    the visible horizon are cut off, which for Table 1's 18 deg elevation beam (a 3-wavelength
    aperture) removes about 1.2% of the integral.
    """
    radar = mitsar.Radar()
    u = np.linspace(-0.999, 0.999, 4001)
    u_az, u_el = np.meshgrid(u, u, indexing="ij")
    inside = u_az**2 + u_el**2 < 1
    cos_b = np.sqrt(np.where(inside, 1 - u_az**2 - u_el**2, 1.0))
    pattern = np.where(inside, one_way_pattern(u_az, u_el, radar.azimuth_beamwidth,
                                               radar.elevation_beamwidth) / cos_b, 0.0)
    solid_angle = pattern.sum() * (u[1] - u[0]) ** 2
    assert solid_angle == pytest.approx(4 * math.pi / radar.antenna_gain, rel=0.02)


def test_two_way_pattern_is_square_of_one_way():
    frame = antenna_frame(mitsar.Look(60.0))
    direction = frame @ np.array([0.03, -0.05, 1.0])
    direction /= np.linalg.norm(direction)
    one = one_way_pattern(0.03 / np.linalg.norm([0.03, -0.05, 1]),
                          -0.05 / np.linalg.norm([0.03, -0.05, 1]), 0.16, 0.32)
    assert two_way_pattern(direction, frame, 0.16, 0.32) == pytest.approx(one**2)
    assert two_way_pattern(-frame[:, 2], frame, 0.16, 0.32) == 0.0  # behind the aperture


def test_linear_waypoint_and_navigation_trajectories_agree():
    start, velocity = np.array([1.0, 2.0, 3.0]), np.array([0.5, 0.1, 0.0])
    linear = mitsar.Trajectory.linear(start, velocity, 4.0)
    waypoints = mitsar.Trajectory.waypoints([start, start + 4 * velocity], speed=np.linalg.norm(
        velocity))
    times = np.linspace(0, 4, 9)
    navigation = mitsar.Trajectory.navigation(times, start + times[:, None] * velocity)
    t = np.array([0.0, 0.77, 2.5, 4.0])
    for other in (waypoints, navigation):
        np.testing.assert_allclose(other.position(t), linear.position(t), atol=1e-12)
        np.testing.assert_allclose(other.velocity(t), linear.velocity(t), atol=1e-9)
    assert linear.is_straight and waypoints.is_straight
    heading = linear.attitude_at(1.0)[0]
    assert heading == pytest.approx(math.atan2(0.1, 0.5))


def test_curved_navigation_is_not_straight_and_times_are_checked():
    times = np.linspace(0, 2, 21)
    positions = np.stack([np.cos(times), np.sin(times), np.zeros_like(times)], -1)
    trajectory = mitsar.Trajectory.navigation(times, positions)
    assert not trajectory.is_straight
    np.testing.assert_allclose(trajectory.velocity(1.0), [-math.sin(1), math.cos(1), 0], atol=1e-3)
    with pytest.raises(mitsar.ParameterError, match="'time'"):
        trajectory.position(2.5)


def test_bad_trajectory_inputs_name_the_parameter():
    with pytest.raises(mitsar.ParameterError, match="'velocity'"):
        mitsar.Trajectory.linear([0, 0, 0], [0, 0, 0], 1.0)
    with pytest.raises(mitsar.ParameterError, match="'start'"):
        mitsar.Trajectory.linear([0, 0], [1, 0, 0], 1.0)
    with pytest.raises(mitsar.ParameterError, match="'off_nadir_deg'"):
        mitsar.Look(-5.0)


# --- drone flights: turns, speed changes, hover (mitsar/model/geometry/flight.py) ----------------

def test_flight_turns_are_circular_arcs_flown_at_constant_speed():
    """A lawn-mower U-turn of radius 1 m: during the turn the antenna stays 1 m from the turn's
    centre, the speed is the commanded one, and the heading turns by 180 deg (1e-6: the
    Hermite interpolation of 1 kHz samples)."""
    track = mitsar.Trajectory.flight([[0, 0, 4], [3, 0, 4], [3, 2, 4], [0, 2, 4]], 0.5,
                                     turn_radius=1.0)
    assert track.duration == pytest.approx((4 + np.pi) / 0.5, rel=1e-6)
    t = np.linspace(0.0, track.duration, 501)
    np.testing.assert_allclose(np.linalg.norm(track.velocity(t), axis=1), 0.5, atol=1e-6)
    turning = (t > 2.0 / 0.5 + 1e-3) & (t < (2.0 + np.pi) / 0.5 - 1e-3)
    radius = np.linalg.norm(track.position(t[turning])[:, :2] - [2.0, 1.0], axis=1)
    np.testing.assert_allclose(radius, 1.0, atol=1e-6)
    heading = track.attitude_at(t)[:, 0]
    assert heading[-1] - heading[0] == pytest.approx(np.pi, abs=1e-6)
    assert not track.is_straight


def test_flight_hover_then_go_and_speed_changes_follow_the_acceleration():
    """From rest after 0.5 s of hover at 1 m/s^2: x = a (t - 0.5)^2 / 2 until 0.5 m/s; then a
    second leg at 0.3 m/s reached by decelerating at the same rate."""
    track = mitsar.Trajectory.flight([[0, 0, 4], [2, 0, 4], [4, 0, 4]], [0.5, 0.3],
                                     acceleration=1.0, hover=0.5)
    t = np.array([0.0, 0.3, 0.7, 0.9])
    x = track.position(t)[:, 0]
    np.testing.assert_allclose(x, [0.0, 0.0, 0.5 * 0.2**2, 0.5 * 0.4**2], atol=2e-4)
    late = track.duration - 0.5
    assert np.linalg.norm(track.velocity(late)) == pytest.approx(0.3, abs=1e-4)
    speeds = np.linalg.norm(track.velocity(np.linspace(0, track.duration, 2001)), axis=1)
    assert np.abs(np.diff(speeds)).max() <= 1.0 * track.duration / 2000 * 1.05


def test_flight_inputs_are_named():
    from mitsar.errors import ParameterError

    with pytest.raises(ParameterError, match="turn_radius"):
        mitsar.Trajectory.flight([[0, 0, 4], [1, 0, 4], [1, 1, 4]], 0.5, turn_radius=5.0)
    with pytest.raises(ParameterError, match="acceleration"):
        mitsar.Trajectory.flight([[0, 0, 4], [1, 0, 4]], 0.5, hover=1.0)
    with pytest.raises(ParameterError, match="points\\[1\\]"):
        mitsar.Trajectory.flight([[0, 0, 4], [1, 0, 4], [0, 0, 4]], 0.5)
    with pytest.raises(ParameterError, match="speed"):
        mitsar.Trajectory.flight([[0, 0, 4], [1, 0, 4], [2, 0, 4]], [0.5, 0.5, 0.5])
