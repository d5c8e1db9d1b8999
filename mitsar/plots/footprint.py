"""The beam on the scene along the trajectory (paper Figs. 12 and 14), and scene-based marks.

* :func:`plot_footprint` — the scene's surfaces (points about evenly spread on every shape), the
  antenna track and the beam's footprint (first hits of rays inside the nominal beam,
  :func:`mitsar.scene.footprint.beam_footprint`) at the first, middle and last sweep, in 3-D
  and from above;
* :func:`scene_range_marks` — NR / CS / FR of an image from the beam's intersection with the
  scene at the middle sweep (:func:`mitsar.scene.footprint.beam_marks`), in the slant grid's
  range coordinate, for :func:`mitsar.plots.figures.plot_image`.
"""

from __future__ import annotations

import math
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.figure import Figure

from mitsar.model.geometry.attitude import antenna_frame
from mitsar.plots import figures  # noqa: F401 - selects the Agg backend first
from mitsar.products.image import vector_attr
from mitsar.products.raw import look_of, radar_of
from mitsar.scene.footprint import beam_footprint, beam_marks
from mitsar.scene.surfaces import sample_surface_points

__all__ = ["plot_footprint", "scene_range_marks"]

_SURFACE_POINTS = 6000
"""About this many points draw the scene's surfaces."""

_COLOURS = ("tab:blue", "tab:orange", "tab:red")


def _track(raw: xr.Dataset) -> tuple[np.ndarray, np.ndarray]:
    """Antenna positions and attitudes of the true track (the one the beam really swept)."""
    prefix = "true_" if "true_platform_position" in raw.variables else ""
    return raw[f"{prefix}platform_position"].values, raw[f"{prefix}attitude"].values


def plot_footprint(scene: Any, raw: xr.Dataset, title: str = "", rays: int = 21) -> Figure:
    """Surfaces, track and beam footprint at the first, middle and last sweep (3-D and top).

    Parameters
    ----------
    scene : mitsuba.Scene
        The loaded scene (:func:`mitsar.scene.load_scene`).
    raw : xarray.Dataset
        A raw product of the acquisition (its track, attitude, radar and look).
    title : str
        Figure title.
    rays : int
        Rays across each beam axis.
    """
    radar, look = radar_of(raw), look_of(raw)
    positions, attitude = _track(raw)
    chosen = sorted({0, len(positions) // 2, len(positions) - 1})
    frames = antenna_frame(look, *attitude[chosen].T)
    hits, _ = beam_footprint(scene, positions[chosen], frames, radar, count=(rays, rays))
    # The region the beam sweeps (track and footprints, 0.5 m around), drawn with its surfaces.
    seen_all = hits.reshape(-1, 3)[np.isfinite(hits.reshape(-1, 3)[:, 0])]
    corners = np.vstack([positions, seen_all])
    low, high = corners.min(axis=0) - 0.5, corners.max(axis=0) + 0.5
    surfaces = scene_surfaces_points(scene, float((high - low).max()) / 60.0)
    inside = np.all((surfaces >= low) & (surfaces <= high), axis=1)
    surfaces = surfaces[inside]
    figure = plt.figure(figsize=(12, 5.2), layout="constrained")
    ax3 = figure.add_subplot(1, 2, 1, projection="3d")
    top = figure.add_subplot(1, 2, 2)
    ax3.scatter(*surfaces.T, s=1, c="0.75", depthshade=False, label="surfaces")
    top.scatter(surfaces[:, 0], surfaces[:, 1], s=1, c="0.8")
    ax3.plot(*positions.T, "k", lw=2, label="track")
    top.plot(positions[:, 0], positions[:, 1], "k", lw=2, label="track")
    for colour, index, points in zip(_COLOURS, chosen, hits, strict=False):
        seen = np.isfinite(points[:, 0])
        label = f"beam at sweep {index}"
        ax3.scatter(*points[seen].T, s=4, c=colour, depthshade=False, label=label)
        top.scatter(points[seen, 0], points[seen, 1], s=4, c=colour, label=label)
        for corner in _outline(points.reshape(rays, rays, 3)):
            ax3.plot(*np.stack([positions[index], corner]).T, c=colour, lw=0.6)
    ax3.set(xlabel="x [m]", ylabel="y [m]", zlabel="z [m]", xlim=(low[0], high[0]),
            ylim=(low[1], high[1]), zlim=(low[2], high[2]))
    ax3.legend(loc="upper left", fontsize=8)
    top.set(xlabel="x [m]", ylabel="y [m]", title="top view", xlim=(low[0], high[0]),
            ylim=(low[1], high[1]))
    top.set_aspect("equal")
    top.legend(fontsize=8, loc="upper center", bbox_to_anchor=(0.5, -0.12), ncols=4)  # off the beam
    figure.suptitle(title or "beam footprint on the scene (paper Figs. 12, 14)")
    return figure


def _outline(grid: np.ndarray) -> list[np.ndarray]:
    """The four corner rays' hits of a (rays, rays, 3) footprint grid that hit something."""
    corners = [grid[0, 0], grid[0, -1], grid[-1, 0], grid[-1, -1]]
    return [c for c in corners if np.all(np.isfinite(c))]


def scene_surfaces_points(scene: Any, spacing: float) -> np.ndarray:
    """Points about ``spacing`` apart on the scene's surfaces, at most about
    :data:`_SURFACE_POINTS` per 10 m² more than the finest drawing needs [m]."""
    probe = sample_surface_points(scene, 1.0)
    total = float(probe.area.sum())
    floor = math.sqrt(total / (50 * _SURFACE_POINTS)) if total > 0 else spacing
    return sample_surface_points(scene, max(spacing, floor, 1e-3)).positions


def scene_range_marks(image: xr.Dataset, raw: xr.Dataset | None, scene: Any
                      ) -> dict[str, float]:
    """NR / CS / FR of a slant-grid image from the beam's first hits in the scene [m].

    Distances from the slant grid's track line (its range coordinate) of where the lower edge,
    the boresight and the upper edge of the elevation beam first meet the scene, at the middle
    sweep of the true track (of ``raw``, or as the image recorded it). Empty for other grids.
    """
    if image.attrs.get("grid_kind") != "slant":
        return {}
    if raw is not None:
        positions, attitude = _track(raw)
        position, angles = positions[len(positions) // 2], attitude[len(positions) // 2]
    elif "mid_platform_attitude" in image.attrs:
        position = vector_attr(image, "mid_platform_position")
        angles = vector_attr(image, "mid_platform_attitude")
    else:
        return {}
    frame = antenna_frame(look_of(image), *angles)
    origin = vector_attr(image, "grid_origin")
    along = vector_attr(image, "grid_along_track")
    return beam_marks(scene, position, frame, radar_of(image), origin, along)
