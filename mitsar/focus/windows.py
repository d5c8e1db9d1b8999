"""Spectral weighting windows as cosine series, usable on samples and inside kernels.

Every window here is ``w(x) = sum_m a_m cos(2 pi m (x - 1/2))`` on ``x in [0, 1]`` (1 at the
centre for the ones below), so a kernel can evaluate it from a handful of coefficients at any
position: rectangular ``[1]``, Hamming ``[0.54, 0.46]``, Hann ``[0.5, 0.5]``, and Taylor
(nbar = 4, -35 dB sidelobes by default; Carrara 1995 App. D), whose coefficients are the Taylor
``F_m`` terms.
"""

from __future__ import annotations

import math
from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError

WINDOWS = ("rect", "hamming", "hann", "taylor")


def window_coefficients(name: str, nbar: int = 4, sidelobe_db: float = 35.0) -> NDArray:
    """Cosine-series coefficients ``a_m`` of a named window (see module docstring).

    Parameters
    ----------
    name : {"rect", "hamming", "hann", "taylor"} or ndarray
        A window's name, or its coefficients already (returned as they are; e.g.
        :data:`mitsar.focus.band_limit.FLAT_TOP`).
    nbar, sidelobe_db : int, float
        Taylor parameters (number of nearly constant sidelobes, sidelobe level [dB]).
    """
    if isinstance(name, np.ndarray):
        return name
    if name in ("rect", "rectangular", None):
        return np.array([1.0])
    if name == "hamming":
        return np.array([0.54, 0.46])
    if name == "hann":
        return np.array([0.5, 0.5])
    if name == "taylor":
        # The Taylor window is a finite cosine series with nbar - 1 harmonics: fit it exactly
        # (least squares on dense samples) rather than re-deriving F_m.
        from scipy.signal import windows as scipy_windows  # lazy: SciPy's signal tools are heavy

        samples = 4096
        x = (np.arange(samples) + 0.5) / samples
        values = scipy_windows.taylor(samples, nbar=nbar, sll=sidelobe_db, norm=True, sym=True)
        basis = np.cos(2 * np.pi * np.arange(nbar)[None, :] * (x[:, None] - 0.5))
        coefficients, *_ = np.linalg.lstsq(basis, values, rcond=None)
        return coefficients
    raise ParameterError("window", "window", f"one of {WINDOWS}", name)


def cosine_series(coefficients: Any, centred: Any, cos: Callable[[Any], Any]) -> Any:
    """``a_0 + sum_m a_m cos(2 pi m xi)`` at ``xi = x - 1/2``, skipping zero coefficients.

    The one expression of every window here, for NumPy (``cos = numpy.cos``) and inside the
    Dr.Jit back-projection kernel (the coefficients are Python floats there, so a rectangular
    window costs nothing).

    Parameters
    ----------
    coefficients : sequence of float
        Cosine-series coefficients ``a_m`` (:func:`window_coefficients`).
    centred : array_like
        Position relative to the window centre, ``xi in [-1/2, 1/2]``.
    cos : callable
        Cosine of the array type of ``centred``.
    """
    value = coefficients[0]
    for harmonic in range(1, len(coefficients)):
        if coefficients[harmonic] != 0.0:
            value = value + coefficients[harmonic] * cos(2 * math.pi * harmonic * centred)
    return value


def evaluate_window(coefficients: ArrayLike, x: ArrayLike) -> NDArray:
    """Window value at normalised positions ``x in [0, 1]`` (0 outside)."""
    x = np.asarray(x, dtype=float)
    value = cosine_series([float(c) for c in np.ravel(coefficients)], x - 0.5, np.cos)
    return np.where((x >= 0) & (x <= 1), value, 0.0)


def window_samples(name: str, count: int) -> NDArray:
    """``count`` samples of a window at the sample centres ``x = (n + 1/2) / count``."""
    return evaluate_window(window_coefficients(name), (np.arange(count) + 0.5) / count)
