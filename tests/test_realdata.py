"""Recorded data into the chain: raw_from_arrays, read_raw, and the AFRL GOTCHA sample.

The GOTCHA tests need ``../shared/realdata/gotcha-sample`` beside the repository (it is never
copied into the project) and are skipped without it.
"""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import mitsar
from mitsar.errors import MitsarError, ParameterError
from mitsar.focus.grid import PlaneGrid, SlantGrid, equivalent_position
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.quality.impulse import measure_impulse_response
from mitsar.raw.recorded import raw_from_arrays, read_gotcha, read_raw

GOTCHA = Path(__file__).resolve().parents[1].parent / "shared" / "realdata" / "gotcha-sample"
needs_gotcha = pytest.mark.skipif(
    not GOTCHA.is_dir(), reason=f"GOTCHA sample not found at {GOTCHA} (../shared is absent)")

# A synthetic X-band stripmap "recording": stop-and-go pulses, frequency samples.
F0, DF, COUNT = 9.5e9, 2.0e6, 256  # 512 MHz: c / 2B = 0.293 m; unambiguous 75 m
TARGETS = np.array([[3.0, 1.0, 0.0], [-4.0, -2.0, 0.0]])
REFERENCE = np.zeros(3)


def _recording(phase_sign: int = -1, referenced: bool = True):
    """Pulses on an arc at x = -800 m, z = 600 m looking at the origin, 2 deg of aperture."""
    pulses = 181
    angle = np.radians(np.linspace(-1.0, 1.0, pulses))
    distance = 1000.0
    positions = np.stack([-0.8 * distance * np.cos(angle), 0.8 * distance * np.sin(angle),
                          np.full(pulses, 0.6 * distance)], axis=1)
    frequency = F0 + DF * np.arange(COUNT)
    reference = np.linalg.norm(positions - REFERENCE, axis=1) if referenced else 0.0
    samples = np.zeros((pulses, COUNT), dtype=complex)
    for target in TARGETS:
        ranges = np.linalg.norm(positions - target, axis=1)
        samples += np.exp(phase_sign * 4j * np.pi * frequency[None, :]
                          * (ranges - reference)[:, None] / SPEED_OF_LIGHT)
    return samples, frequency, positions


def _focus_target(raw, target, half=3.0, step=0.05):
    grid = PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0],
                     u=[-half, half, step], v=[-half, half, step])
    image = mitsar.focus(raw, grid=grid)
    return image, measure_impulse_response(image, target)


def test_referenced_recording_focuses_every_target_on_a_ground_grid():
    samples, frequency, positions = _recording()
    raw = raw_from_arrays(samples, frequency, positions, reference_point=REFERENCE,
                          phase_sign=-1)
    assert raw.attrs["product"] == "raw" and "reference_range" in raw
    assert raw.attrs["radar_bandwidth"] == pytest.approx(COUNT * DF)
    elevation = math.atan2(0.6, 0.8)
    ground_cell = SPEED_OF_LIGHT / (2 * COUNT * DF) / math.cos(elevation)
    for target in TARGETS:
        image, metrics = _focus_target(raw, target)
        assert metrics["peak_offset_m"] < 0.05 * ground_cell
        assert 10 ** (metrics["peak_db"] / 20) == pytest.approx(1.0, abs=0.05)
        assert metrics["range"]["irw_m"] == pytest.approx(0.886 * ground_cell, rel=0.03)
    with pytest.raises(ParameterError, match="bpa"):
        mitsar.focus(raw, algorithm="wda")


def test_phase_sign_and_absolute_range_conventions_agree():
    """-1 data are conjugated; unreferenced (absolute-range) data focus the same."""
    target = TARGETS[0]
    minus = raw_from_arrays(*_recording(-1), reference_point=REFERENCE, phase_sign=-1)
    plus = raw_from_arrays(*_recording(+1), reference_point=REFERENCE, phase_sign=+1)
    np.testing.assert_allclose(minus["raw"].values, plus["raw"].values, atol=1e-9)
    # Absolute range: fine while all ranges fit the unambiguous window (here |R| ~ 1 km does
    # not, but the profile is periodic, so the lookup wraps).
    absolute = raw_from_arrays(*_recording(+1, referenced=False))
    grid = PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-1.0, 1.0, 0.05],
                     v=[-1.0, 1.0, 0.05])
    a, b = mitsar.focus(absolute, grid=grid), mitsar.focus(plus, grid=grid)
    peak = np.abs(b["image"].values).max()
    assert np.abs(np.abs(a["image"].values) - np.abs(b["image"].values)).max() < 0.01 * peak


