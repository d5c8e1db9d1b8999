"""The report's figures as a newcomer sees them (issue 26 item 5): no blank band in the
ambiguity comparison, plane-grid images in world coordinates with the metrics target marked,
sweep plots with human labels and units. Figures are drawn from small synthetic products and
read back as pixels or as Matplotlib artists."""

from __future__ import annotations

import json

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import pytest  # noqa: E402
import xarray as xr  # noqa: E402

from mitsar.ambiguity.plots import plot_comparison  # noqa: E402


def _longest_blank_band(path) -> float:
    """The tallest run of all-white pixel rows of a PNG, as a fraction of its height."""
    image = plt.imread(str(path))[..., :3]
    blank = (image >= 250 / 255).all(axis=(1, 2))
    longest = run = 0
    for row in blank:
        run = run + 1 if row else 0
        longest = max(longest, run)
    return longest / len(blank)


def _comparison(width: float, depth: float) -> xr.Dataset:
    """A comparison of two trajectories over a ``width`` x ``depth`` [m] floor."""
    x, y = np.meshgrid(np.linspace(0, width, 60), np.linspace(0, depth, 20))
    position = np.stack([x.ravel(), y.ravel(), np.zeros(x.size)], axis=-1)
    status = np.stack([(position[:, 1] > depth / 2) * 3, (position[:, 0] > width / 2) * 2])
    tracks = {"a": [[0.0, 1.0, 4.5], [width, 1.0, 4.5]],
              "b": [[0.0, depth - 1, 4.5], [width, depth - 1, 4.5]]}
    return xr.Dataset(
        {"fraction_resolved": (("trajectory", "surface"), [[0.5, 0.0], [0.0, 0.2]]),
         "total_fraction_resolved": ("trajectory", [0.4, 0.1]),
         "status": (("trajectory", "point"), status),
         "position": (("point", "xyz"), position)},
        coords={"trajectory": ["a", "b"], "surface": ["floor", "wall"]},
        attrs={"tracks": json.dumps(tracks), "required_resolution": 0.1})


@pytest.mark.parametrize(("width", "depth"), [(30.0, 10.0), (10.0, 10.0), (4.0, 12.0)])
def test_ambiguity_comparison_has_no_blank_band(width, depth, tmp_path):
    """The status maps of a long room (30 x 10 m, the control volume) sat in a row of fixed
    height: a band of 16 % of the figure was blank. The row now takes the maps' own aspect."""
    path = plot_comparison(_comparison(width, depth), tmp_path / "comparison.png")
    assert _longest_blank_band(path) < 0.08


def _plane_image(axis_u, axis_v, origin=(14.4, 7.3, 0.0), target=(15.0, 8.0, 0.0)):
    """A plane-grid image (:class:`mitsar.focus.grid.PlaneGrid`'s layout) with a bright
    pixel at ``target``, which is also its metrics target."""
    u, v = np.arange(0.0, 1.01, 0.02), np.arange(0.0, 1.21, 0.02)
    axis_u, axis_v, origin = (np.asarray(a, float) for a in (axis_u, axis_v, origin))
    position = origin + v[:, None, None] * axis_v + u[None, :, None] * axis_u
    distance = np.linalg.norm(position - np.asarray(target), axis=-1)
    image = np.exp(-(distance / 0.05) ** 2) + 1e-3
    return xr.Dataset(
        {"image": (("v", "u"), image.astype(complex)), "position": (("v", "u", "xyz"), position)},
        coords={"u": u, "v": v},
        attrs={"product": "image", "grid_kind": "plane", "grid_origin": list(origin),
               "grid_axis_u": list(axis_u), "grid_axis_v": list(axis_v),
               "target_positions": list(target), "metrics_target": list(target)})


def _mark(ax, name):
    return next(line for line in ax.get_lines() if line.get_label() == name)


@pytest.mark.parametrize(("axis_u", "axis_v", "labels"),
                         [((1, 0, 0), (0, 1, 0), ("x [m]", "y [m]")),
                          ((-1, 0, 0), (0, 1, 0), ("x [m]", "y [m]")),
                          ((0, 1, 0), (0, 0, 1), ("y [m]", "z [m]"))])
