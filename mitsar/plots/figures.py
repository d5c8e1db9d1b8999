"""Figures of mitsar products (matplotlib, Agg backend): like the paper's, with metric axes.

* :func:`plot_range_compressed` — range-compressed matrix (slow time vs range, dB);
* :func:`plot_image` — focused image in dB with metre axes and optional marks (NR/CS/FR,
  true target positions);
* :func:`plot_cuts` — range and azimuth cuts through the peak with IRW/PSLR/ISLR;
* :func:`plot_background_histograms` — amplitude and phase histograms of the background with
  the Rayleigh and uniform densities (paper Fig. 7);
* :func:`plot_file` — the natural figure of a product file;
* :func:`save_figure` — atomic PNG/PDF/SVG output.

Every plotting function takes an optional ``ax`` (or ``axes``) and returns what it drew on, so
figures can be composed.
"""

from __future__ import annotations

import functools
import os
import warnings
from collections.abc import Mapping, Sequence
from pathlib import Path
from types import ModuleType
from typing import TYPE_CHECKING, Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.checks import positive
from mitsar.errors import MitsarError
from mitsar.focus.channels import channel_view
from mitsar.focus.compression import range_compress
from mitsar.focus.grid import equivalent_position
from mitsar.io import atomic_output, check_writable, load
from mitsar.model.geometry.attitude import Look, boresight
from mitsar.products.image import vector_attr
from mitsar.products.raw import radar_of
from mitsar.products.requests import metrics_request, target_positions

if TYPE_CHECKING:
    from matplotlib.axes import Axes
    from matplotlib.figure import Figure

__all__ = [
    "METRICS_MARK",
    "first_channel",
    "image_display_axes",
    "plot_background_histograms",
    "plot_cuts",
    "plot_file",
    "plot_image",
    "plot_range_compressed",
    "pyplot",
    "save_figure",
]

_FLOOR = 1e-30


@functools.cache
def pyplot() -> ModuleType:
    """``matplotlib.pyplot`` on the Agg backend (chosen once), imported on first use (lazy:
    Matplotlib is heavy, and a command that draws nothing, such as a no-op campaign rerun, must
    not load it)."""
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _db(values: ArrayLike, reference: float | None = None) -> NDArray[np.float64]:
    """20 log10 |values| relative to ``reference`` (default the peak) [dB]."""
    magnitude = np.abs(np.asarray(values))
    peak = float(magnitude.max()) if reference is None else reference
    return 20.0 * np.log10(np.maximum(magnitude, _FLOOR) / max(peak, _FLOOR))


def _new_axes(ax: Axes | None, figsize: tuple[float, float] = (6.4, 4.8)) -> Axes:
    if ax is not None:
        return ax
    _, ax = pyplot().subplots(figsize=figsize, layout="constrained")
    return ax


def _extent(x: NDArray, y: NDArray) -> list[float]:
    """imshow extent with pixel centres on the coordinates."""
    dx = (x[-1] - x[0]) / max(len(x) - 1, 1) if len(x) > 1 else 1.0
    dy = (y[-1] - y[0]) / max(len(y) - 1, 1) if len(y) > 1 else 1.0
    return [x[0] - dx / 2, x[-1] + dx / 2, y[0] - dy / 2, y[-1] + dy / 2]


# --- range-compressed data ------------------------------------------------------------------
def first_channel(product: xr.Dataset) -> tuple[xr.Dataset, str]:
    """Channel 0 of a multi-channel product (raw or image) and a note for titles.

    Figures of products with a ``channel`` dim (docs/interferometry.md §1) show channel 0 and
    say so; a single-channel product is returned as is, with an empty note.
    """
    if "channel" not in product.dims:
        return product, ""
    note = f" (channel 0 of {product.sizes['channel']})"
    if "raw" in product:
        return channel_view(product, 0), note
    return product.isel(channel=0), note


