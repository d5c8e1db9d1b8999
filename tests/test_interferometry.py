"""Interferometry stage (issue 22 parts 3-4): closed-form checks on synthetic multi-channel images
built to the image contract of docs/interferometry.md §1, and one end-to-end test through the
analytic simulator and focus."""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import mitsar
import mitsar.interferometry.unwrapping as unwrapping_module
from mitsar.errors import MitsarError, ParameterError
from mitsar.interferometry import (
    UnwrappingError,
    coherence,
    interferogram,
    multilook,
    point_cloud,
    predicted_phase_std,
    snr_coherence,
    unwrap,
    write_ply,
)
from mitsar.model.geometry.attitude import body_to_world
from mitsar.model.radar import SPEED_OF_LIGHT

FC = 94e9
WAVELENGTH = SPEED_OF_LIGHT / FC
HEIGHT = 4.5  # platform height [m]: 8 m slant range at 55.7 deg off nadir over the floor
SINGLE_PASS = (np.zeros((2, 3)), np.array([[0.0, 0, 0], [0, 0, 0.05]]))  # (tx, rx) body [m]
PING_PONG = (np.array([[0.0, 0, 0], [0, 0, 0.05]]),) * 2


def _track(n: int = 201) -> tuple[np.ndarray, np.ndarray]:
    """Straight level track along +x at HEIGHT, 1 cm sweeps; zero attitude (looks to +y)."""
    position = np.zeros((n, 3))
    position[:, 0] = np.linspace(-1.0, 1.0, n)
    position[:, 2] = HEIGHT
    return position, np.zeros((n, 3))


def _grid(nx: int = 21, ny: int = 41) -> np.ndarray:
    """Flat pixel grid on z = 0, x aligned with the sweeps, y about 6.6 m (R ~ 8 m)."""
    x, y = np.meshgrid(np.arange(nx) * 0.02 - 0.2, 6.2 + np.arange(ny) * 0.02, indexing="ij")
    return np.stack([x, y, np.zeros_like(x)], -1)


def _centres(aperture: np.ndarray, attitude: np.ndarray, offsets: np.ndarray,
             pixels: np.ndarray) -> np.ndarray:
    """(..., C, 3) world phase centres at each pixel's closest aperture sample (brute force)."""
    a = np.argmin(np.linalg.norm(aperture[:, None, None] - pixels[None], axis=-1), axis=0)
    rot = body_to_world(*attitude[a].transpose(2, 0, 1))
    return aperture[a][..., None, :] + np.einsum("...ij,cj->...ci", rot, offsets)


def _path(q, t, r):
    return np.linalg.norm(t - q, axis=-1) + np.linalg.norm(q - r, axis=-1)


def _on_channel1_range(pixels, heights, aperture, attitude, tx, rx):
    """Scatterers at world z = heights on channel 1's iso-path surface through each pixel, in the
    pixel's zero-Doppler plane x = p_x; channel 1 monostatic at the body origin: a sphere."""
    centre = _centres(aperture, attitude, tx, pixels)[..., 0, :]
    assert np.allclose(tx[0], rx[0])
    r2 = np.sum((pixels - centre) ** 2, -1) - (pixels[..., 0] - centre[..., 0]) ** 2
    y = centre[..., 1] + np.sqrt(r2 - (centre[..., 2] - heights) ** 2)
    return np.stack([pixels[..., 0], y, heights], -1)


def _image(scatterers, pixels, offsets=SINGLE_PASS, amplitude=1.0, noise=0.0, seed=0):
    """A two-channel image to the contract: s_k(p) = a exp(+j 2 pi/lambda (L_k(q) - L_k(p)))
    (docs/interferometry.md §2), plus independent complex Gaussian noise of power noise."""
    aperture, attitude = _track()
    tx = _centres(aperture, attitude, offsets[0], pixels)
    rx = _centres(aperture, attitude, offsets[1], pixels)
    q = scatterers[..., None, :]
    p = pixels[..., None, :]
    phase = 2 * np.pi / WAVELENGTH * (_path(q, tx, rx) - _path(p, tx, rx))
    values = np.moveaxis(amplitude * np.exp(1j * phase), -1, 0)
    rng = np.random.default_rng(seed)
    values = values + np.sqrt(noise / 2) * (rng.standard_normal(values.shape)
                                            + 1j * rng.standard_normal(values.shape))
    return xr.Dataset(
        {"image": (("channel", "v", "u"), values),
         "position": (("v", "u", "xyz"), pixels),
         "transmitter_offset": (("channel", "xyz"), offsets[0]),
         "receiver_offset": (("channel", "xyz"), offsets[1]),
         "aperture_position": (("aperture", "xyz"), aperture),
         "aperture_attitude": (("aperture", "angle"), attitude),
         "aperture_time": (("aperture",), np.arange(len(aperture)) * 1e-3)},
        coords={"channel": [0, 1], "angle": ["heading", "pitch", "roll"],
                "v": pixels[:, 0, 0], "u": pixels[0, :, 1]},
        attrs={"product": "image", "radar_carrier_frequency": FC})


