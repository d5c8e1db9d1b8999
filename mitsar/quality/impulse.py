"""Impulse-response (point-target) quality metrics of a focused image: IRW, PSLR and ISLR.

:func:`measure_impulse_response` finds the target's peak in an image product, cuts a chip around
it, upsamples the chip (:mod:`mitsar.quality.upsample`), refines the peak in 2-D, takes cuts
along the range and azimuth axes through it and measures them (:mod:`mitsar.quality.cuts`, where
the metric definitions of Cumming & Wong 2005 §2.6 are); plus a 2-D ISLR over the chip.

Trust (docs/metrics.md): the peak is searched only within ``search_radius_m`` of the target
(default :data:`SEARCH_CELLS` cells) and must be a local maximum there; the cuts run along the
response's own axes, recorded by the grid (:func:`mitsar.focus.grid.response_frame`: under
squint the response is rotated against a slant grid's axes), or along the grid's axes on
request; any other scatterer within :data:`NEIGHBOUR_DB` of the peak inside the measurement
window is reported in ``warnings``.
"""

from __future__ import annotations

import math
import warnings
from typing import Any, NamedTuple

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy import ndimage

from mitsar import checks
from mitsar.errors import ParameterError
from mitsar.focus.grid import equivalent_position
from mitsar.quality.cuts import (
    EXTENT_OPTION,
    ISLR_EXTENTS,
    MeasurementError,
    measure_cut,
    parse_extent,
)
from mitsar.quality.upsample import band_fill_db, check_factor, upsample_chip

__all__ = ["CUT_AXES", "ISLR_EXTENTS", "NEIGHBOUR_DB", "SEARCH_CELLS",
           "measure_impulse_response"]

_DIRECTIONS = ("range", "azimuth")

#: Default chip half-width, resolution cells, and the one used for ``islr_extent="inf"``.
DEFAULT_CHIP_CELLS = 16.0
INF_CHIP_CELLS = 64.0
#: Default peak-search radius around the target, in resolution cells of the coarser direction:
#: a focused target lies within a fraction of a cell of its position, a neighbour resolved from
#: it (about 1.2 cells away or more at -5 dB) does not capture the search.
SEARCH_CELLS = 2.0
#: A second scatterer within this level of the peak (dB) inside the measurement window is
#: reported in ``warnings``: its response adds to the sidelobes and may move the nulls.
NEIGHBOUR_DB = -20.0
#: Margin over the envelope of the target's own (rectangular-spectrum) sidelobes above which a
#: local maximum counts as another scatterer, dB.
OWN_SIDELOBE_MARGIN_DB = 3.0
#: Directions of the cuts: the response's own axes (default) or the grid's recorded axes.
CUT_AXES = ("response", "grid")
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


def _bad_attribute(name: str, expected: str, found: Any) -> ParameterError:
    return ParameterError("image product", name, expected, found)


def _unit_axis(value: Any, name: str) -> NDArray[np.float64]:
    axis = np.asarray(value, dtype=float).reshape(-1)
    norm = float(np.hypot(*axis)) if axis.size == 2 else 0.0
    if axis.size != 2 or not np.isfinite(norm) or norm == 0.0:
        raise _bad_attribute(name, "a non-zero 2-element vector in the image's (dim0, dim1) "
                             "metre coordinates", value)
    return axis / norm


def _read_geometry(image: xr.Dataset, cut_axes: str) -> _Geometry:
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
        for name in _DIRECTIONS for kind in ("axis", "resolution")
    ):
        prefix = "response_"
    axes = {name: _unit_axis(image.attrs[f"{prefix}{name}_axis"], f"{prefix}{name}_axis")
            for name in _DIRECTIONS}
    if abs(axes["range"][0] * axes["azimuth"][1] - axes["range"][1] * axes["azimuth"][0]) < 1e-6:
        raise _bad_attribute(f"{prefix}range_axis", f"a direction not parallel to "
                             f"{prefix}azimuth_axis", image.attrs[f"{prefix}range_axis"])
    return _Geometry(
        dims=dims,
        values=np.asarray(amplitude.values),
        position=np.asarray(image["position"].transpose(*dims, "xyz").values, dtype=float),
        spacing=np.array(spacing),
        resolution={name: float(image.attrs[f"{prefix}{name}_resolution"])
                    for name in _DIRECTIONS},
        axes=axes,
    )


def _locate(geometry: _Geometry, target: NDArray[np.float64]) -> NDArray[np.float64]:
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


