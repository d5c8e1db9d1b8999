"""Scene preview: Mitsuba's own picture of the scene with the flight and the beam drawn in.

:func:`plot_preview` shows, left, a camera view rendered by Mitsuba
(:func:`mitsar.scene.render.render_view`), shaded by the surface's angle to the camera and
coloured by what each shape is made of (radar surface, absorber, point target, no radar
material), with the trajectory, the antenna at mid-flight and the beam's footprint at the
first, middle and last sweep projected into it; right, the same from above.
"""

from __future__ import annotations

import dataclasses
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
from matplotlib.figure import Figure
from matplotlib.patches import Patch
from numpy.typing import NDArray

from mitsar.model.geometry.attitude import Look, antenna_frame
from mitsar.model.radar import Radar
from mitsar.plots import figures  # noqa: F401 - selects the Agg backend first
from mitsar.plots.footprint import scene_surfaces_points
from mitsar.scene.footprint import beam_footprint
from mitsar.scene.render import Camera, project, render_view, shape_kinds, unobstructed

__all__ = ["KIND_COLOURS", "default_camera", "plot_preview"]

KIND_COLOURS = {"radar surface": (0.80, 0.74, 0.62), "absorber": (0.25, 0.25, 0.25),
                "point target": (0.85, 0.15, 0.15), "no radar material": (0.45, 0.6, 0.85)}
"""Colour of each kind of shape (:func:`mitsar.scene.render.shape_kinds`)."""

_SWEEP_COLOURS = ("tab:blue", "tab:orange", "tab:green")


def default_camera(positions: NDArray, hits: NDArray, width: int = 640,
                   height: int = 480) -> Camera:
    """A camera behind and above the track, looking at the middle footprint."""
    seen = hits.reshape(-1, 3)[np.isfinite(hits.reshape(-1, 3)[:, 0])]
    centre = seen.mean(axis=0) if len(seen) else positions.mean(axis=0) + [0.0, 0.0, -1.0]
    middle = positions[len(positions) // 2]
    back = middle - centre
    back[2] = 0.0
    span = max(float(np.linalg.norm(back)), 1.0)
    back = back / span if np.linalg.norm(back) > 0 else np.array([0.0, -1.0, 0.0])
    track = positions[-1] - positions[0]
    side = track / max(np.linalg.norm(track), 1e-9)
    origin = middle + 0.8 * span * back - 0.6 * span * side + [0.0, 0.0, 0.6 * span + 1.0]
    return Camera(tuple(origin), tuple(centre), fov_deg=70.0, width=width, height=height)


def plot_preview(scene: Any, radar: Radar, look: Look, positions: NDArray, attitude: NDArray,
                 title: str = "", camera: Camera | None = None) -> Figure:
    """The preview figure (module docstring).

    Parameters
    ----------
    scene : mitsuba.Scene
    radar, look : Radar, Look
    positions, attitude : ndarray, shape (sweeps, 3)
        Antenna positions [m] and heading, pitch, roll [rad] at mid-sweep.
    title : str
    camera : Camera, optional
        Default: :func:`default_camera`.
    """
    chosen = sorted({0, len(positions) // 2, len(positions) - 1})
    frames = antenna_frame(look, *attitude[chosen].T)
    hits, _ = beam_footprint(scene, positions[chosen], frames, radar, count=(15, 15))
    if camera is None:
        camera = default_camera(positions, hits)
        camera = dataclasses.replace(camera, origin=unobstructed(scene, camera.target,
                                                                 camera.origin))
    view = render_view(scene, camera)
    kinds = shape_kinds(scene)
    colours = np.array([KIND_COLOURS[k] for k in kinds] + [(1.0, 1.0, 1.0)])
    _, _, forward = camera.frame()
    shade = 0.35 + 0.65 * np.abs(np.einsum("hwi,i->hw", view.normal, forward))
    picture = colours[np.where(view.shape >= 0, view.shape, -1)] * np.where(
        view.shape >= 0, shade, 1.0)[..., None]
    figure, (left, top) = plt.subplots(1, 2, figsize=(13, 5), layout="constrained")
    left.imshow(np.clip(picture, 0, 1))
    track_px, front = project(camera, positions)
    left.plot(*track_px[front].T, "k-", lw=2, label="track")
    antenna_px, ok = project(camera, positions[[chosen[len(chosen) // 2]]])
    if ok[0]:
        left.plot(*antenna_px[0], "k^", ms=9, label="antenna (mid-flight)")
    for colour, index, points in zip(_SWEEP_COLOURS, chosen, hits, strict=False):
        seen = points[np.isfinite(points[:, 0])]
        pixels, ahead = project(camera, seen)
        left.scatter(*pixels[ahead].T, s=4, c=colour, label=f"beam at sweep {index}")
        top.scatter(seen[:, 0], seen[:, 1], s=4, c=colour, label=f"beam at sweep {index}")
    left.set_xlim(0, camera.width)
    left.set_ylim(camera.height, 0)
    left.set_axis_off()
    left.set_title("rendered by Mitsuba (aov integrator), materials by kind")
    handles = [Patch(color=KIND_COLOURS[k], label=k) for k in dict.fromkeys(kinds)]
    left.legend(handles=handles + left.get_legend_handles_labels()[0], fontsize=8,
                loc="lower left")
    seen_all = hits.reshape(-1, 3)[np.isfinite(hits.reshape(-1, 3)[:, 0])]
    corners = np.vstack([positions, seen_all])
    low, high = corners.min(axis=0) - 0.5, corners.max(axis=0) + 0.5
    surfaces = scene_surfaces_points(scene, float((high - low)[:2].max()) / 80.0)
    inside = np.all((surfaces[:, :2] >= low[:2]) & (surfaces[:, :2] <= high[:2]), axis=1)
    top.scatter(surfaces[inside, 0], surfaces[inside, 1], s=1, c="0.8", zorder=0)
    top.plot(positions[:, 0], positions[:, 1], "k-", lw=2, label="track")
    top.set(xlabel="x [m]", ylabel="y [m]", title="top view")
    top.set_aspect("equal")
    top.legend(fontsize=8)
    figure.suptitle(title or "scene preview")
    return figure