def plot_range_compressed(product: xr.Dataset, ax: Axes | None = None,
                          dynamic_range_db: float = 50.0, window: str = "rect",
                          max_range: float | None = None) -> Axes:
    """Range-compressed matrix in dB: slant range [m] across, slow time [s] down.

    Parameters
    ----------
    product : xarray.Dataset
        A raw product (range-compressed here with :func:`mitsar.focus.range_compress`) or a
        range-compressed product with a ``profile`` (sweep, range) variable.
    ax : matplotlib Axes, optional
    dynamic_range_db : float
        Colour scale from the peak down this many dB.
    window : str
        Range window when compressing a raw product.
    max_range : float, optional
        Show ranges up to this [m]; by default 20 % beyond the farthest return within
        60 % of the dynamic range.

    Returns
    -------
    Axes
    """
    product, channel_note = first_channel(product)
    if "profile" not in product:
        if "raw" not in product:
            raise MitsarError("plot_range_compressed: expected a raw product (variable 'raw') "
                              f"or a range-compressed one ('profile'), found variables "
                              f"{sorted(product.data_vars)}")
        product = range_compress(product, window=window)
    profile = product["profile"]
    range_dim = "range" if "range" in profile.dims else profile.dims[-1]
    ranges = np.asarray(product[range_dim].values, dtype=float)
    sweep_dim = profile.dims[0]
    if "slow_time" in product.coords and product["slow_time"].dims == (sweep_dim,):
        slow, slow_label = np.asarray(product["slow_time"].values, dtype=float), "slow time [s]"
    else:
        slow, slow_label = np.arange(profile.shape[0], dtype=float), "sweep"
    values = _db(profile.transpose(sweep_dim, range_dim).values)
    keep = ranges >= 0
    if max_range is None:
        visible = np.flatnonzero((values > -0.6 * dynamic_range_db).any(axis=0) & keep)
        max_range = (ranges[visible[-1]] * 1.2 + 1.0) if visible.size else ranges[-1]
    keep &= ranges <= max_range
    if keep.sum() < 2:
        keep = np.ones_like(keep)
    ax = _new_axes(ax)
    shown = ax.imshow(values[:, keep], origin="lower", aspect="auto", cmap="viridis",
                      vmin=-dynamic_range_db, vmax=0.0, interpolation="nearest",
                      extent=_extent(ranges[keep], slow))
    ax.set_xlabel("slant range [m]")
    ax.set_ylabel(slow_label)
    ax.set_title("range-compressed data" + channel_note)
    ax.figure.colorbar(shown, ax=ax, label="dB (peak = 0)")
    return ax


# --- images ---------------------------------------------------------------------------------
def _image_axes(image: xr.Dataset) -> tuple[str, str, NDArray, NDArray]:
    """Row and column dims and their coordinates [m] of an image product."""
    if "image" not in image:
        raise MitsarError("plot_image: expected an image product (variable 'image'), found "
                          f"variables {sorted(image.data_vars)}")
    rows, cols = image["image"].dims[-2:]  # after a leading "channel" dim, if any
    return (str(rows), str(cols), np.asarray(image[rows].values, dtype=float),
            np.asarray(image[cols].values, dtype=float))


_AXIS_LABELS = {"azimuth": "along track [m]", "range": "slant range [m]", "u": "u [m]",
                "v": "v [m]", "row": "row", "col": "column"}

_WORLD = "xyz"


def _world_axis(direction: ArrayLike) -> tuple[int, float] | None:
    """``(i, sign)`` when ``direction`` is the world axis ``sign * e_i``, else None."""
    direction = np.asarray(direction, dtype=float)
    i = int(np.argmax(np.abs(direction)))
    if abs(abs(direction[i]) - 1.0) > 1e-9 or np.abs(np.delete(direction, i)).max() > 1e-9:
        return None
    return i, float(np.sign(direction[i]))


