"""Figures: every plot draws and saves a PNG; saving is atomic and never overwrites silently."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest
import xarray as xr

from mitsar import io
from mitsar.errors import MitsarError
from mitsar.plots import figures as plots

PNG = b"\x89PNG\r\n\x1a\n"


def _image_product() -> xr.Dataset:
    """A synthetic slant-grid image: a 2-D sinc at (azimuth 0.7 m, range 8.0 m)."""
    azimuth = np.arange(0.1, 1.3001, 0.01)
    slant = np.arange(7.4, 8.6001, 0.01)
    values = (np.sinc((azimuth[:, None] - 0.7) / 0.1) * np.sinc((slant[None, :] - 8.0) / 0.1)
              * np.exp(1j * 0.3)).astype(complex)
    origin = np.array([14.3, 1.4, 4.5])
    look = np.array([0.0, 6.6, -4.5]) / np.hypot(6.6, 4.5)
    position = (origin + azimuth[:, None, None] * np.array([1.0, 0, 0])
                + slant[None, :, None] * look)
    return xr.Dataset(
        {"image": (("azimuth", "range"), values),
         "position": (("azimuth", "range", "xyz"), position)},
        coords={"azimuth": azimuth, "range": slant, "xyz": ["x", "y", "z"]},
        attrs={"product": "image", "algorithm": "bpa", "range_resolution": 0.1,
               "azimuth_resolution": 0.1, "range_axis": [0.0, 1.0], "azimuth_axis": [1.0, 0.0],
               "target_positions": list(origin + 0.7 * np.array([1.0, 0, 0]) + 8.0 * look)})


def _profile_product() -> xr.Dataset:
    sweeps, ranges = np.arange(50), np.linspace(0, 20, 400)
    profile = np.sinc((ranges[None, :] - 8.0 - 0.001 * sweeps[:, None]) / 0.1) + 1e-4
    return xr.Dataset({"profile": (("sweep", "range"), profile.astype(complex))},
                      coords={"sweep": sweeps, "range": ranges,
                              "slow_time": ("sweep", sweeps * 4e-3)},
                      attrs={"product": "range_compressed"})


def test_plot_image_with_marks(tmp_path):
    image = _image_product()
    target = image["position"].values[60, 60]
    ax = plots.plot_image(image, marks={"target": target, "CS": (8.2, 0.5)})
    labels = [line.get_label() for line in ax.get_lines()]
    assert labels == ["target", "CS"]
    np.testing.assert_allclose(ax.get_lines()[0].get_xydata()[0], [8.0, 0.7], atol=1e-9)
    assert ax.get_xlabel() == "slant range [m]" and ax.get_ylabel() == "along track [m]"
    path = plots.save_figure(ax.figure, tmp_path / "image.png")
    assert path.read_bytes()[:8] == PNG


def test_plot_image_skips_marks_outside(tmp_path):
    with pytest.warns(UserWarning, match="outside the image"):
        ax = plots.plot_image(_image_product(), marks={"far": (0.0, 0.0, 0.0)})
    assert ax.get_lines() == []
    plt.close(ax.figure)


def test_plot_cuts_legend_has_metrics(tmp_path):
    metrics = {name: {"irw_m": 0.0886, "irw_cells": 0.886, "pslr_db": -13.26, "islr_db": -10.69}
               for name in ("range", "azimuth")}
    axes = plots.plot_cuts(_image_product(), metrics)
    for ax, name in zip(axes, ("range", "azimuth"), strict=True):
        text = ax.get_legend().get_texts()[0].get_text()
        assert text.startswith(name) and "PSLR -13.26 dB" in text and "ISLR -10.69 dB" in text
        offset, level = ax.get_lines()[0].get_xydata().T
        assert level.max() == pytest.approx(0.0) and offset[np.argmax(level)] == pytest.approx(0)
    plots.save_figure(axes[0].figure, tmp_path / "cuts.png")
    assert (tmp_path / "cuts.png").read_bytes()[:8] == PNG


def test_plot_range_compressed_profile(tmp_path):
    ax = plots.plot_range_compressed(_profile_product())
    assert ax.get_xlabel() == "slant range [m]" and ax.get_ylabel() == "slow time [s]"
    left, right = ax.get_images()[0].get_extent()[:2]
    assert left <= 0.1 and 9.0 < right < 20.0  # cropped beyond the strongest return
    plots.save_figure(ax.figure, tmp_path / "rc.png")
    assert (tmp_path / "rc.png").read_bytes()[:8] == PNG


def test_plot_range_compressed_rejects_other_products():
    with pytest.raises(MitsarError, match="expected a raw product"):
        plots.plot_range_compressed(xr.Dataset({"x": ("i", [1.0])}))


def test_background_histograms(tmp_path):
    rng = np.random.default_rng(0)
    values = 0.1 * (rng.standard_normal(5000) + 1j * rng.standard_normal(5000))
    axes = plots.plot_background_histograms(np.abs(values), np.angle(values), label="-20 dB")
    labels = [t.get_text() for t in axes[0].get_legend().get_texts()]
    assert any("Rayleigh" in label for label in labels)
    assert any("uniform" in t.get_text() for t in axes[1].get_legend().get_texts())
    assert axes[1].get_xlim() == pytest.approx((0, 2 * np.pi))
    plots.save_figure(axes[0].figure, tmp_path / "hist.png")
    assert (tmp_path / "hist.png").read_bytes()[:8] == PNG
    with pytest.raises(MitsarError, match="no background samples"):
        plots.plot_background_histograms([], [])


def test_save_figure_protects_and_is_atomic(tmp_path, monkeypatch):
    path = tmp_path / "fig.png"
    figure, _ = plt.subplots()
    plots.save_figure(figure, path)
    before = path.read_bytes()
    figure, _ = plt.subplots()
    with pytest.raises(io.OutputExistsError, match="--overwrite"):
        plots.save_figure(figure, path)
    assert path.read_bytes() == before

    figure, _ = plt.subplots()

    def broken(*args, **kwargs):
        raise RuntimeError("renderer crashed")

    monkeypatch.setattr(figure, "savefig", broken)
    with pytest.raises(RuntimeError, match="renderer crashed"):
        plots.save_figure(figure, tmp_path / "new.png")
    assert sorted(p.name for p in tmp_path.iterdir()) == ["fig.png"]


def test_save_figure_unknown_format(tmp_path):
    figure, _ = plt.subplots()
    with pytest.raises(MitsarError, match="unsupported figure format 'xyz'"):
        plots.save_figure(figure, tmp_path / "fig.xyz")


def test_plot_file_dispatches(tmp_path):
    image = io.save(_image_product(), tmp_path / "image.nc")
    profile = io.save(_profile_product(), tmp_path / "profile.nc")
    for source in (image, profile):
        out = plots.plot_file(source, tmp_path / f"{source.stem}.png")
        assert out.read_bytes()[:8] == PNG
    other = io.save(xr.Dataset({"x": ("i", [1.0])}, attrs={"product": "ambiguity"}),
                    tmp_path / "other.nc")
    with pytest.raises(MitsarError, match="no figure for a product of type 'ambiguity'"):
        plots.plot_file(other, tmp_path / "other.png")
    assert not (tmp_path / "other.png").exists()


def test_target_marks_from_experiment():
    marks = plots.target_marks(_image_product())
    assert list(marks) == ["target"]


def test_beam_range_marks_closed_form():
    """NR / CS / FR on the floor of a side-looking pass: h / cos(theta -/+ beta/2) (no squint),
    the slant grid's range being the distance from the track."""
    import math

    import mitsar
    from mitsar.plots.figures import beam_range_marks

    radar = mitsar.Radar()
    trajectory = mitsar.Trajectory.linear([0.0, 8.0, 1.0], [0.5, 0, 0], 0.2)
    raw = mitsar.simulate_point_targets(radar, trajectory, mitsar.Look(60.0),
                                        [mitsar.PointTarget([0.05, 9.7, 0.0])], normalized=True)
    image = mitsar.focus(raw, grid=mitsar.grid.SlantGrid(along_track=[0, 0.1, 0.05],
                                                        slant_range=[1.0, 3.0, 0.5]))
    half = radar.elevation_beamwidth / 2
    marks = beam_range_marks(image)
    assert marks["NR"] == pytest.approx(1.0 / math.cos(math.radians(60) - half))
    assert marks["CS"] == pytest.approx(2.0)
    assert marks["FR"] == pytest.approx(1.0 / math.cos(math.radians(60) + half))
