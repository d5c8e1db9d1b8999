"""The image product: focused complex pixels on a resolved grid, with coverage and provenance.

Layout (:data:`IMAGE_SCHEMA`)
-----------------------------
``image`` (row, col) complex
    Focused complex image; the dims are the grid's (``azimuth``, ``range`` on a slant grid;
    ``v``, ``u`` on a plane; ``row``, ``col`` for points), each a coordinate [m].
``position`` (row, col, xyz) [m]
    World position of each pixel.
``coverage`` (row, col) [1]
    Fraction of the full processed aperture that contributed to each pixel.
attributes
    ``product = "image"``, ``radar_*``, ``look_*``, ``range_resolution`` and
    ``azimuth_resolution`` [m], ``range_axis`` and ``azimuth_axis`` (unit vectors in the
    (row, col) plane), the grid's ``grid_*`` and the processing's (``algorithm``, ``window``,
    ...), ``mid_platform_position`` [m] and ``mid_platform_attitude`` [rad] (mid-aperture
    antenna state), provenance (``raw_seed``, ``raw_config``, ``mitsar_version``) and, carried
    from the raw product, what the run asks of the metrics and figures
    (:data:`mitsar.products.requests.CARRIED_ATTRS`).

A volume (``grid_kind = "volume"``, :class:`mitsar.focus.grid.VolumeGrid`) has three grid dims,
``(z, y, x)`` (:data:`VOLUME_SCHEMA`); its ``range_axis`` and ``azimuth_axis`` are 3-D unit
vectors in (z, y, x) order. Several passes combined (:mod:`mitsar.focus.passes`) add
``pass_position`` (pass, xyz) [m], ``pass_baseline`` (pass) [m] and the pass and elevation
attributes.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.products.requests import CARRIED_ATTRS, REQUEST_ATTRS
from mitsar.products.schema import Schema, Variable, validate
from mitsar.version import __version__

__all__ = ["IMAGE_SCHEMA", "VOLUME_SCHEMA", "carry_requests", "image_dims", "make_image_product",
           "validate_image", "vector_attr"]

IMAGE_SCHEMA = Schema(
    product="image",
    variables={
        "image": Variable(("row", "col"), "", "focused complex image"),
        "position": Variable(("row", "col", "xyz"), "m", "world position of the pixel"),
        "coverage": Variable(("row", "col"), "1",
                             "fraction of the full processed aperture that contributed"),
        "xyz": Variable(("xyz",)),
    },
    attrs={"product": "product type", "range_resolution": "range resolution [m]",
           "azimuth_resolution": "azimuth resolution [m]",
           "range_axis": "range direction in the (row, col) plane",
           "azimuth_axis": "azimuth direction in the (row, col) plane",
           "mitsar_version": "version of mitsar that made the product"},
    optional_attrs={key: REQUEST_ATTRS[key] for key in CARRIED_ATTRS},
)
"""The image product's layout (module docstring); ``row`` and ``col`` stand for the grid's own
two dims."""

VOLUME_SCHEMA = Schema(
    product="image",
    variables={
        "image": Variable(("z", "y", "x"), "", "focused complex image"),
        "position": Variable(("z", "y", "x", "xyz"), "m", "world position of the voxel"),
        "coverage": Variable(("z", "y", "x"), "1",
                             "fraction of the full processed aperture that contributed"),
        "xyz": Variable(("xyz",)),
        "z": Variable(("z",), "m"), "y": Variable(("y",), "m"), "x": Variable(("x",), "m"),
    },
    attrs=IMAGE_SCHEMA.attrs,
    optional_attrs=IMAGE_SCHEMA.optional_attrs,
)
"""A volume image product's layout (:class:`mitsar.focus.grid.VolumeGrid`; module
docstring)."""


def image_dims(image: xr.Dataset, where: str = "image product") -> tuple[str, str]:
    """The (row, col) dims of an image product's ``image`` variable."""
    if "image" not in image.variables or image["image"].ndim != 2:
        raise ParameterError(where, "image", "variable 'image' of an image product, 2 dims",
                             f"variables {sorted(map(str, image.variables))}")
    rows, cols = image["image"].dims
    return str(rows), str(cols)


