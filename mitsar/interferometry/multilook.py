"""Multilooking: the boxcar mean of a 2-D field over non-overlapping look windows.

A look window of ``(rows, cols)`` pixels is averaged into one output pixel; the output grid is the
input grid decimated by the window, and the rows and columns left over at the far edges (fewer
than a window) are dropped. Masked pixels do not contribute: the mean is over the valid pixels of
the window, and the number of those is returned as the number of looks (Rosen et al. 2000:
multilooking as the average of L independent samples). docs/interferometry.md §4.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError

__all__ = ["check_looks", "look_sum", "multilook"]


def check_looks(looks: tuple[int, int] | ArrayLike, shape: tuple[int, ...],
                where: str = "multilook") -> tuple[int, int]:
    """``looks`` as two positive ints no larger than the last two dims of ``shape``."""
    try:
        rows, cols = (int(v) for v in np.asarray(looks).reshape(-1))
        ok = all(float(v) == int(v) for v in np.asarray(looks).reshape(-1))
    except (TypeError, ValueError):
        ok = False
    if not ok or rows < 1 or cols < 1:
        raise ParameterError(where, "looks", "two positive integers (rows, cols)", looks)
    if len(shape) < 2 or rows > shape[-2] or cols > shape[-1]:
        raise ParameterError(where, "looks", f"a window no larger than the grid {shape[-2:]}",
                             looks)
    return rows, cols


def look_sum(values: ArrayLike, looks: tuple[int, int]) -> NDArray:
    """Sum of ``values`` over each non-overlapping ``looks`` window of its last two dims.

    Parameters
    ----------
    values : array_like, shape (..., M, N)
        Real or complex values.
    looks : (int, int)
        Window (rows, cols) [pixels].

    Returns
    -------
    ndarray, shape (..., M // rows, N // cols)
    """
    x = np.asarray(values)
    rows, cols = check_looks(looks, x.shape, "look_sum")
    m, n = x.shape[-2] // rows, x.shape[-1] // cols
    x = x[..., : m * rows, : n * cols]
    return x.reshape(*x.shape[:-2], m, rows, n, cols).sum(axis=(-3, -1))


def multilook(values: ArrayLike, looks: tuple[int, int], mask: ArrayLike | None = None
              ) -> tuple[NDArray, NDArray[np.int64]]:
    """Boxcar mean over non-overlapping look windows, and the number of valid looks.

    Parameters
    ----------
    values : array_like, shape (..., M, N)
        Field to average (complex pixels, interferogram, positions with a leading axis...).
    looks : (int, int)
        Window (rows, cols) [pixels]; ``(1, 1)`` returns the input.
    mask : array_like of bool, shape (M, N), optional
        True where a pixel is invalid (excluded from the mean).

    Returns
    -------
    mean : ndarray, shape (..., M // rows, N // cols)
        Mean of the valid pixels of each window; NaN where a window has none.
    count : ndarray of int, shape (M // rows, N // cols)
        Number of valid pixels (looks) per window.
    """
    x = np.asarray(values)
    check_looks(looks, x.shape)
    valid = np.ones(x.shape[-2:], bool) if mask is None else ~np.asarray(mask, bool)
    if valid.shape != x.shape[-2:]:
        raise ParameterError("multilook", "mask", f"a boolean array of shape {x.shape[-2:]}",
                             valid.shape)
    count = look_sum(valid.astype(np.int64), looks)
    total = look_sum(np.where(valid, x, 0), looks)
    with np.errstate(invalid="ignore", divide="ignore"):
        mean = np.where(count > 0, total / np.maximum(count, 1), np.nan)
    return mean, count
