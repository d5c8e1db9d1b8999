"""Choosing the scatterers autofocus estimates from: bright, isolated, standing out of clutter.

PGA (Wahl, Eichel, Ghiglia & Jakowatz, IEEE TAES 30(3), 1994, §III) takes the brightest
pixel of every range line; on a scene of walls and floors most of those are clutter, whose
phase histories carry no common phase error but their own speckle, and on a defocused image a
single reflector leaves several local maxima along its smear. Here a candidate must be

* a local maximum over ``+- separation`` resolution cells along both image dimensions (one
  response, one candidate: pixels per cell from the image's ``range_resolution`` /
  ``azimuth_resolution`` and axes, :func:`cell_pixels`);
* within ``dynamic_range_db`` of the brightest pixel;
* brighter than its surroundings by ``min_scr_db``: the scatterer-to-clutter ratio is the
  candidate's intensity over the median intensity of a box of ``+- clutter_cells`` resolution
  cells around it (the median ignores the candidate's own response and other bright points).

Why a median and what threshold: fully developed speckle has exponentially distributed
intensity, ``P(t > a <t>) = exp(-a)``, whose median is ``ln 2 <t>`` (Goodman, *Speckle
Phenomena in Optics*, 2007, §3.2). A speckle pixel exceeds its box's median by ``r`` (linear)
with probability ``exp(-r ln 2)``: 15 dB (r = 31.6) has probability 3e-10 a cell, so the
default threshold passes no speckle, while a point of 15 dB over the clutter median is a
scatterer whose phase history the clutter disturbs by about ``1/sqrt(r)`` = 0.18 rad.

Candidates are ranked by that ratio, highest first. All steps are array operations
(``scipy.ndimage`` filters, and the medians of the candidates' boxes gathered at once).
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.lib.stride_tricks import sliding_window_view
from numpy.typing import NDArray
from scipy import ndimage

__all__ = ["cell_pixels", "chip_pixels", "chip_reach", "select_scatterers"]


def _cell_geometry(image: xr.Dataset) -> tuple[list[float], float, float, NDArray, NDArray] | None:
    """The pixel spacing of the image's two dims [m], ``range_resolution`` and
    ``azimuth_resolution`` [m] and the ``range_axis`` / ``azimuth_axis`` unit vectors in those
    dims (:mod:`mitsar.focus.grid`), or None when the product does not carry them."""
    dims = image["image"].dims[-2:]
    try:
        spacing = [abs(float(image[d].values[1] - image[d].values[0])) for d in dims]
        return (spacing, float(image.attrs["range_resolution"]),
                float(image.attrs["azimuth_resolution"]),
                np.asarray(image.attrs["range_axis"], dtype=float)[:2],
                np.asarray(image.attrs["azimuth_axis"], dtype=float)[:2])
    except (KeyError, IndexError, TypeError, ValueError):
        return None


def cell_pixels(image: xr.Dataset) -> tuple[float, float]:
    """Pixels per resolution cell along the image's two dimensions.

    Uses the product's ``range_resolution`` / ``azimuth_resolution`` [m] and ``range_axis`` /
    ``azimuth_axis`` (unit vectors in the two metre dims, :mod:`mitsar.focus.grid`): along dim
    i a cell spans ``sqrt((rho_r a_r,i)^2 + (rho_a a_a,i)^2)``; the pixel spacing is that of
    the dim's coordinate. A product without them gives one pixel a cell.
    """
    geometry = _cell_geometry(image)
    if geometry is None:
        return 1.0, 1.0
    spacing, rho_r, rho_a, a_r, a_a = geometry
    cells = np.hypot(rho_r * a_r, rho_a * a_a)
    return tuple(float(max(c / s, 1.0)) if s > 0 else 1.0
                 for c, s in zip(cells, spacing, strict=True))


def select_scatterers(magnitude: NDArray, count: int, dynamic_range_db: float,
                      separation: float, cells: tuple[float, float] = (1.0, 1.0),
                      min_scr_db: float = 0.0, clutter_cells: float = 8.0
                      ) -> tuple[NDArray, NDArray]:
    """Flat indices of the scatterers to estimate from, best first, and their SCR [dB].

    Parameters
    ----------
    magnitude : ndarray, shape (N0, N1)
        Image magnitude.
    count : int
        Scatterers at most.
    dynamic_range_db : float
        Candidates within this of the brightest pixel [dB].
    separation : float
        Local-maximum neighbourhood, +- resolution cells.
    cells : (float, float)
        Pixels per resolution cell along the two dims (:func:`cell_pixels`).
    min_scr_db : float
        Scatterer-to-clutter ratio a candidate needs [dB] (module docstring).
    clutter_cells : float
        Half size of the clutter box, resolution cells.

    Returns
    -------
    indices : ndarray of int
        Flat indices into ``magnitude``, highest SCR first (may be empty).
    scr_db : ndarray
        Their scatterer-to-clutter ratios [dB].
    """
    power = np.asarray(magnitude, dtype=float) ** 2
    shape = power.shape
    size = [2 * int(np.ceil(separation * c)) + 1 for c in cells]
    peaks = power == ndimage.maximum_filter(power, size=size, mode="nearest")
    peaks &= power > 0
    peaks &= power >= power.max() * 10 ** (-dynamic_range_db / 10)
    candidates = np.flatnonzero(peaks)
    if len(candidates) == 0:
        return candidates, np.zeros(0)
    half = [max(1, min(int(np.ceil(clutter_cells * c)), (n - 1) // 2))
            for c, n in zip(cells, shape, strict=True)]
    padded = np.pad(power, [(h, h) for h in half], mode="reflect")
    boxes = sliding_window_view(padded, [2 * h + 1 for h in half])
    rows, cols = np.unravel_index(candidates, shape)
    clutter = np.median(boxes[rows, cols].reshape(len(candidates), -1), axis=1)
    scr_db = 10 * np.log10(power.ravel()[candidates] / np.maximum(clutter, 1e-300))
    keep = scr_db >= min_scr_db
    candidates, scr_db = candidates[keep], scr_db[keep]
    order = np.argsort(scr_db, kind="stable")[::-1][:count]
    return candidates[order], scr_db[order]


def chip_reach(image: xr.Dataset, azimuth_cells: float, range_cells: float
               ) -> tuple[float, float] | None:
    """Half size of a chip along the image's two dims, in pixels, for a box of
    ``+- azimuth_cells`` resolution cells along the image's azimuth axis and ``+- range_cells``
    along its range axis (``azimuth_resolution`` / ``range_resolution`` and axes as
    :func:`cell_pixels`): along dim i, ``(A rho_a |a_a,i| + R rho_r |a_r,i|) / spacing_i``.
    None when the product does not carry them.

    A phase error per sweep does not change the range response (docs/autofocus.md, error
    model), so chips that judge a correction need a range extent of about a cell only.
    """
    geometry = _cell_geometry(image)
    if geometry is None:
        return None
    spacing, rho_r, rho_a, a_r, a_a = geometry
    reach = azimuth_cells * rho_a * np.abs(a_a) + range_cells * rho_r * np.abs(a_r)
    return tuple(float(r / s) if s > 0 else 0.0 for r, s in zip(reach, spacing, strict=True))


def chip_pixels(shape: tuple[int, int], centres: NDArray, cells: tuple[float, float],
                half_cells: float, reach: tuple[float, float] | None = None) -> NDArray:
    """Flat indices of pixels within ``+- half_cells`` resolution cells of the centres.

    Taken every ``floor(cells / 2)`` pixels along each dim (about two samples a resolution
    cell, the Nyquist rate of the image's band), centres included.

    Parameters
    ----------
    shape : (int, int)
        Image shape.
    centres : ndarray of int
        Flat indices of the chips' centres.
    cells : (float, float)
        Pixels per resolution cell along the two dims (:func:`cell_pixels`).
    half_cells : float
        Half size of a chip, resolution cells.
    reach : (float, float), optional
        Half size along the two dims in pixels (:func:`chip_reach`), instead of
        ``half_cells``.

    Returns
    -------
    ndarray of int
        Sorted unique flat indices (chips clipped to the image, overlaps counted once).
    """
    half = [int(np.ceil(half_cells * c)) for c in cells] if reach is None else [
        int(np.ceil(r)) for r in reach]
    step = [max(1, int(c // 2)) for c in cells]  # about two pixels a cell (Nyquist)
    rows, cols = np.unravel_index(np.asarray(centres, dtype=np.int64), shape)
    d0, d1 = np.meshgrid(np.arange(-half[0], half[0] + 1, step[0]),
                         np.arange(-half[1], half[1] + 1, step[1]), indexing="ij")
    r = np.clip(rows[:, None] + d0.ravel()[None, :], 0, shape[0] - 1)
    c = np.clip(cols[:, None] + d1.ravel()[None, :], 0, shape[1] - 1)
    return np.unique(np.ravel_multi_index((r.ravel(), c.ravel()), shape))
