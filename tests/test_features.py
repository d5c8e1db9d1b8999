"""Features stage: CFAR against its closed forms (false-alarm rate, Swerling-0 detection
probability), point features of a focused point target, and RANSAC line fits
(docs/features.md)."""

import math

import numpy as np
import pytest
import xarray as xr
from scipy.signal import fftconvolve

import mitsar
from mitsar.errors import ParameterError
from mitsar.features import cfar, line_features, point_features
from mitsar.features.cfar import (
    ca_threshold_factor,
    detection_probability,
    make_window,
    os_false_alarm,
    os_noise_scale,
    os_threshold_factor,
)
from mitsar.features.clusters import peak_position_sigma


def _noise(shape, seed):
    """Complex circular Gaussian noise of unit mean power."""
    rng = np.random.default_rng(seed)
    return (rng.standard_normal(shape) + 1j * rng.standard_normal(shape)) / math.sqrt(2.0)


def test_threshold_closed_forms():
    """Eq. 2 inverts (1 + a/N)^-N; eq. 3 equals its product form prod (N-i)/(N-i+a) and is
    inverted by os_threshold_factor; eq. 4 is the mean of the k-th order statistic."""
    n, pfa = 96, 1e-6
    alpha = ca_threshold_factor(pfa, n)
    assert (1.0 + alpha / n) ** -n == pytest.approx(pfa, rel=1e-10)
    for k in (1, 48, 72, 96):
        a = 7.3
        product = np.prod([(n - i) / (n - i + a) for i in range(k)])
        assert os_false_alarm(a, n, k) == pytest.approx(product, rel=1e-10)
        assert os_false_alarm(os_threshold_factor(pfa, n, k), n, k) == pytest.approx(pfa,
                                                                                     rel=1e-8)
    draws = np.sort(np.random.default_rng(0).exponential(size=(20000, n)), axis=1)[:, 71]
    assert draws.mean() == pytest.approx(os_noise_scale(n, 72), rel=0.01)
    # At zero SNR every detector's Pd is its Pfa (eqs. 2, 3, 4a).
    for method in ("ideal", "ca", "os"):
        assert detection_probability(0.0, 1e-3, method, n)[0] == pytest.approx(1e-3, rel=1e-6)


def test_window_footprint_counts_training_cells():
    window = make_window(3, guard=(1, 2, 0), training=(2, 1, 3))
    assert window.footprint.shape == (7, 7, 7)
    assert window.footprint.sum() == window.cells == 7 ** 3 - 3 * 5 * 1
    assert not window.footprint[3, 3, 3]


FALSE_ALARM_CASES = [  # (shape, guard, training): >= 4e5 tested cells each
    ((1000, 1000), 2, 3),
    ((80, 80, 80), 1, 2),
]


@pytest.mark.parametrize("method", ["ca", "os"])
@pytest.mark.parametrize(("shape", "guard", "training"), FALSE_ALARM_CASES)
def test_false_alarm_rate_on_noise(method, shape, guard, training):
    """Noise-only complex Gaussian images: measured Pfa within 20 % of the requested 1e-3.

    The false-alarm count is close to binomial (independent CUTs; the overlap of training
    windows correlates neighbours weakly): ~1000 expected in 2-D (sigma 3.2 %), ~510 in 3-D
    (sigma 4.4 %), so 20 % is over 4 sigma. Every cell is tested, the edge ones with their
    truncated windows. Measured (seeds 2 and 3): 2-D CA 0.984, OS 0.981; 3-D CA 0.955, OS 0.990
    of the request."""
    pfa = 1e-3
    result = cfar(_noise(shape, seed=len(shape)), pfa=pfa, method=method, guard=guard,
                  training=training)
    tested = int(result["tested"].sum())
    assert tested >= 1e5
    rate = int(result["detected"].sum()) / tested
    assert abs(rate / pfa - 1.0) < 0.2, rate / pfa
    assert result["tested"].values.all()  # edge cells too, with their truncated windows


@pytest.mark.parametrize("method", ["ca", "os"])
@pytest.mark.parametrize(("shape", "guard", "training", "images"),
                         [((24, 24), 2, 3, 300), ((12, 12, 12), 1, 2, 70)])
