"""Thermal noise in both simulators, its power through BPA, NESZ and SNR (docs/metrics.md
§Noise)."""

import math

import numpy as np
import pytest

import mitsar
from mitsar.focus.grid import PointsGrid, SlantGrid
from mitsar.model.noise import thermal_noise, window_noise_bandwidth
from mitsar.model.radar import BOLTZMANN, REFERENCE_TEMPERATURE, SPEED_OF_LIGHT
from mitsar.raw.analytic import stream_point_targets
from mitsar.raw.traced import simulate_scene

NOISE_FIGURE_DB = 10.0
RADAR = mitsar.Radar(noise_figure_db=NOISE_FIGURE_DB)
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
TARGET = np.array([15.0, 8.0, 0.0])  # on the boresight of LOOK from y = 1.4, z = 4.5
SPEED = 0.5


def _ktbf(radar):
    """k T0 F f_s, written out (complex sampling: noise bandwidth f_s; unit receiver gain)."""
    return (BOLTZMANN * REFERENCE_TEMPERATURE * 10 ** (NOISE_FIGURE_DB / 10)
            * radar.sampling_frequency)


def _check_noise_statistics(noise, radar):
    # 100 sweeps x 660 samples = 66 000 complex samples: the sample variance of circular
    # Gaussian noise has a relative standard deviation 1/sqrt(66 000) = 0.39 %, so 2 % is
    # 5 standard deviations; each quadrature alone (0.55 %) holds half the power within 3 %.
    assert noise.size >= 66_000
    power = _ktbf(radar)
    assert np.mean(np.abs(noise) ** 2) == pytest.approx(power, rel=0.02)
    assert np.var(noise.real) == pytest.approx(power / 2, rel=0.03)
    assert np.var(noise.imag) == pytest.approx(power / 2, rel=0.03)
    # Mean: standard error sqrt(P / N) = 0.39 % of sqrt(P); 2.5 % is 6 standard errors.
    assert abs(np.mean(noise)) < 0.025 * math.sqrt(power)


def test_analytic_noise_only_raw_data_has_ktbf_variance():
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [SPEED, 0, 0], 0.4)  # 100 sweeps
    target = [mitsar.PointTarget(TARGET)]
    clean = mitsar.simulate_point_targets(RADAR, track, LOOK, target, seed=4)
    noisy = mitsar.simulate_point_targets(RADAR, track, LOOK, target, seed=4, noise=True)
    # Same seed and no background: the echoes are identical, the difference is the noise.
    _check_noise_statistics(noisy["raw"].values - clean["raw"].values, RADAR)
    assert noisy.attrs["noise"] == 1 and noisy.attrs["noise_seed"] == 4
    assert noisy.attrs["noise_power"] == pytest.approx(_ktbf(RADAR), rel=1e-12)


def test_traced_noise_only_raw_data_has_ktbf_variance_and_follows_the_seed():
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [SPEED, 0, 0], 0.4)  # 100 sweeps
    clean = simulate_scene(RADAR, track, LOOK, "point_target", seed=2)
    noisy = simulate_scene(RADAR, track, LOOK, "point_target", seed=2, noise=True)
    noise = noisy["raw"].values - clean["raw"].values
    _check_noise_statistics(noise, RADAR)
    assert noisy.attrs["noise"] == 1 and noisy.attrs["noise_seed"] == 2
    # One noise draw per acquisition: a subset of sweeps gets the same noise as the full run.
    part = simulate_scene(RADAR, track, LOOK, "point_target", seed=2, noise=True,
                          sweeps=slice(40, 60))
    # The echoes of a piece equal the whole's to ~1e-5 only (the block kernel starts its
    # visibility blocks at the piece's first sweep, docs/integrator.md §"Performance"): take
    # the piece's own clean echoes.
    clean_part = simulate_scene(RADAR, track, LOOK, "point_target", seed=2, sweeps=slice(40, 60))
    np.testing.assert_allclose(part["raw"].values - clean_part["raw"].values, noise[40:60],
                               atol=1e-6 * math.sqrt(_ktbf(RADAR)))
    other = simulate_scene(RADAR, track, LOOK, "point_target", seed=3, noise=True)
    assert not np.allclose(other["raw"].values - clean["raw"].values, noise)
    with pytest.raises(mitsar.ParameterError, match="'noise'"):
        simulate_scene(mitsar.Radar(), track, LOOK, "point_target", noise=True)


def test_window_noise_bandwidth_of_named_windows():
    # Closed forms: <w^2>/<w>^2 = 1 (rect), 1 + 0.46^2 / (2 0.54^2) (Hamming), 1.5 (Hann).
    assert window_noise_bandwidth([1.0]) == 1.0
    assert window_noise_bandwidth([0.54, 0.46]) == pytest.approx(1 + 0.46**2 / (2 * 0.54**2))
    assert window_noise_bandwidth([0.5, 0.5]) == pytest.approx(1.5)


@pytest.fixture(scope="module")
def noise_only():
    """A noise-only raw product: the geometry of a 2 s pass, samples replaced by noise."""
    track = mitsar.Trajectory.linear([13.8, 1.4, 4.5], [SPEED, 0, 0], 4.0)
    raw = mitsar.simulate_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(TARGET)])
    raw["raw"].values[:] = thermal_noise(RADAR, 1, np.arange(raw.sizes["sweep"]))
    return raw


