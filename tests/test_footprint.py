"""The beam on the scene: NR / CS / FR from rays cast into Mitsuba against plane intersections,
and the footprint figure (paper Figs. 12 and 14)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.experiment import example_path, load_experiment, run_simulation
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.plots.figures import save_figure
from mitsar.plots.footprint import plot_footprint, scene_range_marks
from mitsar.scene import load_scene
from mitsar.scene.footprint import beam_directions, beam_footprint, beam_marks

RADAR = mitsar.Radar()
LOOK = mitsar.Look(60.0)  # the paper's dihedral case (§4.3): P0 = [0.4, 8, 1] m, wall y = 10 m
POSITION = np.array([1.0, 8.0, 1.0])
FRAME = antenna_frame(LOOK)


def _plane_hit(direction, normal_axis, level):
    t = (level - POSITION[normal_axis]) / direction[normal_axis]
    return t if t > 0 else math.inf


def test_marks_are_where_the_beam_edges_meet_the_floor_or_the_wall():
    """Each edge of the elevation beam ends on the nearer of the floor (z = 0) and the wall
    (y = 10 m): the traced distance equals the plane intersection (float32 rays: 1e-5 m)."""
    scene = load_scene("dihedral")
    marks = beam_marks(scene, POSITION, FRAME, RADAR)
    half = RADAR.elevation_beamwidth / 2
    edges = sorted((FRAME @ [0.0, s, math.sqrt(1 - s * s)] for s in (half, -half)),
                   key=lambda d: d[2])  # most downward first: near range
    for name, direction in (("NR", edges[0]), ("CS", FRAME[:, 2]), ("FR", edges[1])):
        expected = min(_plane_hit(direction, 2, 0.0), _plane_hit(direction, 1, 10.0))
        assert marks[name] == pytest.approx(expected, abs=1e-5), name
    assert marks["CS"] == pytest.approx(1.0 / math.cos(math.radians(60.0)), abs=1e-5)
    # The far edge is cut by the wall (a floor-only intersection would be farther).
    assert marks["FR"] < _plane_hit(edges[1], 2, 0.0)


def test_footprint_rays_stay_inside_the_beam_and_hit_the_scene():
    directions = beam_directions(RADAR, FRAME, (5, 7))
    local = directions @ FRAME
    assert np.abs(local[:, 0]).max() == pytest.approx(RADAR.azimuth_beamwidth / 2)
    assert np.abs(local[:, 1]).max() == pytest.approx(RADAR.elevation_beamwidth / 2)
    np.testing.assert_allclose(np.linalg.norm(directions, axis=1), 1.0)
    hits, distance = beam_footprint(load_scene("dihedral"), POSITION[None], FRAME[None], RADAR,
                                    (5, 7))
    assert hits.shape == (1, 35, 3) and np.all(np.isfinite(distance))
    on_floor = np.abs(hits[0, :, 2]) < 1e-4
    on_wall = np.abs(hits[0, :, 1] - 10.0) < 1e-4
    assert np.all(on_floor | on_wall) and on_floor.any() and on_wall.any()


def test_footprint_figure_and_image_marks(tmp_path):
    experiment = load_experiment(example_path("dihedral_3d"))
    raw = run_simulation(experiment)
    scene = load_scene(experiment.scene)
    figure = plot_footprint(scene, raw, title="dihedral")
    assert save_figure(figure, tmp_path / "footprint.png").stat().st_size > 10_000
    image = mitsar.focus(raw, grid=experiment.focus.make_grid(),
                         azimuth_resolution=experiment.focus.azimuth_resolution)
    marks = scene_range_marks(image, raw, scene)
    assert set(marks) == {"NR", "CS", "FR"} and marks["NR"] < marks["CS"] < marks["FR"]
    # The image records the mid-aperture antenna: `mitsar plot` draws the same marks from it.
    assert scene_range_marks(image, None, scene) == pytest.approx(marks)
    assert marks["FR"] < 2.2  # the wall cuts the beam (2.14 m) before the floor would
