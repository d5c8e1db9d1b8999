"""Frequency-domain focusing (RDA, WDA, FSA) against back-projection and closed forms.

Scenes: one unit point target (no antenna pattern, normalised amplitude) seen at ~3 m and
~25 m slant range, broadside and with the antenna squinted 15 deg backwards, by a platform
flying along +x long enough that every pixel of a +-0.6 m slant grid around the target has its
whole processed aperture (10 cm azimuth resolution, paper Table 1).

Closed forms (docs/design.md §5.7): rectangular spectrum IRW 0.886 cells, PSLR -13.26 dB,
ISLR -10.69 dB within +-5 cells.
"""

from __future__ import annotations

import functools
import math

import numpy as np
import pytest

import mitsar
from mitsar.errors import ParameterError
from mitsar.focus.grid import PlaneGrid, SlantGrid, equivalent_position
from mitsar.focus.motion import doppler_range_shift
from mitsar.focus.spectral import chirp_z, evaluate_dtft
from mitsar.model.geometry.attitude import boresight
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import apparent_beat_frequency
from mitsar.quality.impulse import measure_impulse_response

RADAR = mitsar.Radar()
RHO = 0.10
FD = ("rda", "wda", "fsa")
ALL = ("bpa",) + FD
GEOMETRIES = {  # name: (slant range [m], platform height above the target [m], squint [deg])
    "near": (3.0, 1.5, 0.0),
    "near-squint": (3.0, 1.5, 15.0),
    "far": (25.0, 4.5, 0.0),
    "far-squint": (25.0, 4.5, 15.0),
    "paper": (math.hypot(6.6, 4.5), 4.5, 0.0),
    "mid-squint": (8.0, 4.5, 15.0),
}


def _slope(u: float) -> float:
    return u / math.sqrt(1 - u * u)


@functools.cache
def scene(name: str, speed: float = 0.5, span: float = 0.6, step: float = 0.01):
    """Raw product, target and slant grid of a named geometry (cached)."""
    slant_range, height, squint = GEOMETRIES[name]
    look = mitsar.Look(math.degrees(math.acos(height / slant_range)), squint)
    sight = boresight(look, 0.0, 0.0, 0.0)
    target = np.zeros(3)
    centre = target - slant_range * sight  # platform when the target is on boresight
    u_c, h = sight[0], RADAR.wavelength / (4 * RHO)
    y0 = slant_range * math.sqrt(1 - u_c**2)
    ends = [-span - (y0 + s) * _slope(u_c + h) for s in (-span, span)] + \
           [span - (y0 + s) * _slope(u_c - h) for s in (-span, span)]
    start, stop = min(ends) - 0.05, max(ends) + 0.05
    trajectory = mitsar.Trajectory.linear([start, centre[1], centre[2]], [speed, 0, 0],
                                          (stop - start) / speed)
    raw = mitsar.simulate_point_targets(RADAR, trajectory, look, [mitsar.PointTarget(target)],
                                        normalized=True, pattern=False)
    origin = raw["platform_position"].values[0]
    a0, r0 = target[0] - origin[0], float(np.linalg.norm((target - origin)[1:]))
    grid = SlantGrid(along_track=[a0 - span, a0 + span, step],
                     slant_range=[r0 - span, r0 + span, step])
    return raw, target, grid


@functools.cache
def image_of(name: str, algorithm: str):
    raw, _, grid = scene(name)
    return mitsar.focus(raw, algorithm=algorithm, grid=grid, azimuth_resolution=RHO)


@functools.cache
def focused(name: str, algorithm: str):
    image = image_of(name, algorithm)
    return image, measure_impulse_response(image, equivalent_position(image, scene(name)[1]))


def _bpa_focused(name: str):
    """BPA image and metrics."""
    return focused(name, "bpa")


# --------------------------------------------------------------------------------------------
@pytest.mark.parametrize("name", ["near", "near-squint", "far", "far-squint"])
@pytest.mark.parametrize("algorithm", ALL)
def test_point_target_focuses_at_its_position(name, algorithm):
    if algorithm == "bpa":
        image, metrics = _bpa_focused(name)
    else:
        image, metrics = focused(name, algorithm)
    cell = RADAR.range_resolution
    assert metrics["peak_offset_m"] < 0.1 * cell
    assert 10 ** (metrics["peak_db"] / 20) == pytest.approx(1.0, abs=0.03)
    assert image["image"].dims == ("azimuth", "range")
    assert image.attrs["algorithm"] == algorithm
    assert "coverage" in image