def _dim_offsets(index_lo: NDArray, n: tuple[int, int], factor: int, origin: NDArray,
                 spacing: NDArray) -> tuple[NDArray, NDArray]:
    """Signed metre offsets along (dim0, dim1) of upsampled samples from a fractional index."""
    d0 = (index_lo[0] + np.arange(n[0]) / factor - origin[0]) * spacing[0]
    d1 = (index_lo[1] + np.arange(n[1]) / factor - origin[1]) * spacing[1]
    return d0[:, None], d1[None, :]


def _peak_pixel(geometry: _Geometry, target_index: NDArray, search_m: float) -> NDArray:
    """Brightest pixel within ``search_m`` of the target (disc in the image's metres)."""
    shape = np.array(geometry.values.shape)
    half = np.ceil(search_m / np.abs(geometry.spacing)).astype(int) + 1
    centre = np.rint(target_index).astype(int)
    lo = np.clip(centre - half, 0, shape - 1)
    hi = np.clip(centre + half + 1, 1, shape)
    d0, d1 = _dim_offsets(lo, tuple(hi - lo), 1, target_index, geometry.spacing)
    inside = d0**2 + d1**2 <= (search_m + 0.5 * np.abs(geometry.spacing).max()) ** 2
    window = np.where(inside, np.abs(geometry.values[lo[0] : hi[0], lo[1] : hi[1]]), -1.0)
    pixel = lo + np.array(np.unravel_index(int(np.argmax(window)), window.shape))
    if np.any(pixel == 0) or np.any(pixel == shape - 1):
        raise ParameterError(
            "measure_impulse_response", "target",
            "a target whose peak is inside the image; the target is too close to the image "
            f"edge to measure: its peak is on the border pixel {pixel.tolist()} of "
            f"{shape.tolist()}: extend the focusing grid around the target",
            [round(float(v), 6) for v in geometry.position[tuple(pixel)]])
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
    cells: dict[str, NDArray[np.float64]],
    nulls: dict[str, tuple[float, float]],
    extent: float,
) -> float:
    """2-D ISLR: main lobe = rectangle of the two null-to-null main lobes, in range/azimuth cells.

    Sidelobes: the rest of the box of ± ``extent`` cells along both axes, or of the whole chip
    (FastSAR ``quality.point_target``; Cumming & Wong 2005 §2.6). ``cells``: offsets of every
    sample from the peak along the response axes (:func:`_cells`).
    """
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


def _warn_band_fill(chip: NDArray, dims: tuple[str, str]) -> str | None:
    fill = band_fill_db(chip)
    if max(fill) <= BAND_FILL_WARN_DB:
        return None
    message = (
        f"the chip spectrum fills the band (weakest/strongest level {max(fill):.1f} dB along "
        f"{dims[int(np.argmax(fill))]!r}): the image is sampled at about one sample per cell "
        "or coarser, so the interpolated metrics are unreliable; oversample the image "
        "(e.g. zero-pad the focusing FFTs)"
    )
    warnings.warn(message, RuntimeWarning, stacklevel=3)
    return message


def _fine_peak(power: NDArray[np.float64], inside: NDArray[np.bool_], search_m: float,
               distance: NDArray[np.float64]) -> tuple[int, int]:
    """Brightest upsampled sample within the search disc; it must be a local maximum.

    Raises :class:`MeasurementError` when the brightest sample inside is on the disc's boundary,
    rising towards something brighter outside (a stronger neighbour's main lobe).
    """
    k = np.unravel_index(int(np.argmax(np.where(inside, power, -1.0))), power.shape)
    lo = np.maximum(np.array(k) - 1, 0)
    hi = np.minimum(np.array(k) + 2, power.shape)
    if power[k] < power[lo[0] : hi[0], lo[1] : hi[1]].max():
        raise MeasurementError(
            f"no peak within search_radius_m={search_m:.4g} m of the target: the brightest "
            f"sample there is on the search boundary, {float(distance[k]):.4f} m away, rising "
            "towards a brighter response outside (a stronger neighbour, or the target farther "
            "off than the radius); check the target position or raise search_radius_m"
        )
    return int(k[0]), int(k[1])


def _envelope(cells: NDArray[np.float64]) -> NDArray[np.float64]:
    """Upper bound of a rectangular-spectrum response's power, ``min(1, 1/(pi x)^2)``."""
    return np.minimum(1.0, 1.0 / np.maximum((np.pi * cells) ** 2, 1e-300))


