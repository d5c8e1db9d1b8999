"""Impulse-response (point-target) quality metrics of a focused image: IRW, PSLR and ISLR.

:func:`measure_impulse_response` finds the target's peak in an image product, cuts a chip around
it, upsamples the chip (:mod:`mitsar.quality.upsample`), refines the peak in 2-D, takes cuts
along the range and azimuth axes through it and measures them (:mod:`mitsar.quality.cuts`, where
the metric definitions of Cumming & Wong 2005 §2.6 are); plus a 2-D ISLR over the chip.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from mitsar.focus.grid import equivalent_position
from mitsar.quality.cuts import ISLR_EXTENTS, measure_cut, parse_extent
from mitsar.quality.upsample import band_fill_db, check_factor, upsample_chip

__all__ = ["ISLR_EXTENTS", "measure_impulse_response"]

_DIRECTIONS = ("range", "azimuth")

#: Default chip half-width, resolution cells, and the one used for ``islr_extent="inf"``.
DEFAULT_CHIP_CELLS = 16.0
INF_CHIP_CELLS = 64.0
#: Default peak-search half-width, in resolution cells (of the coarser direction).
SEARCH_CELLS = 3.0
#: Minimum extent, in cells either side of the peak, a cut must cover to be measured.
MIN_CUT_CELLS = 3.0
#: Warn when the weakest part of a chip's spectrum is within this many dB of the strongest: the
#: spectrum then fills the band (about one sample per cell or coarser) and the band-limited
#: interpolation, hence every metric, is unreliable.
BAND_FILL_WARN_DB = -10.0
#: Upper bound on the number of samples of an upsampled 2-D chip (128 MiB as complex128); the
#: upsampling factor is reduced so that larger chips stay within it.
MAX_UPSAMPLED_SAMPLES = 2**23


class _Geometry(NamedTuple):
    """What :func:`measure_impulse_response` reads from an image product."""

    dims: tuple[str, str]
    values: NDArray[np.complexfloating]  # complex image, (dim0, dim1)
    position: NDArray[np.float64]  # world position of every pixel, (dim0, dim1, 3), m
    spacing: NDArray[np.float64]  # signed pixel spacing of (dim0, dim1), m
    resolution: dict[str, float]  # one cell in range and azimuth, m
    axes: dict[str, NDArray[np.float64]]  # unit range/azimuth directions in (dim0, dim1)


def _unit_axis(value: Any, name: str) -> NDArray[np.float64]:
    axis = np.asarray(value, dtype=float).reshape(-1)
    norm = float(np.hypot(*axis)) if axis.size == 2 else 0.0
    if axis.size != 2 or not np.isfinite(norm) or norm == 0.0:
        raise ValueError(
            f"image attribute {name!r} must be a non-zero 2-element vector in the image's "
            f"(dim0, dim1) metre coordinates; got {value!r}"
        )
    return axis / norm


def _read_geometry(image: xr.Dataset) -> _Geometry:
    """Validate the image product contract and return its arrays."""
    for name in ("image", "position"):
        if name not in image:
            raise ValueError(f"image dataset has no {name!r} variable")
    missing = [
        key
        for key in ("range_resolution", "azimuth_resolution", "range_axis", "azimuth_axis")
        if key not in image.attrs
    ]
    if missing:
        raise ValueError(f"image dataset lacks the attributes {missing}")
    amplitude = image["image"]
    if amplitude.ndim != 2:
        raise ValueError(f"image['image'] must be 2-D; got dims {amplitude.dims}")
    dims = (str(amplitude.dims[0]), str(amplitude.dims[1]))
    spacing = []
    for dim in dims:
        coord = np.asarray(image[dim].values, dtype=float)
        if coord.size < 3:
            raise ValueError(f"image dimension {dim!r} needs at least 3 samples; got {coord.size}")
        spacing.append(float(coord[1] - coord[0]))
    axes = {name: _unit_axis(image.attrs[f"{name}_axis"], f"{name}_axis") for name in _DIRECTIONS}
    if abs(axes["range"][0] * axes["azimuth"][1] - axes["range"][1] * axes["azimuth"][0]) < 1e-6:
        raise ValueError("image attributes 'range_axis' and 'azimuth_axis' are parallel")
    return _Geometry(
        dims=dims,
        values=np.asarray(amplitude.values),
        position=np.asarray(image["position"].transpose(*dims, "xyz").values, dtype=float),
        spacing=np.array(spacing),
        resolution={name: float(image.attrs[f"{name}_resolution"]) for name in _DIRECTIONS},
        axes=axes,
    )


def _outside_image(position: NDArray[np.float64], index: tuple[int, int], target: NDArray) -> bool:
    """Whether ``target`` lies more than half a pixel beyond the border pixel ``index``."""
    for dim, i in enumerate(index):
        n = position.shape[dim]
        if i not in (0, n - 1):
            continue
        inner = list(index)
        inner[dim] = 1 if i == 0 else n - 2
        outward = position[index] - position[tuple(inner)]
        beyond = float(np.dot(target - position[index], outward) / np.dot(outward, outward))
        if beyond > 0.5:
            return True
    return False


def _peak_pixel(geometry: _Geometry, target: NDArray[np.float64], search_m: float) -> NDArray:
    """Brightest pixel within ``search_m`` (square window) of the pixel nearest ``target``."""
    shape = np.array(geometry.values.shape)
    distance2 = np.sum((geometry.position - target) ** 2, axis=-1)
    nearest = np.unravel_index(int(np.argmin(distance2)), distance2.shape)
    if _outside_image(geometry.position, nearest, target):
        raise ValueError(
            f"target {target.tolist()} is outside the image (nearest pixel {list(nearest)} of "
            f"{shape.tolist()} on {geometry.dims})"
        )
    half = np.ceil(search_m / np.abs(geometry.spacing)).astype(int)
    lo = np.maximum(np.array(nearest) - half, 0)
    hi = np.minimum(np.array(nearest) + half + 1, shape)
    window = np.abs(geometry.values[lo[0] : hi[0], lo[1] : hi[1]])
    pixel = lo + np.array(np.unravel_index(int(np.argmax(window)), window.shape))
    if np.any(pixel == 0) or np.any(pixel == shape - 1):
        raise ValueError(
            f"target {target.tolist()} is too close to the image edge to measure: the peak is on "
            f"the border pixel {pixel.tolist()} of {shape.tolist()}"
        )
    return pixel


def _refine_peak_2d(
    power: NDArray[np.float64], k: tuple[int, int]
) -> tuple[NDArray[np.float64], float]:
    """Fractional peak index and peak power from a quadratic fit of the 3×3 neighbourhood.

    The fit uses the central-difference gradient ``g`` and Hessian ``H``: offset ``−H⁻¹g``,
    value ``p + g·offset / 2``.
    """
    k0, k1 = k
    origin = np.array(k, dtype=float)
    if not (0 < k0 < power.shape[0] - 1 and 0 < k1 < power.shape[1] - 1):
        return origin, float(power[k])
    w = power[k0 - 1 : k0 + 2, k1 - 1 : k1 + 2]
    gradient = 0.5 * np.array([w[2, 1] - w[0, 1], w[1, 2] - w[1, 0]])
    cross = 0.25 * (w[2, 2] - w[2, 0] - w[0, 2] + w[0, 0])
    hessian = np.array(
        [[w[2, 1] - 2 * w[1, 1] + w[0, 1], cross], [cross, w[1, 2] - 2 * w[1, 1] + w[1, 0]]]
    )
    if np.linalg.det(hessian) <= 0.0 or hessian[0, 0] >= 0.0:
        return origin, float(power[k])
    offset = np.clip(-np.linalg.solve(hessian, gradient), -0.5, 0.5)
    return origin + offset, max(float(w[1, 1] + 0.5 * gradient @ offset), float(w[1, 1]))


def _take_cut(
    fine: NDArray[np.complex128],
    peak: NDArray[np.float64],
    peak_int: tuple[int, int],
    axis: NDArray[np.float64],
    fine_spacing: NDArray[np.float64],
) -> tuple[NDArray[np.complex128], int, float]:
    """Samples of the upsampled chip along ``axis`` through the peak.

    An axis-aligned cut reads the row or column through the brightest upsampled sample; any other
    is interpolated with cubic splines (``scipy.ndimage.map_coordinates``) through the refined
    peak, one step of the finer pixel spacing apart. The cut stays within the chip.

    Returns
    -------
    cut : ndarray of complex128
    centre : int
        Index of the sample nearest the peak.
    step_m : float
        Sample spacing along the cut, m.
    """
    along = np.flatnonzero(np.abs(axis) > 1.0 - 1e-9)
    if along.size:
        step = np.zeros(2)
        step[along[0]] = 1.0
        step_m = float(abs(fine_spacing[along[0]]))
        origin = np.array(peak_int, dtype=float)
    else:
        step_m = float(np.min(np.abs(fine_spacing)))
        step = axis * step_m / fine_spacing  # upsampled samples per cut sample
        origin = peak
    with np.errstate(divide="ignore", invalid="ignore"):
        bound_a = -origin / step
        bound_b = (np.array(fine.shape) - 1 - origin) / step
    moving = step != 0.0
    t_lo = math.ceil(np.max(np.minimum(bound_a, bound_b)[moving]) - 1e-9)
    t_hi = math.floor(np.min(np.maximum(bound_a, bound_b)[moving]) + 1e-9)
    coords = origin[:, None] + step[:, None] * np.arange(t_lo, t_hi + 1)[None, :]
    if along.size:
        index = np.rint(coords).astype(int)
        cut = fine[index[0], index[1]]
    else:  # spline-filter only the bounding box of the line (plus the cubic kernel's reach)
        lo = np.maximum(np.floor(coords.min(axis=1)).astype(int) - 3, 0)
        hi = np.minimum(np.ceil(coords.max(axis=1)).astype(int) + 4, fine.shape)
        box = fine[lo[0] : hi[0], lo[1] : hi[1]]
        cut = ndimage.map_coordinates(box, coords - lo[:, None], order=3, mode="nearest")
    return cut, -t_lo, step_m


def _islr_2d_db(
    power: NDArray[np.float64],
    peak: NDArray[np.float64],
    fine_spacing: NDArray[np.float64],
    geometry: _Geometry,
    nulls: dict[str, tuple[float, float]],
    extent: float,
) -> float:
    """2-D ISLR: main lobe = rectangle of the two null-to-null main lobes, in range/azimuth cells.

    Sidelobes: the rest of the box of ± ``extent`` cells along both axes, or of the whole chip
    (FastSAR ``quality.point_target``; Cumming & Wong 2005 §2.6).
    """
    basis = np.column_stack([geometry.axes["range"], geometry.axes["azimuth"]])
    to_axes = np.linalg.inv(basis)  # (dim0, dim1) metre offsets -> (range, azimuth) metres
    d0 = ((np.arange(power.shape[0]) - peak[0]) * fine_spacing[0])[:, None]
    d1 = ((np.arange(power.shape[1]) - peak[1]) * fine_spacing[1])[None, :]
    cells = {
        name: (to_axes[row, 0] * d0 + to_axes[row, 1] * d1) / geometry.resolution[name]
        for row, name in enumerate(_DIRECTIONS)
    }
    main = np.ones(power.shape, dtype=bool)
    box = np.ones(power.shape, dtype=bool)
    for name in _DIRECTIONS:
        main &= (cells[name] >= nulls[name][0]) & (cells[name] <= nulls[name][1])
        box &= np.abs(cells[name]) <= extent
    main_energy = float(np.sum(power[main]))
    return 10.0 * math.log10(float(np.sum(power[box])) / main_energy - 1.0)


def _occupied_band(geometry: _Geometry) -> tuple[float, float]:
    """Occupied fraction of the sampling rate along (dim0, dim1) of the nominal spectrum.

    The impulse response is band-limited to ``|κ_r| ≤ 1/(2ρ_r)``, ``|κ_a| ≤ 1/(2ρ_a)`` in
    cycles/m along the range and azimuth axes; with ``B = [u_r u_a]`` its wavenumbers are
    ``k = B⁻ᵀκ``, whose extent along each image dim times the pixel spacing is the fraction.
    """
    basis = np.column_stack([geometry.axes["range"], geometry.axes["azimuth"]])
    half_width = np.array([0.5 / geometry.resolution[name] for name in _DIRECTIONS])
    extent = np.abs(np.linalg.inv(basis).T) @ half_width  # cycles/m either side, per dim
    band = 2.0 * extent * np.abs(geometry.spacing)
    return float(band[0]), float(band[1])


def _interpolate_position(position: NDArray[np.float64], index: NDArray) -> NDArray[np.float64]:
    """World position at a fractional (dim0, dim1) pixel index, bilinear, m."""
    base = np.clip(np.floor(index).astype(int), 0, np.array(position.shape[:2]) - 2)
    frac = index - base
    corners = position[base[0] : base[0] + 2, base[1] : base[1] + 2]
    weights = np.outer([1.0 - frac[0], frac[0]], [1.0 - frac[1], frac[1]])
    return np.tensordot(weights, corners, axes=([0, 1], [0, 1]))


def _warn_band_fill(chip: NDArray, dims: tuple[str, str]) -> None:
    fill = band_fill_db(chip)
    if max(fill) > BAND_FILL_WARN_DB:
        warnings.warn(
            f"the chip spectrum fills the band (weakest/strongest level {max(fill):.1f} dB along "
            f"{dims[int(np.argmax(fill))]!r}): the image is sampled at about one sample per cell "
            "or coarser, so the interpolated metrics are unreliable; oversample the image "
            "(e.g. zero-pad the focusing FFTs)",
            RuntimeWarning,
            stacklevel=3,
        )


def measure_impulse_response(
    image: xr.Dataset,
    target: ArrayLike,
    *,
    islr_extent: str | float = "paper",
    upsample: int = 32,
    chip_cells: float | None = None,
    search_radius_m: float | None = None,
) -> dict[str, Any]:
    """Point-target impulse-response metrics of a focused image (paper Tables 4–5).

    Parameters
    ----------
    image : xarray.Dataset
        Image product of :mod:`mitsar.focus`: complex ``image`` with two uniformly spaced metre
        dims, ``position`` (dim0, dim1, ``xyz``) world positions of the pixels (m), and attributes
        ``range_resolution`` and ``azimuth_resolution`` (m, one cell each) and ``range_axis`` and
        ``azimuth_axis`` (unit vectors in the (dim0, dim1) metre coordinates).
    target : array_like, shape (3,)
        World position (x, y, z) of the target, m.
    islr_extent : {"paper", "isce3", "chip", "inf"} or float, default "paper"
        Sidelobe extent of the ISLRs (see :func:`islr_db`); in 2-D, a box of ± that many cells
        along the range and azimuth axes. ``"chip"`` and ``"inf"`` use the whole chip, for
        ``"inf"`` by default ``INF_CHIP_CELLS`` (64) cells either side: for a rectangular
        spectrum that gives −9.75 dB, the energy beyond ±L cells being 1/(π²L) of the total.
    upsample : int, default 32
        Upsampling factor of the chip per pixel (reduced for very large chips so that the
        upsampled chip stays below ``MAX_UPSAMPLED_SAMPLES``; the factor used is returned).
    chip_cells : float, optional
        Half-width of the chip around the peak, in cells of the coarser direction; default 16
        (64 for ``islr_extent="inf"``). Clipped to the image.
    search_radius_m : float, optional
        Half-width of the square window, around the pixel nearest ``target``, searched for the
        peak of ``|image|``; default 3 cells of the coarser direction, m.

    Returns
    -------
    dict
        JSON-serialisable: ``range`` and ``azimuth`` each ``{"irw_cells", "irw_m", "pslr_db",
        "islr_db"}``; ``islr_2d_db`` (main lobe: rectangle spanned by the null-to-null main lobes
        of the two cuts; sidelobes: the rest of the extent box or chip); ``peak_position`` (world
        position at the fractional peak index, m), ``peak_index`` (fractional (dim0, dim1)
        index), ``peak_offset_m`` (distance from the peak to ``target``, m; on a slant grid to
        the target's equivalent position on the grid), ``peak_db``
        (20 log10 |peak|, amplitude unit of the image), ``islr_extent``, ``chip_cells`` and
        ``upsample`` (values used).

    Raises
    ------
    ValueError
        If the target is outside the image, too close to its edge to measure, or an argument or
        attribute is invalid.

    Warns
    -----
    RuntimeWarning
        If the chip's spectrum fills the band (see :func:`band_fill_db`).

    Notes
    -----
    Metric definitions: Cumming & Wong 2005 §2.6; basebanded 2-D upsampling as in ISCE3
    ``point_target_info``; 2-D ISLR main lobe as in FastSAR ``quality.point_target``.
    """
    extent = parse_extent(islr_extent)
    factor = check_factor(upsample)
    geometry = _read_geometry(image)
    cell = max(geometry.resolution.values())
    if chip_cells is None:
        chip_cells = INF_CHIP_CELLS if islr_extent == "inf" else DEFAULT_CHIP_CELLS
    if not chip_cells > 0:
        raise ValueError(f"chip_cells must be positive; got {chip_cells!r}")
    if extent != math.inf and extent > chip_cells:
        raise ValueError(
            f"the ISLR extent ({extent:g} cells, islr_extent={islr_extent!r}) exceeds the chip "
            f"(chip_cells={chip_cells:g}); raise chip_cells"
        )
    search_m = SEARCH_CELLS * cell if search_radius_m is None else float(search_radius_m)
    # On a slant grid a world point images where its (along-track, slant-range) coordinates
    # put it, which need not be on the grid's half-plane (mitsar.focus.grid.equivalent_position).
    target = equivalent_position(image, np.asarray(target, dtype=float).reshape(3))
    pixel = _peak_pixel(geometry, target, search_m)

    # Chip of ± chip_cells around the peak (one pixel more, as the peak may be half a pixel off),
    # clipped to the image, upsampled; the wrapped-round tail of the upsampled chip is dropped.
    shape = np.array(geometry.values.shape)
    half = np.ceil(chip_cells * cell / np.abs(geometry.spacing)).astype(int) + 1
    lo = np.maximum(pixel - half, 0)
    hi = np.minimum(pixel + half + 1, shape)
    chip = geometry.values[lo[0] : hi[0], lo[1] : hi[1]]
    _warn_band_fill(chip, geometry.dims)
    factor = max(1, min(factor, math.isqrt(MAX_UPSAMPLED_SAMPLES // chip.size)))
    keep = (np.array(chip.shape) - 1) * factor + 1
    fine = upsample_chip(chip, factor, band=_occupied_band(geometry))[: keep[0], : keep[1]]
    power = np.abs(fine) ** 2
    peak_int = np.unravel_index(int(np.argmax(power)), power.shape)
    peak, peak_power = _refine_peak_2d(power, peak_int)
    fine_spacing = geometry.spacing / factor  # signed, m per upsampled sample

    results: dict[str, Any] = {}
    nulls: dict[str, tuple[float, float]] = {}
    needed = MIN_CUT_CELLS if extent == math.inf else extent
    for name in _DIRECTIONS:
        res = geometry.resolution[name]
        cut, centre, step_m = _take_cut(fine, peak, peak_int, geometry.axes[name], fine_spacing)
        reach = min(centre, cut.size - 1 - centre) * step_m / res
        if reach < needed:
            raise ValueError(
                f"target {target.tolist()} is too close to the image edge to measure: the {name} "
                f"cut reaches only {reach:.2f} cells on one side of the peak, {needed:g} needed "
                f"(islr_extent={islr_extent!r})"
            )
        metrics = measure_cut(cut, step_m / res, islr_extent)
        nulls[name] = (metrics["null_left_cells"], metrics["null_right_cells"])
        results[name] = {
            "irw_cells": metrics["irw_cells"],
            "irw_m": metrics["irw_cells"] * res,
            "pslr_db": metrics["pslr_db"],
            "islr_db": metrics["islr_db"],
        }

    index = lo + peak / factor
    peak_position = _interpolate_position(geometry.position, index)
    return {
        "range": results["range"],
        "azimuth": results["azimuth"],
        "islr_2d_db": _islr_2d_db(power, peak, fine_spacing, geometry, nulls, extent),
        "peak_position": [float(v) for v in peak_position],
        "peak_index": [float(v) for v in index],
        "peak_offset_m": float(np.linalg.norm(peak_position - target)),
        "peak_db": 10.0 * math.log10(peak_power),
        "islr_extent": islr_extent if isinstance(islr_extent, str) else float(islr_extent),
        "chip_cells": float(chip_cells),
        "upsample": int(factor),
    }