def test_axis_aligned_plane_images_are_drawn_in_world_coordinates(axis_u, axis_v, labels):
    """A plane grid along world axes was drawn in u / v (0 ... 1.2 m from its origin): now in
    the scene's x, y, z, the target and the metrics target (a circle) where the scene has them.
    """
    from mitsar.plots.figures import METRICS_MARK, plot_image, target_marks

    origin = np.array([14.4, 7.3, 0.0])
    target = origin + 0.6 * np.asarray(axis_u, float) + 0.7 * np.asarray(axis_v, float)
    image = _plane_image(axis_u, axis_v, origin, target)
    image.attrs["target_positions"] = list(target) + list(origin + 0.2 * np.asarray(axis_u))
    marks = target_marks(image)
    assert list(marks) == [f"target 0 = {METRICS_MARK}", "target 1"]  # marked once
    ax = plot_image(image, marks=marks)
    assert (ax.get_xlabel(), ax.get_ylabel()) == labels
    column, row = ("xyz".index(label[0]) for label in labels)
    both = [line for line in ax.get_lines() if line.get_xydata().size == 2]
    assert sorted(line.get_marker() for line in both) == ["+", "+", "o"]
    (x,), (y,) = _mark(ax, f"target 0 = {METRICS_MARK}").get_data()
    assert x == pytest.approx(target[column], abs=0.011)
    assert y == pytest.approx(target[row], abs=0.011)
    (x,), (y,) = _mark(ax, "target 1").get_data()
    assert x == pytest.approx(origin[column] + 0.2 * sum(axis_u), abs=0.011)
    assert _mark(ax, f"target 0 = {METRICS_MARK}").get_marker() == "o"
    image.attrs["metrics_target"] = list(origin + 0.4 * np.asarray(axis_v))
    assert list(target_marks(image)) == ["target 0", "target 1", METRICS_MARK]
    left, right, _, _ = ax.get_images()[0].get_extent()
    start = origin[column] - 0.01 * np.sign(sum(axis_u))
    assert left == pytest.approx(start, abs=1e-9)  # pixel edges, half a 0.02 m cell out
    plt.close(ax.figure)


def test_an_oblique_plane_states_its_axes_in_world_terms():
    from mitsar.plots.figures import plot_image

    image = _plane_image((0.6, 0.8, 0.0), (-0.8, 0.6, 0.0))
    ax = plot_image(image)
    assert ax.get_xlabel() == "u [m] along (0.6, 0.8, 0) from (14.4, 7.3, 0)"
    assert ax.get_ylabel().startswith("v [m] along (-0.8, 0.6, 0)")
    plt.close(ax.figure)


def test_sweep_figures_label_keys_and_quantities_in_words_with_units(tmp_path,
                                                                    monkeypatch):
    """``mitsar sweep`` figures were labelled ``radar.bandwidth`` and ``range_irw_cells
    [cells]``: now "radar bandwidth [Hz]" and "range IRW [cells]"."""
    from mitsar.experiment.sweep import QUANTITIES, plot_sweep
    from mitsar.plots.labels import key_label, quantity_label

    assert key_label("radar.bandwidth") == "radar bandwidth [Hz]"
    assert key_label("background.cell_rcs_db") == "background cell RCS [dB]"
    assert key_label("look.off_nadir_deg") == "look off nadir [deg]"
    assert key_label("simulation.seed") == "simulation seed"
    assert quantity_label("peak_offset_m") == "peak offset [m]"
    assert quantity_label("fraction_resolved", "%") == "fraction resolved [%]"
    assert quantity_label("points") == "points" and key_label("trajectory.points") == (
        "trajectory points [m]")  # a count measured, a key's positions
    bandwidth = [1.0e9, 1.5e9]
    units = {"cells": "cells", "db": "dB", "m": "m"}
    data = {q: (("radar.bandwidth", "realisation", "algorithm"), np.ones((2, 2, 1)),
                {"units": units[q.rsplit("_", 1)[1]]}) for q in QUANTITIES}
    table = xr.Dataset(data, coords={"radar.bandwidth": bandwidth, "realisation": [0, 1],
                                     "algorithm": ["bpa"]},
                       attrs={"varied": json.dumps(["radar.bandwidth"])})
    seen = []
    original = plt.Figure.savefig

    def record(figure, *args, **kwargs):
        seen.append([(ax.get_xlabel(), ax.get_ylabel()) for ax in figure.axes])
        return original(figure, *args, **kwargs)

    monkeypatch.setattr(plt.Figure, "savefig", record)
    written = plot_sweep(table, tmp_path)
    assert len(written) == len(QUANTITIES) - 1
    assert ("radar bandwidth [Hz]", "range IRW [cells]") in [labels[0] for labels in seen]
    assert ("radar bandwidth [Hz]", "peak offset [m]") in [labels[0] for labels in seen]
