"""Navigation errors: the processes against their definitions, the raw product's two tracks, and
the paired echoes of a sinusoidal track error against the Bessel closed form."""

import math

import numpy as np
import pytest
from scipy.special import jv

import mitsar
from mitsar.errors import ParameterError
from mitsar.experiment import experiment_from_dict, run_simulation
from mitsar.focus.autofocus import correct_raw
from mitsar.focus.bpa import focus_bpa
from mitsar.focus.grid import SlantGrid, equivalent_position
from mitsar.model.geometry.navigation import navigation_track
from mitsar.plots import navigation as plots_navigation
from mitsar.plots.figures import save_figure

RADAR = mitsar.Radar()
START = np.array([14.8, 1.4, 4.5])
TARGET = np.array([15.4, 8.0, 0.0])
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
TRACK = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], 2.4)


def test_gauss_markov_and_random_walk_have_their_stated_statistics():
    """Gauss-Markov: stationary std sigma (200 s / tau = 0.05 s: ~2000 independent samples,
    std of the std estimate ~1.6%: 5% is three of those). Random walk: 1-s increments of std q
    (1000 of them: 2.2%; 8% allowed)."""
    gm = mitsar.NavigationErrors(seed=1, position_noise=(1e-3, 0.0, 2e-3),
                                 position_correlation_time=0.05, sample_rate=1000.0).sample(200.0)
    assert gm["position"][:, 0].std() == pytest.approx(1e-3, rel=0.05)
    assert gm["position"][:, 2].std() == pytest.approx(2e-3, rel=0.05)
    assert np.all(gm["position"][:, 1] == 0.0)
    lag = int(0.05 * 1000)  # correlation exp(-1) at one correlation time
    x = gm["position"][:, 0]
    assert np.corrcoef(x[:-lag], x[lag:])[0, 1] == pytest.approx(math.exp(-1.0), abs=0.05)
    walk = mitsar.NavigationErrors(seed=2, position_random_walk=(0.0, 1e-3, 0.0),
                                   sample_rate=100.0).sample(1000.0)
    increments = np.diff(walk["position"][::100, 1])
    assert increments.std() == pytest.approx(1e-3, rel=0.08)
    assert walk["position"][0, 1] == 0.0


def test_vibration_offset_and_lever_arm_are_exact_on_the_navigation_track():
    """The navigation track is the true one plus the deterministic errors, to the Hermite
    interpolation error (1.5 mm at 12.5 Hz sampled at 200 Hz: ~1e-8 m; 1e-6 m allowed, far
    below lambda / 100 = 32 um)."""
    vibration = mitsar.Vibration((0.0, 1.5e-3, -0.5e-3), 12.5, 0.3)
    errors = mitsar.NavigationErrors(position_offset=(0.01, 0.0, 0.0), vibration=(vibration,),
                                     lever_arm=(0.0, 0.0, 0.05))
    nav = navigation_track(TRACK, errors)
    t = np.linspace(0.0, TRACK.duration, 97)
    expected = (TRACK.position(t) + [0.01, 0.0, 0.0] + vibration.at(t)
                - [0.0, 0.0, 0.05])  # level flight along +x: body z is world z
    np.testing.assert_allclose(nav.position(t), expected, atol=1e-6)
    np.testing.assert_allclose(nav.velocity(t), TRACK.velocity(t) + vibration.rate(t),
                               atol=1e-4)


def test_processes_are_reproducible_from_their_seed():
    errors = dict(position_random_walk=(1e-3, 1e-3, 0.0), attitude_noise_deg=(0.1, 0.1, 0.1))
    a = mitsar.NavigationErrors(seed=7, **errors).sample(1.0)
    b = mitsar.NavigationErrors(seed=7, **errors).sample(1.0)
    c = mitsar.NavigationErrors(seed=8, **errors).sample(1.0)
    np.testing.assert_array_equal(a["position"], b["position"])
    np.testing.assert_array_equal(a["attitude"], b["attitude"])
    assert np.abs(a["position"] - c["position"]).max() > 1e-5