def test_fmcw_arrays_with_continuous_motion_feed_every_algorithm():
    """Arrays of a simulated FMCW acquisition (RVP removed) round-trip to a plain product."""
    radar = mitsar.Radar()
    trajectory = mitsar.Trajectory.linear([14.3, 1.4, 4.5], [0.5, 0, 0], 2.8)
    target = [15.0, 8.0, 0.0]
    look = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
    sim = mitsar.simulate_point_targets(radar, trajectory, look, [mitsar.PointTarget(target)],
                                        normalized=True, pattern=False, rvp=False)
    frequency = radar.carrier_frequency + radar.chirp_rate * sim["fast_time"].values
    raw = raw_from_arrays(sim["raw"].values, frequency, sim["platform_position"].values,
                          sweep_times=sim["slow_time"].values, continuous_motion=True,
                          velocities=sim["platform_velocity"].values,
                          boresight=sim["boresight"].values)
    assert "reference_range" not in raw
    assert raw.attrs["radar_prf"] == pytest.approx(radar.prf)
    assert raw.attrs["radar_bandwidth"] == pytest.approx(radar.bandwidth)
    origin = raw["platform_position"].values[0]
    grid = SlantGrid(along_track=[15.0 - origin[0] - 0.6, 15.0 - origin[0] + 0.6, 0.01],
                     slant_range=[math.hypot(6.6, 4.5) - 0.6, math.hypot(6.6, 4.5) + 0.6, 0.01])
    for algorithm in ("bpa", "wda"):
        image = mitsar.focus(raw, algorithm=algorithm, grid=grid, azimuth_resolution=0.1)
        metrics = measure_impulse_response(image, equivalent_position(image, target))
        assert metrics["peak_offset_m"] < 0.1 * radar.range_resolution
        assert metrics["range"]["irw_cells"] == pytest.approx(0.886, abs=0.01)


@pytest.mark.parametrize("suffix", [".npz", ".h5", ".nc"])
def test_read_raw_generic_layout(tmp_path, suffix):
    samples, frequency, positions = _recording()
    path = tmp_path / f"recording{suffix}"
    if suffix == ".npz":
        np.savez(path, samples=samples, frequencies=frequency, antenna_positions=positions,
                 reference_point=REFERENCE, phase_sign=-1)
    elif suffix == ".h5":
        import h5py

        with h5py.File(path, "w") as handle:
            handle["samples"] = samples
            handle["frequencies"] = frequency
            handle["antenna_positions"] = positions
            handle["reference_point"] = REFERENCE
            handle.attrs["phase_sign"] = -1
    else:
        xr.Dataset({"samples": (("sweep", "sample"), samples),
                    "frequencies": (("sample",), frequency),
                    "antenna_positions": (("sweep", "xyz"), positions),
                    "reference_point": (("xyz",), REFERENCE)},
                   attrs={"phase_sign": -1}).to_netcdf(path, engine="h5netcdf")
    raw = read_raw(path)
    direct = raw_from_arrays(samples, frequency, positions, reference_point=REFERENCE,
                             phase_sign=-1)
    np.testing.assert_allclose(raw["raw"].values, direct["raw"].values)
    np.testing.assert_allclose(raw["reference_range"].values, direct["reference_range"].values)


def test_read_raw_reads_saved_products_and_refuses_other_files(tmp_path):
    from mitsar.io import save

    samples, frequency, positions = _recording()
    product = raw_from_arrays(samples, frequency, positions, reference_point=REFERENCE,
                              phase_sign=-1)
    save(product, tmp_path / "raw.nc")
    again = read_raw(tmp_path / "raw.nc")
    np.testing.assert_allclose(again["raw"].values, product["raw"].values)
    np.savez(tmp_path / "other.npz", x=np.zeros(3))
    with pytest.raises(MitsarError, match="generic layout"):
        read_raw(tmp_path / "other.npz")
    with pytest.raises(MitsarError, match="no such file"):
        read_raw(tmp_path / "missing.nc")


def test_raw_from_arrays_validates_its_inputs():
    samples, frequency, positions = _recording()
    with pytest.raises(ParameterError, match="uniform"):
        raw_from_arrays(samples, frequency + np.linspace(0, 1, COUNT) ** 2 * 1e6, positions)
    with pytest.raises(ParameterError, match="antenna_positions"):
        raw_from_arrays(samples, frequency, positions[:-1])
    with pytest.raises(ParameterError, match="phase_sign"):
        raw_from_arrays(samples, frequency, positions, phase_sign=2)


@needs_gotcha
@pytest.mark.realdata
def test_gotcha_point_targets_reach_the_theoretical_resolution():
    """Two isolated bright points of pass 1 (HH, 0-4 deg), back-projected on the ground.

    Unweighted theory: ground range 0.886 c / (2 B cos phi), cross range
    0.886 lambda / (2 dtheta cos phi) with B = 622.4 MHz, phi = 45.75 deg, dtheta = 4 deg.
    """
    raw = read_gotcha(GOTCHA)
    assert raw.sizes["sweep"] == 469 and raw.sizes["sample"] == 424
    phi = math.radians(45.75)
    band = 622.36e6
    wavelength = SPEED_OF_LIGHT / 9.5993e9
    ground = 0.886 * SPEED_OF_LIGHT / (2 * band * math.cos(phi))
    cross = 0.886 * wavelength / (2 * math.radians(4.0) * math.cos(phi))
    for target in ([-15.6, 21.6, 0.0], [-27.8, 38.8, 0.0]):
        grid = PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0],
                         u=[-2.0, 2.0, 0.025], v=[-2.0, 2.0, 0.025])
        image = mitsar.focus(raw, grid=grid)
        metrics = measure_impulse_response(image, target)
        assert metrics["peak_offset_m"] < 0.1
        assert metrics["range"]["irw_m"] == pytest.approx(ground, rel=0.10)
        assert metrics["azimuth"]["irw_m"] == pytest.approx(cross, rel=0.10)