def image_display_axes(image: xr.Dataset) -> tuple[Any, Any, str, str]:
    """How an image's columns and rows are shown: two maps from the image coordinate [m] to
    the shown one, and the axis labels.

    A plane grid (``origin + u axis_u + v axis_v``, :class:`mitsar.focus.grid.PlaneGrid`)
    whose axes are world axes is shown in world coordinates: ``x = origin_x + u`` for
    ``axis_u = (1, 0, 0)``, ``-u`` for ``(-1, 0, 0)``, labelled "x [m]" (the scene's frame,
    where the targets and the scene's surfaces are given). Another plane keeps u and v and
    states their directions and origin in world terms; other grids keep their axes
    (:data:`_AXIS_LABELS`).
    """
    rows, cols, _, _ = _image_axes(image)

    def keep(value: Any) -> Any:
        return value

    labels = [_AXIS_LABELS.get(cols, f"{cols} [m]"), _AXIS_LABELS.get(rows, f"{rows} [m]")]
    maps = [keep, keep]
    if image.attrs.get("grid_kind") != "plane" or "grid_axis_u" not in image.attrs:
        return maps[0], maps[1], labels[0], labels[1]
    origin = vector_attr(image, "grid_origin")
    for k, name in enumerate((cols, rows)):
        if name not in ("u", "v"):
            continue
        direction = vector_attr(image, f"grid_axis_{name}")
        world = _world_axis(direction)
        if world is None:
            along = ", ".join(f"{v:.3g}" for v in direction)
            start = ", ".join(f"{v:.3g}" for v in origin)
            labels[k] = f"{name} [m] along ({along}) from ({start})"
            continue
        i, sign = world
        maps[k] = (lambda value, o=float(origin[i]), s=sign: o + s * np.asarray(value))
        labels[k] = f"{_WORLD[i]} [m]"
    return maps[0], maps[1], labels[0], labels[1]


def _mark_location(image: xr.Dataset, position: ArrayLike) -> tuple[float, float] | None:
    """Image coordinates (column, row) of a mark: 2 numbers as-is, 3 numbers a world point."""
    position = np.asarray(position, dtype=float).reshape(-1)
    rows, cols, y, x = _image_axes(image)
    if position.size == 2:
        return float(position[0]), float(position[1])
    if position.size != 3 or "position" not in image:
        return None
    world = equivalent_position(image, position)
    pixels = image["position"].transpose(rows, cols, "xyz").values
    distance = np.linalg.norm(pixels - world, axis=-1)
    i, j = np.unravel_index(int(np.argmin(distance)), distance.shape)
    spacing = max(np.abs(np.diff(x)).max(initial=0), np.abs(np.diff(y)).max(initial=0))
    if distance[i, j] > 2 * spacing + 1e-9:
        return None
    return float(x[j]), float(y[i])


