"""Coherence: the sample correlation coefficient of two co-registered channels.

``gamma_hat = |sum s1 s2*| / sqrt(sum |s1|^2 sum |s2|^2)`` over each look window (the boxcar
estimator; Rosen et al. 2000; Touzi et al. 1999). It is biased upward for few looks
(Touzi et al. 1999: E[gamma_hat] > gamma, most at low coherence; at L = 1 it is identically 1).
For two channels with a common signal and independent noise of equal SNR the expected value is
``1 / (1 + 1/SNR)`` (Zebker & Villasenor 1992). docs/interferometry.md §4.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.interferometry.multilook import look_sum

__all__ = ["coherence", "snr_coherence"]


def coherence(s1: ArrayLike, s2: ArrayLike, looks: tuple[int, int] = (1, 1),
              mask: ArrayLike | None = None) -> NDArray[np.float64]:
    """Boxcar coherence estimate of two complex channels over non-overlapping look windows.

    Parameters
    ----------
    s1, s2 : array_like, shape (..., M, N)
        Co-registered complex pixels of the two channels.
    looks : (int, int)
        Look window (rows, cols) [pixels].
    mask : array_like of bool, shape (M, N), optional
        True where a pixel is excluded.

    Returns
    -------
    ndarray, shape (..., M // rows, N // cols)
        Coherence magnitude in [0, 1] [1] (Touzi et al. 1999); NaN where a window has no
        valid pixel or zero power.
    """
    a, b = np.asarray(s1), np.asarray(s2)
    if a.shape != b.shape:
        raise ParameterError("coherence", "s2", f"an array of the shape of s1 {a.shape}",
                             b.shape)
    if mask is not None:
        keep = ~np.asarray(mask, bool)
        a, b = np.where(keep, a, 0), np.where(keep, b, 0)
    cross = look_sum(a * np.conj(b), looks)
    p1 = look_sum(np.abs(a) ** 2, looks)
    p2 = look_sum(np.abs(b) ** 2, looks)
    with np.errstate(invalid="ignore", divide="ignore"):
        gamma = np.abs(cross) / np.sqrt(p1 * p2)
    return np.where(p1 * p2 > 0, np.clip(gamma, 0.0, 1.0), np.nan)


def snr_coherence(snr: ArrayLike) -> NDArray[np.float64]:
    """Thermal-noise decorrelation ``1 / (1 + 1/SNR)`` (Zebker & Villasenor 1992).

    Parameters
    ----------
    snr : array_like
        Signal-to-noise power ratio of each channel (equal on both) [1], linear.

    Returns
    -------
    ndarray
        Expected coherence [1].
    """
    snr = np.asarray(snr, float)
    return 1.0 / (1.0 + 1.0 / snr)
