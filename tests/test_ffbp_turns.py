"""FFBP at a chosen azimuth resolution on curved tracks and at a varying speed, against BPA.

There the processed band is cut per pixel and sweep on the pixel's aspect angle (BPA's
"pixel" band selection with aspect frames, docs/focusing.md "Curved tracks"); FFBP builds
unwindowed sub-aperture images and sums each pixel's band from whole sub-apertures of any
stage plus single sweeps at its two edges (mitsar.focus.ffbp_band.merge_band,
docs/focusing.md § FFBP). The reference is exact BPA on the same grid; the error is
``20 log10(||ffbp - bpa|| / ||bpa||)`` over the image, and the bound -35 dB is the issue's
(FFBP's bound on straight tracks). Measured: -46 to -50 dB, every case here.
"""

import math

import numpy as np
import pytest
from test_curved_tracks import _broadside_point  # tests/ is on sys.path (no __init__.py)

import mitsar
from mitsar.focus import ffbp as ffbp_module
from mitsar.focus.aperture import aspect_frames
from mitsar.focus.bp_setup import prepare
from mitsar.focus.bpa import curved_sweep_range
from mitsar.focus.grid import PlaneGrid, PointsGrid
from mitsar.quality.cuts import irw

RADAR = mitsar.Radar()
LOOK = mitsar.Look(55.7)
HEIGHT = 4.5
BOUND_DB = -35.0


def error_db(image, reference):
    return 20 * math.log10(np.linalg.norm(image - reference) / np.linalg.norm(reference))


def _broadside_raw(track: mitsar.Trajectory, time: float) -> tuple:
    """Raw data of a point seen broadside (left) at ``time``, and the point
    (tests/test_curved_tracks.py's set-up: same radar, look and height)."""
    raw, target, _ = _broadside_point(track, time)
    return raw, target


def _turn(side: int) -> tuple:
    """A 20-degree turn of radius 10 m (left +1: towards the look side; right -1), the point
    broadside at its middle (as tests/test_curved_tracks.py)."""
    radius, turn = 10.0, math.radians(20.0) * side
    points = [[12.0, 1.4, HEIGHT], [15.0, 1.4, HEIGHT],
              [15.0 + 3 * math.cos(turn), 1.4 + 3 * math.sin(turn), HEIGHT]]
    middle = 3 - radius * math.tan(abs(turn) / 2) + radius * abs(turn) / 2
    return _broadside_raw(mitsar.Trajectory.flight(points, 0.5, turn_radius=radius),
                          middle / 0.5)


def _plane(target: np.ndarray, extent: float = 0.6, step: float = 0.005) -> PlaneGrid:
    """A ground grid (121 x 121 at the defaults: aspect frames from the sub-grid)."""
    axis = [-extent / 2, extent / 2, step]
    return PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=axis, v=axis)


@pytest.fixture(scope="module")
def left_turn():
    return _turn(+1)


@pytest.fixture(scope="module")
def right_turn():
    return _turn(-1)


@pytest.fixture(scope="module")
def varying_speed():
    """A straight pass whose speed changes from 0.3 to 0.7 m/s at 0.5 m/s^2 while the point
    is in the beam (not uniform: "pixel" band selection, as on a turn)."""
    track = mitsar.Trajectory.flight([[13.0, 1.4, HEIGHT], [15.0, 1.4, HEIGHT],
                                      [17.0, 1.4, HEIGHT]], [0.3, 0.7], acceleration=0.5)
    target = np.array([15.0, 1.4 + HEIGHT * math.tan(math.radians(LOOK.off_nadir_deg)), 0.0])
    raw = mitsar.simulate_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(target)],
                                        normalized=True)
    return raw, target


def _both(raw, grid, **settings) -> tuple[np.ndarray, np.ndarray, dict]:
    exact = mitsar.focus(raw, grid=grid, **settings)["image"].values
    fast = mitsar.focus(raw, "ffbp", grid=grid, **settings)
    return fast["image"].values, exact, fast.attrs


