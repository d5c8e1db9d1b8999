"""``mitsar preview``: a picture of an experiment before anything is simulated.

Any bundled or user experiment: its XML scene (or, without one, a stand-in made of the
ambiguity file's rectangles, the point targets and a floor under them), rendered by Mitsuba,
with the trajectory, the antenna and the beam's footprint at the first, middle and last sweep
(:func:`mitsar.plots.preview.plot_preview`). Ambiguity files show their first trajectory.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from mitsar.ambiguity.config import load_ambiguity_experiment
from mitsar.experiment.loading import experiment_from_dict, read_toml
from mitsar.io import check_writable
from mitsar.model.signal import sweep_count
from mitsar.plots.figures import save_figure
from mitsar.plots.preview import plot_preview
from mitsar.plugins.variant import import_mitsuba
from mitsar.raw.product import sweep_geometry
from mitsar.scene import load_scene
from mitsar.scene.render import stand_in_scene

__all__ = ["preview", "scene_or_stand_in"]

_FLOOR_MARGIN = 3.0
"""Half-size added around the targets and the track for a stand-in floor [m]."""


def preview(path: str | Path, out: str | Path, overwrite: bool = False) -> Path:
    """Write the preview figure of an experiment or ambiguity file to ``out`` (PNG/PDF/SVG)."""
    path = Path(path)
    check_writable(out, overwrite)
    document = read_toml(path)
    if "trajectories" in document or ("ambiguity" in document and "targets" not in document):
        spec = load_ambiguity_experiment(path)
        name, trajectory = next(iter(spec["trajectories"].items()))
        look = spec["look"][name] if isinstance(spec["look"], dict) else spec["look"]
        radar, scene_name, planes, points = spec["radar"], spec["scene"], spec["planes"], []
        title = f"{spec['name'] or path.stem}: trajectory {name!r}"
    else:
        experiment = experiment_from_dict(document, source=path)
        radar, look, trajectory = experiment.radar, experiment.look, experiment.trajectory
        scene_name, planes = experiment.scene, []
        points = [np.asarray(t.position, float) for t in experiment.targets]
        title = experiment.name or path.stem
    geometry = sweep_geometry(radar, trajectory, look, max(sweep_count(radar,
                                                                      trajectory.duration), 1))
    scene = scene_or_stand_in(None if scene_name is None else load_scene(scene_name), planes,
                              points, geometry.position)
    figure = plot_preview(scene, radar, look, geometry.position, geometry.attitude,
                          title=title, targets=np.array(points).reshape(-1, 3))
    written = save_figure(figure, out, overwrite=overwrite, dpi=110)
    plt.close(figure)
    return written


def scene_or_stand_in(scene: Any, planes: list[dict], points: list,
                      positions: np.ndarray) -> Any:
    """The experiment's loaded scene (a ``mitsuba.Scene``), or when it is None a stand-in:
    its rectangles, else a floor under the targets and the track (:data:`_FLOOR_MARGIN` around
    them), with the targets as spheres.

    Parameters
    ----------
    scene : mitsuba.Scene or None
        The scene, loaded once by the caller.
    planes : list of dict
        Rectangles of an ambiguity file (``origin``, ``axis_u``, ``axis_v``, ``size`` [m]).
    points : list of array_like
        Point targets' positions [m].
    positions : ndarray, shape (sweeps, 3)
        Antenna positions [m].
    """
    if scene is not None:
        return scene
    import_mitsuba()
    if not planes:
        corners = np.vstack([positions] + ([np.array(points)] if points else []))
        low = corners.min(axis=0) - _FLOOR_MARGIN
        size = corners.max(axis=0) + _FLOOR_MARGIN - low
        floor_z = min(p[2] for p in points) if points else 0.0
        planes = [{"origin": [low[0], low[1], floor_z], "axis_u": [1, 0, 0],
                   "axis_v": [0, 1, 0], "size": [size[0], size[1]]}]
    return stand_in_scene(planes, points)
