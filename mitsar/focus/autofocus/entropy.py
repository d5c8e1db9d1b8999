"""Minimum-entropy autofocus: the phase per sub-aperture (down to per sweep) that makes the
image sharpest.

The image after a correction is ``g(x) = sum_k B_k(x) exp(-j phi_k)`` with ``B_k(x) = w_k(x)
c_k(x)`` the weighted per-sweep contributions of back-projection
(:mod:`mitsar.focus.autofocus.contributions`). Its entropy (Xi, Guo & Wang 1999, IEEE TAES
35(4); Kragh 2006, "Monotonic iterative algorithm for minimum-entropy autofocus", ASAP
workshop)

``E = -sum_x (t_x / Z) ln(t_x / Z) = ln Z - (1/Z) sum_x t_x ln t_x``,  ``t_x = |g(x)|^2``,
``Z = sum_x t_x``

is smallest for a focused image. With sub-apertures (blocks of consecutive sweeps) ``m`` and a
phase ``theta_m`` per block added to the current estimate ``phi``, the image is
``g = sum_m I_m exp(-j theta_m)`` with the sub-images ``I_m = sum_(k in m) B_k exp(-j phi_k)``,
and the gradient follows in closed form from ``dE/dt_x = (S_t / Z - ln t_x) / Z``
(``S_t = sum t ln t``) and ``dt_x/dtheta_m = 2 Im(conj(g_x) I_m(x) exp(-j theta_m))``:

``dE/dtheta_m = 2 sum_x (dE/dt_x) Im(conj(g_x) I_m(x) exp(-j theta_m))``,

one matrix product for all blocks. L-BFGS (scipy) minimises E stage by stage from coarse to
fine blocks (2, 4, 8, ... sweeps per block down to ``finest``), each stage starting from the
previous one, which keeps the search out of the local minima a per-sweep start from zero falls
into when the error is several radians (the coarse-to-fine scheme of sub-aperture autofocus).
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray
from scipy.optimize import minimize

from mitsar.errors import ParameterError
from mitsar.focus.autofocus.phase import remove_linear_phase

__all__ = ["EntropyOptions", "estimate_entropy", "image_entropy"]

_TINY = 1e-300


@dataclass(frozen=True)
class EntropyOptions:
    """Parameters of :func:`estimate_entropy` (``autofocus_options`` of :func:`mitsar.focus.focus`).

    Attributes
    ----------
    coarsest : int
        Number of sub-apertures of the first stage (default 2).
    finest : int
        Sweeps per sub-aperture of the last stage (default 1: a phase per sweep).
    iterations : int
        L-BFGS iterations per stage at most (default 50; 100 before 2026-11).
    domain : {"lines", "image"}
        Where the entropy is evaluated: on azimuth lines through the brightest scatterers
        (default; :mod:`mitsar.focus.autofocus.lines`, full beam, sampled at half a cell over
        the alias-free extent, so the model image is a near-unitary transform of the phase
        histories and a linear phase, an image shift, is the only ambiguity), or on the
        image's own pixels with the focuser's processed aperture (at most ``max_pixels``, the
        brightest). The second is what a user sees, but a pixel-windowed BP image is not shift
        invariant and, sampled at a few pixels per cell, has per-sweep solutions sharper than
        the truth (measured: entropy 2.1 against 4.0 for the true phase on the point target of
        ``docs/autofocus.md``), so it suits sub-apertures (``finest`` > 1) only.
    scatterers, dynamic_range_db, separation_cells, oversample : int or float
        Selection and sampling of the lines (as :class:`PGAOptions`; defaults 16 (32 before
        2026-11), 30 dB, 3 pixels, 2 points a cell).
    line_cells : float or None
        Half length of the lines in resolution cells of their aperture (default None: the
        whole alias-free extent). Shorter lines are faster but no longer a near-unitary
        transform of the histories: per-sweep phases then find images sharper than the truth
        (measured on the room of docs/autofocus.md: 16 cells, model entropy 5.9 -> 3.4 nats
        while the image stayed defocused), so keep None unless ``finest`` > 1.
    max_pixels : int
        Image pixels at most with ``domain="image"`` (default 2^14).
    fallback : bool
        Return the uncorrected image (with a warning) when the correction raises the whole
        image's entropy (default True); False returns the corrected one (with a warning).
    max_elements : int
        Bound on sweeps x points held at once (default 2^23).
    tolerance : float
        Relative entropy change that ends a stage (default 1e-7; 1e-9 before 2026-11).
    """

    coarsest: int = 2
    finest: int = 1
    iterations: int = 50
    tolerance: float = 1e-7
    domain: str = "lines"
    scatterers: int = 16
    dynamic_range_db: float = 30.0
    separation_cells: float = 3.0
    oversample: int = 2
    line_cells: float | None = None
    max_pixels: int = 1 << 14
    max_elements: int = 1 << 23
    fallback: bool = True

    def __post_init__(self) -> None:
        checks = {"coarsest": ("an integer >= 1", self.coarsest >= 1),
                  "finest": ("an integer >= 1 (sweeps per sub-aperture)", self.finest >= 1),
                  "iterations": ("an integer >= 1", self.iterations >= 1),
                  "max_pixels": ("an integer >= 16", self.max_pixels >= 16),
                  "domain": ("'lines' or 'image'", self.domain in ("lines", "image")),
                  "tolerance": ("a number >= 0", self.tolerance >= 0),
                  "scatterers": ("an integer >= 1", self.scatterers >= 1),
                  "dynamic_range_db": ("a level > 0 dB", self.dynamic_range_db > 0),
                  "separation_cells": ("a number of pixels >= 0", self.separation_cells >= 0),
                  "oversample": ("an integer >= 1", self.oversample >= 1),
                  "line_cells": ("None or a number of cells >= 2",
                                 self.line_cells is None or self.line_cells >= 2),
                  "max_elements": ("an integer >= 1", self.max_elements >= 1)}
        for name, (expected, good) in checks.items():
            if not good:
                raise ParameterError("autofocus 'entropy'", name, expected, getattr(self, name))


def image_entropy(values: NDArray) -> float:
    """Entropy ``-sum p ln p`` of the normalised intensity ``p = |g|^2 / sum |g|^2`` [nats]."""
    power = np.abs(np.asarray(values).ravel()) ** 2
    total = power.sum()
    if total <= 0:
        return 0.0
    share = power / total
    return float(-np.sum(share * np.log(share + _TINY)))


def _entropy_and_gradient(theta: NDArray, sub_images: NDArray) -> tuple[float, NDArray]:
    """Entropy of ``g = sum_m I_m exp(-j theta_m)`` and its gradient over theta (module doc)."""
    rotated = sub_images * np.exp(-1j * theta).astype(sub_images.dtype)[:, None]  # (M, P)
    image = rotated.sum(axis=0)
    power = (image.real**2 + image.imag**2).astype(np.float64)
    total = power.sum()
    log_power = np.log(power + _TINY)
    s_t = float(np.sum(power * log_power))
    entropy = np.log(total) - s_t / total
    d_power = ((s_t / total - log_power) / total).astype(image.real.dtype)
    gradient = 2 * np.imag(rotated @ (d_power * image.conj()))
    return float(entropy), gradient.astype(np.float64)


def _stages(sweeps: int, options: EntropyOptions) -> list[int]:
    """Numbers of sub-apertures, doubling from ``coarsest`` to ``sweeps / finest``."""
    last = max(1, int(np.ceil(sweeps / options.finest)))
    counts, count = [], min(options.coarsest, last)
    while count < last:
        counts.append(count)
        count *= 2
    return [*counts, last]


def estimate_entropy(terms: NDArray, options: EntropyOptions) -> tuple[NDArray, dict]:
    """Estimate the phase error per sweep by minimising the entropy of ``sum_k terms_k``.

    Parameters
    ----------
    terms : ndarray, shape (S, N), complex
        Per-sweep contributions ``B_k(x)`` to N image points: the points of azimuth lines
        through bright scatterers (:mod:`mitsar.focus.autofocus.lines`, the default domain) or
        image pixels (:mod:`mitsar.focus.autofocus.contributions`).
    options : EntropyOptions

    Returns
    -------
    phase : ndarray, shape (S,)
        Estimated phase error per sweep [rad], constant and linear trend removed (over the
        sweeps that contribute); the raw sweeps are corrected by ``exp(-j phase)``.
    info : dict
        ``stages`` (sub-aperture counts), ``iterations`` (L-BFGS iterations, all stages),
        ``converged`` (the entropy fell and the finest stage changed it by at most 5 % of the
        whole reduction),
        ``entropy_initial`` and ``entropy_final`` (of the model image, nats),
        ``covered_sweeps``.
    """
    sweeps = len(terms)
    coverage = (np.abs(terms).sum(axis=1) > 0).astype(float)
    # Only the sweeps that hold signal are optimised (the others keep phase 0 until the trend
    # removal).
    rows = np.flatnonzero(coverage > 0)
    active = np.asarray(terms[rows], dtype=np.complex128)
    phase = np.zeros(sweeps)
    stages = _stages(len(rows), options)
    entropy_initial = image_entropy(terms.sum(axis=0))
    total_iterations = 0
    last = (0.0, 0.0)
    for count in stages:
        block = np.minimum((np.arange(len(rows)) * count) // len(rows), count - 1)
        sub_images = np.zeros((count, active.shape[1]), dtype=np.complex128)
        np.add.at(sub_images, block, active * np.exp(-1j * phase[rows])[:, None])
        result = minimize(_entropy_and_gradient, np.zeros(count), args=(sub_images,),
                          jac=True, method="L-BFGS-B",
                          options={"maxiter": options.iterations, "ftol": options.tolerance})
        total_iterations += int(result.nit)
        last = (float(_entropy_and_gradient(np.zeros(count), sub_images)[0]),
                float(result.fun))
        step = np.zeros(sweeps)
        step[rows] = result.x[block]
        phase = remove_linear_phase(phase + step, coverage)
    entropy_final = image_entropy((terms * np.exp(-1j * phase)[:, None]).sum(axis=0))
    # converged: the finest stage changed the entropy by at most 5 % of the whole reduction
    # (it only polishes), and the entropy fell
    reduction = max(entropy_initial - entropy_final, 0.0)
    converged = entropy_final < entropy_initial and last[0] - last[1] <= 0.05 * reduction
    return phase, {"stages": stages, "iterations": total_iterations,
                   "converged": bool(converged),
                   "entropy_initial": entropy_initial, "entropy_final": entropy_final,
                   "covered_sweeps": int(coverage.sum())}
