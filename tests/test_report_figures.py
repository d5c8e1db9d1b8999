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
