"""``mitsar preview``'s figure (issue 26 item 5): the top view is Mitsuba's render from above, so
every shape shows (a user's reflector away from the beam, seen through a ceiling); point targets
are marked where they are and named in the legend only then; the legend covers neither view."""

from __future__ import annotations

import matplotlib.pyplot as plt
import numpy as np
import pytest

import mitsar
from mitsar.plots.preview import _top_camera, _top_extent, plot_preview
from mitsar.plugins.variant import import_mitsuba
from mitsar.scene.render import render_view, stand_in_scene

TRACK_Z = 2.0
FLOOR = {"origin": [0.0, 0.0, 0.0], "axis_u": [1, 0, 0], "axis_v": [0, 1, 0], "size": [10, 10]}
CEILING = {**FLOOR, "origin": [0.0, 0.0, 3.0]}
REFLECTOR = {"origin": [8.6, 0.6, 0.5], "axis_u": [1, 0, 0], "axis_v": [0, 1, 0],
             "size": [0.3, 0.3]}
"""A 0.3 m plate 0.5 m above the floor, behind the end of the track, outside the beam."""


@pytest.fixture(scope="module")
def scene():
    import_mitsuba()
    return stand_in_scene([FLOOR, CEILING, REFLECTOR])


def _track(sweeps: int = 20):
    positions = np.column_stack([np.linspace(3.0, 5.0, sweeps), np.full(sweeps, 1.0),
                                 np.full(sweeps, TRACK_Z)])
    return positions, np.zeros((sweeps, 3))


def test_the_top_view_shows_every_shape_under_the_track(scene):
    positions, _ = _track()
    low, high = _top_extent(scene, np.vstack([positions, [[5.0, 5.0, 0.0]]]))
    # The reflector is inside the box although neither track nor footprint comes near it.
    assert low[0] < 8.6 and high[0] > 8.9 and low[1] < 0.6
    camera = _top_camera(low, high, TRACK_Z)
    view = render_view(scene, camera)
    ids = [shape.id() for shape in scene.shapes()]
    # Pixel of a world (x, y): x to the right from low[0], y up from the top row.
    def pixel(x, y):
        column = int((x - low[0]) / (high[0] - low[0]) * camera.width)
        row = int((0.5 * (low[1] + high[1]) - y) / (high[0] - low[0]) * camera.width
                  + camera.height / 2)
        return row, column
    assert ids[view.shape[pixel(8.75, 0.75)]] == "plane2"  # the reflector, from above
    assert ids[view.shape[pixel(5.0, 5.0)]] == "plane0"  # the floor, under the ceiling


def test_point_targets_are_marked_and_legends_cover_no_view(scene):
    positions, attitude = _track()
    look = mitsar.Look(50.0)
    figure = plot_preview(scene, mitsar.Radar(), look, positions, attitude, title="t")
    labels = [t.get_text() for legend in figure.legends for t in legend.get_texts()]
    assert "point target" not in labels  # nothing to see, nothing named
    assert all(axis.get_legend() is None for axis in figure.axes)
    plt.close(figure)
    target = np.array([[4.0, 4.5, 0.0]])
    figure = plot_preview(scene, mitsar.Radar(), look, positions, attitude, targets=target)
    labels = [t.get_text() for legend in figure.legends for t in legend.get_texts()]
    assert labels.count("point target") == 1
    top = figure.axes[1]
    marked = [line for line in top.get_lines() if line.get_marker() == "x"]
    assert marked and np.allclose(marked[0].get_xydata(), target[:, :2])
    plt.close(figure)