def _neighbours(power: NDArray[np.float64], peak_power: float,
                cells: dict[str, NDArray[np.float64]], extent: float, factor: int,
                level_db: float) -> list[tuple[tuple[int, int], float, float, float]]:
    """Local maxima of another scatterer within ``level_db`` of the peak in the window.

    A local maximum counts when it is at least ``level_db`` relative to the peak, exceeds the
    envelope of the target's own separable sidelobes (:func:`_envelope` per axis, Cumming &
    Wong 2005 §2.6) by :data:`OWN_SIDELOBE_MARGIN_DB`, and lies within ± ``extent`` cells along
    both response axes (the whole chip for an infinite extent) and off the chip border.

    Returns
    -------
    list of ((i0, i1), level dB, range cells, azimuth cells), strongest first.
    """
    stride = max(1, factor // 8)
    coarse = power[::stride, ::stride]
    local = coarse == ndimage.maximum_filter(coarse, size=3, mode="nearest")
    local[[0, -1], :] = False
    local[:, [0, -1]] = False
    u = cells["range"][::stride, ::stride]
    w = cells["azimuth"][::stride, ::stride]
    relative = coarse / peak_power
    own = _envelope(u) * _envelope(w) * 10 ** (OWN_SIDELOBE_MARGIN_DB / 10)
    window = (np.abs(u) <= extent) & (np.abs(w) <= extent)
    found = local & window & (relative >= 10 ** (level_db / 10)) & (relative > own)
    out = []
    for i0, i1 in zip(*np.nonzero(found), strict=True):
        out.append(((int(i0) * stride, int(i1) * stride),
                    10.0 * math.log10(float(relative[i0, i1])), float(u[i0, i1]),
                    float(w[i0, i1])))
    return sorted(out, key=lambda item: -item[1])


def _cells(shape: tuple[int, ...], peak: NDArray[np.float64], fine_spacing: NDArray[np.float64],
           geometry: _Geometry) -> dict[str, NDArray[np.float64]]:
    """Offsets of every upsampled sample from the peak along the response axes, in cells."""
    basis = np.column_stack([geometry.axes["range"], geometry.axes["azimuth"]])
    to_axes = np.linalg.inv(basis)  # (dim0, dim1) metre offsets -> (range, azimuth) metres
    d0 = ((np.arange(shape[0]) - peak[0]) * fine_spacing[0])[:, None]
    d1 = ((np.arange(shape[1]) - peak[1]) * fine_spacing[1])[None, :]
    return {
        name: (to_axes[row, 0] * d0 + to_axes[row, 1] * d1) / geometry.resolution[name]
        for row, name in enumerate(_DIRECTIONS)
    }


def measure_impulse_response(
    image: xr.Dataset,
    target: ArrayLike,
    *,
    islr_extent: str | float = "paper",
    upsample: int = 32,
    chip_cells: float | None = None,
    search_radius_m: float | None = None,
    cut_axes: str = "response",
    neighbour_db: float = NEIGHBOUR_DB,
) -> dict[str, Any]:
    """Point-target impulse-response metrics of a focused image (paper Tables 4–5).

    Parameters
    ----------
    image : xarray.Dataset
        Image product of :mod:`mitsar.focus`: complex ``image`` with two uniformly spaced metre
        dims, ``position`` (dim0, dim1, ``xyz``) world positions of the pixels (m), and attributes
        ``range_resolution`` and ``azimuth_resolution`` (m, one cell each) and ``range_axis`` and
        ``azimuth_axis`` (unit vectors in the (dim0, dim1) metre coordinates); optionally the
        response's own ``response_range_axis`` etc. (:func:`mitsar.focus.grid.response_frame`).
    target : array_like, shape (3,)
        World position (x, y, z) of the target, m.
    islr_extent : {"paper", "isce3", "chip", "inf"} or float, default "paper"
        Sidelobe extent of the ISLRs (see :func:`islr_db`); in 2-D, a box of ± that many cells
        along the range and azimuth axes. ``"chip"`` and ``"inf"`` use the whole chip, for
        ``"inf"`` a large one (±64 cells; the upsampling factor is then reduced for very large
        chips so that the upsampled chip stays below ``MAX_UPSAMPLED_SAMPLES``; the factor used
        is returned). The same box is the measurement window searched for neighbours.
    upsample : int, default 32
        Upsampling factor of the chip.
    chip_cells : float, optional
        Half-width of the chip around the peak, in cells of the coarser direction; default 16
        (64 for ``islr_extent="inf"``). Clipped to the image.
    search_radius_m : float, optional
        Radius around the target (in the image's metre coordinates; on a slant grid around the
        target's equivalent position) within which the peak is searched, m; default
        :data:`SEARCH_CELLS` (2) cells of the coarser direction. The peak must be a local
        maximum inside it.
    cut_axes : {"response", "grid"}, default "response"
        ``"response"``: cut along the response's own range and azimuth axes, as recorded by the
        grid (under squint a slant-grid response is rotated by the squint, and its azimuth cell
        is ``rho cos(squint)``); falls back to ``range_axis`` / ``azimuth_axis`` for products
        without them. ``"grid"``: along ``range_axis`` / ``azimuth_axis`` with
        ``range_resolution`` / ``azimuth_resolution`` (the slant grid's own axes; the behaviour
        of mitsar before 0.x, for comparison with tools that cut along image axes).
    neighbour_db : float, default -20
        Report other scatterers at least this strong relative to the peak (dB) inside the
        measurement window (:data:`NEIGHBOUR_DB`).

    Returns
    -------
    dict
        JSON-serialisable: ``range`` and ``azimuth`` each ``{"irw_cells", "irw_m", "pslr_db",
        "islr_db", "axis", "cell_m"}`` (``axis``: unit cut direction in (dim0, dim1); ``cell_m``:
        one cell along it); ``islr_2d_db`` (main lobe: rectangle spanned by the null-to-null
        main lobes of the two cuts; sidelobes: the rest of the extent box or chip);
        ``peak_position`` (world position at the fractional peak index, m), ``peak_index``
        (fractional (dim0, dim1) index), ``peak_offset_m`` (distance from the peak to
        ``target``, m; on a slant grid to the target's equivalent position on the grid),
        ``peak_db`` (20 log10 |peak|, amplitude unit of the image); ``snr_db`` and ``nesz_db``
        (the peak over the pixel's ``noise_power``, and its ``nesz_db``; only for images that
        carry them, docs/metrics.md §Noise); ``warnings`` (list of str:
        neighbours, band fill) and ``neighbours`` (list of ``{"position", "level_db",
        "distance_m", "offset_cells"}``); ``islr_extent``, ``chip_cells``, ``upsample``,
        ``search_radius_m`` and ``cut_axes`` (values used).

    Raises
    ------
    ParameterError
        If an argument or image attribute is invalid, the target is outside the image or too
        close to its edge (the message says how far the grid must extend).
    MeasurementError
        If no peak is found within the search radius or a cut has no nulls or half-power points.

    Warns
    -----
    RuntimeWarning
        If the chip's spectrum fills the band (see :func:`band_fill_db`).

    Notes
    -----
    Metric definitions: Cumming & Wong 2005 §2.6; basebanded 2-D upsampling as in ISCE3
    ``point_target_info``; 2-D ISLR main lobe as in FastSAR ``quality.point_target``.
    Conventions and measured numbers: docs/metrics.md.
    """
    extent = parse_extent(islr_extent)
    factor = check_factor(upsample)
    if search_radius_m is not None:
        checks.positive("measure_impulse_response", "search_radius_m", search_radius_m,
                        "a positive radius, m")
    if cut_axes not in CUT_AXES:
        raise ParameterError("measure_impulse_response", "cut_axes", f"one of {CUT_AXES}",
                             cut_axes)
    geometry = _read_geometry(image, cut_axes)
    cell = max(geometry.resolution.values())
    if chip_cells is None:
        chip_cells = INF_CHIP_CELLS if islr_extent == "inf" else DEFAULT_CHIP_CELLS
    if not (isinstance(chip_cells, int | float) and chip_cells > 0):
        raise ParameterError("measure_impulse_response", "chip_cells",
                             "a positive number of cells", chip_cells)
    if extent != math.inf and extent > chip_cells:
        raise ParameterError(
            "measure_impulse_response", "chip_cells",
            f"at least the ISLR extent ({extent:g} cells, {EXTENT_OPTION}={islr_extent!r}); "
            "raise chip_cells or lower the extent", chip_cells)
    if search_radius_m is None:
        search_m = SEARCH_CELLS * cell
    elif not (math.isfinite(float(search_radius_m)) and float(search_radius_m) > 0):
        raise ParameterError("measure_impulse_response", "search_radius_m",
                             "a positive radius, m", search_radius_m)
    else:
        search_m = float(search_radius_m)
    # On a slant grid a world point images where its (along-track, slant-range) coordinates
    # put it, which need not be on the grid's half-plane (mitsar.focus.grid.equivalent_position).
    target = equivalent_position(image, checks.vector(
        "measure_impulse_response", "target", target, 3, "the target's world position: "
        "3 finite numbers [m]"))
    target_index = _locate(geometry, target)
    pixel = _peak_pixel(geometry, target_index, search_m)
    messages: list[str] = []

    # Chip of ± chip_cells around the peak (one pixel more, as the peak may be half a pixel off),
    # clipped to the image, upsampled; the wrapped-round tail of the upsampled chip is dropped.
    shape = np.array(geometry.values.shape)
    half = np.ceil(chip_cells * cell / np.abs(geometry.spacing)).astype(int) + 1
    lo = np.maximum(pixel - half, 0)
    hi = np.minimum(pixel + half + 1, shape)
    chip = geometry.values[lo[0] : hi[0], lo[1] : hi[1]]
    band_message = _warn_band_fill(chip, geometry.dims)
    if band_message:
        messages.append(band_message)
    factor = max(1, min(factor, math.isqrt(MAX_UPSAMPLED_SAMPLES // chip.size)))
    keep = (np.array(chip.shape) - 1) * factor + 1
    fine = upsample_chip(chip, factor, band=_occupied_band(geometry))[: keep[0], : keep[1]]
    power = np.abs(fine) ** 2
    d0, d1 = _dim_offsets(lo, power.shape, factor, target_index, geometry.spacing)
    distance = np.sqrt(d0**2 + d1**2)
    peak_int = _fine_peak(power, distance <= search_m, search_m, distance)
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
            need_m = needed * res + float(np.max(np.abs(geometry.spacing)))
            raise ParameterError(
                "measure_impulse_response", f"{EXTENT_OPTION} or the image grid",
                f"a target farther from the image edge: the grid must extend at least "
                f"{need_m:.3f} m beyond the target in {name} (along "
                f"{np.round(geometry.axes[name], 4).tolist()} in {geometry.dims}) for "
                f"{needed:g} cells of {res:.4f} m; the target is too close to the image edge "
                f"to measure: the {name} cut reaches only {reach * res:.3f} m ({reach:.2f} "
                f"cells) on one side. Extend the focusing grid, or lower {EXTENT_OPTION}",
                islr_extent)
        metrics = measure_cut(cut, step_m / res, islr_extent)
        nulls[name] = (metrics["null_left_cells"], metrics["null_right_cells"])
        results[name] = {
            "irw_cells": metrics["irw_cells"],
            "irw_m": metrics["irw_cells"] * res,
            "pslr_db": metrics["pslr_db"],
            "islr_db": metrics["islr_db"],
            "axis": [float(v) for v in geometry.axes[name]],
            "cell_m": res,
        }

    cells = _cells(power.shape, peak, fine_spacing, geometry)
    index = lo + peak / factor
    peak_position = _interpolate_position(geometry.position, index)
    # Own sidelobes are told from neighbours in the response's frame, whichever axes are cut.
    frame = geometry if cut_axes == "response" else _read_geometry(image, "response")
    own_cells = cells if frame is geometry else _cells(power.shape, peak, fine_spacing, frame)
    neighbours = []
    for (i0, i1), level, u, w in _neighbours(power, peak_power, own_cells, extent, factor,
                                             neighbour_db):
        where = _interpolate_position(geometry.position, lo + np.array([i0, i1]) / factor)
        gap = float(np.linalg.norm(where - peak_position))
        neighbours.append({"position": [float(v) for v in where], "level_db": level,
                           "distance_m": gap, "offset_cells": [u, w]})
        messages.append(
            f"a second scatterer at {np.round(where, 3).tolist()} m, {level:+.1f} dB relative "
            f"to the peak and {gap:.3f} m from it ({u:+.1f} range, {w:+.1f} azimuth cells), "
            f"lies inside the measurement window ({EXTENT_OPTION}={islr_extent!r}): the "
            "sidelobe metrics include its response"
        )
    noise = {}
    if "noise_power" in image.variables:  # SNR over the pixel noise floor, docs/metrics.md §Noise
        at = tuple(np.clip(np.round(index).astype(int), 0, shape - 1))
        floor = image["noise_power"].transpose(*geometry.dims).values[at]
        noise = {"snr_db": 10.0 * math.log10(peak_power / float(floor)),
                 "nesz_db": float(image["nesz_db"].transpose(*geometry.dims).values[at])}
    return {
        **noise,
        "range": results["range"],
        "azimuth": results["azimuth"],
        "islr_2d_db": _islr_2d_db(power, cells, nulls, extent),
        "peak_position": [float(v) for v in peak_position],
        "peak_index": [float(v) for v in index],
        "peak_offset_m": float(np.linalg.norm(peak_position - target)),
        "peak_db": 10.0 * math.log10(peak_power),
        "warnings": messages,
        "neighbours": neighbours,
        "islr_extent": islr_extent if isinstance(islr_extent, str) else float(islr_extent),
        "chip_cells": float(chip_cells),
        "upsample": int(factor),
        "search_radius_m": float(search_m),
        "cut_axes": cut_axes,
    }
