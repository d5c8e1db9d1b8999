"""The image product: focused complex pixels on a resolved grid, with coverage and provenance."""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

from mitsar.version import __version__


def make_image_product(raw: xr.Dataset, image: np.ndarray, layout: dict, processing: dict,
                       coverage: np.ndarray | None = None) -> xr.Dataset:
    """Assemble the image product from focused values and a resolved grid layout.

    ``coverage`` (same shape as ``image``) is the fraction of the full processed aperture that
    contributed to each pixel (ones when omitted).
    """
    dims = layout["dims"]
    product = xr.Dataset(
        {"image": (dims, image, {"long_name": "focused complex image"}),
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
    product["coverage"] = (dims, np.ones(image.shape) if coverage is None else coverage, {
        "long_name": "fraction of the full processed aperture that contributed", "units": "1"})
    return product
