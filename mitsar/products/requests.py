"""What a run asks of its later stages, recorded in its products as plain attributes.

An experiment is parsed once (:mod:`mitsar.experiment`); what focusing, the metrics and the
figures need from it is written into the raw product when it is made
(:func:`request_attrs`) and carried into the image (:data:`CARRIED_ATTRS`). Later stages read
it back with :func:`focus_request`, :func:`metrics_request`, :func:`target_positions` and
:func:`scene_of`, never by parsing the experiment again: the ``experiment`` attribute (the
configuration as JSON) is provenance only.

Attributes
----------
``experiment``, ``experiment_source``, ``experiment_name``
    The configuration as JSON, its file and its name (provenance).
``experiment_scene``
    The XML scene the run traced (a file or a canned scene's name); absent without one.
``target_positions``
    World positions [m] of the point targets, flat: x0, y0, z0, x1, ...; absent without any.
``metrics_target``
    World position [m] of the target to measure (``[metrics] target``, else the first point
    target); absent without one.
``metrics_islr_extent``
    ISLR side-lobe extent: a name (``"paper"``, ``"isce3"``, ``"chip"``, ``"inf"``) or a
    number of resolution cells.
``focus_algorithm``, ``focus_window``
    Focusing algorithm and window (names).
``focus_azimuth_resolution``
    Processed azimuth resolution [m]; absent: the full beam.
``focus_grid``
    The output grid table as JSON (:func:`mitsar.focus.grid.from_dict`); absent: the
    algorithm's default grid.
``focus_autofocus``
    Autofocus method; absent: none.
``focus_band_limit``
    1: band-limit BPA's and FFBP's images off a straight track (:mod:`mitsar.focus.band_limit`),
    0: not; absent: 1.
"""

from __future__ import annotations

import json
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

__all__ = ["CARRIED_ATTRS", "REQUEST_ATTRS", "focus_request", "metrics_request",
           "request_attrs", "scene_of", "target_positions"]

REQUEST_ATTRS: dict[str, str] = {
    "experiment": "the experiment's configuration, JSON (provenance)",
    "experiment_source": "the experiment's file",
    "experiment_name": "the experiment's name",
    "experiment_scene": "the XML scene traced (file or canned name)",
    "target_positions": "point targets' world positions, flat x0 y0 z0 x1 ... [m]",
    "metrics_target": "world position of the target to measure [m]",
    "metrics_islr_extent": "ISLR side-lobe extent (name or resolution cells)",
    "focus_algorithm": "focusing algorithm",
    "focus_window": "spectral window of range and azimuth compression",
    "focus_azimuth_resolution": "processed azimuth resolution [m] (absent: full beam)",
    "focus_grid": "output grid table, JSON (absent: the algorithm's default)",
    "focus_autofocus": "autofocus method (absent: none)",
    "focus_band_limit": "1: band-limit images off a straight track, 0: not (absent: 1)",
}
"""The request attributes a raw product may carry (module docstring)."""

CARRIED_ATTRS: tuple[str, ...] = tuple(key for key in REQUEST_ATTRS
                                       if not key.startswith("focus_"))
"""Request attributes an image carries over from its raw product (the focus options are the
raw product's: the image records the ones it was focused with)."""


def request_attrs(*, config: Mapping[str, Any] | None = None, source: str | None = None,
                  name: str | None = None, scene: str | None = None,
                  targets: Sequence[ArrayLike] = (), metrics_target: ArrayLike | None = None,
                  islr_extent: str | float = "paper",
                  focus: Mapping[str, Any] | None = None) -> dict[str, Any]:
    """The request attributes of a run (module docstring), encoded for netCDF.

    Parameters
    ----------
    config : mapping, optional
        The experiment's configuration (provenance, written as JSON).
    source, name : str, optional
        The experiment's file and name.
    scene : str, optional
        The XML scene traced.
    targets : sequence of array_like of 3 floats
        Point targets' world positions [m].
    metrics_target : array_like of 3 floats, optional
        World position [m] of the target to measure; default the first of ``targets``.
    islr_extent : str or float
        ISLR side-lobe extent.
    focus : mapping, optional
        ``algorithm``, ``window``, ``azimuth_resolution`` [m], ``grid`` (table),
        ``autofocus``, ``band_limit`` (bool, written 0 or 1); None values are left out.

    Returns
    -------
    dict
        Attributes (str, float, or flat lists of floats).
    """
    attrs: dict[str, Any] = {}
    if config is not None:
        attrs["experiment"] = json.dumps(config)
    if source is not None:
        attrs["experiment_source"] = str(source)
    if name:
        attrs["experiment_name"] = name
    if scene is not None:
        attrs["experiment_scene"] = str(scene)
    positions = [[float(v) for v in np.ravel(p)] for p in targets]
    if positions:
        attrs["target_positions"] = [v for p in positions for v in p]
    if metrics_target is None and positions:
        metrics_target = positions[0]
    if metrics_target is not None:
        attrs["metrics_target"] = [float(v) for v in np.ravel(metrics_target)]
    attrs["metrics_islr_extent"] = islr_extent
    for key, value in (focus or {}).items():
        if isinstance(value, bool):  # netCDF has no boolean attribute
            value = int(value)
        if value is not None:
            attrs[f"focus_{key}"] = json.dumps(value) if isinstance(value, dict) else value
    return attrs


def target_positions(product: xr.Dataset) -> NDArray[np.float64]:
    """World positions [m] of the point targets recorded in a product, shape (n, 3)."""
    flat = product.attrs.get("target_positions")
    if flat is None:
        return np.zeros((0, 3))
    return np.asarray(flat, dtype=float).reshape(-1, 3)


def metrics_request(product: xr.Dataset) -> tuple[list[float] | None, str | float | None]:
    """(target [m] or None, ISLR extent or None) recorded in a product."""
    target = product.attrs.get("metrics_target")
    extent = product.attrs.get("metrics_islr_extent")
    if extent is not None and not isinstance(extent, str):
        extent = float(extent)
    return (None if target is None else [float(v) for v in np.ravel(target)]), extent


def focus_request(product: xr.Dataset) -> dict[str, Any]:
    """The focus options recorded in a raw product: ``algorithm``, ``window``,
    ``azimuth_resolution``, ``grid`` (a table), ``autofocus``, ``band_limit`` (bool); only those
    present."""
    out: dict[str, Any] = {}
    for key in ("algorithm", "window", "azimuth_resolution", "grid", "autofocus", "band_limit"):
        value = product.attrs.get(f"focus_{key}")
        if value is None:
            continue
        if key == "grid":
            value = json.loads(value) if isinstance(value, str) else dict(value)
        elif key == "azimuth_resolution":
            value = float(value)
        elif key == "band_limit":
            value = bool(int(value))
        else:
            value = str(value)
        out[key] = value
    return out


def scene_of(product: xr.Dataset) -> str | None:
    """The XML scene a run traced, recorded in its product (None: no scene)."""
    scene = product.attrs.get("experiment_scene")
    return None if scene is None else str(scene)