def validate_image(product: xr.Dataset, where: str = "image product") -> xr.Dataset:
    """Check an image product against :data:`IMAGE_SCHEMA`, its grid dims standing for
    ``row`` and ``col``, or a volume (``grid_kind = "volume"``) against :data:`VOLUME_SCHEMA`
    (:func:`mitsar.products.schema.validate`)."""
    checked = product
    if product.attrs.get("product") == "image" and product.attrs.get("grid_kind") == "volume":
        validate(product, VOLUME_SCHEMA, where)
        return product
    if product.attrs.get("product") == "image":
        rows, cols = image_dims(product, where)
        if (rows, cols) != ("row", "col"):
            checked = product.rename({rows: "row", cols: "col"})
    validate(checked, IMAGE_SCHEMA, where)
    return product


def make_image_product(raw: xr.Dataset, image: np.ndarray, layout: dict, processing: dict,
                       coverage: np.ndarray | None = None) -> xr.Dataset:
    """Assemble the image product from focused values and a resolved grid layout.

    Parameters
    ----------
    raw : xarray.Dataset
        The raw product focused (radar, look, track and request attributes are kept).
    image : ndarray, complex
        Focused values on the grid.
    layout : dict
        The resolved grid (:meth:`mitsar.focus.grid.SlantGrid.resolve`): ``dims``,
        ``coords`` [m], ``position`` [m], resolutions [m], axes, ``attrs``.
    processing : dict
        Processing attributes (algorithm, window, ...; dicts as JSON).
    coverage : ndarray, optional
        Same shape as ``image``: the fraction of the full processed aperture that contributed
        to each pixel (ones when omitted).

    Returns
    -------
    xarray.Dataset
        The image product (:data:`IMAGE_SCHEMA`).
    """
    dims = layout["dims"]
    variables = IMAGE_SCHEMA.variables
    product = xr.Dataset(
        {"image": (dims, image, {"long_name": variables["image"].long_name}),
         "position": (dims + ("xyz",), layout["position"], {"units": "m"})},
        coords={**{name: (name, values, {"units": "m"})
                   for name, values in layout["coords"].items()}, "xyz": ["x", "y", "z"]})
    keep = {k: v for k, v in raw.attrs.items() if k.startswith(("radar_", "look_"))}
    product.attrs.update(keep)
    product.attrs.update(
        product="image", mitsar_version=__version__,
        range_resolution=float(layout["range_resolution"]),
        azimuth_resolution=float(layout["azimuth_resolution"]),
        range_axis=list(map(float, layout["range_axis"])),
        azimuth_axis=list(map(float, layout["azimuth_axis"])),
        raw_seed=raw.attrs.get("seed", -1), raw_config=raw.attrs.get("config", "{}"))
    # Mid-aperture antenna state of the track that flew (true when known): what the beam's
    # footprint and its near / centre / far range on the scene are drawn from.
    truth = "true_" if "true_platform_position" in raw.variables else ""
    if f"{truth}platform_position" in raw.variables and raw.sizes.get("sweep", 0):
        middle = raw.sizes["sweep"] // 2
        product.attrs["mid_platform_position"] = [
            float(v) for v in raw[f"{truth}platform_position"].values[middle]]
        if f"{truth}attitude" in raw.variables:
            product.attrs["mid_platform_attitude"] = [
                float(v) for v in raw[f"{truth}attitude"].values[middle]]
    for key, value in {**layout["attrs"], **processing}.items():
        product.attrs[key] = json.dumps(value) if isinstance(value, dict) else value
    carry_requests(raw, product)
    product["coverage"] = (dims, np.ones(image.shape) if coverage is None else coverage,
                           variables["coverage"].attrs())
    return product


def vector_attr(product: xr.Dataset, key: str) -> NDArray[np.float64]:
    """A vector attribute of a product (e.g. ``grid_origin`` [m]) as floats; also reads the
    JSON text some files hold for lists."""
    value = product.attrs[key]
    return np.asarray(json.loads(value) if isinstance(value, str) else np.ravel(value),
                      dtype=float)


def carry_requests(raw: xr.Dataset, image: xr.Dataset) -> xr.Dataset:
    """Copy the raw product's request attributes (:data:`CARRIED_ATTRS`) that ``image`` lacks
    into it (in place); return ``image``."""
    for key in CARRIED_ATTRS:
        if key in raw.attrs and key not in image.attrs:
            image.attrs[key] = raw.attrs[key]
    return image
