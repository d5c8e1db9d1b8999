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
from matplotlib.lines import Line2D
from matplotlib.patches import Patch
from numpy.typing import ArrayLike, NDArray

from mitsar.model.geometry.attitude import Look, antenna_frame
from mitsar.model.radar import Radar
from mitsar.plots import figures  # noqa: F401 - selects the Agg backend first
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
                 title: str = "", camera: Camera | None = None,
                 targets: ArrayLike | None = None) -> Figure:
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
    targets : array_like, shape (n, 3), optional
        Point targets [m], marked in both views (as are the scene's point-target shapes).
    """
    chosen = sorted({0, len(positions) // 2, len(positions) - 1})
    frames = antenna_frame(look, *attitude[chosen].T)
    hits, _ = beam_footprint(scene, positions[chosen], frames, radar, count=(15, 15))
    if camera is None:
        camera = default_camera(positions, hits)
        camera = dataclasses.replace(camera, origin=unobstructed(scene, camera.target,
                                                                 camera.origin))
    kinds = shape_kinds(scene)
    marks = _target_marks(scene, kinds, targets)
    view = render_view(scene, camera)
    seen_all = hits.reshape(-1, 3)[np.isfinite(hits.reshape(-1, 3)[:, 0])]
    low, high = _top_extent(scene, np.vstack([positions, seen_all, marks]))
    top_camera = _top_camera(low, high, float(positions[:, 2].max()))
    top_view = render_view(scene, top_camera)
    aspect = top_camera.width / top_camera.height
    figure, (left, top) = plt.subplots(
        1, 2, figsize=(4.2 * (camera.width / camera.height + aspect) + 0.8, 5.2),
        width_ratios=[camera.width / camera.height, aspect], layout="constrained")
    left.imshow(_picture(view, kinds))
    track_px, front = project(camera, positions)
    left.plot(*track_px[front].T, "k-", lw=2)
    antenna_px, ok = project(camera, positions[[chosen[len(chosen) // 2]]])
    if ok[0]:
        left.plot(*antenna_px[0], "k^", ms=9)
    for colour, points in zip(_SWEEP_COLOURS, hits, strict=False):
        seen = points[np.isfinite(points[:, 0])]
        pixels, ahead = project(camera, seen)
        left.scatter(*pixels[ahead].T, s=4, c=colour)
        top.scatter(seen[:, 0], seen[:, 1], s=4, c=colour)
    marked = False
    if len(marks):
        pixels, ahead = project(camera, marks)
        inside = ahead & (pixels[:, 0] >= 0) & (pixels[:, 0] < camera.width) & (
            pixels[:, 1] >= 0) & (pixels[:, 1] < camera.height)
        left.plot(*pixels[inside].T, **_TARGET_STYLE)
        top.plot(marks[:, 0], marks[:, 1], **_TARGET_STYLE)
        marked = True
    left.set_xlim(0, camera.width)
    left.set_ylim(camera.height, 0)
    left.set_axis_off()
    left.set_title("rendered by Mitsuba (aov integrator), materials by kind", fontsize=10)
    half_y = 0.5 * (high[0] - low[0]) * top_camera.height / top_camera.width
    centre_y = 0.5 * (low[1] + high[1])
    low[1], high[1] = centre_y - half_y, centre_y + half_y  # the rendered pixels' extent
    top.imshow(_picture(top_view, kinds), extent=(low[0], high[0], low[1], high[1]),
               origin="upper", zorder=0)
    top.plot(positions[:, 0], positions[:, 1], "k-", lw=2)
    top.set(xlabel="x [m]", ylabel="y [m]", xlim=(low[0], high[0]), ylim=(low[1], high[1]))
    top.set_title("from above, below the track", fontsize=10)
    top.set_aspect("equal")
    shown = set(view.shape[view.shape >= 0].tolist()) | set(
        top_view.shape[top_view.shape >= 0].tolist())
    handles = [Patch(color=KIND_COLOURS[k], label=k)
               for k in dict.fromkeys(kinds[i] for i in sorted(shown))
               if not (marked and k == "point target")]  # the marker stands for them
    handles += [Line2D([], [], color="k", lw=2, label="track"),
                Line2D([], [], color="k", marker="^", ls="", ms=9, label="antenna (mid-flight)")]
    if marked:
        handles.append(Line2D([], [], label="point target", **_TARGET_STYLE))
    handles += [Line2D([], [], color=colour, marker="o", ls="", ms=4,
                       label=f"beam at sweep {index}")
                for colour, index in zip(_SWEEP_COLOURS, chosen, strict=False)]
    figure.legend(handles=handles, loc="outside lower center", ncol=min(len(handles), 5),
                  fontsize=8, frameon=False)
    figure.suptitle(title or "scene preview")
    return figure


_TARGET_STYLE = {"color": "red", "marker": "x", "ls": "", "ms": 9, "mew": 2}
"""How point targets are marked over both views."""


def _picture(view: Any, kinds: list[str]) -> NDArray:
    """RGB picture of a rendered view: each shape in its kind's colour, lit from over the
    camera's shoulder (faces of different orientation differ), with the outlines of shapes and
    creases (normals more than 25 degrees apart) drawn dark; white where nothing is hit."""
    camera = view.camera
    left, up, forward = camera.frame()
    light = -forward + 0.6 * up + 0.4 * left
    light /= np.linalg.norm(light)
    shade = 0.35 + 0.65 * np.abs(np.einsum("hwi,i->hw", view.normal, light))
    colours = np.array([KIND_COLOURS[k] for k in kinds] + [(1.0, 1.0, 1.0)])
    hit = view.shape >= 0
    picture = colours[np.where(hit, view.shape, -1)] * np.where(hit, shade, 1.0)[..., None]
    edge = np.zeros(view.shape.shape, dtype=bool)
    for axis in (0, 1):
        other = np.roll(view.shape, -1, axis=axis)
        crease = np.abs(np.sum(view.normal * np.roll(view.normal, -1, axis=axis), axis=-1))
        step = (other != view.shape) | (hit & (crease < 0.9))
        if axis == 0:
            step[-1, :] = False
        else:
            step[:, -1] = False
        edge |= step
    picture[edge] = 0.15
    return np.clip(picture, 0.0, 1.0)


def _target_marks(scene: Any, kinds: list[str], targets: ArrayLike | None) -> NDArray:
    """Positions to mark as point targets [m]: the experiment's, and the centres of the
    scene's point-target shapes."""
    marks = [np.asarray(targets, float).reshape(-1, 3)] if targets is not None else []
    for shape, kind in zip(scene.shapes(), kinds, strict=True):
        if kind == "point target":
            box = shape.bbox()
            marks.append(0.5 * (np.array(box.min, float) + np.array(box.max, float))[None])
    return np.vstack(marks) if marks else np.zeros((0, 3))


def _top_extent(scene: Any, points: NDArray) -> tuple[NDArray, NDArray]:
    """The x, y box of the top view [m]: the track, footprints and targets, and every shape
    smaller than them (a reflector, a person, a cabinet: what lies about in the scene; floors,
    walls and rooms larger than the box are cut to it), with a margin."""
    low, high = points.min(axis=0), points.max(axis=0)
    span = float((high - low)[:2].max())
    for shape in scene.shapes():
        box = shape.bbox()
        lo, hi = np.array(box.min, float), np.array(box.max, float)
        if np.all(np.isfinite(lo)) and float((hi - lo)[:2].max()) <= span:
            low, high = np.minimum(low, lo), np.maximum(high, hi)
    margin = 0.05 * float((high - low)[:2].max()) + 0.2
    low, high = low - margin, high + margin
    size = (high - low)[:2]  # widened to an aspect (height / width) of 0.5 to 1.5
    grow = np.array([max(size[1] / 1.5 - size[0], 0.0), max(0.5 * size[0] - size[1], 0.0)])
    low[:2], high[:2] = low[:2] - grow / 2, high[:2] + grow / 2
    return low, high


def _top_camera(low: NDArray, high: NDArray, track_height: float) -> Camera:
    """A camera far above the box looking straight down (x to the right, y up), nearly
    orthographic (0.5 % of a 1 m height at the box's edge), seeing nothing above the track
    plus 0.3 m (a ceiling)."""
    size = high[:2] - low[:2]
    centre = 0.5 * (low + high)
    distance = 200.0 * float(size.max())
    width = 480
    height = int(round(width * size[1] / size[0]))  # the box's aspect, to a pixel
    fov = 2.0 * np.degrees(np.arctan(0.5 * size[0] / distance))
    origin = (float(centre[0]), float(centre[1]), float(low[2]) + distance)
    near = max(origin[2] - (track_height + 0.3), 0.01)
    return Camera(origin=origin, target=(float(centre[0]), float(centre[1]), float(low[2])),
                  up=(0.0, 1.0, 0.0), fov_deg=float(fov), width=width, height=height,
                  near_clip=near)
