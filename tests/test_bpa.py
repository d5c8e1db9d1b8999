"""Back-projection: the Dr.Jit kernel against the NumPy reference, and geometry of the image."""

import math

import numpy as np
import pytest

import mitsar
from mitsar.focus.grid import PlaneGrid, PointsGrid, SlantGrid, equivalent_position

RADAR = mitsar.Radar()
TARGET = np.array([15.0, 8.0, 0.0])
START = np.array([14.8, 1.4, 4.5])
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))


@pytest.fixture(scope="module")
def raw():
    trajectory = mitsar.Trajectory.linear(START, [0.5, 0, 0], 0.8)
    return mitsar.simulate_point_targets(RADAR, trajectory, LOOK, [mitsar.PointTarget(TARGET)],
                                         normalized=True)


def _peak(image):
    magnitude = np.abs(image["image"].values)
    index = np.unravel_index(np.argmax(magnitude), magnitude.shape)
    return image["position"].values[index], magnitude[index]


def test_drjit_kernel_equals_numpy_reference(raw):
    """Same sum, two implementations: agree to 3e-5 of the peak.

    ``focus`` sums a grid by row segments (:mod:`mitsar.focus.bp_tiled`): float64 range and
    phase once per segment and sweep, each pixel's offset within its segment (up to 7 cm here)
    in float32, whose rounding leaves ~1e-5 rad of phase (docs/focusing.md, error budget);
    the reference is all float64. The exact kernel's 1e-6 of the peak (float64 range per
    pixel) is asserted in tests/test_bpa_fast.py.
    """
    grid = SlantGrid(along_track=[0.1, 0.3, 0.02], slant_range=[7.8, 8.2, 0.02])
    fast = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1, window="hamming")
    reference = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1, window="hamming",
                             backend="numpy")
    peak = np.abs(reference["image"].values).max()
    np.testing.assert_allclose(fast["image"].values, reference["image"].values,
                               atol=3e-5 * peak)