@pytest.mark.parametrize("name", ["paper", "far"])
@pytest.mark.parametrize("algorithm", ALL)
def test_unweighted_range_metrics_are_the_rect_closed_form(name, algorithm):
    _, metrics = focused(name, algorithm)
    assert metrics["range"]["irw_cells"] == pytest.approx(0.886, abs=0.01)
    assert metrics["range"]["pslr_db"] == pytest.approx(-13.26, abs=0.2)
    assert metrics["range"]["islr_db"] == pytest.approx(-10.69, abs=0.3)


@pytest.mark.parametrize("name", ["far", "far-squint"])
@pytest.mark.parametrize("algorithm", FD)
def test_frequency_domain_algorithms_agree_with_bpa(name, algorithm):
    _, reference = _bpa_focused(name)
    _, metrics = focused(name, algorithm)
    for direction in ("range", "azimuth"):
        assert metrics[direction]["irw_cells"] == pytest.approx(
            reference[direction]["irw_cells"], abs=0.01), direction
        assert metrics[direction]["pslr_db"] == pytest.approx(
            reference[direction]["pslr_db"], abs=0.2), direction


@pytest.mark.parametrize("name", ["far", "near-squint"])
def test_frequency_domain_images_agree_pixel_for_pixel(name):
    """RDA, WDA and FSA evaluate the same matched filter: complex images within 1 %."""
    images = {a: focused(name, a)[0]["image"].values for a in FD}
    for algorithm in ("rda", "fsa"):
        difference = np.abs(images[algorithm] - images["wda"]).max()
        assert difference < 0.01 * np.abs(images["wda"]).max(), algorithm


def test_broadside_bpa_and_wda_images_agree_pixel_for_pixel():
    bpa = focused("far", "bpa")[0]["image"].values
    wda = focused("far", "wda")[0]["image"].values
    correlation = abs(np.vdot(bpa, wda)) / (np.linalg.norm(bpa) * np.linalg.norm(wda))
    assert correlation > 0.999
    assert np.abs(bpa - wda).max() < 0.03 * np.abs(wda).max()


