"""Image formation: range compression and focusing (BPA; RDA, WDA, FSA for straight tracks).

:func:`focus` is the one entry point; every algorithm writes the same image product on the same
grids, so images compare pixel for pixel.
"""

from __future__ import annotations

import json

import numpy as np
import xarray as xr

import mitsar
from mitsar.errors import ParameterError
from mitsar.focus.bpa import aperture_half_width, backproject_drjit, backproject_numpy
from mitsar.focus.compression import range_compress, range_spectrum
from mitsar.focus.windows import WINDOWS, window_coefficients
from mitsar.grid import Grid, SlantGrid
from mitsar.raw import radar_of

ALGORITHMS = ("bpa",)

__all__ = ["focus", "range_compress", "range_spectrum", "ALGORITHMS"]


def focus(raw: xr.Dataset, algorithm: str = "bpa", grid: Grid | dict | None = None, *,
          window: str = "rect", range_window: str | None = None,
          azimuth_resolution: float | None = None, remove_rvp: bool = True,
          motion_correction: bool = True, backend: str = "drjit",
          range_upsample: int = 16, pixel_chunk: int = 1 << 20) -> xr.Dataset:
    """Focus a raw product into an image.

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product (:mod:`mitsar.raw`).
    algorithm : {"bpa"}
        Focusing algorithm.
    grid : SlantGrid, PlaneGrid, PointsGrid, dict or None
        Output grid; a dict is passed to :func:`mitsar.grid.from_dict`; default slant grid.
    window : str
        Azimuth window over the processed aperture (and the range window unless
        ``range_window`` is given): "rect", "hamming", "hann", "taylor".
    azimuth_resolution : float, optional
        Nominal azimuth resolution rho [m]: the processed aperture spans ``lambda / (2 rho)``
        in direction sine (paper: 0.10 m). Default: the whole beam.
    remove_rvp : bool
        Remove the residual video phase.
    motion_correction : bool
        Correct the continuous-motion (Doppler) range shift.
    backend : {"drjit", "numpy"}
        BPA kernel.
    range_upsample : int
        Zero-padding factor of the range FFT before linear interpolation.
    pixel_chunk : int
        Pixels per kernel launch (memory bound).

    Returns
    -------
    xarray.Dataset
        Image product: ``image`` (two dims, metre coordinates), ``position`` (pixel world
        positions), attributes ``range_resolution``, ``azimuth_resolution``, ``range_axis``,
        ``azimuth_axis``, grid description and provenance.
    """
    if algorithm not in ALGORITHMS:
        raise ParameterError("focus", "algorithm", f"one of {ALGORITHMS}", algorithm)
    if window not in WINDOWS:
        raise ParameterError("focus", "window", f"one of {WINDOWS}", window)
    range_window = window if range_window is None else range_window
    if azimuth_resolution is not None and not azimuth_resolution > 0:
        raise ParameterError("focus", "azimuth_resolution", "None or a resolution > 0 m",
                             azimuth_resolution)
    if backend not in ("drjit", "numpy"):
        raise ParameterError("focus", "backend", "'drjit' or 'numpy'", backend)
    if raw.attrs.get("product") != "raw":
        raise ParameterError("focus", "raw", "a raw product (attribute product='raw')",
                             raw.attrs.get("product"))
    if isinstance(grid, dict):
        from mitsar.grid import from_dict
        grid = from_dict(grid)
    grid = SlantGrid() if grid is None else grid

    radar = radar_of(raw)
    half_width = aperture_half_width(radar, azimuth_resolution)
    nominal_azimuth = radar.wavelength / (4 * half_width)
    layout = grid.resolve(raw, radar, nominal_azimuth)
    pixels = layout["position"].reshape(-1, 3)

    frequency, profile = range_spectrum(
        raw["raw"].values, radar, window=range_window, remove_rvp=remove_rvp,
        upsample=range_upsample, rvp_present=bool(raw.attrs.get("rvp", 1)))
    positions = raw["platform_position"].values
    velocities = raw["platform_velocity"].values
    speed = np.linalg.norm(velocities, axis=-1)
    centroid = np.einsum("si,si->s", raw["boresight"].values, velocities) / np.where(
        speed > 0, speed, 1.0)
    kernel = backproject_drjit if backend == "drjit" else backproject_numpy
    coefficients = window_coefficients(window)
    values = np.concatenate([
        kernel(profile, frequency, radar, pixels[start:start + pixel_chunk], positions,
               velocities, centroid, half_width, coefficients, motion_correction)
        for start in range(0, len(pixels), pixel_chunk)])

    return make_image_product(raw, values.reshape(layout["position"].shape[:2]), layout, {
        "algorithm": algorithm, "window": window, "range_window": range_window,
        "azimuth_resolution_requested": -1.0 if azimuth_resolution is None
        else float(azimuth_resolution),
        "rvp_removed": int(remove_rvp), "motion_correction": int(motion_correction),
        "backend": backend})


def make_image_product(raw: xr.Dataset, image: np.ndarray, layout: dict,
                       processing: dict) -> xr.Dataset:
    """Assemble the image product from focused values and a resolved grid layout."""
    dims = layout["dims"]
    product = xr.Dataset(
        {"image": (dims, image, {"long_name": "focused complex image"}),
         "position": (dims + ("xyz",), layout["position"], {"units": "m"})},
        coords={**{name: (name, values, {"units": "m"})
                   for name, values in layout["coords"].items()}, "xyz": ["x", "y", "z"]})
    keep = {k: v for k, v in raw.attrs.items() if k.startswith(("radar_", "look_"))}
    product.attrs.update(keep)
    product.attrs.update(
        product="image", mitsar_version=mitsar.__version__,
        range_resolution=float(layout["range_resolution"]),
        azimuth_resolution=float(layout["azimuth_resolution"]),
        range_axis=list(map(float, layout["range_axis"])),
        azimuth_axis=list(map(float, layout["azimuth_axis"])),
        raw_seed=raw.attrs.get("seed", -1), raw_config=raw.attrs.get("config", "{}"))
    for key, value in {**layout["attrs"], **processing}.items():
        product.attrs[key] = json.dumps(value) if isinstance(value, dict) else value
    return product
