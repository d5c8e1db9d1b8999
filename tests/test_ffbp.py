"""Fast factorised back-projection (FFBP) against exact back-projection and closed forms.

The reference is mitsar's exact BPA on the same grid (an independent path: one exact sum per
pixel and sweep); the error is ``20 log10(||ffbp - bpa|| / ||bpa||)`` over the whole image.
"""

import math

import numpy as np
import pytest

import mitsar
from mitsar.errors import MemoryBudgetError
from mitsar.focus import ffbp as ffbp_module
from mitsar.focus.ffbp import FFBP_DEFAULTS
from mitsar.focus.ffbp_stages import Stage, node_frames, polar_node
from mitsar.focus.grid import PlaneGrid, PointsGrid, SlantGrid

RADAR = mitsar.Radar()
TARGET = np.array([15.0, 8.0, 0.0])
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
SLANT = SlantGrid(along_track=[0.7, 1.3, 0.01], slant_range=[7.7, 8.3, 0.01])
# Rectangular spectrum: IRW = 0.8859 cells (Cumming & Wong 2005 §2.6; docs/design.md §5.7).
RECT_IRW_CELLS = 0.8859


def error_db(image, reference):
    return 20 * math.log10(np.linalg.norm(image - reference) / np.linalg.norm(reference))


@pytest.fixture(scope="module")
def straight():
    """1000 sweeps (4 s at 0.5 m/s) past a point 8 m away: 1.2 m of track per 0.1 m cell
    aperture with margin on both sides."""
    trajectory = mitsar.Trajectory.linear([14.0, 1.4, 4.5], [0.5, 0, 0], 4.0)
    return mitsar.simulate_point_targets(RADAR, trajectory, LOOK, [mitsar.PointTarget(TARGET)],
                                         normalized=True)


@pytest.fixture(scope="module")
def curved():
    """Two straight legs with a 20-degree turn right where the target is broadside."""
    turn = math.radians(20.0)
    points = [[13.6, 1.4, 4.5], [15.0, 1.4, 4.5], [16.3, 1.4 + 1.3 * math.tan(turn), 4.5]]
    trajectory = mitsar.Trajectory.waypoints(points, 0.5)
    return mitsar.simulate_point_targets(RADAR, trajectory, LOOK, [mitsar.PointTarget(TARGET)],
                                         normalized=True)


@pytest.fixture(scope="module")
def straight_bpa(straight):
    return mitsar.focus(straight, grid=SLANT, azimuth_resolution=0.1)["image"].values


def test_straight_track_matches_exact_bpa_at_the_defaults(straight, straight_bpa):
    """Doppler band selection, slant grid: measured -44 dB; -35 dB is the requirement."""
    image = mitsar.focus(straight, algorithm="ffbp", grid=SLANT, azimuth_resolution=0.1)
    assert error_db(image["image"].values, straight_bpa) < -35.0
    # The peak keeps the BPA normalisation: the Keys interpolation loses ~1 % over 3 stages.
    assert np.abs(image["image"].values).max() == pytest.approx(
        np.abs(straight_bpa).max(), rel=0.02)


def test_error_falls_with_angular_oversampling(straight, straight_bpa):
    """The angular interpolation dominates the error (docs/focusing.md § FFBP): halving the
    polar grids' angular step must gain at least 3 dB each time (measured 19 and 4 dB: the
    Keys kernel's error falls as the 3rd power of the step until the range sampling and the
    first-stage lookup take over)."""
    errors = [error_db(mitsar.focus(straight, algorithm="ffbp", grid=SLANT,
                                    azimuth_resolution=0.1,
                                    algorithm_options={"angle_oversample": q})["image"].values,
                       straight_bpa) for q in (2.0, 4.0, 8.0)]
    assert errors[1] < errors[0] - 3.0 and errors[2] < errors[1] - 3.0
    assert errors[2] < -45.0


@pytest.mark.parametrize(("options", "documented_db"), [
    ({"factor": 8}, -40.0),
    ({"final_subapertures": 2}, -39.0),
    ({"lookup_upsample": 8}, -39.0),
])
def test_error_at_other_factorisations_is_within_the_documented_bound(straight, straight_bpa,
                                                                      options, documented_db):
    """The error of docs/focusing.md § FFBP (table of error against the factorisation
    parameters) at three points other than the defaults, with a 3 dB margin: the measured
    values moved by up to 2 dB when the kernels changed (float32 sums, packed gathers)."""
    image = mitsar.focus(straight, algorithm="ffbp", grid=SLANT, azimuth_resolution=0.1,
                         algorithm_options=options)["image"].values
    assert error_db(image, straight_bpa) < documented_db + 3.0


