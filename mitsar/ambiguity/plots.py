"""Figures of ambiguity products: unfolded maps, a 3-D view, a time line, a comparison.

Matplotlib is imported lazily (with the ``Agg`` backend) so that computing maps does not need
it; every figure is written atomically and never overwrites a file unless asked.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.ambiguity.maps import STATUS_MEANINGS
from mitsar.io import atomic_output

__all__ = ["plot_ambiguity", "plot_ambiguity_3d", "plot_ambiguity_maps",
           "plot_ambiguity_timeline", "plot_comparison"]

_STATUS_COLOURS = ("#bdbdbd", "#636363", "#e6550d", "#31a354")
"""Colours of the status codes 0..3 (never in beam, shadowed, only ambiguous, resolved)."""


def _requirement_text(attrs: Mapping[str, Any]) -> str:
    required = float(attrs.get("required_resolution", 0.1))
    r = float(attrs.get("required_range_resolution", required))
    a = float(attrs.get("required_azimuth_resolution", required))
    return f"{r:g} m" if r == a else f"{r:g} m (range) x {a:g} m (azimuth)"


def _pyplot() -> Any:
    import matplotlib  # lazy: matplotlib is needed for figures only

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(figure: Any, path: str | os.PathLike, overwrite: bool) -> Path:
    path = Path(path)
    with atomic_output(path, overwrite) as tmp:
        figure.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=120)
    _pyplot().close(figure)
    return path


def _status_colormap() -> tuple[Any, Any]:
    from matplotlib.colors import BoundaryNorm, ListedColormap  # lazy: see _pyplot

    return ListedColormap(_STATUS_COLOURS), BoundaryNorm(np.arange(-0.5, 4.5), 4)


def _marker_size(u: NDArray, v: NDArray, area: NDArray, width_in: float) -> float:
    extent = max(np.ptp(u), np.ptp(v), 1e-6)
    step = math.sqrt(max(float(np.median(area)), 1e-12))
    points = width_in * 72 * step / (extent + step)
    return max(1.0, points**2)


def plot_ambiguity_maps(product: xr.Dataset, path: str | os.PathLike | None = None, *,
                        overwrite: bool = False, max_facets: int = 8) -> Any:
    """Unfolded maps per planar facet: status, best range and best azimuth resolution.

    One row per facet (a wall, the floor, a face of a box), the ``max_facets`` largest ones.
    """
    plt = _pyplot()
    from matplotlib.colors import LogNorm  # lazy: see _pyplot

    required = float(product.attrs.get("required_resolution", 0.1))
    required_by_key = {
        "best_range_resolution": float(product.attrs.get("required_range_resolution",
                                                         required)),
        "best_azimuth_resolution": float(product.attrs.get("required_azimuth_resolution",
                                                           required))}
    index = product["facet_index"].values
    facet_area = np.bincount(index, weights=product["area"].values,
                             minlength=product.sizes["facet"])
    chosen = [int(i) for i in np.argsort(-facet_area, kind="stable")[:max_facets]
              if facet_area[i] > 0]
    cmap, norm = _status_colormap()
    res_norm = LogNorm(vmin=required / 3, vmax=required * 30)
    figure, axes = plt.subplots(len(chosen), 3, figsize=(13, 2.6 * len(chosen) + 0.6),
                                squeeze=False, layout="constrained")
    for row, facet in enumerate(chosen):
        mask = index == facet
        u, v = product["map_u"].values[mask], product["map_v"].values[mask]
        size = _marker_size(u, v, product["area"].values[mask], 3.8)
        name = str(product["facet"].values[facet])
        ax = axes[row, 0]
        im = ax.scatter(u, v, c=product["status"].values[mask], cmap=cmap, norm=norm, s=size,
                        marker="s", linewidths=0)
        ax.set_title(f"{name}: status")
        bar = figure.colorbar(im, ax=ax, ticks=range(4))
        bar.ax.set_yticklabels([m.replace("_", " ") for m in STATUS_MEANINGS], fontsize=7)
        for col, key in ((1, "best_range_resolution"), (2, "best_azimuth_resolution")):
            ax = axes[row, col]
            values = product[key].values[mask]
            missing = ~np.isfinite(values)
            ax.scatter(u[missing], v[missing], c="#dddddd", s=size, marker="s", linewidths=0)
            im = ax.scatter(u[~missing], v[~missing], c=values[~missing], cmap="viridis_r",
                            norm=res_norm, s=size, marker="s", linewidths=0)
            ax.set_title(f"{name}: {key.replace('_', ' ')} [m]")
            bar = figure.colorbar(im, ax=ax)
            bar.ax.axhline(required_by_key[key], color="red", linewidth=2)
        for ax in axes[row]:
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel("map u [m]")
            ax.set_ylabel("map v [m]")
    figure.suptitle(f"Gradient method: required {_requirement_text(product.attrs)}, min "
                    "angle "
                    f"{product.attrs.get('min_angle_deg', 0):g} deg; grey: not observed; "
                    "red line: requirement")
    if path is not None:
        return _save(figure, path, overwrite)
    return figure


def plot_ambiguity_3d(product: xr.Dataset, path: str | os.PathLike | None = None, *,
                      overwrite: bool = False, max_points: int = 40000) -> Any:
    """A 3-D view: surface points coloured by status, and the platform track."""
    plt = _pyplot()
    cmap, norm = _status_colormap()
    position = product["position"].values
    step = max(1, len(position) // max_points)
    figure = plt.figure(figsize=(9, 7), layout="constrained")
    ax = figure.add_subplot(projection="3d")
    im = ax.scatter(*position[::step].T, c=product["status"].values[::step], cmap=cmap,
                    norm=norm, s=3, depthshade=False)
    track = product["platform_position"].values
    ax.plot(*track.T, color="black", linewidth=2, label="track")
    ax.scatter(*track[0], color="black", marker="o", s=30, label="start")
    mid = len(track) // 2
    reach = 0.3 * float(np.ptp(position, axis=0).max() or 1.0)
    ax.quiver(*track[mid], *(product["boresight"].values[mid] * reach), color="red",
              label="boresight (mid)")
    span = np.ptp(np.vstack([position, track]), axis=0)
    ax.set_box_aspect(np.maximum(span, 0.05 * span.max()))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    bar = figure.colorbar(im, ax=ax, ticks=range(4), shrink=0.6)
    bar.ax.set_yticklabels([m.replace("_", " ") for m in STATUS_MEANINGS])
    ax.legend(loc="upper left")
    ax.set_title("Observation status over the trajectory")
    if path is not None:
        return _save(figure, path, overwrite)
    return figure


def plot_ambiguity_timeline(product: xr.Dataset, path: str | os.PathLike | None = None, *,
                            overwrite: bool = False) -> Any:
    """Along the track: area illuminated and resolved, and median resolutions, vs time."""
    plt = _pyplot()
    time = product["time"].values
    rows = 2 if "range_resolution" in product else 1
    figure, axes = plt.subplots(rows, 1, figsize=(9, 3.2 * rows), sharex=True, squeeze=False,
                                layout="constrained")
    ax = axes[0, 0]
    ax.plot(time, 100 * product["observed_fraction"].values, label="illuminated")
    ax.plot(time, 100 * product["resolved_fraction"].values, label="resolved (unambiguous)")
    ax.plot(time, 100 * product["cumulative_resolved_fraction"].values,
            label="resolved so far", linestyle="--")
    ax.set_ylabel("area [%]")
    ax.legend()
    ax.grid(alpha=0.3)
    if rows == 2:
        ax = axes[1, 0]
        lit = product["observation"].values >= 2
        for key, label in (("range_resolution", "range"), ("azimuth_resolution", "azimuth")):
            values = np.where(lit, product[key].values, np.nan)
            with np.errstate(all="ignore"):
                finite = np.where(np.isfinite(values), values, np.nan)
                counts = np.sum(~np.isnan(finite), axis=0)
                median = np.full(len(time), np.nan)
                has = counts > 0
                median[has] = np.nanmedian(finite[:, has], axis=0)
            ax.semilogy(time, median, label=f"median {label} resolution (illuminated)")
        attrs = product.attrs
        required = float(attrs.get("required_resolution", 0.1))
        ax.axhline(float(attrs.get("required_range_resolution", required)), color="C0",
                   linestyle=":", label="required (range)")
        ax.axhline(float(attrs.get("required_azimuth_resolution", required)), color="C1",
                   linestyle=":", label="required (azimuth)")
        ax.set_ylabel("resolution [m]")
        ax.legend()
        ax.grid(alpha=0.3, which="both")
    axes[-1, 0].set_xlabel("time [s]")
    figure.suptitle("Resolution and observation along the trajectory")
    if path is not None:
        return _save(figure, path, overwrite)
    return figure


def plot_ambiguity(product: xr.Dataset, out_dir: str | os.PathLike, prefix: str = "ambiguity",
                   *, overwrite: bool = False, suffix: str = ".png") -> list[Path]:
    """Write the maps, the 3-D view and the time line of a product into ``out_dir``."""
    out_dir = Path(out_dir)
    return [plot_ambiguity_maps(product, out_dir / f"{prefix}_maps{suffix}",
                                overwrite=overwrite),
            plot_ambiguity_3d(product, out_dir / f"{prefix}_3d{suffix}", overwrite=overwrite),
            plot_ambiguity_timeline(product, out_dir / f"{prefix}_timeline{suffix}",
                                    overwrite=overwrite)]


def plot_comparison(comparison: xr.Dataset, path: str | os.PathLike | None = None, *,
                    overwrite: bool = False) -> Any:
    """Candidate trajectories side by side: resolved area per surface and overall status."""
    plt = _pyplot()
    names = [str(n) for n in comparison["trajectory"].values]
    surfaces = [str(s) for s in comparison["surface"].values]
    tracks = json.loads(comparison.attrs.get("tracks", "{}"))
    position = comparison["position"].values
    extent = np.vstack([position[:, :2]] + [np.asarray(t)[:, :2] for t in tracks.values()])
    low, high = extent.min(axis=0), extent.max(axis=0)
    margin = 0.03 * float(np.max(high - low) or 1.0)
    # The top views keep x and y to scale: their row is as tall as a panel's width times the
    # scene's aspect (a fixed height left a blank band around a long, narrow room).
    width, columns = max(9, 1.2 * len(surfaces) + 4), max(2, len(names))
    span = np.maximum(high - low + 2 * margin, 1e-9)
    maps = float(np.clip((width / columns - 0.7) * span[1] / span[0], 0.8, 6.0)) + 0.9
    figure = plt.figure(figsize=(width, 4 + maps + 0.3), layout="constrained")
    grid = figure.add_gridspec(2, columns, height_ratios=(4, maps))
    ax = figure.add_subplot(grid[0, :])
    width = 0.8 / len(names)
    x = np.arange(len(surfaces) + 1)
    for i, name in enumerate(names):
        values = list(100 * comparison["fraction_resolved"].values[i])
        values.append(100 * float(comparison["total_fraction_resolved"].values[i]))
        ax.bar(x - 0.4 + width * (i + 0.5), values, width, label=name)
    ax.set_xticks(x, surfaces + ["all"], rotation=20)
    ax.set_ylabel("area resolved [%]")
    ax.set_ylim(0, 100)
    ax.legend()
    ax.grid(alpha=0.3, axis="y")
    ax.set_title(f"Area observed at {_requirement_text(comparison.attrs)} without ambiguity")
    cmap, norm = _status_colormap()
    order = np.argsort(-position[:, 2], kind="stable")  # top view: the lowest drawn last
    for i, name in enumerate(names):
        axis = figure.add_subplot(grid[1, i])
        axis.scatter(position[order, 0], position[order, 1],
                     c=comparison["status"].values[i][order], cmap=cmap, norm=norm, s=2,
                     linewidths=0)
        if name in tracks:
            track = np.asarray(tracks[name])
            axis.plot(track[:, 0], track[:, 1], color="black", linewidth=1.5)
            axis.plot(track[0, 0], track[0, 1], "ko", markersize=4)
        axis.set_xlim(low[0] - margin, high[0] + margin)
        axis.set_ylim(low[1] - margin, high[1] + margin)
        axis.set_aspect("equal")
        axis.set_title(f"{name}: status (top view)", fontsize=9)
        axis.set_xlabel("x [m]")
        axis.set_ylabel("y [m]")
    from matplotlib.patches import Patch  # lazy: see _pyplot

    figure.legend(handles=[Patch(color=c, label=m.replace("_", " "))
                           for c, m in zip(_STATUS_COLOURS, STATUS_MEANINGS, strict=True)],
                  loc="outside lower center", ncols=4, fontsize=8)
    if path is not None:
        return _save(figure, path, overwrite)
    return figure