def test_kernel_per_pixel_sweep_ranges_match_the_numpy_sum_over_those_sweeps(raw):
    """Pixels with scattered sweep ranges (sorted and grouped into lanes by the kernel, the
    last lane padded, some ranges empty) against the float64 NumPy sum over each pixel's own
    sweeps, in the whole beam with a Hamming window and the Doppler term on.

    Tolerance 1e-5 of each pixel's magnitude of terms: the kernel sums float32 terms (relative
    error ~1e-7 each, ~1e-6 over a few hundred sweeps); a pixel mixed up with its lane
    neighbour or a sweep dropped would be off by a whole term (~1e-2 of the sum).
    """
    from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
    from mitsar.focus.compression import range_spectrum
    from mitsar.focus.windows import window_coefficients

    frequency, profile = range_spectrum(raw["raw"].values, RADAR, upsample=16)
    positions = raw["platform_position"].values
    velocities = raw["platform_velocity"].values
    centroid = raw["boresight"].values @ np.array([1.0, 0, 0])
    rng = np.random.default_rng(3)
    pixels = TARGET + rng.uniform(-0.2, 0.2, (23, 3)) * [1, 1, 0]
    sweeps = len(positions)
    first = rng.integers(0, sweeps, len(pixels))
    end = np.minimum(first + rng.integers(0, sweeps // 2, len(pixels)), sweeps)
    end[3] = first[3]  # an empty range
    window = window_coefficients("hamming")
    common = (0.5, window)
    values, totals = backproject_drjit(profile, frequency, RADAR, pixels, positions, velocities,
                                       centroid, *common, sweep_range=(first, end))
    for i in range(len(pixels)):
        k = slice(first[i], end[i])
        reference, total = backproject_numpy(profile[k], frequency, RADAR, pixels[i:i + 1],
                                             positions[k], velocities[k], centroid[k], *common)
        scale = max(float(total[0]), 1.0) * np.abs(profile[k]).max(initial=0.0)
        assert abs(values[i] - reference[0]) <= 1e-5 * scale
        assert totals[i] == pytest.approx(total[0], rel=1e-5, abs=1e-6)
    assert values[3] == 0 and totals[3] == 0


@pytest.mark.parametrize(("band_selection", "amplitude_tolerance"),
                         [("pixel", 0.02), ("doppler", 0.03)])
def test_point_target_focuses_at_its_position_with_unit_amplitude(raw, band_selection,
                                                                  amplitude_tolerance):
    """A unit echo focuses to ~1 at its position.

    Pixel windowing sums exactly the echo's own aperture (pattern ~0.99 over 0.9 deg): 2%.
    Doppler band-pass weights the echo's azimuth spectrum, whose Fresnel ripple (a chirp cut
    off by the 0.4 m track) moves the peak by about a percent more: 3%.
    """
    from mitsar.focus.bpa import focus_bpa

    grid = SlantGrid(along_track=[0.15, 0.25, 0.0025], slant_range=[7.93, 8.05, 0.0025])
    image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1)
    layout = grid.resolve(raw, RADAR, 0.1)
    values, coverage, extra = focus_bpa(
        raw, layout["position"].reshape(-1, 3), half_width=RADAR.wavelength / 0.4,
        window="rect", range_window="rect", remove_rvp=True, motion_correction=True,
        backend="drjit", range_upsample=16, pixel_chunk=1 << 20, band_selection=band_selection)
    assert extra["band_selection"] == band_selection
    image["image"].values = values.reshape(image["image"].shape)
    position, amplitude = _peak(image)
    # Within one grid step (2.5 mm) of the true position mapped onto the slant grid.
    assert np.linalg.norm(position - equivalent_position(image, TARGET)) < 2.5e-3 * math.sqrt(2)
    assert amplitude == pytest.approx(1.0, abs=amplitude_tolerance)
    assert coverage.max() == pytest.approx(1.0)
    assert image["image"].dims == ("azimuth", "range")
    assert image.attrs["azimuth_resolution"] == pytest.approx(0.1)


def test_ground_plane_grid_puts_the_target_at_its_world_position(raw):
    grid = PlaneGrid(origin=[15.0, 8.0, 0.0], axis_u=[1, 0, 0], axis_v=[0, 1, 0],
                     u=[-0.1, 0.1, 0.004], v=[-0.15, 0.15, 0.004])
    image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1)
    position, _ = _peak(image)
    assert np.linalg.norm(position - TARGET) < 0.004 * math.sqrt(2)
    # Ground-range resolution c / (2B sin(theta_inc)) and range axis along +y.
    cos_incidence = 4.5 / math.hypot(6.6, 4.5)
    ground = RADAR.range_resolution / math.sqrt(1 - cos_incidence**2)
    assert image.attrs["range_resolution"] == pytest.approx(ground, rel=1e-3)
    np.testing.assert_allclose(image.attrs["range_axis"], [1.0, 0.0], atol=1e-2)


def test_points_grid_and_motion_correction(raw):
    points = np.array([TARGET, TARGET + [1.05, 0.0, 0.0]])  # 10.5 azimuth cells away
    image = mitsar.focus(raw, grid=PointsGrid(points), azimuth_resolution=0.1)
    values = np.abs(image["image"].values[:, 0])
    # 3%: Doppler band-pass ripple (see the test above).
    assert values[0] == pytest.approx(1.0, abs=0.03) and values[1] < 0.05
    without = mitsar.focus(raw, grid=PointsGrid(points), azimuth_resolution=0.1,
                           motion_correction=False)
    # At broadside the Doppler shift is ~0 over the 10 cm aperture: little changes.
    assert abs(without["image"].values[0, 0]) == pytest.approx(values[0], abs=0.01)


