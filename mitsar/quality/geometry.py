"""The image product as the impulse-response metrics read it (docs/metrics.md).

:func:`read_geometry` checks an image product's contract and returns its arrays with the range and
azimuth axes the cuts run along: the response's own (:func:`mitsar.focus.grid.response_frame`;
under squint it is rotated against a slant grid's axes) or the grid's. The rest maps between a
target's world position, fractional pixel indices and offsets in resolution cells, and gives the
band the response occupies (the upsampling's basebanding, :mod:`mitsar.quality.upsample`).
"""

from __future__ import annotations

from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import ParameterError

__all__ = ["DIRECTIONS", "ImageGeometry", "dim_offsets", "interpolate_position", "locate_target",
           "occupied_band", "read_geometry", "response_cells"]

DIRECTIONS = ("range", "azimuth")
"""The response's two axes, in the order of the metrics."""


class ImageGeometry(NamedTuple):
    """What :func:`mitsar.quality.impulse.measure_impulse_response` reads from an image."""

    dims: tuple[str, str]
    values: NDArray[np.complexfloating]  # complex image, (dim0, dim1)
    position: NDArray[np.float64]  # world position of every pixel, (dim0, dim1, 3), m
    spacing: NDArray[np.float64]  # signed pixel spacing of (dim0, dim1), m
    resolution: dict[str, float]  # one cell in range and azimuth, m
    axes: dict[str, NDArray[np.float64]]  # unit range/azimuth directions in (dim0, dim1)


def _bad_attribute(name: str, expected: str, found: Any) -> ParameterError:
    return ParameterError("image product", name, expected, found)


def _unit_axis(value: Any, name: str) -> NDArray[np.float64]:
    axis = np.asarray(value, dtype=float).reshape(-1)
    norm = float(np.hypot(*axis)) if axis.size == 2 else 0.0
    if axis.size != 2 or not np.isfinite(norm) or norm == 0.0:
        raise _bad_attribute(name, "a non-zero 2-element vector in the image's (dim0, dim1) "
                             "metre coordinates", value)
    return axis / norm


def read_geometry(image: xr.Dataset, cut_axes: str) -> ImageGeometry:
    """Validate the image product contract and return its arrays.

    ``cut_axes="response"`` reads ``response_range_axis`` etc. where the grid recorded them
    (:func:`mitsar.focus.grid.response_frame`), else ``range_axis`` etc.; ``"grid"`` always the
    latter.
    """
    for name in ("image", "position"):
        if name not in image:
            raise _bad_attribute(name, "a variable of an image product (mitsar.focus)", None)
    missing = [
        key
        for key in ("range_resolution", "azimuth_resolution", "range_axis", "azimuth_axis")
        if key not in image.attrs
    ]
    if missing:
        raise _bad_attribute(missing[0], "the attributes range_resolution, azimuth_resolution, "
                             "range_axis and azimuth_axis of an image product", None)
    amplitude = image["image"]
    if amplitude.ndim != 2:
        raise _bad_attribute("image", "a 2-D image", amplitude.dims)
    dims = (str(amplitude.dims[0]), str(amplitude.dims[1]))
    spacing = []
    for dim in dims:
        coord = np.asarray(image[dim].values, dtype=float)
        if coord.size < 3:
            raise _bad_attribute(dim, "at least 3 samples", coord.size)
        spacing.append(float(coord[1] - coord[0]))
    prefix = ""
    if cut_axes == "response" and all(
        f"response_{name}_{kind}" in image.attrs
        for name in DIRECTIONS for kind in ("axis", "resolution")
    ):
        prefix = "response_"
    axes = {name: _unit_axis(image.attrs[f"{prefix}{name}_axis"], f"{prefix}{name}_axis")
            for name in DIRECTIONS}
    if abs(axes["range"][0] * axes["azimuth"][1] - axes["range"][1] * axes["azimuth"][0]) < 1e-6:
        raise _bad_attribute(f"{prefix}range_axis", f"a direction not parallel to "
                             f"{prefix}azimuth_axis", image.attrs[f"{prefix}range_axis"])
    return ImageGeometry(
        dims=dims,
        values=np.asarray(amplitude.values),
        position=np.asarray(image["position"].transpose(*dims, "xyz").values, dtype=float),
        spacing=np.array(spacing),
        resolution={name: float(image.attrs[f"{prefix}{name}_resolution"])
                    for name in DIRECTIONS},
        axes=axes,
    )