def test_false_alarm_rate_at_the_edges(method, shape, guard, training, images):
    """Cells whose window the image edge truncates (n < N training cells; OS with its own
    rank k - m) keep the requested pfa = 1e-2: over 114 000 (2-D, guard 2, training 3) and
    106 000 (3-D, guard 1, training 2) such cells the rate within 20 % (binomial sigma ~3 %).
    Measured: 2-D CA 0.99, OS 1.00; 3-D CA 0.98, OS 1.00. With edges="inside" they are not
    tested."""
    pfa, alarms, cells = 1e-2, 0, 0
    for seed in range(images):
        result = cfar(_noise(shape, seed), pfa=pfa, method=method, guard=guard,
                      training=training)
        edge = result["tested"].values & (result["training_cells"].values
                                          < result.attrs["cells"])
        alarms += int((result["detected"].values & edge).sum())
        cells += int(edge.sum())
    assert cells > 1e5
    assert abs(alarms / cells / pfa - 1.0) < 0.2, alarms / cells / pfa
    inside = cfar(_noise(shape, 0), pfa=pfa, method=method, guard=guard, training=training,
                  edges="inside")
    assert (inside["tested"].values == (inside["training_cells"].values
                                        == inside.attrs["cells"])).all()
    assert np.isnan(inside["noise"].values[(0,) * len(shape)])


SPACING = 12  # > the 11-cell window: no target in another's training cells
SNR_DB = (8.0, 11.0, 14.0)


@pytest.mark.parametrize("method", ["ca", "os", "ideal"])
def test_detection_probability_swerling0(method):
    """Non-fluctuating one-cell targets (random phase) on a 60 x 60 lattice in unit noise,
    pfa 1e-4, N = 96 (guard 2, training 3), at 8, 11 and 14 dB: the detected fraction of
    3600 trials within 0.05 of the closed form (docs/features.md §4; binomial sigma <= 0.0083):
    CA and OS against the Marcum Q averaged over their noise estimate, "ideal" (known noise,
    threshold -ln pfa) against Q1(sqrt(2 SNR), sqrt(2 T)) itself. Measured vs closed form:
    CA 0.260/0.762/0.998 vs 0.244/0.763/0.997; OS 0.247/0.744/0.997 vs 0.231/0.743/0.996;
    ideal 0.281/0.792/0.999 vs 0.271/0.798/0.998."""
    pfa, cells = 1e-4, 96
    side = SPACING * 60
    centre = np.arange(SPACING // 2, side, SPACING)
    rows, cols = np.meshgrid(centre, centre, indexing="ij")
    rng = np.random.default_rng(5)
    measured, expected = [], detection_probability(10 ** (np.array(SNR_DB) / 10), pfa, method,
                                                   cells)
    for snr_db in SNR_DB:
        image = _noise((side, side), seed=int(snr_db))
        phase = rng.uniform(0, 2 * np.pi, rows.shape)
        image[rows, cols] += 10 ** (snr_db / 20) * np.exp(1j * phase)
        if method == "ideal":
            hits = np.abs(image[rows, cols]) ** 2 > -math.log(pfa)
        else:
            result = cfar(image, pfa=pfa, method=method, guard=2, training=3)
            assert result.attrs["cells"] == cells
            hits = result["detected"].values[rows, cols]
        measured.append(hits.mean())
    np.testing.assert_allclose(measured, expected, atol=0.05)


@pytest.fixture(scope="module")
def point_image():
    """A point target simulated and focused on the ground plane (unweighted), noise-free."""
    target = np.array([15.0, 8.0, 0.0])
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], 0.8)
    raw = mitsar.simulate_point_targets(
        mitsar.Radar(), track, mitsar.Look(math.degrees(math.atan2(6.6, 4.5))),
        [mitsar.PointTarget(target)], normalized=True)
    grid = mitsar.grid.PlaneGrid(origin=[15.03, 7.98, 0.0], axis_u=[1, 0, 0],
                                 axis_v=[0, 1, 0], u=[-0.6, 0.6, 0.025], v=[-0.6, 0.6, 0.025])
    return mitsar.focus(raw, grid=grid, azimuth_resolution=0.1), target


