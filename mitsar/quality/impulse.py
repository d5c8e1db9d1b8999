"""Impulse-response (point-target) quality metrics of a focused image: IRW, PSLR and ISLR.

:func:`measure_impulse_response` finds the target's peak in an image product, cuts a chip around
it, upsamples the chip (:mod:`mitsar.quality.upsample`), refines the peak in 2-D, takes cuts
along the range and azimuth axes through it and measures them (:mod:`mitsar.quality.cuts`, where
the metric definitions of Cumming & Wong 2005 §2.6 are); plus a 2-D ISLR over the chip.
The image product's geometry and the target's pixel are read by :mod:`mitsar.quality.geometry`,
the peak found by :mod:`mitsar.quality.peak`.

Trust (docs/metrics.md): the peak is searched only within ``search_radius_m`` of the target
(default :data:`SEARCH_CELLS` cells) and must be a local maximum there; the cuts run along the
response's own axes, recorded by the grid (:func:`mitsar.focus.grid.response_frame`: under
squint the response is rotated against a slant grid's axes), or along the grid's axes on
request; any other scatterer within :data:`NEIGHBOUR_DB` of the peak inside the measurement
window, brighter than the target's own sidelobes and the background's speckle reach, is reported
in ``warnings``, at the focusing grid's pixel where it is imaged.
"""

from __future__ import annotations

import math
import warnings
from typing import Any

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
    measure_cut,
    parse_extent,
)
from mitsar.quality.geometry import (
    DIRECTIONS,
    dim_offsets,
    interpolate_position,
    locate_target,
    occupied_band,
    read_geometry,
    response_cells,
)
from mitsar.quality.peak import fine_peak, peak_pixel, refine_peak_2d
from mitsar.quality.upsample import band_fill_db, check_factor, upsample_chip

__all__ = ["CUT_AXES", "ISLR_EXTENTS", "NEIGHBOUR_DB", "SEARCH_CELLS",
           "measure_impulse_response"]

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
#: Chance that the brightest speckle of the background in the measurement window is taken for a
#: second scatterer: a local maximum counts only above ``ln(N / SPECKLE_FALSE_ALARM)`` times the
#: background's mean power, N the window's resolution cells (fully developed speckle and
#: thermal noise have exponentially distributed power, P(p > t mean) = exp(-t); Goodman,
#: *Speckle Phenomena in Optics*, 2007, §3.2).
SPECKLE_FALSE_ALARM = 0.01
#: The background's mean power is estimated outside this many cells from the peak (beyond the
#: main lobe and first sidelobes of any window), from the median (mean = median / ln 2).
BACKGROUND_INNER_CELLS = 3.0
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
    sample from the peak along the response axes (:func:`response_cells`).
    """
    main = np.ones(power.shape, dtype=bool)
    box = np.ones(power.shape, dtype=bool)
    for name in DIRECTIONS:
        main &= (cells[name] >= nulls[name][0]) & (cells[name] <= nulls[name][1])
        box &= np.abs(cells[name]) <= extent
    main_energy = float(np.sum(power[main]))
    return 10.0 * math.log10(float(np.sum(power[box])) / main_energy - 1.0)


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


def _envelope(cells: NDArray[np.float64]) -> NDArray[np.float64]:
    """Upper bound of a rectangular-spectrum response's power, ``min(1, 1/(pi x)^2)``."""
    return np.minimum(1.0, 1.0 / np.maximum((np.pi * cells) ** 2, 1e-300))