def plot_image(image: xr.Dataset, ax: Axes | None = None, dynamic_range_db: float = 40.0,
               marks: Mapping[str, ArrayLike] | None = None, title: str | None = None,
               range_marks: Mapping[str, float] | None = None) -> Axes:
    """Focused image in dB (peak = 0) on its metre axes.

    Parameters
    ----------
    image : xarray.Dataset
        An image product (:func:`mitsar.focus.focus`).
    ax : matplotlib Axes, optional
    dynamic_range_db : float
        Colour scale from the peak down this many dB.
    marks : mapping of str to array_like, optional
        Named marks: a world position ``(x, y, z)`` [m] (placed at its pixel; for a slant
        grid at its equivalent position) or image coordinates ``(column, row)`` [m], e.g.
        ``{"NR": ..., "CS": ..., "FR": ..., "target": (15, 8, 0)}``. Marks outside the image
        are skipped with a warning.
    title : str, optional
    range_marks : mapping of str to float, optional
        Slant ranges [m] drawn as lines across a slant-grid image, e.g. near range, centre
        scene and far range from :func:`beam_range_marks` (paper Figs. 13 and 15b).

    Returns
    -------
    Axes
    """
    image, channel_note = first_channel(image)
    rows, cols, y, x = _image_axes(image)
    show_x, show_y, xlabel, ylabel = image_display_axes(image)
    values = _db(image["image"].transpose(rows, cols).values)
    ax = _new_axes(ax)
    shown = ax.imshow(values, origin="lower", aspect="equal", cmap="gray",
                      vmin=-dynamic_range_db, vmax=0.0, interpolation="nearest",
                      extent=_extent(show_x(x), show_y(y)))
    ax.set_xlabel(xlabel)
    ax.set_ylabel(ylabel)
    algorithm = str(image.attrs.get("algorithm", "")).upper()
    ax.set_title(title if title is not None
                 else f"focused image {algorithm}".strip() + channel_note)
    ax.figure.colorbar(shown, ax=ax, label="dB (peak = 0)", shrink=0.9)
    for index, (name, position) in enumerate((marks or {}).items()):
        where = _mark_location(image, position)
        if where is None:
            warnings.warn(f"plot_image: mark {name!r} at {list(np.ravel(position))} is outside "
                          "the image; not drawn", stacklevel=2)
            continue
        colour = f"C{(index + 1) % 10}"
        where = (float(show_x(where[0])), float(show_y(where[1])))
        if METRICS_MARK in name:  # a circle; with a cross when it is a target too
            ax.plot(*where, marker="o", markersize=16, markeredgewidth=1.5, color=colour,
                    markerfacecolor="none", linestyle="none", label=name)
            if name != METRICS_MARK:
                ax.plot(*where, marker="+", markersize=14, markeredgewidth=1.5, color=colour,
                        linestyle="none")
            ax.annotate(name, where, xytext=(10, 8), textcoords="offset points", color=colour)
            continue
        ax.plot(*where, marker="+", markersize=14, markeredgewidth=1.5, color=colour,
                linestyle="none", label=name)
        ax.annotate(name, where, xytext=(6, 6), textcoords="offset points", color=colour)
    if range_marks and cols == "range":
        for (name, value), style in zip(range_marks.items(), (":", "--", "-.", ":"),
                                        strict=False):
            if x.min() <= value <= x.max():
                ax.axvline(value, color="tab:cyan", lw=1.0, linestyle=style)
                ax.annotate(name, (value, y.max()), xytext=(3, -12), textcoords="offset points",
                            color="tab:cyan", fontsize=8)
    return ax


def beam_range_marks(image: xr.Dataset, floor_z: float = 0.0) -> dict[str, float]:
    """Near range, centre scene and far range of the beam on a floor, on a slant grid.

    Distances from the track (the slant grid's range coordinate) to where the lower edge, the
    boresight and the upper edge of the elevation beam (off-nadir theta -/+ half the elevation
    beamwidth lambda/d, same squint) meet the horizontal plane ``z = floor_z``. Far range is
    omitted when the upper edge does not reach the floor.
    """
    if image.attrs.get("grid_kind") != "slant" or "look_off_nadir_deg" not in image.attrs:
        return {}
    origin = vector_attr(image, "grid_origin")
    along = vector_attr(image, "grid_along_track")
    height = origin[2] - floor_z
    half = np.degrees(radar_of(image).elevation_beamwidth) / 2
    off_nadir = float(image.attrs["look_off_nadir_deg"])
    squint = float(image.attrs.get("look_squint_deg", 0.0))
    heading = float(np.arctan2(along[1], along[0]))
    marks = {}
    for name, angle in (("NR", off_nadir - half), ("CS", off_nadir), ("FR", off_nadir + half)):
        if not 0.0 <= angle < 90.0 or height <= 0:
            continue
        sight = boresight(Look(angle, squint), heading=heading)
        slant = height / -sight[2]
        marks[name] = float(slant * np.sqrt(max(1.0 - (sight @ along) ** 2, 0.0)))
    return marks