def test_point_scatterer_height_noise_free():
    """(a) 5 cm vertical receivers, one scatterer 12 cm above a flat grid: height within 1 mm."""
    pixels = _grid()
    aperture, attitude = _track()
    heights = np.zeros(pixels.shape[:2])
    heights[10, 20] = 0.12
    q = _on_channel1_range(pixels, heights, aperture, attitude, *SINGLE_PASS)
    ifg = interferogram(_image(q, pixels), unwrap=False)
    error = np.abs(ifg["height"].values - heights)
    assert error.max() < 1e-3, error.max()
    assert np.abs(ifg["position"].values - q).max() < 1e-3
    assert ifg["height"].values[10, 20] == pytest.approx(0.12, abs=1e-9)
    for name, variable in ifg.data_vars.items():
        assert variable.attrs["units"] is not None and variable.attrs["long_name"], name
    # the product describes itself (mitsar.products.interferogram) and its validator names a gap
    from mitsar.errors import ParameterError
    from mitsar.products.interferogram import validate_interferogram

    assert validate_interferogram(ifg) is ifg
    with pytest.raises(ParameterError, match="height_std"):
        validate_interferogram(ifg.drop_vars("height_std"))


def test_sign_convention_and_ping_pong_doubles_the_phase():
    """(e) absolute phase = 2 pi (R1 - R2)/lambda single-pass, twice that ping-pong."""
    pixels = _grid(5, 7)
    aperture, attitude = _track()
    heights = np.full(pixels.shape[:2], 0.05)
    q = _on_channel1_range(pixels, heights, aperture, attitude, *SINGLE_PASS)
    rx = _centres(aperture, attitude, SINGLE_PASS[1], pixels)
    ranges = np.linalg.norm(q[..., None, :] - rx, axis=-1)
    expected = 2 * np.pi / WAVELENGTH * (ranges[..., 0] - ranges[..., 1])
    single = interferogram(_image(q, pixels, SINGLE_PASS), unwrap=False)
    double = interferogram(_image(q, pixels, PING_PONG), unwrap=False)
    absolute_1 = single["unwrapped_phase"] + single["reference_phase"]
    absolute_2 = double["unwrapped_phase"] + double["reference_phase"]
    np.testing.assert_allclose(absolute_1, expected, atol=1e-6)
    np.testing.assert_allclose(absolute_2, 2 * expected, atol=1e-6)
    np.testing.assert_allclose(double["height"], 0.05, atol=1e-6)
    assert double.attrs["baseline"] == pytest.approx([0, 0, 0.1])
    assert double.attrs["ambiguity_height"] == pytest.approx(
        single.attrs["ambiguity_height"] / 2, rel=1e-2)


def test_ambiguity_height_and_sensitivity_against_first_order():
    """Exact ambiguity height near lambda R sin(theta)/B_perp = lambda R / B (vertical B)."""
    pixels = _grid(5, 7)
    ifg = interferogram(_image(pixels, pixels), unwrap=False)
    slant = ifg.attrs["scene_centre_range"]
    assert ifg.attrs["perpendicular_baseline"] == pytest.approx(
        0.05 * np.sin(ifg.attrs["scene_centre_look_angle"]), rel=1e-6)
    assert ifg.attrs["ambiguity_height_first_order"] == pytest.approx(
        WAVELENGTH * slant / 0.05, rel=1e-6)
    assert ifg.attrs["ambiguity_height"] == pytest.approx(WAVELENGTH * slant / 0.05, rel=0.02)


