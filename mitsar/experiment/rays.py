"""``mitsar rays``: trace an experiment's scene and write the ray and echo figures.

The workflow behind paper Figs. 6, 10 and 11: one sweep of the experiment is traced with its
multipath options (:func:`mitsar.raw.traced.trace`), the path log of some rays is taken
(:func:`mitsar.raw.traced.trace_paths`), and the figures of :mod:`mitsar.plots.rays` and a
``summary.json`` are written.
"""

from __future__ import annotations

from pathlib import Path
from typing import Any

import numpy as np

from mitsar import checks
from mitsar.errors import ParameterError
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.options import Experiment
from mitsar.io import write_json
from mitsar.plots.figures import save_figure
from mitsar.plots.rays import (
    beam_marks,
    echo_profiles,
    figure_echoes,
    figure_ray_geometry_2d,
    plane_axes,
    plot_rays_3d,
)
from mitsar.raw.traced import trace, trace_paths
from mitsar.scene import load_scene, sample_surface_points

__all__ = ["run_rays"]


def run_rays(experiment_path: str | Path | Experiment, out: str | Path,
             path_rays: int | None = None, sweep: int = 0,
             overwrite: bool = False) -> dict[str, Any]:
    """Trace an experiment with a scene and write the ray and echo figures and a summary.

    Parameters
    ----------
    experiment_path : path-like or Experiment
        A TOML experiment with a ``scene`` and multipath options in ``[simulation]``.
    out : path-like
        Output folder (created).
    path_rays : int, optional
        Rays in the path log (2D default: the whole fan; 3D: 300).
    sweep : int
        The sweep of the echo profiles and of the path log.

    Returns
    -------
    dict
        The summary (also written to ``summary.json``): NR/CS/FR, echo peaks per order, the
        ratio of the reflections' peak to the backscatter peak, captures.
    """
    if path_rays is not None:
        checks.integer("mitsar rays", "rays", path_rays, 1)
    checks.integer("mitsar rays", "sweep", sweep, 0)
    exp = (experiment_path if isinstance(experiment_path, Experiment)
           else load_experiment(experiment_path))
    if exp.scene is None:
        raise ParameterError(str(exp.source or "experiment"), "scene", "a scene (XML file or "
                             "canned name) to trace rays in", None)
    out = Path(out)
    out.mkdir(parents=True, exist_ok=True)
    options = exp.simulation
    hist = trace(exp.radar, exp.trajectory, exp.look, exp.scene, options=options,
                 sweeps=[sweep])
    planar = options.plane_normal is not None
    count = hist.attrs["rays_per_sweep"]
    if path_rays is None:
        path_rays = count if planar else min(count, 300)
    every_ray = trace_paths(exp.radar, exp.trajectory, exp.look, exp.scene, sweep=sweep,
                            rays=count, options=options)
    paths = every_ray if path_rays >= count else every_ray.isel(
        path=np.unique(np.round(np.linspace(0, count - 1, path_rays)).astype(int)))
    marks = beam_marks(every_ray)
    source = exp.source if exp.source is not None else "experiment"
    name = exp.name or Path(source).stem
    figures = {}
    fig = figure_echoes(hist, marks, title=name)
    figures["echoes"] = save_figure(fig, out / "echoes.png", overwrite=overwrite, dpi=130)
    if planar:
        u, v, _ = plane_axes(paths)
        ends = paths["end"].values[paths["hit"].values]
        bounds = (ends @ u).min(), (ends @ u).max(), (ends @ v).min(), (ends @ v).max()
        fig = figure_ray_geometry_2d(paths, bounds=bounds, title=name)
        figures["rays"] = save_figure(fig, out / "rays_2d.png", overwrite=overwrite, dpi=130)
    else:
        box = np.ptp(paths["end"].values[paths["hit"].values], axis=0).max()
        surfaces = sample_surface_points(load_scene(exp.scene), max(box / 50.0, 0.01))
        ax = plot_rays_3d(paths, every=max(1, len(paths["path"]) // 150),
                          surfaces=surfaces.positions)
        ax.set_title(f"ray geometry: {name}")
        figures["rays"] = save_figure(ax.figure, out / "rays_3d.png", overwrite=overwrite,
                                      dpi=130)
    profiles = echo_profiles(hist, 0)
    back_peak = float(np.abs(profiles["backscatter"]).max())
    reflections = profiles["total"] - profiles["backscatter"]
    refl_peak = float(np.abs(reflections).max())
    orders = hist["histogram"].values[0]
    summary = {
        "experiment": str(source), "marks_m": marks,
        "captures": int(hist.attrs["traced_captures"]),
        "captured_rays_in_log": int((every_ray["captured"].values.sum(axis=1) > 0).sum()),
        "order_power_w": [float(abs(orders[o].sum()) ** 2) for o in range(orders.shape[0])],
        "backscatter_peak": back_peak, "reflections_peak": refl_peak,
        "reflections_over_backscatter_amplitude": refl_peak / back_peak if back_peak else None,
        "reflections_peak_range_m": float(profiles["range"][np.argmax(np.abs(reflections))])
        if refl_peak > 0 else None,
        "figures": {k: str(v) for k, v in figures.items()},
    }
    write_json(summary, out / "summary.json", overwrite=overwrite)
    return summary