def _cut_through_peak(image: xr.Dataset, metrics: Mapping[str, Any] | None
                      ) -> dict[str, tuple[NDArray, NDArray, str]]:
    """Range and azimuth cuts (offset [m], complex values, label) through the peak pixel."""
    rows, cols, y, x = _image_axes(image)
    values = image["image"].transpose(rows, cols).values
    magnitude = np.abs(values)
    if metrics and "peak_index" in metrics:
        i, j = (int(round(v)) for v in metrics["peak_index"])
        i, j = min(max(i, 0), len(y) - 1), min(max(j, 0), len(x) - 1)
    else:
        i, j = np.unravel_index(int(np.argmax(magnitude)), magnitude.shape)
    range_axis = np.asarray(image.attrs.get("range_axis", (0.0, 1.0)), dtype=float)
    along_cols = abs(range_axis[1]) >= abs(range_axis[0])
    row_cut = (x - x[j], values[i, :], cols)
    col_cut = (y - y[i], values[:, j], rows)
    return ({"range": row_cut, "azimuth": col_cut} if along_cols
            else {"range": col_cut, "azimuth": row_cut})


def _metrics_label(name: str, metrics: Mapping[str, Any] | None) -> str:
    if not metrics or name not in metrics:
        return name
    m = metrics[name]
    return (f"{name}: IRW {m['irw_m'] * 100:.2f} cm ({m['irw_cells']:.3f} cells), "
            f"PSLR {m['pslr_db']:.2f} dB, ISLR {m['islr_db']:.2f} dB")


def plot_cuts(image: xr.Dataset, metrics: Mapping[str, Any] | None = None,
              axes: Sequence[Axes] | None = None, dynamic_range_db: float = 50.0,
              half_width: float | None = None) -> Sequence[Axes]:
    """Range and azimuth cuts through the image peak in dB, metrics in the legends.

    Parameters
    ----------
    image : xarray.Dataset
        An image product.
    metrics : mapping, optional
        Output of :func:`mitsar.quality.impulse.measure_impulse_response` (``range``/``azimuth``
        sub-dicts with ``irw_m``, ``irw_cells``, ``pslr_db``, ``islr_db``; ``peak_index``
        chooses the cut).
    axes : two matplotlib Axes, optional
    dynamic_range_db : float
        Lower limit of the plots below the peak [dB].
    half_width : float, optional
        Half width of the plotted cuts [m]; by default 8 resolution cells.

    Returns
    -------
    sequence of Axes
        The range and azimuth axes.
    """
    if axes is None:
        _, axes = pyplot().subplots(1, 2, figsize=(11, 4), layout="constrained")
    image, channel_note = first_channel(image)
    cuts = _cut_through_peak(image, metrics)
    for ax, name in zip(axes, ("range", "azimuth"), strict=True):
        offset, values, dim = cuts[name]
        resolution = float(image.attrs.get(f"{name}_resolution", 0.0) or 0.0)
        width = half_width if half_width is not None else (
            8 * resolution if resolution > 0 else np.abs(offset).max())
        keep = np.abs(offset) <= width + 1e-12
        ax.plot(offset[keep], _db(values)[keep], marker=".", markersize=3,
                label=_metrics_label(name, metrics))
        ax.axhline(-3.0, color="0.6", linewidth=0.8, linestyle=":")
        ax.set_ylim(-dynamic_range_db, 3.0)
        ax.set_xlabel(f"{name} offset from the peak [m] (along '{dim}')")
        ax.set_ylabel("dB (peak = 0)")
        ax.set_title(f"{name} cut{channel_note}")
        ax.grid(True, alpha=0.3)
        ax.legend(loc="lower center", fontsize="small")
    return axes