def test_bad_focus_parameters_are_named(raw):
    with pytest.raises(mitsar.ParameterError, match="'algorithm'"):
        mitsar.focus(raw, algorithm="magic")
    with pytest.raises(mitsar.ParameterError, match="'window'"):
        mitsar.focus(raw, window="boxcar")
    with pytest.raises(mitsar.ParameterError, match="'slant_range'"):
        mitsar.focus(raw, grid=SlantGrid(slant_range=[9, 8, 0.1]))


def test_processed_band_wider_than_the_prf_is_refused():
    """At 2.5 m/s the whole beam (first nulls, 4 v / l_AZ = 500 Hz) exceeds the 250 Hz PRF and
    would alias into a ghost; a 10 cm band (v / rho = 25 Hz) fits."""
    trajectory = mitsar.Trajectory.linear(START, [2.5, 0, 0], 0.2)
    fast = mitsar.simulate_point_targets(RADAR, trajectory, LOOK, [mitsar.PointTarget(TARGET)],
                                         normalized=True)
    grid = SlantGrid(along_track=[0.0, 0.2, 0.05], slant_range=[7.9, 8.1, 0.05])
    with pytest.raises(mitsar.ParameterError, match="'azimuth_resolution'.*PRF"):
        mitsar.focus(fast, grid=grid)
    assert mitsar.focus(fast, grid=grid, azimuth_resolution=0.1)["image"].size == 25


def test_hovering_platform_is_refused(raw):
    hovering = raw.copy()
    hovering["platform_velocity"] = hovering["platform_velocity"] * 0.0
    with pytest.raises(mitsar.ParameterError, match="'platform_velocity'"):
        mitsar.focus(hovering, azimuth_resolution=0.1)


def test_foreign_inputs_get_mitsars_errors(raw):
    """What a fuzz campaign found raising TypeError or failing inside NumPy (issue 15)."""
    with pytest.raises(mitsar.ParameterError, match="raw"):
        mitsar.focus(np.zeros(3))
    with pytest.raises(mitsar.ParameterError, match="range_upsample"):
        mitsar.focus(raw, range_upsample=0)
    with pytest.raises(mitsar.ParameterError, match="off_nadir_deg"):
        mitsar.Look("x")
    with pytest.raises(mitsar.ParameterError, match="off_nadir_deg"):
        mitsar.Look(None)
    with pytest.raises(mitsar.ParameterError, match="points"):
        mitsar.Trajectory.waypoints([[0, 0, 1], [1, 0]], 0.5)
    with pytest.raises(mitsar.ParameterError, match="targets"):
        mitsar.simulate_point_targets(RADAR, mitsar.Trajectory.linear(START, [0.5, 0, 0], 0.1),
                                      LOOK, mitsar.PointTarget(TARGET))


def test_more_fuzz_findings_are_refused_by_name(raw, tmp_path):
    """NaN or 2-element targets, a zero grid axis, a seed that no product can record, and a
    Monte Carlo folder that is a file (issue 15)."""
    from mitsar.cli import main
    from mitsar.experiment.examples import example_path

    grid = SlantGrid(along_track=[0.1, 0.3, 0.02], slant_range=[7.8, 8.2, 0.02])
    image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1)
    for target in ((np.nan, np.nan, np.nan), (15.0, 8.0)):
        with pytest.raises(mitsar.ParameterError, match="target"):
            mitsar.measure_impulse_response(image, target)
    with pytest.raises(mitsar.ParameterError, match="axis_u"):
        mitsar.focus(raw, grid=PlaneGrid(origin=TARGET, axis_u=[0, 0, 0], axis_v=[0, 1, 0],
                                         u=[-0.1, 0.1, 0.05], v=[-0.1, 0.1, 0.05]))
    experiment = str(example_path("paper_point_target"))
    assert main(["simulate", experiment, "-o", str(tmp_path / "r.nc"), "-q",
                 "--seed", str(2**64)]) == 2
    blocker = tmp_path / "mc"
    blocker.write_text("")
    assert main(["montecarlo", experiment, "-n", "1", "-o", str(blocker), "-q"]) == 2