def test_the_raw_product_records_the_navigation_track_and_keeps_the_true_one():
    """Echoes follow the true track: the samples do not depend on the navigation errors."""
    short = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], 0.2)
    target = [mitsar.PointTarget([14.85, 8.0, 0.0])]
    plain = mitsar.simulate_point_targets(RADAR, short, LOOK, target, normalized=True)
    errors = mitsar.NavigationErrors(seed=3, position_random_walk=(0.0, 2e-3, 0.0),
                                     attitude_offset_deg=(1.0, 0.0, 0.0))
    raw = mitsar.simulate_point_targets(RADAR, short, LOOK, target, normalized=True,
                                        navigation=errors)
    np.testing.assert_array_equal(raw["raw"].values, plain["raw"].values)
    np.testing.assert_allclose(raw["true_platform_position"].values,
                               plain["platform_position"].values, atol=1e-12)
    offset = raw["platform_position"].values - raw["true_platform_position"].values
    assert np.abs(offset[:, 1]).max() > 1e-4 and np.abs(offset[:, [0, 2]]).max() < 1e-9
    heading = raw["attitude"].values[:, 0] - raw["true_attitude"].values[:, 0]
    np.testing.assert_allclose(heading, math.radians(1.0), atol=1e-9)
    assert '"seed": 3' in raw.attrs["config"]


def _pixel_image(raw, grid):
    layout = grid.resolve(raw, RADAR, 0.1)
    values, _, _ = focus_bpa(raw, layout["position"].reshape(-1, 3), half_width=RADAR.wavelength
                             / (4 * 0.1), window="hamming", range_window="rect", remove_rvp=True,
                             motion_correction=True, backend="drjit", range_upsample=16,
                             pixel_chunk=1 << 20, band_selection="pixel")
    return np.abs(values.reshape(layout["position"].shape[:2]))


@pytest.mark.parametrize("beta", [0.5, 1.2])
def test_sinusoidal_track_error_gives_paired_echoes_at_the_bessel_ratio(beta):
    """Line-of-sight error a sin(2 pi x / p) on the true track, focused on the ideal navigation
    track: echoes at +-lambda R / (2 p) along track, at J1(beta)/J0(beta) of the main peak,
    beta = 4 pi a / lambda (Jacobi-Anger expansion of the phase error). The pattern is off so
    that the ghost's aperture sees the target as fully as the main one does (the closed form
    assumes it), and the azimuth window is Hamming so that the main lobe's sidelobes (-43 dB)
    do not add to the ghosts. Tolerance 3%: the hyperbolic range history and the 5 mm image
    sampling (peak loss < 0.3%)."""
    los = TARGET - (START + [TARGET[0] - START[0], 0.0, 0.0])
    slant = float(np.linalg.norm(los))
    period = 0.03  # [m] along track: ghosts 4.3 cells away
    amplitude = beta * RADAR.wavelength / (4 * math.pi)
    vibration = mitsar.Vibration(tuple(amplitude * los / slant), 0.5 / period)
    # The true track wobbles; navigation records the ideal line.
    true = navigation_track(TRACK, mitsar.NavigationErrors(vibration=(vibration,)))
    raw = mitsar.simulate_point_targets(RADAR, true, LOOK, [mitsar.PointTarget(TARGET)],
                                        normalized=True, pattern=False, navigation=TRACK)
    grid = SlantGrid(along_track=[0.05, 1.15, 0.005], slant_range=[slant - 0.02, slant + 0.02,
                                                                   0.005])
    image = _pixel_image(raw, grid)
    profile = image.max(axis=1)
    along = np.arange(len(profile)) * 0.005 + 0.05
    centre = TARGET[0] - START[0]
    shift = RADAR.wavelength * slant / (2 * period)

    def peak_near(x):
        near = np.abs(along - x) <= 0.03
        return profile[near].max()

    main = peak_near(centre)
    expected = jv(1, beta) / jv(0, beta)
    assert peak_near(centre + shift) / main == pytest.approx(expected, rel=0.03)
    assert peak_near(centre - shift) / main == pytest.approx(expected, rel=0.03)
    # The main peak keeps J0(beta) of the error-free one (same processing, ideal truth).
    ideal = mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                          normalized=True, pattern=False, navigation=TRACK)
    reference = _pixel_image(ideal, grid).max()
    assert main / reference == pytest.approx(jv(0, beta), rel=0.03)