# --- background statistics ------------------------------------------------------------------
def plot_background_histograms(amplitudes: ArrayLike, phases: ArrayLike,
                               axes: Sequence[Axes] | None = None, bins: int = 50,
                               label: str | None = None) -> Sequence[Axes]:
    """Amplitude and phase histograms of background reflectivities (paper Fig. 7).

    The amplitude histogram (a density) is overlaid with the Rayleigh pdf of the same mean
    power, ``p(A) = A / s^2 exp(-A^2 / 2 s^2)`` with ``2 s^2 = <A^2>``; the phase histogram
    with the uniform pdf ``1 / 2 pi`` on ``[0, 2 pi)``.

    Parameters
    ----------
    amplitudes : array_like
        Amplitudes |a| of the background scatterers (one sweep).
    phases : array_like
        Their phases [rad] (wrapped to ``[0, 2 pi)`` here).
    axes : two matplotlib Axes, optional
    bins : int
        Number of histogram bins.
    label : str, optional
        Legend label of the histograms (e.g. ``"-20 dB background, one sweep"``).

    Returns
    -------
    sequence of Axes
        The amplitude and phase axes.
    """
    amplitudes = np.abs(np.asarray(amplitudes, dtype=float).ravel())
    phases = np.mod(np.asarray(phases, dtype=float).ravel(), 2 * np.pi)
    if amplitudes.size == 0 or phases.size == 0:
        raise MitsarError("plot_background_histograms: no background samples to plot")
    if axes is None:
        _, axes = pyplot().subplots(1, 2, figsize=(11, 4), layout="constrained")
    ax_a, ax_p = axes
    ax_a.hist(amplitudes, bins=bins, density=True, color="C0", alpha=0.6,
              label=label or f"{amplitudes.size} scatterers")
    scale2 = float(np.mean(amplitudes**2)) / 2
    grid = np.linspace(0, amplitudes.max() * 1.05, 400)
    if scale2 > 0:
        ax_a.plot(grid, grid / scale2 * np.exp(-(grid**2) / (2 * scale2)), color="C3",
                  label=f"Rayleigh pdf, s = {np.sqrt(scale2):.3g}")
    ax_a.set_xlabel("amplitude |a| [m] (square root of RCS)")
    ax_a.set_ylabel("probability density")
    ax_a.set_title("background amplitude")
    ax_a.legend(fontsize="small")
    ax_p.hist(phases, bins=bins, range=(0, 2 * np.pi), density=True, color="C0", alpha=0.6,
              label=label or f"{phases.size} scatterers")
    ax_p.axhline(1 / (2 * np.pi), color="C3", label="uniform pdf 1/(2 pi)")
    ax_p.set_xlim(0, 2 * np.pi)
    ax_p.set_xlabel("phase [rad]")
    ax_p.set_ylabel("probability density")
    ax_p.set_title("background phase")
    ax_p.legend(fontsize="small", loc="lower center")
    return axes


def background_samples(raw: xr.Dataset) -> tuple[NDArray, NDArray]:
    """Amplitudes and phases [rad] of the background reflectivities recorded in a raw product.

    Raises
    ------
    MitsarError
        If the product holds no background draw (variable ``background_reflectivity``).
    """
    if "background_reflectivity" not in raw:
        raise MitsarError("the raw product has no background draw (variable "
                          "'background_reflectivity'); simulate with a [background]")
    values = np.asarray(raw["background_reflectivity"].values)
    return np.abs(values), np.angle(values)