def _neighbours(power: NDArray[np.float64], peak_power: float,
                cells: dict[str, NDArray[np.float64]], extent: float, factor: int,
                level_db: float) -> tuple[list[tuple[tuple[int, int], float, float, float,
                                                     float]], float]:
    """Local maxima of another scatterer within ``level_db`` of the peak in the window.

    A local maximum counts when it is at least ``level_db`` relative to the peak, exceeds the
    level that the target's own sidelobes and the background's speckle reach together there:
    their amplitudes added in phase, ``(sqrt(own) + sqrt(speckle))^2``, with ``own`` the
    envelope of the target's separable sidelobes (:func:`_envelope` per axis, Cumming & Wong
    2005 §2.6) raised by :data:`OWN_SIDELOBE_MARGIN_DB` and ``speckle`` the level the
    background's speckle stays below (:func:`_speckle_threshold`), so that neither a sidelobe
    lifted by clutter nor the brightest speckle of a -20 dB background counts; and it lies
    within ± ``extent`` cells along both response axes (the whole chip for an infinite extent)
    and off the chip border.

    Returns
    -------
    list of ((i0, i1), level dB, range cells, azimuth cells, bound dB), strongest first (bound:
    what sidelobes and speckle reach there); the background's mean power relative to the
    peak, dB.
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
    background, speckle = _speckle_threshold(relative, u, w, window)
    bound = (np.sqrt(own) + math.sqrt(speckle)) ** 2
    found = local & window & (relative >= 10 ** (level_db / 10)) & (relative > bound)
    out = []
    for i0, i1 in zip(*np.nonzero(found), strict=True):
        out.append(((int(i0) * stride, int(i1) * stride),
                    10.0 * math.log10(float(relative[i0, i1])), float(u[i0, i1]),
                    float(w[i0, i1]), _db(float(bound[i0, i1]))))
    return sorted(out, key=lambda item: -item[1]), _db(background)


def _db(ratio: float) -> float:
    """10 log10 of a power ratio, at least -300 dB (finite, for JSON)."""
    return 10.0 * math.log10(max(ratio, 1e-30))


def _speckle_threshold(relative: NDArray[np.float64], u: NDArray[np.float64],
                       w: NDArray[np.float64], window: NDArray[np.bool_]) -> tuple[float, float]:
    """Mean power of the background around the target and the level its speckle stays below.

    The background (clutter speckle and thermal noise: exponentially distributed power,
    Goodman, *Speckle Phenomena in Optics*, 2007, §3.2) has mean ``median / ln 2``, the median
    taken over the measurement window beyond :data:`BACKGROUND_INNER_CELLS` from the peak
    (over the chip beyond them when that is less than a quarter of the window): local, as the
    antenna beam weights the clutter around its centre, and where the target's own response is
    only its two sidelobe ridges (a small part of the area; a few other scatterers do not move
    a median). The brightest of N independent cells exceeds ``t`` times that mean with
    probability ``1 - (1 - exp(-t))^N`` ≈ ``N exp(-t)``; ``t = ln(N / SPECKLE_FALSE_ALARM)``
    with N the window's area in resolution cells.

    Returns
    -------
    background, threshold : float
        Power relative to the peak [1]: the background's mean and the threshold.
    """
    ring = np.maximum(np.abs(u), np.abs(w)) > BACKGROUND_INNER_CELLS
    if np.count_nonzero(ring & window) >= 0.25 * np.count_nonzero(window):
        ring &= window  # the background where the neighbours are sought (beam-weighted)
    if not ring.any():
        return 0.0, 0.0
    background = float(np.median(relative[ring])) / math.log(2.0)
    cells = max(float(np.ptp(u[window]) * np.ptp(w[window])) if window.any() else 0.0, 1.0)
    return background, background * math.log(cells / SPECKLE_FALSE_ALARM)


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
    channel: int = 0,
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
    channel : int, default 0
        The receive channel measured in a multi-channel image (``channel`` dim; recorded as
        ``channel`` in the result); ignored for a single-channel image.

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
        "distance_m", "offset_cells", "background_db"}``: the focusing grid's pixel where the
        neighbour is imaged, m; its level and the background's mean around the target relative
        to the peak, dB; ...); ``islr_extent``, ``chip_cells``, ``upsample``,
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
    if "image" in image.variables and "channel" in image["image"].dims:
        count = image.sizes["channel"]
        checks.integer("measure_impulse_response", "channel", channel, 0,
                       f"a channel index in [0, {count})")
        if channel >= count:
            raise ParameterError("measure_impulse_response", "channel",
                                 f"a channel index in [0, {count})", channel)
        return {**measure_impulse_response(
            image.isel(channel=channel), target, islr_extent=islr_extent, upsample=upsample,
            chip_cells=chip_cells, search_radius_m=search_radius_m, cut_axes=cut_axes,
            neighbour_db=neighbour_db), "channel": int(channel)}
    extent = parse_extent(islr_extent)
    factor = check_factor(upsample)
    if search_radius_m is not None:
        checks.positive("measure_impulse_response", "search_radius_m", search_radius_m,
                        "a positive radius, m")
        checks.bounded("measure_impulse_response", "search_radius_m", search_radius_m, "m",
                       "a positive radius, m")
    if cut_axes not in CUT_AXES:
        raise ParameterError("measure_impulse_response", "cut_axes", f"one of {CUT_AXES}",
                             cut_axes)
    geometry = read_geometry(image, cut_axes)
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
    target_index = locate_target(geometry, target)
    pixel = peak_pixel(geometry, target_index, search_m)
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
    fine = upsample_chip(chip, factor, band=occupied_band(geometry))[: keep[0], : keep[1]]
    power = np.abs(fine) ** 2
    d0, d1 = dim_offsets(lo, power.shape, factor, target_index, geometry.spacing)
    distance = np.sqrt(d0**2 + d1**2)
    peak_int = fine_peak(power, distance <= search_m, search_m, distance)
    peak, peak_power = refine_peak_2d(power, peak_int)
    fine_spacing = geometry.spacing / factor  # signed, m per upsampled sample

    results: dict[str, Any] = {}
    nulls: dict[str, tuple[float, float]] = {}
    needed = MIN_CUT_CELLS if extent == math.inf else extent
    for name in DIRECTIONS:
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
                f"cells) on one side. Extend the focusing grid ([focus.grid], mitsar focus "
                f"--grid), or lower {EXTENT_OPTION}",
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

    cells = response_cells(power.shape, peak, fine_spacing, geometry)
    index = lo + peak / factor
    peak_position = interpolate_position(geometry.position, index)
    # Own sidelobes are told from neighbours in the response's frame, whichever axes are cut.
    frame = geometry if cut_axes == "response" else read_geometry(image, "response")
    own_cells = (cells if frame is geometry
                 else response_cells(power.shape, peak, fine_spacing, frame))
    neighbours = []
    found, background_db = _neighbours(power, peak_power, own_cells, extent, factor,
                                       neighbour_db)
    for (i0, i1), level, u, w, bound_db in found:
        where = interpolate_position(geometry.position, lo + np.array([i0, i1]) / factor)
        gap = float(np.linalg.norm(where - peak_position))
        neighbours.append({"position": [float(v) for v in where], "level_db": level,
                           "distance_m": gap, "offset_cells": [u, w],
                           "background_db": background_db})
        messages.append(
            f"a second scatterer, imaged at the pixel {np.round(where, 3).tolist()} m of the "
            f"focusing grid ({gap:.3f} m from the peak, {u:+.1f} range, {w:+.1f} azimuth "
            f"cells), {level:+.1f} dB relative to the peak where the target's own sidelobes "
            f"and the background's speckle (mean {background_db:.1f} dB) reach {bound_db:.1f} "
            f"dB, lies inside the measurement window ({EXTENT_OPTION}={islr_extent!r}): the "
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