def test_curved_track_matches_exact_bpa_on_a_ground_plane(curved):
    """A 20-degree turn: sub-apertures are not on one line, so the polar grids lie in the image
    plane (the ground) and every node is exact; whole beam, rect window (its edges sit on the
    pattern's nulls). Measured -40 dB; -35 dB required."""
    grid = PlaneGrid(origin=TARGET, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-0.3, 0.3, 0.01],
                     v=[-0.3, 0.3, 0.01])
    reference = mitsar.focus(curved, grid=grid)["image"].values
    image = mitsar.focus(curved, algorithm="ffbp", grid=grid)
    assert error_db(image["image"].values, reference) < -35.0


def test_point_response_has_the_rect_spectrum_irw_and_unit_amplitude(straight):
    """IRW within 3 % of 0.8859 cells in range and azimuth (measured 0.8858 and 0.8846), and a
    unit echo focuses to ~1 (3 %: the Doppler band-pass ripple of tests/test_bpa.py; exact
    BPA gives 0.973 on this grid, FFBP 0.972)."""
    grid = SlantGrid(along_track=[0.2, 1.8, 0.025], slant_range=[7.2, 8.8, 0.025])
    image = mitsar.focus(straight, algorithm="ffbp", grid=grid, azimuth_resolution=0.1)
    metrics = mitsar.measure_impulse_response(image, TARGET)
    assert metrics["range"]["irw_cells"] == pytest.approx(RECT_IRW_CELLS, rel=0.03)
    assert metrics["azimuth"]["irw_cells"] == pytest.approx(RECT_IRW_CELLS, rel=0.03)
    assert np.abs(image["image"].values).max() == pytest.approx(1.0, abs=0.03)


def test_points_grid_values_match_bpa(straight):
    """Any pixel set: the target and a point 10.5 cells away, as in tests/test_bpa.py."""
    points = PointsGrid(np.array([TARGET, TARGET + [1.05, 0.0, 0.0], TARGET + [0.0, 0.3, 0.0]]))
    reference = mitsar.focus(straight, grid=points, azimuth_resolution=0.1)["image"].values
    image = mitsar.focus(straight, algorithm="ffbp", grid=points,
                         azimuth_resolution=0.1)["image"].values
    # 2e-2 of the peak: -35 dB with margin, at three points rather than over an image.
    np.testing.assert_allclose(image, reference, atol=2e-2 * np.abs(reference).max())


def test_bad_options_are_named(straight):
    with pytest.raises(mitsar.ParameterError, match="algorithm_options"):
        mitsar.focus(straight, algorithm="ffbp", grid=SLANT, azimuth_resolution=0.1,
                     algorithm_options={"magic": 1})
    with pytest.raises(mitsar.ParameterError, match="factor"):
        mitsar.focus(straight, algorithm="ffbp", grid=SLANT, azimuth_resolution=0.1,
                     algorithm_options={"factor": 1})
    assert set(FFBP_DEFAULTS) >= {"factor", "first_subaperture", "angle_oversample",
                                  "range_oversample"}


