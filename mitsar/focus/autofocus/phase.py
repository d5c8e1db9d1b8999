"""Per-sweep phase bookkeeping of autofocus: integrate gradients, remove the linear phase.

A constant phase over the aperture changes nothing in the image's magnitude and a phase linear
in sweep index (for a straight track at constant speed: linear in azimuth frequency) only shifts
it (Fourier shift theorem; Wahl et al. 1994 §II), so neither is observable from a focused image
and estimates are returned without them. A phase per sweep is also only known modulo 2 pi, so
the linear phase is taken wrap-invariantly: the slope is the circular mean of the sweep-to-sweep
differences, ``arg sum_k w_k w_(k-1) exp(j (phi_k - phi_(k-1)))`` (the kernel of the PGA
gradient estimator), and the constant the circular mean ``arg sum_k w_k exp(j phi_k)``; a least
squares line would follow the 2 pi steps and shift the image.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

__all__ = ["integrate_gradient", "remove_linear_phase", "wrap"]


def wrap(phase: NDArray) -> NDArray:
    """Phase wrapped to (-pi, pi] [rad]."""
    return np.angle(np.exp(1j * np.asarray(phase, dtype=float)))


def remove_linear_phase(phase: NDArray, weight: NDArray | None = None) -> NDArray:
    """Phase minus its wrap-invariant linear part ``a + b k`` (module docstring) [rad].

    The result is unwrapped along the sweeps (equal to ``phase - a - b k`` modulo 2 pi) and
    has a weighted circular mean of zero.

    Parameters
    ----------
    phase : ndarray, shape (S,)
        Phase per sweep [rad].
    weight : ndarray, shape (S,), optional
        Non-negative weight per sweep (e.g. 1 where the sweep holds signal); uniform by default.
    """
    phase = np.asarray(phase, dtype=float)
    weight = np.ones(len(phase)) if weight is None else np.asarray(weight, dtype=float)
    sweeps = np.arange(len(phase), dtype=float)
    if len(phase) > 1:
        pairs = weight[1:] * weight[:-1] * np.exp(1j * np.diff(phase))
        slope = float(np.angle(pairs.sum())) if np.abs(pairs.sum()) > 0 else 0.0
        phase = phase - slope * sweeps
    constant = np.sum(weight * np.exp(1j * phase))
    phase = np.unwrap(wrap(phase - (np.angle(constant) if np.abs(constant) > 0 else 0.0)))
    return phase - 2 * np.pi * np.round(np.average(phase, weights=weight if weight.sum() > 0
                                                   else None) / (2 * np.pi))


def integrate_gradient(gradient: NDArray) -> NDArray:
    """Phase per sweep from the phase differences ``phi_k - phi_(k-1)``, ``phi_0 = 0`` [rad].

    Parameters
    ----------
    gradient : ndarray, shape (S - 1,)
    """
    return np.concatenate([[0.0], np.cumsum(gradient)])