def locate_target(geometry: ImageGeometry, target: NDArray[np.float64]) -> NDArray[np.float64]:
    """Fractional (dim0, dim1) index of ``target``; ParameterError if it is outside the image.

    Linear in the pixel steps around the nearest pixel (exact on slant and plane grids).
    """
    position, shape = geometry.position, np.array(geometry.values.shape)
    distance2 = np.sum((position - target) ** 2, axis=-1)
    nearest = np.array(np.unravel_index(int(np.argmin(distance2)), distance2.shape))
    steps = []
    for dim in range(2):
        ahead = nearest.copy()
        ahead[dim] = nearest[dim] + 1 if nearest[dim] + 1 < shape[dim] else nearest[dim] - 1
        sign = 1.0 if ahead[dim] > nearest[dim] else -1.0
        steps.append(sign * (position[tuple(ahead)] - position[tuple(nearest)]))
    basis = np.column_stack(steps)
    offset = np.linalg.lstsq(basis, target - position[tuple(nearest)], rcond=None)[0]
    index = nearest + offset
    beyond = np.maximum(-0.5 - index, index - (shape - 0.5))
    if np.any(beyond > 0.0):
        dim = int(np.argmax(beyond))
        short = float(beyond[dim] * abs(geometry.spacing[dim]))
        raise ParameterError(
            "measure_impulse_response", "target",
            f"a position inside the image; the target is outside the image by {short:.3f} m "
            f"along {geometry.dims[dim]!r} (image {shape.tolist()} pixels on {geometry.dims}): "
            f"extend the focusing grid by at least that much plus the measurement window",
            [round(float(v), 6) for v in target])
    return index


def dim_offsets(index_lo: NDArray, n: tuple[int, int], factor: int, origin: NDArray,
                 spacing: NDArray) -> tuple[NDArray, NDArray]:
    """Signed metre offsets along (dim0, dim1) of upsampled samples from a fractional index."""
    d0 = (index_lo[0] + np.arange(n[0]) / factor - origin[0]) * spacing[0]
    d1 = (index_lo[1] + np.arange(n[1]) / factor - origin[1]) * spacing[1]
    return d0[:, None], d1[None, :]


def occupied_band(geometry: ImageGeometry) -> tuple[float, float]:
    """Occupied fraction of the sampling rate along (dim0, dim1) of the nominal spectrum.

    The impulse response is band-limited to ``|κ_r| ≤ 1/(2ρ_r)``, ``|κ_a| ≤ 1/(2ρ_a)`` in
    cycles/m along the range and azimuth axes; with ``B = [u_r u_a]`` its wavenumbers are
    ``k = B⁻ᵀκ``, whose extent along each image dim times the pixel spacing is the fraction.
    """
    basis = np.column_stack([geometry.axes["range"], geometry.axes["azimuth"]])
    half_width = np.array([0.5 / geometry.resolution[name] for name in DIRECTIONS])
    extent = np.abs(np.linalg.inv(basis).T) @ half_width  # cycles/m either side, per dim
    band = 2.0 * extent * np.abs(geometry.spacing)
    return float(band[0]), float(band[1])


def interpolate_position(position: NDArray[np.float64], index: NDArray) -> NDArray[np.float64]:
    """World position at a fractional (dim0, dim1) pixel index, bilinear, m."""
    base = np.clip(np.floor(index).astype(int), 0, np.array(position.shape[:2]) - 2)
    frac = index - base
    corners = position[base[0] : base[0] + 2, base[1] : base[1] + 2]
    weights = np.outer([1.0 - frac[0], frac[0]], [1.0 - frac[1], frac[1]])
    return np.tensordot(weights, corners, axes=([0, 1], [0, 1]))


def response_cells(shape: tuple[int, ...], peak: NDArray[np.float64],
                   fine_spacing: NDArray[np.float64],
                   geometry: ImageGeometry) -> dict[str, NDArray[np.float64]]:
    """Offsets of every upsampled sample from the peak along the response axes, in cells."""
    basis = np.column_stack([geometry.axes["range"], geometry.axes["azimuth"]])
    to_axes = np.linalg.inv(basis)  # (dim0, dim1) metre offsets -> (range, azimuth) metres
    d0 = ((np.arange(shape[0]) - peak[0]) * fine_spacing[0])[:, None]
    d1 = ((np.arange(shape[1]) - peak[1]) * fine_spacing[1])[None, :]
    return {
        name: (to_axes[row, 0] * d0 + to_axes[row, 1] * d1) / geometry.resolution[name]
        for row, name in enumerate(DIRECTIONS)
    }
