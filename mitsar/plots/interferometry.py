"""Figures of an interferogram (:func:`mitsar.interferometry.interferogram`): maps of the wrapped
phase, coherence, unwrapped phase, height and predicted height noise on the image grid.

Each map is drawn on world x / y [m] where the grid's rows and columns run along world axes (a
plane grid on the floor with ``axis_u = [1, 0, 0]``, ``axis_v = [0, 1, 0]``), else on the grid's
own metre axes (along track, slant range, u, v). Pixels fainter than ``dynamic_range_db`` below
the brightest one are left blank: their phase is that of side lobes or noise, and a blank map
reads better than one full of meaningless heights. docs/interferometry.md.
"""

from __future__ import annotations

from collections.abc import Mapping
from dataclasses import dataclass

import matplotlib

matplotlib.use("Agg")

import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402
from matplotlib.axes import Axes  # noqa: E402
from matplotlib.figure import Figure  # noqa: E402
from numpy.typing import NDArray  # noqa: E402

from mitsar.errors import ParameterError  # noqa: E402

__all__ = ["INTERFEROGRAM_MAPS", "InterferogramMap", "interferogram_figures",
           "plot_interferogram_map"]


@dataclass(frozen=True)
class InterferogramMap:
    """How one variable of an interferogram is drawn.

    Attributes
    ----------
    variable : str
        The dataset's variable.
    title : str
        Figure title (the channel pair is appended).
    label : str
        Colour-bar label, with units.
    cmap : str
        Matplotlib colour map.
    scale : float
        Factor from the variable's units to the label's (1000 for m -> mm).
    limits : (float, float) or None
        Fixed colour limits; ``None``: the 2nd-98th percentiles of the shown pixels.
    """

    variable: str
    title: str
    label: str
    cmap: str
    scale: float = 1.0
    limits: tuple[float, float] | None = None


INTERFEROGRAM_MAPS: dict[str, InterferogramMap] = {
    "phase": InterferogramMap("phase", "wrapped interferometric phase",
                              "flat phase [rad]", "twilight", limits=(-np.pi, np.pi)),
    "coherence": InterferogramMap("coherence", "coherence", "coherence [1]", "viridis",
                                  limits=(0.0, 1.0)),
    "unwrapped_phase": InterferogramMap("unwrapped_phase", "unwrapped phase",
                                        "unwrapped flat phase [rad]", "coolwarm"),
    "height": InterferogramMap("height", "height", "height z [m]", "terrain"),
    "height_std": InterferogramMap("height_std", "predicted height noise",
                                   "height standard deviation [mm]", "magma", scale=1e3),
}
"""The maps drawn of an interferogram, by name."""

_GRID_LABELS = {"azimuth": "along track [m]", "range": "slant range [m]", "u": "u [m]",
                "v": "v [m]"}
_WORLD = ("x", "y", "z")


def _world_axis(pixels: NDArray, along: int) -> int | None:
    """The world axis (0, 1, 2) that pixel positions (ROW, COL, xyz) follow along grid axis
    ``along`` (0: rows, 1: cols), or None when they do not follow one axis alone."""
    steps = np.diff(pixels, axis=along).reshape(-1, 3)
    steps = steps[np.isfinite(steps).all(axis=1)]
    if steps.size == 0:
        return None
    mean = steps.mean(axis=0)
    norm = float(np.linalg.norm(mean))
    if norm == 0.0:
        return None
    axis = int(np.argmax(np.abs(mean)))
    others = np.delete(steps, axis, axis=1)
    return axis if np.abs(others).max() <= 1e-6 * norm else None


def _axes_of(ifg: xr.Dataset) -> tuple[NDArray, NDArray, str, str]:
    """Column and row coordinates [m] and their labels: world x / y where the grid follows
    them, else the grid's own coordinates, else pixel indices."""
    rows, cols = (str(d) for d in ifg["phase"].dims[-2:])
    pixels = ifg["pixel_position"].transpose(rows, cols, "xyz").values
    out = []
    for along, dim in ((1, cols), (0, rows)):
        axis = _world_axis(pixels, along) if pixels.shape[along] > 1 else None
        if axis is not None:
            values = np.nanmean(np.moveaxis(pixels[..., axis], along, 0).reshape(
                pixels.shape[along], -1), axis=1)
            out.append((values, f"world {_WORLD[axis]} [m]"))
        elif dim in ifg.coords:
            out.append((np.asarray(ifg[dim].values, float), _GRID_LABELS.get(dim, f"{dim} [m]")))
        else:
            out.append((np.arange(ifg.sizes[dim], dtype=float), f"{dim} [pixel]"))
    (x, x_label), (y, y_label) = out
    return x, y, x_label, y_label


