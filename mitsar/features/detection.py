"""``mitsar.detect``: CFAR detection of an image and its point features in one call."""

from __future__ import annotations

from typing import Any

import xarray as xr

from mitsar.features.cfar import cfar
from mitsar.features.clusters import point_features

__all__ = ["detect"]


def detect(image: Any, pfa: float = 1e-6, method: str = "ca", *, guard: Any = None,
           training: Any = None, rank: int | None = None, resolution: Any = None,
           edges: str = "truncate") -> xr.Dataset:
    """Detect the point features of a 2-D or 3-D image: CFAR, then clusters.

    :func:`mitsar.features.cfar.cfar` tests every cell against a threshold set for the
    false-alarm probability ``pfa`` from its training cells (docs/features.md §2–3);
    :func:`mitsar.features.clusters.point_features` groups the detected cells into connected
    clusters and locates each (docs/features.md §5). Line features along walls:
    :func:`mitsar.features.lines.line_features` of the result.

    Parameters
    ----------
    image : xarray.Dataset, xarray.DataArray or array_like
        Image product of :func:`mitsar.focus` (2-D plane/slant grid or 3-D volume), or a plain
        complex array (positions are then its indices).
    pfa : float
        False-alarm probability per tested cell, in (0, 1).
    method : {"ca", "os"}
        Cell-averaging or ordered-statistic CFAR.
    guard, training : int or sequence of int, optional
        Guard and training cells on each side of the cell under test, per dimension (default 2
        and 3: docs/features.md §2).
    rank : int, optional
        OS-CFAR's k; default ``round(3N/4)``.
    resolution : float or sequence of float, optional
        Resolution cell along each image dim [m]; default from the image's attributes.
    edges : {"truncate", "inside"}
        Test the cells near the image's edges with the training cells inside it (default), or
        only cells whose whole window fits.

    Returns
    -------
    xarray.Dataset
        Dim ``detection``, one per cluster, strongest first: ``position`` (detection, xyz) [m],
        ``amplitude`` (peak ``|x|``), ``snr`` (peak signal-to-noise power ratio, linear),
        ``snr_db`` [dB], ``uncertainty`` (detection, xyz) [m, 1 sigma], ``cells``; dim
        ``cell``, every detected cell: ``cell_position`` [m], ``cell_amplitude``,
        ``cell_snr``, ``cell_detection``. Attributes: ``method``, ``pfa``, ``guard``,
        ``training``, ``cells`` (N), ``alpha``, ``rank``, ``resolution`` [m].

    Raises
    ------
    ParameterError
        Bad ``pfa``, ``method``, window or image (:func:`mitsar.features.cfar.cfar`).

    Examples
    --------
    >>> found = mitsar.detect(image, pfa=1e-6, method="ca")       # doctest: +SKIP
    >>> found["position"].sel(detection=0).values                  # doctest: +SKIP
    """
    return point_features(cfar(image, pfa, method, guard, training, rank, resolution, edges))