def test_polar_nodes_lie_on_their_sphere_cone_and_the_image_plane():
    """The node formula (docs/focusing.md § FFBP; mitsar.focus.ffbp_stages.polar_node), which
    the kernels evaluate in Dr.Jit, against its own definition in NumPy: |x - c| = rho,
    a.(x - c) = rho alpha, (x - p0).n = 0, and x on the pixels' side of the track. Tilted
    plane and axis, so no term vanishes; 1e-9 m: float64 rounding of ~10 m coordinates with
    a few dozen operations."""
    rng = np.random.default_rng(3)
    centre = np.array([[0.0, -7.0, 4.5], [0.4, -7.1, 4.4]])
    axis = np.array([[1.0, 0.05, 0.02], [0.98, -0.2, 0.0]])
    axis /= np.linalg.norm(axis, axis=-1, keepdims=True)
    normal = np.array([0.05, -0.1, 1.0]) / np.linalg.norm([0.05, -0.1, 1.0])
    plane_point = np.array([0.1, 0.2, 0.0])
    stage = Stage(np.array([0, 8]), np.array([8, 16]), centre, axis, np.zeros(2), np.zeros(2),
                  0.1, 0.01, (1, 1))
    frame = node_frames(stage, normal, plane_point)
    rho = rng.uniform(8.0, 9.5, (2, 50))
    alpha = rng.uniform(-0.3, 0.3, (2, 50))
    x = np.stack(polar_node(rho, alpha, {k: v[:, None] for k, v in frame.items()}), axis=-1)
    offset = x - centre[:, None, :]
    np.testing.assert_allclose(np.linalg.norm(offset, axis=-1), rho, atol=1e-9)
    np.testing.assert_allclose(np.einsum("jpi,ji->jp", offset, axis), rho * alpha, atol=1e-9)
    np.testing.assert_allclose((x - plane_point) @ normal, 0.0, atol=1e-9)
    side = np.einsum("jpi,ji->jp", offset, np.cross(normal, axis))
    expected = np.sign(np.einsum("ji,ji->j", plane_point - centre, np.cross(normal, axis)))
    assert np.all(np.sign(side) == expected[:, None])


def test_merging_stops_where_the_polar_grids_cannot_hold_the_range_curvature(monkeypatch):
    """A point 2.8 m from a 2 m track: sub-apertures longer than the bound of
    ``_longest_subaperture`` (0.59 m here) add more range bandwidth than the polar grids
    sample. Asked to merge down to one sub-aperture, FFBP stops at the bound and stays as
    close to exact BPA as its default plan (1 dB: the same grids up to the last stage; measured
    -45.1 dB both); with the bound lifted it merges on and loses at least 6 dB (measured
    -23.9 dB)."""
    target = np.array([15.0, 3.4, 2.5])
    trajectory = mitsar.Trajectory.linear([14.0, 1.4, 4.5], [0.5, 0, 0], 4.0)
    raw = mitsar.simulate_point_targets(RADAR, trajectory, mitsar.Look(45.0),
                                        [mitsar.PointTarget(target)], normalized=True)
    axis = [-0.3, 0.3, 0.01]
    grid = PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=axis, v=axis)
    settings = {"grid": grid, "window": "hamming"}
    reference = mitsar.focus(raw, **settings)["image"].values

    def error(options):
        image = mitsar.focus(raw, algorithm="ffbp", algorithm_options=options, **settings)
        return error_db(image["image"].values, reference), image.attrs["ffbp_stages"]

    default, _ = error({})
    bounded, bounded_stages = error({"final_subapertures": 1})
    monkeypatch.setattr(ffbp_module, "_CURVATURE_SHARE", 1e6)
    unbounded, unbounded_stages = error({"final_subapertures": 1})
    assert bounded_stages < unbounded_stages
    assert bounded < default + 1.0
    assert unbounded > bounded + 6.0


def test_polar_grids_too_large_are_refused_before_any_kernel(straight, monkeypatch):
    """Absurd oversampling (found by hand, not by the fuzz campaign, which does not vary
    ``algorithm_options``) used to end in Dr.Jit's own RuntimeError (an array of 1e12
    entries); it is a ParameterError naming the options now, and a grid that fits Dr.Jit but
    not the memory budget is a MemoryBudgetError (docs/reliability.md)."""
    with pytest.raises(mitsar.ParameterError, match="from 1 to 1000"):
        mitsar.focus(straight, algorithm="ffbp", grid=SLANT,
                     algorithm_options={"angle_oversample": 1e9})
    with pytest.raises(mitsar.ParameterError, match="2\\^30 nodes"):
        mitsar.focus(straight, algorithm="ffbp", grid=SLANT,
                     algorithm_options={"angle_oversample": 1000, "first_angle_oversample": 1000})
    with pytest.raises(mitsar.ParameterError, match="final_subapertures"):  # a bool is no count
        mitsar.focus(straight, algorithm="ffbp", grid=SLANT,
                     algorithm_options={"final_subapertures": True})
    monkeypatch.setenv("MITSAR_MEMORY_LIMIT", "50M")
    mitsar.focus(straight, algorithm="ffbp", grid=SLANT, azimuth_resolution=0.1)
    with pytest.raises(MemoryBudgetError, match="oversampling"):
        mitsar.focus(straight, algorithm="ffbp", grid=SLANT, azimuth_resolution=0.1,
                     algorithm_options={"angle_oversample": 256.0})