def test_zero_amplitude_and_mask_are_left_out():
    pixels = _grid(6, 6)
    image = _image(pixels, pixels)
    image["image"][0, 1, 1] = 0
    mask = np.zeros((6, 6), bool)
    mask[4, 4] = True
    ifg = interferogram(image, unwrap=False, mask=mask)
    assert np.isnan(ifg["height"].values[1, 1]) and np.isnan(ifg["height"].values[4, 4])
    assert ifg["looks"].values[1, 1] == 0
    assert np.isfinite(ifg["height"].values).sum() == 34
    ml = interferogram(image, looks=(2, 2), unwrap=False, mask=mask)
    assert ml.sizes == {"v": 3, "u": 3, "xyz": 3}
    assert ml["looks"].values[0, 0] == 3 and ml["looks"].values[2, 2] == 3


def test_bad_pair_and_missing_variables():
    pixels = _grid(4, 4)
    image = _image(pixels, pixels)
    with pytest.raises(ParameterError, match="pair"):
        interferogram(image, pair=(0, 0))
    with pytest.raises(ParameterError, match="aperture_position"):
        interferogram(image.drop_vars("aperture_position"))


def test_multilook_closed_form():
    values = np.arange(24.0).reshape(4, 6)
    mean, count = multilook(values, (2, 3))
    np.testing.assert_allclose(mean, [[4.0, 7.0], [16.0, 19.0]])
    assert (count == 6).all()
    mask = np.zeros((4, 6), bool)
    mask[0, 0] = True
    mean, count = multilook(values, (2, 3), mask)
    assert mean[0, 0] == pytest.approx((1 + 2 + 6 + 7 + 8) / 5) and count[0, 0] == 5
    with pytest.raises(ParameterError, match="looks"):
        multilook(values, (0, 1))


@pytest.mark.parametrize("snr", [1.0, 3.0, 10.0])
def test_coherence_of_signal_plus_noise(snr):
    """(b) coherence within 0.02 of 1/(1 + 1/SNR) (Zebker & Villasenor 1992)."""
    rng = np.random.default_rng(int(snr * 10))
    shape = (256, 256)

    def gauss(power):
        return np.sqrt(power / 2) * (rng.standard_normal(shape) + 1j * rng.standard_normal(shape))

    signal = gauss(1.0)
    s1, s2 = signal + gauss(1 / snr), signal + gauss(1 / snr)
    estimate = coherence(s1, s2, (32, 32))
    assert abs(estimate.mean() - snr_coherence(snr)) < 0.02, (estimate.mean(), snr)


def test_phase_spread_reaches_the_cramer_rao_bound():
    """(c) 2000 seeded realisations of L = 25 looks at gamma = 0.9: std within 20 % of CRB."""
    gamma, looks, n = 0.9, 25, 2000
    rng = np.random.default_rng(7)

    def gauss():
        return (rng.standard_normal((n, looks)) + 1j * rng.standard_normal((n, looks))) / np.sqrt(2)

    s1 = gauss()
    s2 = gamma * s1 + np.sqrt(1 - gamma ** 2) * gauss()
    phase = np.angle(multilook(s1 * np.conj(s2), (1, looks))[0][:, 0])
    ratio = phase.std() / predicted_phase_std(gamma, looks)
    assert abs(ratio - 1) < 0.2, ratio
    assert predicted_phase_std(gamma, looks) == pytest.approx(
        np.sqrt((1 - 0.81) / (2 * 25 * 0.81)))


def test_height_std_predicts_the_height_spread():
    """Noisy flat floor, 5 x 5 looks: the spread of heights is the predicted height_std (20 %)."""
    pixels = _grid(100, 60)
    ifg = interferogram(_image(pixels, pixels, noise=0.1, seed=3), looks=(5, 5), unwrap=False)
    measured = np.nanstd(ifg["height"].values)
    predicted = np.nanmean(ifg["height_std"].values)
    assert abs(measured / predicted - 1) < 0.2, (measured, predicted)
    sensitivity = ifg.attrs["ambiguity_height"] / (2 * np.pi)
    gamma = np.nanmean(ifg["coherence"].values)
    assert predicted == pytest.approx(predicted_phase_std(gamma, 25) * sensitivity, rel=0.05)


HAVE_SNAPHU = unwrapping_module.snaphu is not None