# --- files ----------------------------------------------------------------------------------
def save_figure(figure: Figure, path: str | os.PathLike, overwrite: bool = False,
                dpi: int = 150) -> Path:
    """Save a figure atomically (temporary file + rename) and close it.

    Parameters
    ----------
    figure : matplotlib Figure
    path : path-like
        Output file; the format follows the suffix (``.png``, ``.pdf``, ``.svg``).
    overwrite : bool
        Replace an existing file.
    dpi : int
        Resolution of raster formats.

    Returns
    -------
    Path
    """
    path = Path(path)
    fmt = path.suffix.lstrip(".").lower() or "png"
    supported = figure.canvas.get_supported_filetypes()
    if fmt not in supported:
        pyplot().close(figure)
        raise MitsarError(f"{path}: unsupported figure format {fmt!r}; use one of "
                          f"{', '.join(sorted(supported))}")
    try:
        with atomic_output(path, overwrite) as tmp:
            figure.savefig(tmp, format=fmt, dpi=dpi)
    finally:
        pyplot().close(figure)
    return path


def plot_file(path: str | os.PathLike, out: str | os.PathLike, overwrite: bool = False,
              dynamic_range_db: float | None = None,
              range_marks: Mapping[str, float] | None = None) -> Path:
    """Plot a product file with its natural figure and save it.

    A raw or range-compressed product gives the range-compressed matrix, an image product the
    image in dB (with its point targets marked).

    Parameters
    ----------
    path : path-like
        A product file (:func:`mitsar.io.save`).
    out : path-like
        Figure file (``.png``, ``.pdf``, ``.svg``).
    overwrite : bool
        Replace an existing figure.
    dynamic_range_db : float, optional
        Colour scale depth [dB].
    range_marks : mapping, optional
        NR / CS / FR of an image (default: the beam on a horizontal floor,
        :func:`beam_range_marks`; ``mitsar plot`` passes the scene's own,
        :func:`mitsar.plots.footprint.scene_range_marks`).

    Returns
    -------
    Path
        The figure file.
    """
    if dynamic_range_db is not None:
        dynamic_range_db = positive("plot_file", "dynamic_range_db (--dynamic-range)",
                                    dynamic_range_db, "a colour scale depth > 0 dB")
    check_writable(out, overwrite)
    product = load(path)
    kind = product.attrs["product"]
    if kind == "image":
        figure, ax = pyplot().subplots(figsize=(7, 6), layout="constrained")
        plot_image(product, ax=ax, dynamic_range_db=dynamic_range_db or 40.0,
                   marks=target_marks(product),
                   range_marks=beam_range_marks(product) if range_marks is None else range_marks)
    elif "raw" in product or "profile" in product:
        figure, ax = pyplot().subplots(figsize=(8, 5), layout="constrained")
        plot_range_compressed(product, ax=ax, dynamic_range_db=dynamic_range_db or 50.0)
    else:
        raise MitsarError(f"{path}: no figure for a product of type {kind!r} (plots exist for "
                          "raw, range-compressed and image products)")
    return save_figure(figure, out, overwrite=overwrite)


METRICS_MARK = "metrics target"
"""Name of the mark of the point where the metrics are measured (drawn as a circle; a target
there is marked once, ``"target = metrics target"``, circle and cross)."""


def target_marks(image: xr.Dataset) -> dict[str, list[float]]:
    """Marks for the point targets recorded in an image product (``target_positions``,
    :mod:`mitsar.products.requests`) and for its metrics target (``metrics_target``, named
    :data:`METRICS_MARK`), those that fall inside it."""
    positions = target_positions(image)
    marks = {}
    for index, position in enumerate(positions):
        name = "target" if len(positions) == 1 else f"target {index}"
        marks[name] = [float(v) for v in position]
    metrics_target = metrics_request(image)[0]
    if metrics_target is not None and len(metrics_target) == 3:
        same = [name for name, position in marks.items()
                if np.linalg.norm(np.subtract(position, metrics_target)) < 1e-6]
        if same:  # one mark, one label: "target = metrics target"
            marks = {(f"{name} = {METRICS_MARK}" if name == same[0] else name): position
                     for name, position in marks.items()}
        else:
            marks[METRICS_MARK] = [float(v) for v in metrics_target]
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        return {k: v for k, v in marks.items() if _mark_location(image, v) is not None}