@pytest.mark.parametrize("algorithm", ALL)
def test_motion_correction_off_shifts_the_target_by_the_doppler_range(algorithm):
    """Without H_cm the echo sits at the beat frequency K tau + f_c dtau/dt: the target moves
    along the line of sight by -c f_D / (2K) (farther here: the antenna looks back)."""
    raw, target, grid = scene("mid-squint")
    image = mitsar.focus(raw, algorithm=algorithm, grid=grid, azimuth_resolution=RHO,
                         motion_correction=False)
    metrics = measure_impulse_response(image, equivalent_position(image, target))
    centre = raw["platform_position"].values[raw.sizes["sweep"] // 2]
    sight = (target - centre) / np.linalg.norm(target - centre)
    velocity = raw["platform_velocity"].values[0]
    # Doppler of the target at the aperture centre, and its beat shift per signal.py.
    doppler = 2 * velocity @ sight / RADAR.wavelength
    delay, rate = 2 * 8.0 / SPEED_OF_LIGHT, -2 * velocity @ sight / SPEED_OF_LIGHT
    beat_shift = apparent_beat_frequency(delay, rate, RADAR) - RADAR.chirp_rate * delay
    shift = doppler_range_shift(RADAR, doppler)
    assert shift == pytest.approx(SPEED_OF_LIGHT * beat_shift / (2 * RADAR.chirp_rate),
                                  rel=1e-9)
    assert shift > 0.2 * RADAR.range_resolution
    expected = equivalent_position(image, target + shift * sight)
    measured = np.asarray(metrics["peak_position"])
    assert np.linalg.norm(measured - expected) < 0.03 * RADAR.range_resolution
    # With the correction the target is back in place.
    corrected = mitsar.focus(raw, algorithm=algorithm, grid=grid, azimuth_resolution=RHO)
    back = measure_impulse_response(corrected, equivalent_position(corrected, target))
    assert back["peak_offset_m"] < 0.02 * RADAR.range_resolution


def test_rvp_ablation_changes_little():
    """The residual video phase is <= 0.05 rad here: leaving it changes the image by < 2 %."""
    raw, target, grid = scene("paper")
    on = focused("paper", "wda")[0]["image"].values
    off = mitsar.focus(raw, algorithm="wda", grid=grid, azimuth_resolution=RHO,
                       remove_rvp=False)["image"].values
    assert 1e-5 < np.abs(on - off).max() < 0.02 * np.abs(on).max()


# --------------------------------------------------------------------------------------------
def test_fsa_aliasing_bound_is_checked_and_upsampling_fixes_it():
    raw, target, grid = scene("mid-squint")
    with pytest.raises(ParameterError, match="aliasing bound"):
        mitsar.focus(raw, algorithm="fsa", grid=grid, azimuth_resolution=RHO,
                     algorithm_options={"upsample": 1})
    aliased = mitsar.focus(raw, algorithm="fsa", grid=grid, azimuth_resolution=RHO,
                           algorithm_options={"upsample": 1, "check_aliasing": False})
    good = mitsar.focus(raw, algorithm="fsa", grid=grid, azimuth_resolution=RHO)
    assert good.attrs["fsa_upsample"] > 1
    wda = mitsar.focus(raw, algorithm="wda", grid=grid, azimuth_resolution=RHO)
    scale = np.abs(wda["image"].values).max()
    assert np.abs(good["image"].values - wda["image"].values).max() < 0.01 * scale
    assert np.abs(aliased["image"].values - wda["image"].values).max() > 0.3 * scale


def test_hamming_window_widens_as_expected():
    raw, target, grid = scene("far")
    for algorithm in FD:
        image = mitsar.focus(raw, algorithm=algorithm, grid=grid, azimuth_resolution=RHO,
                             window="hamming")
        metrics = measure_impulse_response(image, equivalent_position(image, target))
        assert metrics["range"]["irw_cells"] == pytest.approx(1.303, abs=0.02)
        assert metrics["azimuth"]["irw_cells"] == pytest.approx(1.303, abs=0.02)
        assert metrics["range"]["pslr_db"] < -38


# --------------------------------------------------------------------------------------------
def _curved_raw():
    """An arc of 50 m radius through the aperture (3.6 mm off a straight line at +-0.6 m)."""
    times = np.linspace(0.0, 3.2, 33)
    x = 14.2 + 0.5 * times
    positions = np.stack([x, 1.4 + (x - 15.0) ** 2 / 100.0, np.full_like(x, 4.5)], axis=1)
    velocities = np.stack([np.full_like(x, 0.5), (x - 15.0) / 100.0, 0 * x], axis=1)
    trajectory = mitsar.Trajectory.navigation(times, positions, velocities)
    return mitsar.simulate_point_targets(
        RADAR, trajectory, mitsar.Look(math.degrees(math.atan2(6.6, 4.5))),
        [mitsar.PointTarget([15.0, 8.0, 0.0])], normalized=True, pattern=False)


def _accelerating_raw():
    times = np.linspace(0.0, 2.2, 12)
    positions = np.stack([14.4 + 0.4 * times + 0.1 * times**2, np.full_like(times, 1.4),
                          np.full_like(times, 4.5)], axis=1)
    velocities = np.stack([0.4 + 0.2 * times, 0 * times, 0 * times], axis=1)
    trajectory = mitsar.Trajectory.navigation(times, positions, velocities)
    return mitsar.simulate_point_targets(
        RADAR, trajectory, mitsar.Look(math.degrees(math.atan2(6.6, 4.5))),
        [mitsar.PointTarget([15.0, 8.0, 0.0])], normalized=True, pattern=False)


@pytest.mark.parametrize("make", [_curved_raw, _accelerating_raw])
def test_curved_or_accelerating_tracks_are_refused_and_bpa_focuses_them(make):
    """Without motion compensation (``motion_compensation=False``) the frequency-domain
    algorithms refuse a curved or accelerating track and point to BPA, which focuses it."""
    raw = make()
    target = np.array([15.0, 8.0, 0.0])
    grid = PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-0.3, 0.3, 0.01],
                     v=[-0.4, 0.4, 0.01])
    slant = SlantGrid(along_track=[0.0, 0.5, 0.02], slant_range=[7.5, 8.5, 0.02])
    for algorithm in FD:
        with pytest.raises(ParameterError, match="bpa"):
            mitsar.focus(raw, algorithm=algorithm, grid=slant, azimuth_resolution=RHO,
                         motion_compensation=False)
        stripped = raw.copy()
        stripped.attrs.pop("trajectory_straight")  # the geometric check alone also refuses
        with pytest.raises(ParameterError, match="straight|constant|spacing"):
            mitsar.focus(stripped, algorithm=algorithm, grid=slant, azimuth_resolution=RHO,
                         motion_compensation=False)
    image = mitsar.focus(raw, grid=grid, azimuth_resolution=RHO)
    metrics = measure_impulse_response(image, target, islr_extent=2)
    assert metrics["peak_offset_m"] < 0.1 * RADAR.range_resolution


