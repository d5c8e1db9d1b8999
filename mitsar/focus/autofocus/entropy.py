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

from collections.abc import Callable
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.focus.autofocus.lines import AzimuthLines
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
    growth : int
        Factor between the sub-aperture counts of consecutive stages (default 4; 2 before
        2026-11).
    iterations : int
        L-BFGS iterations per stage at most (default 30; 50, and 100 before, until 2026-11).
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
    scatterers, dynamic_range_db, separation_cells, min_scr_db, clutter_cells, oversample
        Selection and sampling of the lines (as :class:`PGAOptions`,
        :mod:`mitsar.focus.autofocus.selection`; defaults 8 (16, and 32 before, until
        2026-11), 30 dB,
        0.5 resolution cells (3 pixels before 2026-11), 15 dB, 8 cells, and 1 point a cell
        (2 before 2026-11: the lines then hold about as many points as sweeps, a square,
        near-unitary transform, at half the cost per evaluation).
    line_cells : float or None
        Half length of the lines in resolution cells of their aperture (default None: the
        whole alias-free extent). Shorter lines are faster but no longer a near-unitary
        transform of the histories: per-sweep phases then find images sharper than the truth
        (measured on the room of docs/autofocus.md: 16 cells, model entropy 5.9 -> 3.4 nats
        while the image stayed defocused), so keep None unless ``finest`` > 1.
    check_cells : float
        Half size of the image chips around the scatterers whose entropy chooses the stage
        returned, resolution cells (default 4; ``check`` of :func:`estimate_entropy`).
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
    growth: int = 4
    iterations: int = 30
    tolerance: float = 1e-7
    domain: str = "lines"
    scatterers: int = 8
    dynamic_range_db: float = 30.0
    separation_cells: float = 0.5
    min_scr_db: float = 15.0
    clutter_cells: float = 8.0
    oversample: int = 1
    line_cells: float | None = None
    check_cells: float = 4.0
    max_pixels: int = 1 << 14
    max_elements: int = 1 << 23
    fallback: bool = True

    def __post_init__(self) -> None:
        checks = {"coarsest": ("an integer >= 1", self.coarsest >= 1),
                  "finest": ("an integer >= 1 (sweeps per sub-aperture)", self.finest >= 1),
                  "growth": ("an integer >= 2", self.growth >= 2),
                  "iterations": ("an integer >= 1", self.iterations >= 1),
                  "max_pixels": ("an integer >= 16", self.max_pixels >= 16),
                  "domain": ("'lines' or 'image'", self.domain in ("lines", "image")),
                  "tolerance": ("a number >= 0", self.tolerance >= 0),
                  "scatterers": ("an integer >= 1", self.scatterers >= 1),
                  "dynamic_range_db": ("a level > 0 dB", self.dynamic_range_db > 0),
                  "separation_cells": ("a number of cells >= 0", self.separation_cells >= 0),
                  "min_scr_db": ("a ratio in dB", np.isfinite(self.min_scr_db)),
                  "clutter_cells": ("a number of cells >= 1", self.clutter_cells >= 1),
                  "oversample": ("an integer >= 1", self.oversample >= 1),
                  "line_cells": ("None or a number of cells >= 2",
                                 self.line_cells is None or self.line_cells >= 2),
                  "check_cells": ("a number of cells > 0", self.check_cells > 0),
                  "max_elements": ("an integer >= 1", self.max_elements >= 1)}
        for name, (expected, good) in checks.items():
            if not good:
                raise ParameterError("autofocus 'entropy'", name, expected, getattr(self, name))


def image_entropy(values: NDArray) -> float:
    """Entropy ``-sum p ln p`` of the normalised intensity ``p = |g|^2 / sum |g|^2`` [nats]."""
    power = np.abs(np.asarray(values).ravel()).astype(np.float64) ** 2
    total = power.sum()
    if total <= 0:
        return 0.0
    share = power / total
    return float(-np.sum(share * np.log(share + _TINY)))


def _entropy_and_gradient(theta: NDArray, sub_images: NDArray) -> tuple[float, NDArray]:
    """Entropy of ``g = sum_m I_m exp(-j theta_m)`` and its gradient over theta (module doc).

    ``sub_images`` may be complex64 (the sums in float32, the entropy's logarithms and totals
    in float64). Written as element-wise products and sums, not BLAS matrix products: a
    multi-threaded BLAS called a few hundred times on small matrices spent 100x the work
    waiting on its threads on a loaded machine (measured 15.6 s against 0.27 s single-threaded
    for the same estimate).
    """
    rotation = np.exp(-1j * theta).astype(sub_images.dtype)
    image = (sub_images * rotation[:, None]).sum(axis=0)  # g, (P,)
    power = (image.real**2 + image.imag**2).astype(np.float64)
    total = power.sum()
    log_power = np.log(power + _TINY)
    s_t = float(np.sum(power * log_power))
    entropy = np.log(total) - s_t / total
    d_power = ((s_t / total - log_power) / total).astype(image.real.dtype)
    weighted = (d_power * image.conj())[None, :]
    gradient = 2 * np.imag(rotation * (sub_images * weighted).sum(axis=1))
    return float(entropy), gradient.astype(np.float64)


def minimise(function: Callable[[NDArray], tuple[float, NDArray]], start: NDArray,
             iterations: int, tolerance: float, memory: int = 8) -> tuple[NDArray, float, int]:
    """Minimise a smooth function by limited-memory BFGS with a backtracking line search.

    The two-loop recursion (Nocedal & Wright, *Numerical Optimization*, 2nd ed., 2006,
    Algorithm 7.4) with ``memory`` pairs, initial Hessian ``s.y / y.y`` (their eq. 7.20), the
    first step scaled to at most 0.5 rad per parameter, and Armijo backtracking (their
    Algorithm 3.1, c = 1e-4). Plain NumPy element-wise arithmetic (no BLAS threads, see
    :func:`_entropy_and_gradient`).

    Parameters
    ----------
    function : callable
        ``x -> (f(x), grad f(x))``.
    start : ndarray
        Starting point.
    iterations : int
        Iterations at most.
    tolerance : float
        Stop when an iteration lowers f by at most ``tolerance * max(|f|, 1)`` (as L-BFGS-B's
        ``ftol``).

    Returns
    -------
    x : ndarray
    value : float
        f(x).
    iterations : int
        Iterations run.
    """
    x = np.asarray(start, dtype=float).copy()
    value, gradient = function(x)
    pairs: list[tuple[NDArray, NDArray, float]] = []
    done = 0
    while done < iterations:
        done += 1
        direction = -gradient
        alphas = []
        for s, y, rho in reversed(pairs):
            alpha = rho * float((s * direction).sum())
            direction = direction - alpha * y
            alphas.append(alpha)
        if pairs:
            s, y, _ = pairs[-1]
            direction = direction * (float((s * y).sum()) / float((y * y).sum()))
        else:
            direction = direction * min(1.0, 0.5 / max(float(np.abs(gradient).max()), 1e-300))
        for (s, y, rho), alpha in zip(pairs, reversed(alphas), strict=True):
            direction = direction + s * (alpha - rho * float((y * direction).sum()))
        slope = float((gradient * direction).sum())
        if not slope < 0:  # not a descent direction: restart from the scaled gradient
            pairs.clear()
            direction = -gradient * min(1.0, 0.5 / max(float(np.abs(gradient).max()), 1e-300))
            slope = float((gradient * direction).sum())
            if not slope < 0:
                break
        step = 1.0
        while True:
            trial, trial_gradient = function(x + step * direction)
            if trial <= value + 1e-4 * step * slope or step < 1e-8:
                break
            step *= 0.5
        if trial > value:
            break
        s, y = step * direction, trial_gradient - gradient
        curvature = float((s * y).sum())
        if curvature > 1e-12:
            pairs = [*pairs[-(memory - 1):], (s, y, 1.0 / curvature)]
        change = value - trial
        x, value, gradient = x + s, trial, trial_gradient
        if change <= tolerance * max(abs(value), 1.0):
            break
    return x, value, done


def _stages(sweeps: int, options: EntropyOptions) -> list[int]:
    """Numbers of sub-apertures, growing by ``growth`` from ``coarsest`` to ``sweeps / finest``."""
    last = max(1, int(np.ceil(sweeps / options.finest)))
    counts, count = [], min(options.coarsest, last)
    while count < last:
        counts.append(count)
        count *= options.growth
    return [*counts, last]


def model_terms(lines: AzimuthLines) -> NDArray:
    """Per-sweep terms of the line images, ``D_kpq h_kp``, shape (S, P Q), complex64."""
    terms = lines.kernel.astype(np.complex64) * lines.history.astype(np.complex64)[:, :, None]
    return terms.reshape(len(lines.history), -1)


def estimate_entropy(source: NDArray | AzimuthLines, options: EntropyOptions,
                     check: NDArray | None = None) -> tuple[NDArray, dict]:
    """Estimate the phase error per sweep by minimising the entropy of ``sum_k terms_k``.

    Parameters
    ----------
    source : AzimuthLines or ndarray, shape (S, N), complex
        Azimuth lines through bright scatterers (:mod:`mitsar.focus.autofocus.lines`, the
        default domain), or the per-sweep contributions ``B_k(x)`` to N image pixels
        (:mod:`mitsar.focus.autofocus.contributions`).
    options : EntropyOptions
    check : ndarray, shape (S, C), complex, optional
        Per-sweep contributions to C image pixels (chips around the scatterers, with the
        focuser's processed aperture): the estimate of the stage whose chips have the lowest
        entropy is returned, none (zero phase) included. The model can out-sharpen the truth
        when there are more phases than it constrains (per-sweep phases on a few lines that
        carry clutter: measured on the traced room of docs/autofocus.md, model entropy 2.85
        against 3.15 nats with one phase per two sweeps, the peak 3.5 dB lower); the chips
        are what the image shows. Default: the model itself (the last stage).

    Returns
    -------
    phase : ndarray, shape (S,)
        Estimated phase error per sweep [rad], constant and linear trend removed (over the
        sweeps that contribute); the raw sweeps are corrected by ``exp(-j phase)``.
    info : dict
        ``stages`` (sub-aperture counts), ``iterations`` (L-BFGS iterations, all stages),
        ``kept_stage`` (1-based stage whose estimate is returned, 0: none),
        ``converged`` (a stage lowered the entropy of the check chips and of the model),
        ``kept_stage_settled`` (its L-BFGS stopped on the tolerance, not the limit),
        ``entropy_initial`` and ``entropy_final`` (of the model image, nats),
        ``check_entropy_initial`` / ``_final`` (of the check chips, or the model, nats),
        ``covered_sweeps``.
    """
    terms = model_terms(source) if isinstance(source, AzimuthLines) else np.asarray(source)
    sweeps = len(terms)
    coverage = (np.abs(terms).sum(axis=1) > 0).astype(float)
    # Only the sweeps that hold signal are optimised (the others keep phase 0 until the trend
    # removal); sums in float32 (the image's dynamic range is far inside its 24 bits).
    rows = np.flatnonzero(coverage > 0)
    active = np.asarray(terms[rows], dtype=np.complex64)
    checked = None if check is None else np.asarray(check, dtype=np.complex64)[rows]

    def sharpness(phase: NDArray) -> float:
        """Entropy of the check chips (or of the model) with the estimate [nats]."""
        values = active if checked is None else checked
        return image_entropy((values * np.exp(-1j * phase[rows]).astype(np.complex64)[:, None]
                              ).sum(axis=0))

    phase = np.zeros(sweeps)
    stages = _stages(len(rows), options)
    entropy_initial = image_entropy(active.sum(axis=0))
    best = (sharpness(phase), phase, 0, True)
    check_initial = best[0]
    total_iterations = 0
    for number, count in enumerate(stages, start=1):
        block = np.minimum((np.arange(len(rows)) * count) // len(rows), count - 1)
        starts = np.flatnonzero(np.diff(block, prepend=-1))
        rotated = active * np.exp(-1j * phase[rows]).astype(np.complex64)[:, None]
        sub_images = np.add.reduceat(rotated, starts, axis=0)
        theta, _, done = minimise(lambda t, sub=sub_images: _entropy_and_gradient(t, sub),
                                  np.zeros(count), options.iterations, options.tolerance)
        total_iterations += done
        step = np.zeros(sweeps)
        step[rows] = theta[block]
        phase = remove_linear_phase(phase + step, coverage)
        score = sharpness(phase)
        if score < best[0]:
            best = (score, phase, number, done < options.iterations)
    check_final, phase, kept, settled = best
    entropy_final = image_entropy(
        (active * np.exp(-1j * phase[rows]).astype(np.complex64)[:, None]).sum(axis=0))
    # converged: a stage sharpened the check chips (or the model) and the model; a stage that
    # stops on its iteration limit is normal (the next one starts from it) and only recorded
    converged = kept > 0 and check_final < check_initial and entropy_final < entropy_initial
    return phase, {"stages": stages, "iterations": total_iterations,
                   "converged": bool(converged), "kept_stage": int(kept),
                   "kept_stage_settled": bool(settled),
                   "entropy_initial": entropy_initial, "entropy_final": entropy_final,
                   "check_entropy_initial": float(check_initial),
                   "check_entropy_final": float(check_final),
                   "covered_sweeps": int(coverage.sum())}