def _with_noise(image, snr_db, seed):
    """``image`` plus focused noise at ``snr_db`` peak SNR per pixel: white complex noise
    through the image's own point response (a matched filter's output noise has the signal's
    spectrum), scaled to unit power before the SNR."""
    clean = image["image"].values
    colored = fftconvolve(_noise(clean.shape, seed), clean, mode="same")
    colored /= np.sqrt(np.sum(np.abs(clean) ** 2))
    sigma = np.abs(clean).max() / 10 ** (snr_db / 20)
    return image.assign(image=(image["image"].dims, clean + sigma * colored))


@pytest.mark.parametrize("method", ["ca", "os"])
def test_point_target_found_within_a_resolution_cell(point_image, method):
    """At 30 dB peak SNR the strongest point feature lies within one resolution cell of the
    simulated target in 3-D (cells 0.12 m x 0.10 m), its uncertainty is eq. 5 of its SNR, and
    with pfa 1e-6 on 2401 cells the target is one cluster."""
    image, target = point_image
    found = mitsar.detect(_with_noise(image, 30.0, seed=3), pfa=1e-6, method=method)
    assert found.sizes["detection"] >= 1
    resolution = np.asarray(found.attrs["resolution"])
    assert found.attrs["resolution_source"].startswith("image")
    np.testing.assert_allclose(resolution, [0.121, 0.100], atol=0.002)
    assert np.linalg.norm(found["position"].values[0] - target) < resolution.min()
    assert found["snr_db"].values[0] > 15.0
    # v is y and u is x: eq. 5 per dim lands on y and x, nothing out of the plane.
    sigma = peak_position_sigma(resolution, found["snr"].values[0])
    np.testing.assert_allclose(found["uncertainty"].values[0], [sigma[1], sigma[0], 0.0],
                               rtol=1e-9)
    assert found.sizes["detection"] == 1
    assert (found["cell_detection"].values == 0).all()
    assert found.attrs["pfa"] == 1e-6 and found.attrs["method"] == method
    assert found["position"].attrs["units"] == "m"


def test_uncertainty_predicts_the_position_scatter(point_image):
    """Eq. 5 against Monte Carlo: 150 noise draws at 15 dB peak SNR (unweighted response,
    guard 6, training 4): the spread of the centroid in x and y within 25 % of the mean
    predicted 1-sigma (the spread's own sampling error is ~6 %). Measured 7.5 / 9.0 mm against
    7.5 / 9.0 mm predicted; no bias beyond 1 mm."""
    image, target = point_image
    positions, predicted = [], []
    for seed in range(150):
        found = mitsar.detect(_with_noise(image, 15.0, seed), pfa=1e-6, guard=6, training=4)
        if found.sizes["detection"]:
            positions.append(found["position"].values[0])
            predicted.append(found["uncertainty"].values[0])
    positions = np.array(positions)
    assert len(positions) >= 140
    spread, expected = positions.std(axis=0)[:2], np.mean(predicted, axis=0)[:2]
    np.testing.assert_allclose(spread, expected, rtol=0.25)
    assert np.all(np.abs(positions.mean(axis=0) - target)[:2] < 2e-3)


def test_volume_positions_from_coordinates():
    """A 3-D volume without a position variable (coordinates x, y, z, dims z, y, x): a blob's
    centroid lands at its world position, with the per-dim resolution attribute."""
    x, y, z = np.arange(0, 2, 0.05), np.arange(1, 2.5, 0.05), np.arange(-0.5, 0.5, 0.05)
    zz, yy, xx = np.meshgrid(z, y, x, indexing="ij")
    centre = np.array([1.02, 1.71, 0.11])
    blob = 300 * np.exp(-((xx - centre[0]) ** 2 + (yy - centre[1]) ** 2
                          + (zz - centre[2]) ** 2) / (2 * 0.04 ** 2))
    volume = xr.Dataset({"image": (("z", "y", "x"), blob + _noise(blob.shape, seed=9))},
                        coords={"x": x, "y": y, "z": z}, attrs={"resolution": [0.1, 0.1, 0.1]})
    found = mitsar.detect(volume, pfa=1e-6, method="ca")
    assert found.attrs["guard"] == [2, 2, 2] and found.attrs["training"] == [3, 3, 3]
    np.testing.assert_allclose(found["position"].values[0], centre, atol=0.01)
    assert np.all(found["uncertainty"].values[0] > 0)


