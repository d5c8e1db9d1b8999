"""Interferometric phase noise: the Cramér–Rao bound of the multilooked phase.

``sigma_phi^2 = (1 - gamma^2) / (2 L gamma^2)`` for L independent looks of coherence gamma
(Rodriguez & Martin 1992; Rosen et al. 2000). The bound is reached for large L
(about L > 4); for few looks the true spread is larger (the exact pdf: Lee et al. 1994).
docs/interferometry.md §4.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["predicted_phase_std"]


def predicted_phase_std(gamma: ArrayLike, looks: ArrayLike) -> NDArray[np.float64]:
    """Cramér–Rao standard deviation of the interferometric phase (Rodriguez & Martin 1992).

    Parameters
    ----------
    gamma : array_like
        Coherence magnitude [1], in (0, 1].
    looks : array_like
        Number of independent looks L [1], broadcast with ``gamma``.

    Returns
    -------
    ndarray
        ``sqrt((1 - gamma^2) / (2 L gamma^2))`` [rad]; NaN where gamma or L is not positive.
    """
    g = np.asarray(gamma, float)
    n = np.asarray(looks, float)
    with np.errstate(invalid="ignore", divide="ignore"):
        var = (1.0 - np.clip(g, 0.0, 1.0) ** 2) / (2.0 * n * g ** 2)
    return np.where((g > 0) & (n > 0), np.sqrt(var), np.nan)