def test_bad_navigation_inputs_are_named():
    with pytest.raises(ParameterError, match="navigation"):
        mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                      navigation="gps")
    with pytest.raises(ParameterError, match="position_random_walk"):
        mitsar.NavigationErrors(position_random_walk=(-1.0, 0.0, 0.0))
    with pytest.raises(ParameterError, match="sample_rate"):
        mitsar.NavigationErrors(sample_rate=0.0)
    with pytest.raises(ParameterError, match="vibration.frequency"):
        mitsar.Vibration((0.0, 1e-3, 0.0), -2.0)
    with pytest.raises(ParameterError, match="bogus"):
        mitsar.NavigationErrors.from_dict({"bogus": 1})
    short = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], 0.1)
    with pytest.raises(ParameterError, match="navigation"):
        mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                      navigation=short)


def test_traced_scenes_record_both_tracks_and_trace_the_true_one():
    """The ray tracer follows the true track too: its samples do not change with navigation
    errors, the histogram and raw products carry both tracks."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.2)
    look = mitsar.Look(55.71)
    errors = mitsar.NavigationErrors(seed=5, position_noise=(0.0, 1e-3, 1e-3))
    plain = mitsar.simulate_scene(RADAR, track, look, "point_target", normalized=True)
    raw = mitsar.simulate_scene(RADAR, track, look, "point_target", normalized=True,
                                navigation=errors)
    np.testing.assert_array_equal(raw["raw"].values, plain["raw"].values)
    np.testing.assert_allclose(raw["true_platform_position"].values,
                               plain["platform_position"].values, atol=1e-12)
    assert np.abs(raw["platform_position"].values
                  - raw["true_platform_position"].values).max() > 1e-4
    histogram = mitsar.trace(RADAR, track, look, "point_target", navigation=errors, sweeps=[3])
    back = mitsar.histogram_to_raw_product(histogram)
    np.testing.assert_allclose(back["platform_position"].values,
                               raw["platform_position"].values[[3]], atol=1e-12)
    np.testing.assert_allclose(back["true_platform_position"].values,
                               raw["true_platform_position"].values[[3]], atol=1e-12)


def test_experiments_take_navigation_errors_from_the_trajectory_table():
    document = {
        "trajectory": {"kind": "linear", "start": [14.8, 1.4, 4.5], "velocity": [0.5, 0, 0],
                       "duration": 0.1,
                       "errors": {"seed": 4, "position_random_walk": [0.0, 2e-3, 0.0],
                                  "vibration": [{"amplitude": [0, 1.5e-3, 0],
                                                 "frequency": 10.0}]}},
        "look": {"off_nadir_deg": 55.7},
        "targets": [{"position": [14.83, 8.0, 0.0]}],
        "simulation": {"normalized": True},
    }
    experiment = experiment_from_dict(document)
    assert experiment.navigation.seed == 4
    assert experiment.navigation.vibration[0].frequency == 10.0
    assert experiment.config["trajectory"]["errors"]["position_random_walk"] == [0.0, 2e-3, 0.0]
    raw = run_simulation(experiment)
    assert "true_platform_position" in raw.variables
    again = experiment_from_dict(experiment.config)  # the record runs again
    assert again.navigation == experiment.navigation
    document["trajectory"]["errors"]["bogus"] = 1
    with pytest.raises(ParameterError, match="trajectory.errors.bogus"):
        experiment_from_dict(document)
    document["trajectory"]["errors"].pop("bogus")
    document["trajectory"]["errors"]["vibration"][0]["frequency"] = -1.0
    with pytest.raises(ParameterError, match="trajectory.errors.vibration"):
        experiment_from_dict(document)


def test_navigation_phase_and_figures(tmp_path):
    """The injected phase at a point is 4 pi / lambda times the line-of-sight error: a 0.2 mm
    vibration along the line of sight gives 4 pi 0.2 mm / lambda = 0.788 rad of amplitude (to
    the second-order range change of the off-sight components, < 1e-3 rad)."""
    short = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], 0.4)
    point = np.array([14.9, 8.0, 0.0])
    sight = point - short.position(0.2)
    sight /= np.linalg.norm(sight)
    errors = mitsar.NavigationErrors(vibration=(mitsar.Vibration(tuple(2e-4 * sight), 5.0),))
    raw = mitsar.simulate_point_targets(RADAR, short, LOOK, [mitsar.PointTarget(point)],
                                        normalized=True, navigation=errors)
    phase = plots_navigation.navigation_phase(raw, point)
    assert np.abs(phase).max() == pytest.approx(4 * math.pi * 2e-4 / RADAR.wavelength,
                                                rel=2e-3)
    axes = plots_navigation.plot_tracks(raw)
    assert save_figure(axes[0].figure, tmp_path / "tracks.png").stat().st_size > 1000
    ax = plots_navigation.plot_phase(raw, point, {"estimate": -phase})
    assert save_figure(ax.figure, tmp_path / "phase.png").stat().st_size > 1000
    with pytest.raises(ParameterError, match="raw"):
        plots_navigation.navigation_phase(
            mitsar.simulate_point_targets(RADAR, short, LOOK, [mitsar.PointTarget(point)],
                                          normalized=True), point)


@pytest.mark.parametrize("method", ["pga", "entropy"])
def test_autofocus_removes_simulated_navigation_errors(method):
    """End to end: NavigationErrors of +-10 rad at the target (2 mm/sqrt(s) cross-track and
    1 mm/sqrt(s) vertical random walk, 1.5 mm vibration at 7 Hz) defocus the point; autofocus
    brings IRW within 5% and PSLR within 1 dB of the oracle (the same navigation track and band
    selection, the true phase removed), in range and azimuth."""
    track = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], 0.8)
    target = np.array([15.0, 8.0, 0.0])
    errors = mitsar.NavigationErrors(
        seed=11, position_random_walk=(0.0, 2e-3, 1e-3),
        vibration=(mitsar.Vibration((0.0, 1.5e-3, 0.0), 7.0, 0.5),))
    raw = mitsar.simulate_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(target)],
                                        normalized=True, navigation=errors)
    grid = SlantGrid(along_track=[-0.4, 0.8, 0.01], slant_range=[7.4, 8.6, 0.01])
    phase = plots_navigation.navigation_phase(raw, target)
    assert np.ptp(plots_navigation.detrend(phase)) > 6.0  # several radians

    def measured(image):
        return mitsar.measure_impulse_response(image, equivalent_position(image, target))

    oracle = measured(mitsar.focus(correct_raw(raw, phase), grid=grid, azimuth_resolution=0.1))
    blurred = measured(mitsar.focus(raw, grid=grid, azimuth_resolution=0.1))
    assert blurred["azimuth"]["pslr_db"] > -3.0 and blurred["peak_db"] < -6.0
    image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1, autofocus=method)
    fixed = measured(image)
    for direction in ("range", "azimuth"):
        assert fixed[direction]["irw_cells"] == pytest.approx(oracle[direction]["irw_cells"],
                                                              rel=0.05), direction
        assert fixed[direction]["pslr_db"] == pytest.approx(oracle[direction]["pslr_db"],
                                                            abs=1.0), direction
    residual = plots_navigation.detrend(image["autofocus_phase"].values - phase)
    assert np.sqrt(np.mean(residual**2)) < 0.05  # rad: < 0.1% of the peak
