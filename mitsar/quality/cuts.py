"""One-dimensional impulse-response metrics of a cut through a point target: IRW, PSLR, ISLR.

Definitions follow Cumming & Wong 2005 §2.6:

* **IRW**: width of the main lobe at −3 dB (half power), in resolution cells and metres.
* **PSLR**: ratio of the highest sidelobe (outside the first nulls) to the peak, dB.
* **ISLR**: ``10 log10((P_total − P_main) / P_main)``, main lobe between the first nulls (null to
  null); the sidelobe extent ``P_total`` is integrated over is selectable (see
  :data:`ISLR_EXTENTS`) because the processors we compare against disagree on it.

A *cell* is the nominal unweighted resolution of the direction considered (e.g. ``c / 2B`` in
range). For an unweighted (rectangular) spectrum the continuous closed forms are IRW 0.8859 cells,
PSLR −13.26 dB, ISLR −9.68 dB to infinity and −10.69 dB within ±5 cells.

All functions take a *cut*: either complex amplitude samples or real non-negative power samples,
uniformly sampled at ``spacing_cells`` resolution cells per sample.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import MitsarError, ParameterError
from mitsar.quality.upsample import check_factor, upsample_cut

__all__ = [
    "ISLR_EXTENTS",
    "MeasurementError",
    "first_nulls",
    "irw",
    "islr_db",
    "measure_cut",
    "parse_extent",
    "pslr_db",
]

#: Named sidelobe extents for ISLR, in resolution cells either side of the peak.
#: ``"paper"``: ±5 cells (reproduces the paper's −10.69 dB for a rectangular spectrum);
#: ``"isce3"``: ±11 cells (ISCE3 ``compute_islr_pslr``: 10 × the peak-to-null distance beyond each
#: null of a rectangular spectrum); ``"chip"``: the whole cut/chip; ``"inf"``: best estimate of an
#: infinite extent, i.e. the whole cut of a large chip (see :func:`measure_impulse_response`).
ISLR_EXTENTS: dict[str, float] = {"paper": 5.0, "isce3": 11.0, "chip": math.inf, "inf": math.inf}

#: How the ISLR extent is named in the experiment (``[metrics] islr_extent``, also
#: ``--set metrics.islr_extent=...``), the Python API and ``mitsar metrics --islr-extent``.
EXTENT_OPTION = "islr_extent ([metrics] islr_extent, --islr-extent)"


class MeasurementError(MitsarError, ValueError):
    """A point-target response cannot be measured as asked (no nulls, no half-power points,
    a peak on the search boundary, ...); the message says what to change.

    A :class:`ValueError` as well, for callers that caught the plain errors of earlier versions.
    """


def parse_extent(islr_extent: str | float) -> float:
    """Sidelobe extent in cells either side of the peak (``inf`` for the whole cut)."""
    if isinstance(islr_extent, str):
        if islr_extent in ISLR_EXTENTS:
            return ISLR_EXTENTS[islr_extent]
    elif (
        isinstance(islr_extent, int | float | np.integer | np.floating)
        and not isinstance(islr_extent, bool)
        and islr_extent > 0
    ):
        return float(islr_extent)
    allowed = ", ".join(repr(name) for name in ISLR_EXTENTS)
    raise ParameterError("metrics", EXTENT_OPTION,
                         f"one of {allowed} or a positive number of cells", islr_extent)


def _as_power(cut: ArrayLike) -> NDArray[np.float64]:
    """Power samples from a complex amplitude cut or a real non-negative power cut."""
    x = np.asarray(cut)
    if x.ndim != 1 or x.size < 5:
        raise ParameterError("metrics", "cut", "a 1-D cut of at least 5 samples", x.shape)
    if np.iscomplexobj(x):
        return np.abs(x) ** 2
    p = x.astype(float)
    if np.any(p < 0):
        raise ParameterError(
            "metrics", "cut", "complex amplitude, or real power that is non-negative (pass "
            "cut.astype(complex) for a real-valued amplitude)", f"{int(np.sum(p < 0))} negative "
            "samples")
    return p


def _check_spacing(spacing_cells: float) -> float:
    if not (np.isfinite(spacing_cells) and spacing_cells > 0):
        raise ParameterError("metrics", "spacing_cells", "a positive finite number of "
                             "resolution cells per sample", spacing_cells)
    return float(spacing_cells)


def _parabola(p: NDArray[np.float64], k: int) -> tuple[float, float]:
    """Vertex (fractional index, value) of the parabola through samples ``k−1, k, k+1``."""
    if k <= 0 or k >= p.size - 1:
        return float(k), float(p[k])
    left, mid, right = p[k - 1], p[k], p[k + 1]
    curvature = left - 2.0 * mid + right
    if curvature == 0.0:
        return float(k), float(mid)
    delta = float(np.clip(0.5 * (left - right) / curvature, -0.5, 0.5))
    return k + delta, float(mid - 0.25 * (left - right) * delta)


def _peak(p: NDArray[np.float64]) -> tuple[int, float, float]:
    """Peak sample index, refined fractional index and refined peak power."""
    k = int(np.argmax(p))
    position, value = _parabola(p, k)
    return k, position, max(value, float(p[k]))


def _null_indices(p: NDArray[np.float64], k: int) -> tuple[int, int]:
    """Sample indices of the first local minima either side of the peak sample ``k``.

    Searched beyond the half-power points only: a null lies below -3 dB, and near the flat top
    of a finely sampled main lobe rounding noise (float32 images) can make a spurious minimum.
    """
    half = 0.5 * p[k]
    below_right = np.flatnonzero(p[k:] < half)
    below_left = np.flatnonzero(p[k::-1] < half)
    start_right = int(below_right[0]) if below_right.size else p.size - k - 1
    start_left = int(below_left[0]) if below_left.size else k
    rising_right = start_right + np.flatnonzero(np.diff(p[k + start_right:]) >= 0.0)
    rising_left = start_left + np.flatnonzero(np.diff(p[k - start_left::-1]) >= 0.0)
    if rising_right.size == 0 or rising_left.size == 0:
        side = "right" if rising_right.size == 0 else "left"
        raise MeasurementError(
            f"no first null on the {side} of the peak: the cut is too short or does not hold a "
            "point-target response (clutter or a neighbour filling the null); measure a longer "
            "cut (chip_cells, a larger image grid) or check the target position"
        )
    return k - int(rising_left[0]), k + int(rising_right[0])


def _null_positions(p: NDArray[np.float64], k: int) -> tuple[float, float]:
    """Fractional indices of the first nulls (parabolic refinement of the minima)."""
    left, right = _null_indices(p, k)
    # The vertex of a minimum is that of the negated parabola.
    return _parabola(-p, left)[0], _parabola(-p, right)[0]


def _half_power_crossings(p: NDArray[np.float64], k: int, half: float) -> tuple[float, float]:
    """Fractional indices where the power falls below ``half`` either side of the peak sample.

    Linear interpolation between the last sample above and the first below (FastSAR ``_cut``).
    """
    below = p < half
    right_hits = np.flatnonzero(below[k:])
    left_hits = np.flatnonzero(below[k::-1])
    if right_hits.size == 0 or left_hits.size == 0:
        raise MeasurementError(
            "the cut does not fall to half power on both sides of the peak (a neighbour or "
            "clutter as bright as half the peak next to it, or a cut shorter than the main lobe); "
            "check the target position or enlarge the image grid around it"
        )
    j = k + int(right_hits[0])
    right = (j - 1) + (p[j - 1] - half) / (p[j - 1] - p[j])
    i = k - int(left_hits[0])
    left = (i + 1) - (p[i + 1] - half) / (p[i + 1] - p[i])
    return float(left), float(right)


def _cumulative(p: NDArray[np.float64]) -> NDArray[np.float64]:
    """Cumulative trapezoidal integral of ``p`` over sample index, starting at 0."""
    return np.concatenate(([0.0], np.cumsum(0.5 * (p[1:] + p[:-1]))))


def _energy(cum: NDArray[np.float64], start: float, stop: float) -> float:
    """Integral of the power between fractional indices ``start`` and ``stop``."""
    index = np.arange(cum.size)
    return float(np.interp(stop, index, cum) - np.interp(start, index, cum))


def _power_and_peak(
    cut: ArrayLike, spacing_cells: float
) -> tuple[NDArray[np.float64], float, int, float, float]:
    """Power samples, checked spacing, peak sample, refined peak index and power of a cut."""
    p = _as_power(cut)
    spacing = _check_spacing(spacing_cells)
    k, centre, peak = _peak(p)
    return p, spacing, k, centre, peak


def irw(cut: ArrayLike, spacing_cells: float = 1.0) -> float:
    """Impulse-response width at −3 dB (half power), in resolution cells.

    Parameters
    ----------
    cut : array_like, shape (N,)
        Complex amplitude or non-negative power, finely sampled (upsampled) through the peak.
    spacing_cells : float, default 1.0
        Sample spacing, resolution cells per sample.

    Returns
    -------
    float
        Distance between the half-power crossings, cells; the crossings are interpolated linearly
        between samples and the peak power is refined by a parabola (Cumming & Wong 2005 §2.6).
    """
    p, spacing, k, _, peak = _power_and_peak(cut, spacing_cells)
    left, right = _half_power_crossings(p, k, 0.5 * peak)
    return (right - left) * spacing


def first_nulls(cut: ArrayLike, spacing_cells: float = 1.0) -> tuple[float, float]:
    """Positions of the first nulls (first local minima either side of the peak).

    Parameters
    ----------
    cut : array_like, shape (N,)
        Complex amplitude or non-negative power, finely sampled through the peak.
    spacing_cells : float, default 1.0
        Sample spacing, resolution cells per sample.

    Returns
    -------
    (float, float)
        Left and right null positions relative to the (refined) peak, cells; the left one is
        negative. About ±1 cell for a rectangular spectrum (Cumming & Wong 2005 §2.6).
    """
    p, spacing, k, centre, _ = _power_and_peak(cut, spacing_cells)
    left, right = _null_positions(p, k)
    return (left - centre) * spacing, (right - centre) * spacing


def pslr_db(cut: ArrayLike) -> float:
    """Peak sidelobe ratio, dB: highest sidelobe outside the first nulls over the peak.

    Parameters
    ----------
    cut : array_like, shape (N,)
        Complex amplitude or non-negative power, finely sampled through the peak.

    Returns
    -------
    float
        ``10 log10(P_sidelobe / P_peak)`` over the whole cut, both maxima refined by a parabola;
        −13.26 dB for a rectangular spectrum (Cumming & Wong 2005 §2.6).
    """
    p = _as_power(cut)
    k, _, peak = _peak(p)
    return _pslr_from(p, k, peak)


def _pslr_from(p: NDArray[np.float64], k: int, peak: float) -> float:
    left, right = _null_indices(p, k)
    outside = np.ones(p.size, dtype=bool)
    outside[left : right + 1] = False
    candidates = np.flatnonzero(outside)
    j = int(candidates[np.argmax(p[candidates])])
    _, sidelobe = _parabola(p, j)
    return 10.0 * math.log10(max(sidelobe, float(p[j])) / peak)


def islr_db(
    cut: ArrayLike, spacing_cells: float = 1.0, islr_extent: str | float = "paper"
) -> float:
    """Integrated sidelobe ratio, dB, with a null-to-null main lobe.

    Parameters
    ----------
    cut, spacing_cells
        The cut through the peak and its sample spacing in cells, as for :func:`irw`.
    islr_extent : {"paper", "isce3", "chip", "inf"} or float, default "paper"
        Sidelobe extent either side of the peak: ±5 cells, ±11 cells, the whole cut, the whole
        cut (meant for a cut long enough, or periodic, to hold all the energy), or a number of
        cells. See :data:`ISLR_EXTENTS`.

    Returns
    -------
    float
        ``10 log10((P_extent − P_main) / P_main)`` with the powers integrated by the trapezoidal
        rule between the refined nulls and extent limits (Cumming & Wong 2005 §2.6). For a
        rectangular spectrum: −10.69 dB (±5 cells), −10.11 dB (±11), −9.68 dB (infinite).
    """
    p, spacing, k, centre, _ = _power_and_peak(cut, spacing_cells)
    extent = parse_extent(islr_extent)
    return _islr_from(p, k, centre, extent / spacing)


def _islr_from(p: NDArray[np.float64], k: int, centre: float, extent_samples: float) -> float:
    left, right = _null_positions(p, k)
    start = max(centre - extent_samples, 0.0)
    stop = min(centre + extent_samples, p.size - 1.0)
    if start > left or stop < right:
        inside = max(centre - left, right - centre)
        raise MeasurementError(
            f"the ISLR extent ends inside the main lobe (null to null, up to {inside:.0f} "
            f"samples from the peak, the extent reaches {min(centre - start, stop - centre):.0f})"
            f": widen {EXTENT_OPTION}, or give a longer cut"
        )
    cum = _cumulative(p)
    main = _energy(cum, left, right)
    total = _energy(cum, start, stop)
    return 10.0 * math.log10((total - main) / main)


def measure_cut(
    cut: ArrayLike,
    spacing_cells: float = 1.0,
    islr_extent: str | float = "paper",
    *,
    upsample: int = 1,
) -> dict[str, float]:
    """IRW, first nulls, PSLR and ISLR of a 1-D cut through a point-target response.

    Parameters
    ----------
    cut : array_like, shape (N,)
        Complex amplitude or (only with ``upsample=1``) non-negative power samples.
    spacing_cells : float, default 1.0
        Sample spacing of ``cut``, resolution cells per sample.
    islr_extent : {"paper", "isce3", "chip", "inf"} or float, default "paper"
        Sidelobe extent for the ISLR (see :func:`islr_db`).
    upsample : int, default 1
        If > 1, upsample the complex cut by this factor first (:func:`upsample_cut`, with the
        occupied band ``spacing_cells`` of a cut along its own direction); leave at 1 for cuts
        that are already finely sampled.

    Returns
    -------
    dict
        ``irw_cells`` (−3 dB width, cells), ``null_left_cells`` and ``null_right_cells`` (first
        nulls relative to the peak, cells), ``pslr_db`` and ``islr_db`` (dB), ``peak_cells``
        (refined peak position, cells from the first sample) and ``peak_power`` (refined peak
        power, unit of the input squared). Definitions: Cumming & Wong 2005 §2.6.
    """
    spacing = _check_spacing(spacing_cells)
    extent = parse_extent(islr_extent)
    factor = check_factor(upsample)
    if factor > 1:
        if not np.iscomplexobj(np.asarray(cut)):
            raise ParameterError("measure_cut", "upsample", "1 for a power cut (upsampling "
                                 "needs complex amplitude)", upsample)
        cut = upsample_cut(cut, factor, band=spacing)
        spacing /= factor
    p = _as_power(cut)
    k, centre, peak = _peak(p)
    half_left, half_right = _half_power_crossings(p, k, 0.5 * peak)
    null_left, null_right = _null_positions(p, k)
    return {
        "irw_cells": (half_right - half_left) * spacing,
        "null_left_cells": (null_left - centre) * spacing,
        "null_right_cells": (null_right - centre) * spacing,
        "pslr_db": _pslr_from(p, k, peak),
        "islr_db": _islr_from(p, k, centre, extent / spacing),
        "peak_cells": centre * spacing,
        "peak_power": peak,
    }