@pytest.mark.parametrize("resolution", [0.05, 0.1])
@pytest.mark.parametrize("turn", ["left_turn", "right_turn"])
def test_turn_at_a_chosen_resolution_matches_exact_bpa(request, turn, resolution):
    """Rect window (the default): the band's hard cut is BPA's to the sweep (whole
    sub-apertures inside it, single sweeps with BPA's own window test at its edges), so
    only the interpolation error of the sub-aperture images is left. Measured -48 to -49 dB;
    the peak within 0.2 % of BPA's."""
    raw, target = request.getfixturevalue(turn)
    fast, exact, attrs = _both(raw, _plane(target), azimuth_resolution=resolution)
    assert attrs["band_selection"] == "pixel" and attrs["ffbp_final"] == "pixel band"
    assert error_db(fast, exact) < BOUND_DB
    assert np.abs(fast).max() == pytest.approx(np.abs(exact).max(), rel=0.01)


@pytest.mark.parametrize("resolution", [0.05, 0.1])
def test_varying_speed_at_a_chosen_resolution_matches_exact_bpa(varying_speed, resolution):
    """An accelerating straight pass: measured -50 dB at both resolutions."""
    raw, target = varying_speed
    fast, exact, _ = _both(raw, _plane(target), azimuth_resolution=resolution)
    assert error_db(fast, exact) < BOUND_DB


def test_tapered_window_on_a_turn_matches_exact_bpa(right_turn):
    """Hamming at 5 cm: a cosine-series window weights a whole sub-aperture's sweeps by
    reading its image at shifted direction cosines (one read per harmonic,
    ffbp_band._windowed_piece). Measured -46 dB (a constant weight per sub-aperture
    gave -15 dB)."""
    raw, target = right_turn
    fast, exact, _ = _both(raw, _plane(target), azimuth_resolution=0.05, window="hamming")
    assert error_db(fast, exact) < BOUND_DB


def test_scattered_points_on_a_turn_match_exact_bpa(left_turn):
    """A PointsGrid (the frames pixel by pixel, no sub-grid): an azimuth cut through the point
    at 2.5 mm, 5 cm resolution; and its IRW equal to BPA's within 1 %."""
    raw, target = left_turn
    offsets = np.arange(-0.15, 0.15 + 1e-9, 0.0025)
    grid = PointsGrid(target + offsets[:, None] * np.array([1.0, 0.0, 0.0]))
    fast, exact, _ = _both(raw, grid, azimuth_resolution=0.05)
    assert error_db(fast.ravel(), exact.ravel()) < BOUND_DB
    assert irw(fast.ravel(), spacing_cells=1.0) == pytest.approx(
        irw(exact.ravel(), spacing_cells=1.0), rel=0.01)


def test_whole_beam_on_a_turn_is_unchanged(left_turn):
    """No resolution: the sub-aperture images are windowed per sweep at their nodes and
    merged onto the pixels as before (docs/focusing.md § FFBP: -40 dB on the turn)."""
    raw, target = left_turn
    fast, exact, attrs = _both(raw, _plane(target))
    assert attrs["ffbp_final"] == "sub-apertures"
    assert error_db(fast, exact) < BOUND_DB


def test_sub_grid_frames_agree_with_the_exact_ones(left_turn):
    """The aspect frames interpolated from the sub-grid (ffbp._grid_band_setup) against BPA's
    pixel by pixel, on the left turn, where part of a 1 m patch never crosses the beam centre
    on the track (frames piecewise there: those cells are computed exactly): every frame
    within the tolerance and every exact sweep range inside the interpolated one."""
    raw, target = left_turn
    half_width = RADAR.wavelength / (4 * 0.05)
    bp = prepare(raw, half_width=half_width, window="rect", range_window="rect",
                 remove_rvp=True, range_upsample=1)
    axis = np.linspace(-0.5, 0.5, 96)
    grid = target + axis[:, None, None] * [1.0, 0, 0] + axis[None, :, None] * [0, 1.0, 0]
    (direction, centre), (first, end) = ffbp_module._grid_band_setup(bp, grid, half_width)
    pixels = grid.reshape(-1, 3)
    track = (bp.positions, bp.velocities, bp.centroid)
    exact_direction, exact_centre = aspect_frames(pixels, *track)
    exact_first, exact_end = curved_sweep_range(pixels, *track, half_width,
                                                (exact_direction, exact_centre))
    error = np.abs(direction - exact_direction).sum(axis=-1) + np.abs(centre - exact_centre)
    assert error.max() < 10 * ffbp_module._FRAME_TOLERANCE
    assert np.percentile(error, 99) < ffbp_module._FRAME_TOLERANCE
    assert np.all((first <= exact_first) & (end >= exact_end))