def test_line_fit_recovers_lines():
    """Two noisy segments (sigma 1 cm per axis) and 100 outliers: RANSAC (seeded) finds both,
    direction within 0.01 rad, endpoints within 3 cm of the segment ends, and the seed is
    recorded."""
    rng = np.random.default_rng(3)
    a, d1 = np.array([1.0, 2.0, 0.5]), np.array([1.0, 1.0, 0.2]) / np.linalg.norm([1, 1, 0.2])
    b, d2 = np.array([0.0, 0.0, 0.0]), np.array([1.0, -1.0, 0.0]) / math.sqrt(2)
    t1 = np.concatenate([[0.0, 2.0], rng.uniform(0, 2, 198)])
    t2 = np.concatenate([[0.0, 1.5], rng.uniform(0, 1.5, 148)])
    points = np.vstack([a + t1[:, None] * d1, b + t2[:, None] * d2])
    points += rng.normal(0, 0.01, points.shape)
    points = np.vstack([points, rng.uniform(-1, 3, (100, 3))])
    lines = line_features(points, tolerance=0.04, seed=11)
    assert lines.attrs["seed"] == 11 and lines.sizes["line"] == 2
    for k, (origin, direction, length) in enumerate(((a, d1, 2.0), (b, d2, 1.5))):
        found = lines["direction"].values[k]
        assert math.acos(min(abs(found @ direction), 1.0)) < 0.01
        ends = np.sort([(lines["start"].values[k] - origin) @ direction,
                        (lines["end"].values[k] - origin) @ direction])
        np.testing.assert_allclose(ends, [0.0, length], atol=0.03)
        assert lines["uncertainty"].values[k] < 0.01
    again = line_features(points, tolerance=0.04, seed=11)
    xr.testing.assert_identical(lines, again)


def test_lines_from_detections_of_a_wall():
    """A bright line of pixels in a noisy image, detected and fitted through mitsar.detect's
    cells: one line along it."""
    image = _noise((120, 120), seed=4)
    image[60, 10:110] += 30.0
    found = mitsar.detect(image, pfa=1e-6, method="os", guard=2, training=3)
    lines = line_features(found, min_points=20)
    assert lines.sizes["line"] == 1
    assert abs(lines["direction"].values[0] @ [0, 1, 0]) > 0.999
    assert lines["length"].values[0] == pytest.approx(99, abs=1)


@pytest.mark.parametrize(("kwargs", "name"), [
    ({"pfa": 0.0}, "pfa"), ({"pfa": 1.0}, "pfa"), ({"pfa": float("nan")}, "pfa"),
    ({"method": "go"}, "method"), ({"guard": 30}, "guard/training"),
    ({"guard": -1}, "guard"), ({"training": (1, 2, 3)}, "training"),
    ({"method": "os", "rank": 500}, "rank"),
])
def test_bad_parameters_raise_parameter_error(kwargs, name):
    with pytest.raises(ParameterError) as error:
        mitsar.detect(_noise((40, 40), seed=0), **kwargs)
    assert error.value.name == name


def test_bad_images_raise_parameter_error():
    channels = xr.Dataset({"image": (("channel", "v", "u"), _noise((2, 20, 20), seed=0))})
    for image in (channels, _noise((50,), seed=0), xr.Dataset({"x": ("a", [1.0])})):
        with pytest.raises(ParameterError):
            mitsar.detect(image)
    with pytest.raises(ParameterError):
        point_features(xr.Dataset())
    image = _noise((30, 30), seed=1)
    image[15, 15] += 20.0
    xr.testing.assert_identical(point_features(image, pfa=1e-4, method="os"),
                                mitsar.detect(image, pfa=1e-4, method="os"))
    with pytest.raises(ParameterError):
        line_features(np.zeros((5, 2)), tolerance=0.1)
    with pytest.raises(ParameterError):
        line_features(np.zeros((5, 3)))  # no resolution recorded: tolerance needed