@pytest.mark.parametrize("make", [_curved_raw, _accelerating_raw])
@pytest.mark.parametrize("algorithm", FD)
def test_curved_or_accelerating_tracks_are_motion_compensated(make, algorithm):
    """By default the same tracks are compensated to the fitted line (4.3 mm off it for the
    arc; the accelerating one resampled along track): the target focuses where it is, with the
    rect closed form (0.886 cells, -13.26 dB; 0.02 cells and 0.3 dB as in test_mocomp.py)."""
    raw = make()
    target = np.array([15.0, 8.0, 0.0])
    origin = raw["platform_position"].values[0]
    slant = SlantGrid(along_track=[target[0] - origin[0] - 0.6, target[0] - origin[0] + 0.6,
                                   0.01], slant_range=[7.4, 8.6, 0.01])
    image = mitsar.focus(raw, algorithm=algorithm, grid=slant, azimuth_resolution=RHO)
    assert image.attrs["motion_compensation"] == 1
    metrics = measure_impulse_response(image, equivalent_position(image, target))
    assert metrics["peak_offset_m"] < 0.1 * RADAR.range_resolution
    for direction in ("range", "azimuth"):
        assert metrics[direction]["irw_cells"] == pytest.approx(0.886, abs=0.02), direction
        assert metrics[direction]["pslr_db"] == pytest.approx(-13.26, abs=0.3), direction


def test_plane_grids_are_refused_with_a_pointer_to_bpa():
    raw, target, _ = scene("far")
    grid = PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-0.1, 0.1, 0.05],
                     v=[-0.1, 0.1, 0.05])
    with pytest.raises(ParameterError, match="SlantGrid"):
        mitsar.focus(raw, algorithm="wda", grid=grid, azimuth_resolution=RHO)
    with pytest.raises(ParameterError, match="algorithm_options"):
        mitsar.focus(raw, algorithm="rda", grid=scene("far")[2], azimuth_resolution=RHO,
                     algorithm_options={"upsample": 2})


def test_chirp_z_equals_the_direct_dtft():
    rng = np.random.default_rng(1)
    x = rng.standard_normal((3, 37)) + 1j * rng.standard_normal((3, 37))
    start, step = np.array([0.1, -2.0, 1.0]), np.array([0.01, 0.3, -0.07])
    direct = np.einsum("rn,rjn->rj", x, np.exp(-1j * (start[:, None, None] + step[:, None, None]
                                                      * np.arange(11)[None, :, None])
                                                * np.arange(37)))
    np.testing.assert_allclose(chirp_z(x, start, step, 11), direct, atol=1e-10)
    points = np.array([0.0, 0.3, 0.35, 1.0])  # not evenly spaced: direct evaluation
    expected = x @ np.exp(-1j * 2.0 * (points[None, :] - 0.5) * np.arange(37)[:, None])
    np.testing.assert_allclose(evaluate_dtft(x, 2.0, points, 0.5), expected, atol=1e-10)
