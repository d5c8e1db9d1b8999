"""Figures of the multipath mechanism: ray geometry and echoes (paper Figs. 4-6, 10, 11).

- :func:`plot_rays_2d` / :func:`figure_ray_geometry_2d`: rays of a path log
  (:func:`mitsar.raw.traced.trace_paths`) in the plane of the 2D mode, coloured by the number of
  reflections, the rays the receiver captures drawn thick (Figs. 4, 5, 10c-d, 11c-d);
- :func:`plot_rays_3d`: the same in 3D, reflection points as crosses (Fig. 6);
- :func:`beam_marks`: near range, centre scene and far range of the illuminated area (NR, CS, FR
  of §4.2-4.3) from the first hits of the rays inside the nominal beam;
- :func:`echo_profiles` / :func:`figure_echoes`: echoes after the range FFT for backscatter only
  (order 0) and the difference that the reflections make (Figs. 10a-b, 11a-b).

``mitsar rays EXPERIMENT.toml -o DIR`` (:func:`mitsar.experiment.rays.run_rays`) traces an
experiment with a scene and writes these figures and a ``summary.json``.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import matplotlib.pyplot as plt
import numpy as np
import xarray as xr
from matplotlib.patches import Rectangle
from numpy.typing import NDArray

from mitsar.focus.compression import range_compress
from mitsar.raw.traced import histogram_to_raw_product

__all__ = ["beam_marks", "echo_profiles", "figure_echoes", "figure_ray_geometry_2d",
           "plane_axes", "plot_echoes", "plot_rays_2d", "plot_rays_3d"]

ORDER_COLOURS = ("0.35", "tab:blue", "tab:red", "tab:green", "tab:purple", "tab:orange",
                 "tab:brown", "tab:pink")
"""Colour of a segment after k reflections (k = 0, 1, 2, ...)."""


def _axes(ax: Any, projection: str | None = None, figsize: tuple[float, float] = (6.4, 4.8)
          ) -> Any:
    if ax is not None:
        return ax
    fig = plt.figure(figsize=figsize)
    return fig.add_subplot(projection=projection)


def plane_axes(paths: xr.Dataset) -> tuple[NDArray, NDArray, tuple[str, str]]:
    """Two in-plane display axes of a 2D path log and their labels.

    The world axis closest to the plane normal is dropped (the paper's y-z plane for the
    normal x); for an oblique plane, the axes are (horizontal in-plane, the rest).
    """
    normal = np.asarray(paths.attrs.get("plane_normal", [1.0, 0.0, 0.0]), dtype=float)
    drop = int(np.argmax(np.abs(normal)))
    if abs(normal[drop]) > 1.0 - 1e-9:
        keep = [i for i in range(3) if i != drop]
        eye = np.eye(3)
        names = ("x", "y", "z")
        return eye[keep[0]], eye[keep[1]], (f"{names[keep[0]]} [m]", f"{names[keep[1]]} [m]")
    u = np.cross(normal, [0.0, 0.0, 1.0])
    u = u / np.linalg.norm(u) if np.linalg.norm(u) > 1e-9 else np.array([1.0, 0.0, 0.0])
    v = np.cross(u, normal)
    return u, v, ("in-plane horizontal [m]", "in-plane [m]")


def plot_rays_2d(paths: xr.Dataset, ax: Any = None, *, bounds: Sequence[float] | None = None,
                 zoom: Sequence[float] | None = None, every: int = 1,
                 mark_zoom: Sequence[float] | None = None) -> Any:
    """Ray geometry of a 2D path log (paper Figs. 4, 5, 10c-d, 11c-d).

    Parameters
    ----------
    paths : xarray.Dataset
        :func:`mitsar.raw.traced.trace_paths` in 2D mode.
    ax : matplotlib Axes, optional
    bounds : (u0, u1, v0, v1), optional
        A rectangle drawn as the room outline (display coordinates, e.g. y-z).
    zoom : (u0, u1, v0, v1), optional
        Axis limits (a magnified view).
    every : int
        Draw every ``every``-th ray (captured rays are always drawn).
    mark_zoom : (u0, u1, v0, v1), optional
        Outline of a magnified area (drawn in black, as Fig. 10c).

    Returns
    -------
    matplotlib Axes
    """
    ax = _axes(ax)
    u, v, labels = plane_axes(paths)
    start = paths["start"].values
    end = paths["end"].values
    alive = paths["alive"].values
    hit = paths["hit"].values
    captured = paths["captured"].values
    n_paths, n_seg = alive.shape
    chosen = np.zeros(n_paths, bool)
    chosen[::max(1, every)] = True
    chosen |= captured.sum(axis=1) > 0
    chosen[[0, -1]] = True
    for i in np.nonzero(chosen)[0]:
        for k in range(n_seg):
            if not alive[i, k]:
                break
            a, b = start[i, k], end[i, k]
            thick = captured[i, k] > 0
            ax.plot([a @ u, b @ u], [a @ v, b @ v], color=ORDER_COLOURS[k % 8],
                    lw=2.0 if thick else 0.5, ls="-" if hit[i, k] else ":",
                    alpha=1.0 if thick else 0.6, zorder=3 if thick else 2)
    # Beam borders (first and last ray of the fan), as the paper's blue dotted and red dashed.
    for i, style in ((0, dict(color="tab:blue", ls=(0, (1, 2)))),
                     (n_paths - 1, dict(color="tab:red", ls="--"))):
        a, b = start[i, 0], end[i, 0]
        ax.plot([a @ u, b @ u], [a @ v, b @ v], lw=1.2, zorder=4, **style)
    tx = paths["transmitter"].values
    rx = paths["receiver"].values
    ax.plot(tx @ u, tx @ v, "o", color="k", ms=6, zorder=5, label="antenna")
    if np.linalg.norm(rx - tx) > 0:
        ax.plot(rx @ u, rx @ v, "o", mfc="none", color="0.4", ms=8, zorder=5, label="receiver")
    if bounds is not None:
        u0, u1, v0, v1 = bounds
        ax.add_patch(Rectangle((u0, v0), u1 - u0, v1 - v0, fill=False, lw=1.5, color="0.2"))
    if mark_zoom is not None:
        u0, u1, v0, v1 = mark_zoom
        ax.add_patch(Rectangle((u0, v0), u1 - u0, v1 - v0, fill=False, lw=1.5, color="k"))
    if zoom is not None:
        ax.set_xlim(zoom[0], zoom[1])
        ax.set_ylim(zoom[2], zoom[3])
    for k in range(n_seg):
        ax.plot([], [], color=ORDER_COLOURS[k % 8], lw=1.0,
                label="direct" if k == 0 else f"after {k} reflection{'s' * (k > 1)}")
    ax.plot([], [], color="k", lw=2.0, label="captured (thick)")
    ax.set_xlabel(labels[0])
    ax.set_ylabel(labels[1])
    ax.set_aspect("equal", adjustable="datalim" if zoom is None else "box")
    return ax


def figure_ray_geometry_2d(paths: xr.Dataset, *, bounds: Sequence[float] | None = None,
                           zoom: Sequence[float] | None = None, every: int = 10,
                           title: str = "") -> Any:
    """Two panels as paper Fig. 10c-d: the ray geometry with the magnified area outlined, and
    the magnification. ``zoom`` defaults to a 1 m box around the captured rays' last hits (or
    around the antenna)."""
    u, v, _ = plane_axes(paths)
    if zoom is None:
        centre = paths["transmitter"].values
        captured = paths["captured"].values > 0
        if captured.any():
            i, k = np.argwhere(captured)[0]
            centre = 0.5 * (paths["start"].values[i, k] + paths["transmitter"].values)
        half = 0.6 * max(0.5, float(np.linalg.norm(centre - paths["transmitter"].values)) + 0.3)
        zoom = (centre @ u - half, centre @ u + half, centre @ v - half, centre @ v + half)
    fig, (left, right) = plt.subplots(1, 2, figsize=(12, 5))
    plot_rays_2d(paths, left, bounds=bounds, every=every, mark_zoom=zoom)
    plot_rays_2d(paths, right, bounds=bounds, zoom=zoom, every=max(1, every // 3))
    left.set_title("(c) ray geometry" + (f": {title}" if title else ""))
    right.set_title("(d) magnified")
    right.legend(loc="best", fontsize=7)
    fig.tight_layout()
    return fig


def plot_rays_3d(paths: xr.Dataset, ax: Any = None, *, every: int = 1,
                 escape: float | None = None, surfaces: NDArray | None = None) -> Any:
    """Rays of a path log in 3D: segments by number of reflections, reflection points as blue
    crosses, the antenna as a black dot, the scene's surfaces as grey points (paper Fig. 6).

    Segments that leave the scene are drawn dotted over ``escape`` metres (default: a third of
    the size of the box holding the hits and the antenna); the axes frame that box.
    ``surfaces`` (N, 3) [m] are points on the scene's surfaces; those inside the box are drawn.
    """
    ax = _axes(ax, projection="3d", figsize=(7, 6))
    start, end = paths["start"].values, paths["end"].values
    alive, hit = paths["alive"].values, paths["hit"].values
    captured = paths["captured"].values
    tx = paths["transmitter"].values
    corners = np.vstack([end[alive & hit], tx[None]])
    lo, hi = corners.min(axis=0), corners.max(axis=0)
    if escape is None:
        escape = max(0.3, float(np.linalg.norm(hi - lo)) / 3)
    points = []
    for i in range(0, alive.shape[0], max(1, every)):
        for k in range(alive.shape[1]):
            if not alive[i, k]:
                break
            a, b = start[i, k], end[i, k]
            if not hit[i, k]:
                b = a + escape * (b - a) / np.linalg.norm(b - a)
            thick = captured[i, k] > 0
            ax.plot(*np.stack([a, b]).T, color=ORDER_COLOURS[k % 8], lw=2.0 if thick else 0.5,
                    ls="-" if hit[i, k] else ":", alpha=0.8)
            if hit[i, k]:
                points.append(b)
    if points:
        points = np.array(points)
        ax.scatter(*points.T, marker="x", color="tab:blue", s=12, label="reflection points")
    ax.scatter(*tx, color="k", s=40, label="antenna")
    margin = 0.05 * float(np.max(hi - lo)) + 0.1
    if surfaces is not None and len(surfaces):
        inside = np.all((surfaces >= lo - margin) & (surfaces <= hi + margin), axis=1)
        ax.scatter(*np.asarray(surfaces)[inside].T, s=1, c="0.75", depthshade=False,
                   label="surfaces")
    ax.set_xlim(lo[0] - margin, hi[0] + margin)
    ax.set_ylim(lo[1] - margin, hi[1] + margin)
    ax.set_zlim(lo[2] - margin, hi[2] + margin)
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    ax.legend(loc="upper left", fontsize=8)
    return ax


def beam_marks(paths: xr.Dataset) -> dict[str, float]:
    """Near range, centre scene and far range of the illuminated area [m] (paper §4.2-4.3).

    From the first hits (segment 0) of the rays whose launch direction lies inside the nominal
    beam (``|p| <= β_p / 2``, ``|q| <= β_q / 2``, the beamwidths of Table 1 as full widths):
    NR = the nearest, FR = the farthest, CS = the boresight's (the rays nearest to it).
    """
    launch = paths["launch"].values
    hit0 = paths["hit"].values[:, 0]
    distance = np.linalg.norm(paths["end"].values[:, 0] - paths["start"].values[:, 0], axis=-1)
    half_p = 0.5 * paths.attrs.get("beamwidth_p", np.inf) or np.inf
    half_q = 0.5 * paths.attrs["beamwidth_q"]
    inside = hit0 & (np.abs(launch[:, 0]) <= half_p) & (np.abs(launch[:, 1]) <= half_q)
    if not inside.any():
        return {"NR": float("nan"), "CS": float("nan"), "FR": float("nan")}
    near = np.argsort(np.hypot(launch[:, 0], launch[:, 1]))[:4]
    near = near[hit0[near]]
    return {"NR": float(distance[inside].min()),
            "CS": float(distance[near].mean()) if len(near) else float("nan"),
            "FR": float(distance[inside].max())}


def echo_profiles(histogram: xr.Dataset, sweep: int = 0, upsample: int = 4
                  ) -> dict[str, NDArray]:
    """Range-compressed echoes of one sweep: backscatter only (order 0) and everything.

    Returns
    -------
    dict
        ``range`` [m], ``backscatter`` and ``total`` (complex profiles; a tone of amplitude a
        peaks at a), ``difference`` = ``|total| - |backscatter|``.
    """
    one = histogram.isel(sweep=[sweep])
    back = range_compress(histogram_to_raw_product(one, orders=0), upsample=upsample)
    total = range_compress(histogram_to_raw_product(one), upsample=upsample)
    b = back["profile"].values[0]
    t = total["profile"].values[0]
    return {"range": back["range"].values, "backscatter": b, "total": t,
            "difference": np.abs(t) - np.abs(b)}


def plot_echoes(profiles: dict[str, NDArray], which: str = "backscatter", ax: Any = None,
                marks: dict[str, float] | None = None, limits: Sequence[float] | None = None
                ) -> Any:
    """One panel of Figs. 10a-b / 11a-b: ``|backscatter|`` or the ``difference``, with NR, CS and
    FR marked."""
    ax = _axes(ax)
    values = np.abs(profiles[which]) if which != "difference" else profiles["difference"]
    ax.plot(profiles["range"], values, lw=1.0, color="k" if which != "difference" else "tab:red")
    for name, style in (("NR", ":"), ("CS", "--"), ("FR", "-.")):
        if marks and np.isfinite(marks.get(name, np.nan)):
            ax.axvline(marks[name], color="tab:blue", ls=style, lw=1.0)
            ax.text(marks[name], 0.97, f" {name}", transform=ax.get_xaxis_transform(),
                    va="top", fontsize=8, color="tab:blue")
    if limits is not None:
        ax.set_xlim(*limits)
    ax.set_xlabel("range [m]")
    ax.set_ylabel("echo amplitude [√W]" if which != "difference"
                  else "|total| − |backscatter| [√W]")
    return ax


def figure_echoes(histogram: xr.Dataset, marks: dict[str, float] | None = None,
                  sweep: int = 0, limits: Sequence[float] | None = None, title: str = "") -> Any:
    """Two panels as paper Fig. 10a-b: backscatter-only echoes after the range FFT, and the
    difference the reflections make."""
    profiles = echo_profiles(histogram, sweep)
    if limits is None and marks and np.all(np.isfinite(list(marks.values()))):
        span = marks["FR"] - marks["NR"]
        limits = (marks["NR"] - 0.5 * span, marks["FR"] + 0.5 * span)
    fig, (top, bottom) = plt.subplots(2, 1, figsize=(7, 6.5), sharex=True)
    plot_echoes(profiles, "backscatter", top, marks, limits)
    plot_echoes(profiles, "difference", bottom, marks, limits)
    top.set_title("(a) backscatter only, after the range FFT" + (f": {title}" if title else ""))
    bottom.set_title("(b) (backscatter + reflections) − backscatter")
    fig.tight_layout()
    return fig