@pytest.mark.parametrize("window", ["rect", "hamming"])
def test_noise_power_through_bpa_matches_the_closed_form(noise_only, window):
    resolution = 0.03
    image = mitsar.focus(noise_only, grid=SlantGrid(along_track=[0.3, 1.7, resolution],
                                                   slant_range=[5.0, 12.0, 0.1]),
                         window=window, azimuth_resolution=resolution)
    full = image["coverage"].values > 0.999
    measured = np.abs(image["image"].values[full]) ** 2
    predicted = image["noise_power"].values[full]
    # ~3 300 pixels spaced about one resolution cell apart in both directions, i.e. about as
    # many independent exponential samples: the mean has a relative standard error of ~1.7 %
    # (somewhat more with the Hamming window's wider response); 8 % is > 4 of them.
    assert full.sum() > 3000
    assert np.mean(measured) / np.mean(predicted) == pytest.approx(1.0, abs=0.08)


def _textbook_nesz(slant_range, sin_incidence, half_width):
    """NESZ = (4 pi)^3 R^3 4 v B sin(theta) k T0 F / (P_T G^2 lambda^3 c) on the beam centre of
    an unsquinted strip map with duty cycle 1 (eq. N2 of mitsar.model.noise with the radar
    equation, N_s = f_s / PRF, M = 2 h R PRF / v and rho_a = lambda / 4h written out); the
    processed band h does not enter."""
    del half_width
    r = RADAR
    return ((4 * math.pi) ** 3 * slant_range**3 * 4 * SPEED * r.bandwidth * sin_incidence
            * BOLTZMANN * REFERENCE_TEMPERATURE * 10 ** (NOISE_FIGURE_DB / 10)
            / (r.transmit_power * r.antenna_gain**2 * r.wavelength**3 * SPEED_OF_LIGHT))


def test_nesz_and_snr_on_the_beam_centre_match_the_textbook_forms():
    track = mitsar.Trajectory.linear([14.3, 1.4, 4.5], [SPEED, 0, 0], 2.0)
    raw = mitsar.simulate_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(TARGET, 2.0)])
    resolution = 0.1
    image = mitsar.focus(raw, grid=PointsGrid([TARGET]), azimuth_resolution=resolution)
    slant_range = math.hypot(6.6, 4.5)
    sin_incidence = 6.6 / slant_range
    half_width = RADAR.wavelength / (4 * resolution)
    expected = 10 * math.log10(_textbook_nesz(slant_range, sin_incidence, half_width))
    # The textbook form takes the two-way pattern as 1 over the processed band |u| <= h; the
    # sinc^2 pattern there is > 0.99 (h = 0.008 against a beamwidth of 0.16): < 0.05 dB.
    assert float(image["nesz_db"].values.ravel()[0]) == pytest.approx(expected, abs=0.05)

    # SNR of a 2 m^2 point: radar-equation peak power over P_n / (N_s M), M = 2 h R PRF / v.
    grid = SlantGrid(along_track=[0.0, 1.4, 0.025], slant_range=[7.2, 8.8, 0.025])
    metrics = mitsar.measure_impulse_response(
        mitsar.focus(raw, grid=grid, azimuth_resolution=resolution), TARGET)
    peak = (RADAR.transmit_power * RADAR.antenna_gain**2 * RADAR.wavelength**2 * 2.0
            / ((4 * math.pi) ** 3 * slant_range**4))
    floor = _ktbf(RADAR) / (RADAR.samples_per_sweep * 2 * half_width * slant_range
                            * RADAR.prf / SPEED)
    # 0.15 dB: the pattern over the band (< 0.05 dB) and BPA's normalisation to "about a"
    # (measured within 1 % in amplitude, 0.09 dB in power).
    assert metrics["snr_db"] == pytest.approx(10 * math.log10(peak / floor), abs=0.15)
    assert metrics["nesz_db"] == pytest.approx(expected, abs=0.1)


def test_normalised_or_noiseless_images_carry_no_noise_floor():
    track = mitsar.Trajectory.linear([14.3, 1.4, 4.5], [SPEED, 0, 0], 0.4)
    raw = mitsar.simulate_point_targets(mitsar.Radar(), track, LOOK, [mitsar.PointTarget(TARGET)])
    image = mitsar.focus(raw, grid=PointsGrid([TARGET]), azimuth_resolution=0.1)
    assert "nesz_db" not in image and "noise_power" not in image


def test_noise_is_a_function_of_seed_sweep_and_sample():
    """Counter-based draws (docs/metrics.md §Noise): a subset, a chunk and the whole acquisition
    carry bit-identical noise; another seed gives other noise."""
    whole = thermal_noise(RADAR, 7, np.arange(300))
    subset = np.array([3, 4, 5, 100, 299, 0])
    np.testing.assert_array_equal(thermal_noise(RADAR, 7, subset), whole[subset])
    chunks = np.vstack([thermal_noise(RADAR, 7, np.arange(a, min(a + 64, 300)))
                        for a in range(0, 300, 64)])
    np.testing.assert_array_equal(chunks, whole)
    assert not np.allclose(thermal_noise(RADAR, 8, np.arange(3)), whole[:3])


def test_streamed_noise_equals_the_in_memory_noise():
    track = mitsar.Trajectory.linear([13.8, 1.4, 4.5], [SPEED, 0, 0], 0.2)
    whole = mitsar.simulate_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(TARGET)],
                                          seed=11, noise=True)
    parts = list(stream_point_targets(RADAR, track, LOOK, [mitsar.PointTarget(TARGET)],
                                      seed=11, noise=True, sweeps_per_chunk=17))
    np.testing.assert_array_equal(np.concatenate([p["raw"].values for p in parts]),
                                  whole["raw"].values)