def _edges(values: NDArray) -> NDArray:
    """Cell edges of pixel centres (one pixel: +-0.5)."""
    if values.size == 1:
        return np.array([values[0] - 0.5, values[0] + 0.5])
    mid = (values[1:] + values[:-1]) / 2
    return np.concatenate([[2 * values[0] - mid[0]], mid, [2 * values[-1] - mid[-1]]])


def plot_interferogram_map(ifg: xr.Dataset, name: str, ax: Axes | None = None,
                           dynamic_range_db: float | None = 40.0) -> Axes:
    """One map of an interferogram on metre axes with a colour bar in units.

    Parameters
    ----------
    ifg : xarray.Dataset
        Output of :func:`mitsar.interferometry.interferogram`.
    name : str
        A key of :data:`INTERFEROGRAM_MAPS` (``"phase"``, ``"coherence"``,
        ``"unwrapped_phase"``, ``"height"``, ``"height_std"``).
    ax : matplotlib Axes, optional
    dynamic_range_db : float or None
        Pixels whose amplitude is more than this [dB] below the brightest pixel are blank;
        ``None`` shows every pixel.

    Returns
    -------
    Axes
    """
    if name not in INTERFEROGRAM_MAPS:
        raise ParameterError("plot_interferogram_map", "name",
                             f"one of {sorted(INTERFEROGRAM_MAPS)}", name)
    spec = INTERFEROGRAM_MAPS[name]
    needed = (spec.variable, "amplitude", "pixel_position")
    if not isinstance(ifg, xr.Dataset) or any(v not in ifg for v in needed):
        raise ParameterError("plot_interferogram_map", "ifg",
                             f"an interferogram dataset with {needed}",
                             type(ifg).__name__ if not isinstance(ifg, xr.Dataset)
                             else sorted(map(str, ifg.data_vars)))
    rows, cols = (str(d) for d in ifg["phase"].dims[-2:])
    values = ifg[spec.variable].transpose(rows, cols).values.astype(float) * spec.scale
    amplitude = ifg["amplitude"].transpose(rows, cols).values
    shown = np.isfinite(values)
    if dynamic_range_db is not None and np.isfinite(amplitude).any():
        with np.errstate(divide="ignore", invalid="ignore"):
            level = 20 * np.log10(amplitude / np.nanmax(amplitude))
        shown &= level >= -float(dynamic_range_db)
    values = np.where(shown, values, np.nan)
    limits = spec.limits
    if limits is None:
        finite = values[np.isfinite(values)]
        low, high = (np.percentile(finite, [2, 98]) if finite.size else (0.0, 1.0))
        if not high > low:
            low, high = low - 0.5 * max(abs(low), 1e-3), high + 0.5 * max(abs(high), 1e-3)
        limits = (float(low), float(high))
    x, y, x_label, y_label = _axes_of(ifg)
    if ax is None:
        _, ax = plt.subplots(figsize=(6.4, 5.2), layout="constrained")
    order_x, order_y = np.argsort(x), np.argsort(y)
    mesh = ax.pcolormesh(_edges(x[order_x]), _edges(y[order_y]),
                         values[np.ix_(order_y, order_x)], cmap=spec.cmap, vmin=limits[0],
                         vmax=limits[1], shading="flat")
    ax.set_aspect("equal")
    ax.set_xlabel(x_label)
    ax.set_ylabel(y_label)
    pair = list(ifg.attrs.get("pair", [0, 1]))
    looks = (ifg.attrs.get("looks_azimuth", 1), ifg.attrs.get("looks_range", 1))
    ax.set_title(f"{spec.title}, channels {pair[0]}-{pair[1]}, {looks[0]}x{looks[1]} looks",
                 fontsize="medium")
    ax.figure.colorbar(mesh, ax=ax, label=spec.label, shrink=0.9)
    return ax


def interferogram_figures(ifg: xr.Dataset, dynamic_range_db: float | None = 40.0
                          ) -> Mapping[str, Figure]:
    """Every map of :data:`INTERFEROGRAM_MAPS` as its own figure, by name.

    Parameters
    ----------
    ifg : xarray.Dataset
        Output of :func:`mitsar.interferometry.interferogram`.
    dynamic_range_db : float or None
        As in :func:`plot_interferogram_map`.

    Returns
    -------
    dict of str to matplotlib Figure
        The caller saves and closes them (:func:`mitsar.plots.figures.save_figure`).
    """
    figures = {}
    for name in INTERFEROGRAM_MAPS:
        figure, ax = plt.subplots(figsize=(6.4, 5.2), layout="constrained")
        plot_interferogram_map(ifg, name, ax=ax, dynamic_range_db=dynamic_range_db)
        figures[name] = figure
    return figures