@pytest.mark.skipif(not HAVE_SNAPHU, reason="snaphu is not installed (pip install snaphu)")
def test_snaphu_unwraps_a_ramp_exactly():
    """(d) a smooth ramp of several cycles unwraps to itself up to a constant 2 pi k."""
    rows, cols = np.meshgrid(np.arange(64), np.arange(80), indexing="ij")
    truth = 2 * np.pi * (3 * cols / 80 + 2 * rows / 64) + 0.3
    unwrapped, components = unwrap(np.exp(1j * truth), np.full(truth.shape, 0.95), 1.0)
    offset = unwrapped - truth
    cycles = offset / (2 * np.pi)
    assert np.allclose(offset, offset[0, 0], atol=1e-9)
    assert abs(cycles[0, 0] - np.round(cycles[0, 0])) < 1e-9
    assert (components > 0).all()


@pytest.mark.skipif(not HAVE_SNAPHU, reason="snaphu is not installed (pip install snaphu)")
def test_heights_over_several_ambiguities_unwrapped_to_1_mm():
    """A floor rising 1.2 m across the grid (over two ambiguity heights): SNAPHU + the tie to
    the reference pixel (a floor pixel at z = 0) recover every height within 1 mm."""
    pixels = _grid(21, 61)
    aperture, attitude = _track()
    heights = np.broadcast_to(1.2 * np.arange(61) / 60, (21, 61)).copy()
    q = _on_channel1_range(pixels, heights, aperture, attitude, *SINGLE_PASS)
    ifg = interferogram(_image(q, pixels), reference_pixel=(0, 0))
    assert ifg.attrs["ambiguity_height"] < 0.6
    assert np.abs(ifg["height"].values - heights).max() < 1e-3


def test_missing_snaphu_raises_a_mitsar_error(monkeypatch):
    monkeypatch.setattr(unwrapping_module, "snaphu", None)
    with pytest.raises(UnwrappingError, match="snaphu"):
        unwrap(np.ones((8, 8), complex), np.ones((8, 8)), 1.0)
    assert issubclass(UnwrappingError, MitsarError)


def test_point_cloud_ply_round_trip(tmp_path):
    """(f) the PLY file reads back with plyfile; overwrite refused without overwrite=True."""
    plyfile = pytest.importorskip("plyfile")
    pixels = _grid(6, 5)
    aperture, attitude = _track()
    heights = np.linspace(0, 0.1, 30).reshape(6, 5)
    q = _on_channel1_range(pixels, heights, aperture, attitude, *SINGLE_PASS)
    ifg = interferogram(_image(q, pixels), unwrap=False)
    cloud = point_cloud(ifg, min_coherence=0.5)
    assert cloud.sizes["point"] == 30
    path = tmp_path / "cloud.ply"
    write_ply(cloud, path)
    data = plyfile.PlyData.read(str(path))
    assert not data.text and data.byte_order == "<"
    vertex = data["vertex"]
    np.testing.assert_array_equal(vertex["x"], cloud["x"].values)
    np.testing.assert_array_equal(vertex["z"], cloud["z"].values)
    np.testing.assert_allclose(vertex["z"], q[..., 2].reshape(-1), atol=1e-6)
    np.testing.assert_allclose(vertex["coherence"], cloud["coherence"].values, rtol=1e-6)
    with pytest.raises(MitsarError):
        write_ply(cloud, path)
    write_ply(cloud.isel(point=slice(0, 3)), path, overwrite=True)
    assert plyfile.PlyData.read(str(path))["vertex"].count == 3
    assert [p.name for p in tmp_path.iterdir()] == ["cloud.ply"]


def test_end_to_end_through_the_simulator_and_focus():
    """The contract as focus makes it: a point target 10 cm above its pixel (same range, same
    zero-Doppler plane), simulated analytically with 5 cm vertical receivers and back-projected:
    height within 1 mm (measured 0.01 mm)."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.8)
    target = np.array([15.0, 8.0, 0.3])
    radar = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.05)])
    raw = mitsar.simulate_point_targets(radar, track, mitsar.Look(55.7),
                                        [mitsar.PointTarget(target)], normalized=True)
    slant = np.hypot(target[1] - 1.4, target[2] - 4.5)
    pixel = np.array([15.0, 1.4 + np.sqrt(slant ** 2 - (4.5 - 0.2) ** 2), 0.2])
    image = mitsar.focus(raw, "bpa", mitsar.grid.PointsGrid(pixel[None]),
                         azimuth_resolution=0.1, backend="numpy")
    ifg = interferogram(image, unwrap=False)
    assert abs(ifg["height"].values.item() - target[2]) < 1e-3
    assert np.abs(ifg["position"].values.reshape(3) - target).max() < 1e-3
