"""``mitsar preview``: Mitsuba's picture of every bundled experiment, and the footprint drawn
where the beam meets the scene."""

from __future__ import annotations

import numpy as np
import pytest

import mitsar
from mitsar.cli import main
from mitsar.experiment.examples import example_path, examples_dir
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.scene import load_scene
from mitsar.scene.footprint import beam_footprint
from mitsar.scene.render import Camera, project, render_view

RADAR = mitsar.Radar()


@pytest.mark.parametrize("name", sorted(p.stem for p in examples_dir().glob("*.toml")))
def test_every_bundled_experiment_previews(name, tmp_path):
    out = tmp_path / f"{name}.png"
    assert main(["preview", str(example_path(name)), "-o", str(out), "-q"]) == 0
    assert out.stat().st_size > 20_000
    assert main(["preview", str(example_path(name)), "-o", str(out), "-q"]) == 2  # no overwrite


def test_footprint_lies_where_the_beam_meets_the_rendered_scene():
    """Every footprint point, projected into Mitsuba's render, lands on a pixel that shows a
    surface at the same distance from the camera (within the depth change across one pixel,
    5 cm here) and on the shape its ray hit."""
    scene = load_scene("dihedral")
    position = np.array([1.0, 8.0, 1.0])
    frame = antenna_frame(mitsar.Look(60.0))
    hits, _ = beam_footprint(scene, position[None], frame[None], RADAR, (9, 9))
    points = hits[0][np.isfinite(hits[0][:, 0])]
    camera = Camera(origin=(0.2, 6.5, 3.0), target=tuple(points.mean(axis=0)), width=400,
                    height=300, fov_deg=60.0)
    view = render_view(scene, camera)
    pixels, ahead = project(camera, points)
    assert ahead.all()
    column, row = np.rint(pixels).astype(int).T
    inside = (column >= 0) & (column < camera.width) & (row >= 0) & (row < camera.height)
    assert inside.mean() > 0.95
    distance = np.linalg.norm(points - np.asarray(camera.origin), axis=1)
    # The render's depth is the distance along the pixel's own ray (through its centre).
    np.testing.assert_allclose(view.depth[row[inside], column[inside]], distance[inside],
                               atol=0.05)
    ids = [shape.id() for shape in scene.shapes()]
    expected = np.where(np.abs(points[inside, 2]) < 1e-3, ids.index("floor"),
                        ids.index("wall_y10"))
    shown = view.shape[row[inside], column[inside]]
    assert np.mean(shown == expected) > 0.9  # pixels on the floor/wall edge may show either


def test_preview_prints_no_mitsuba_film_warning(tmp_path):
    """Mitsuba's ``WARN [HDRFilm] Monochrome mode enabled`` (printed by its C++ logger, in red)
    is not provoked: the film asks for the luminance a mono variant develops anyway."""
    import subprocess
    import sys

    out = tmp_path / "preview.png"
    done = subprocess.run([sys.executable, "-m", "mitsar", "preview",
                           str(example_path("paper_point_target")), "-o", str(out)],
                          capture_output=True, text=True, timeout=300, check=True)
    assert out.is_file()
    assert "HDRFilm" not in done.stdout + done.stderr
    assert "WARN" not in done.stdout + done.stderr
