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

computed from the sub-images already formed for E (no finite differences, no refocus).
L-BFGS (:func:`minimise`, NumPy) minimises E stage by stage from coarse to fine blocks (2, 8,
32, ... blocks, growing by ``growth``, down to ``finest`` sweeps per block), each stage
starting from the previous one, which keeps the search out of the local minima a per-sweep
start from zero falls into when the error is several radians (the coarse-to-fine scheme of
sub-aperture autofocus). Its first inverse Hessian is diagonal, ``1 / energy`` of each block
(the entropy's curvature in a block phase grows with that block's share of the image): on the
traced room of docs/autofocus.md this halved the iterations (233 -> 114) for the same
estimate.

**Robust by construction** (issue 24 item 4):

* a stage ends when an iteration both gains less than ``tolerance`` (relative) **and** moves
  the observable phase (without its constant and linear part) by less than
  ``phase_tolerance``, not after a fixed count; ``iterations`` is only a bound, and a kept
  stage that reaches it makes the estimate "not converged" (a warning);
* the unobservable linear phase is removed over the sweeps where the scatterers are within
  ``trend_db`` of their strongest (:func:`trend_weight`), so the weak, loosely determined
  phases of the beam's edges cannot shift the image: the reflector of the traced room lands at
  the same place (within 0.04 cm) after 10, 20, 30 iterations a stage or at convergence,
  against +1.6 to +2.7 cm (0.6-1.1 cell) with the trend over every covered sweep;
* the stage returned is the finest whose check chips (the image around the scatterers with the
  focuser's aperture) are within ``check_margin`` of the sharpest; a coarser one kept must put
  the scatterers where the finest does (``shift_cells``), or the estimate is reported as not
  converged, with the distance, rather than silently shifting the image.
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
        L-BFGS iterations per stage at most, a safety bound (default 200; until 2026-11 a fixed
        budget of 30, 50 and 100): a stage ends on convergence (``tolerance`` and
        ``phase_tolerance``), and a kept stage that reaches the bound is reported.
    tolerance : float
        Relative entropy decrease of an iteration below which a stage may end (default 1e-5;
        1e-7 and 1e-9, alone, before 2026-11).
    phase_tolerance : float
        ... and the largest move of the observable phase (the step without its least-squares
        line over the blocks) below which it ends [rad] (default 0.02: a phase error of that
        size costs 0.04 % of the peak, ``1 - exp(-sigma^2)``).
    check_margin : float
        The finest stage whose check chips are within this of the sharpest is returned [nats]
        (default 0.01: a 1 % change of the chips' effective area ``exp(E)``).
    trend_db : float
        The linear phase is removed over the sweeps whose scatterer energy is within this of
        the strongest sweep's (default 10 dB; :func:`trend_weight`).
    shift_cells : float
        Largest distance between the scatterers of a coarser stage kept and the finest stage,
        image azimuth resolution cells, before the estimate counts as not converged
        (default 0.5).
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
        returned, along the image's azimuth axis, resolution cells (default 4; ``check`` of
        :func:`estimate_entropy`).
    check_range_cells : float
        Their half size along the range axis, range resolution cells (default 1; 4 before
        2026-11: a phase per sweep does not change the range response, and the chips were
        most of the estimate's cost).
    max_pixels : int
        Image pixels at most with ``domain="image"`` (default 2^14).
    fallback : bool
        Return the uncorrected image (with a warning) when the correction raises the whole
        image's entropy (default True); False returns the corrected one (with a warning).
    max_elements : int
        Bound on sweeps x points held at once (default 2^23).
    """

    coarsest: int = 2
    finest: int = 1
    growth: int = 4
    iterations: int = 200
    tolerance: float = 1e-5
    phase_tolerance: float = 0.02
    check_margin: float = 0.01
    trend_db: float = 10.0
    shift_cells: float = 0.5
    domain: str = "lines"
    scatterers: int = 8
    dynamic_range_db: float = 30.0
    separation_cells: float = 0.5
    min_scr_db: float = 15.0
    clutter_cells: float = 8.0
    oversample: int = 1
    line_cells: float | None = None
    check_cells: float = 4.0
    check_range_cells: float = 1.0
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
                  "phase_tolerance": ("a phase >= 0 rad", self.phase_tolerance >= 0),
                  "trend_db": ("a level > 0 dB", self.trend_db > 0),
                  "shift_cells": ("a number of cells > 0", self.shift_cells > 0),
                  "check_margin": ("an entropy >= 0 nats", self.check_margin >= 0),
                  "scatterers": ("an integer >= 1", self.scatterers >= 1),
                  "dynamic_range_db": ("a level > 0 dB", self.dynamic_range_db > 0),
                  "separation_cells": ("a number of cells >= 0", self.separation_cells >= 0),
                  "min_scr_db": ("a ratio in dB", np.isfinite(self.min_scr_db)),
                  "clutter_cells": ("a number of cells >= 1", self.clutter_cells >= 1),
                  "oversample": ("an integer >= 1", self.oversample >= 1),
                  "line_cells": ("None or a number of cells >= 2",
                                 self.line_cells is None or self.line_cells >= 2),
                  "check_cells": ("a number of cells > 0", self.check_cells > 0),
                  "check_range_cells": ("a number of cells > 0", self.check_range_cells > 0),
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
             iterations: int, tolerance: float, step_tolerance: float = 0.0,
             step_size: Callable[[NDArray], float] | None = None,
             scale: NDArray | None = None, memory: int = 8) -> tuple[NDArray, float, int, bool]:
    """Minimise a smooth function by limited-memory BFGS with a backtracking line search.

    The two-loop recursion (Nocedal & Wright, *Numerical Optimization*, 2nd ed., 2006,
    Algorithm 7.4) with ``memory`` pairs, initial Hessian ``s.y / y.y`` (their eq. 7.20), the
    first step scaled to at most 0.5 rad per parameter, and Armijo backtracking (their
    Algorithm 3.1, c = 1e-4). Plain NumPy element-wise arithmetic (no BLAS threads, see
    :func:`_entropy_and_gradient`).

    Convergence is tested on both what the search gains and where it goes (their §7.2 and
    the stopping tests of §3.5): an iteration that lowers f by at most
    ``tolerance * max(|f|, 1)`` **and** moves no parameter by more than ``step_tolerance``
    ends the search as converged. A small decrease with a large step (a flat valley the
    search is still crossing, e.g. a linear phase, which moves the image) goes on.

    Parameters
    ----------
    function : callable
        ``x -> (f(x), grad f(x))``.
    start : ndarray
        Starting point.
    iterations : int
        Iterations at most (a safety bound: reaching it is reported, not converged).
    tolerance : float
        Relative decrease of f below which an iteration may end the search.
    step_tolerance : float
        Largest parameter change [rad] of such an iteration.
    step_size : callable, optional
        ``s -> size`` of a step, compared with ``step_tolerance``; default the largest
        ``|s_i|``. (The entropy's estimate measures it without the unobservable constant and
        linear phase, along which the search may drift at no cost.)

    Returns
    -------
    x : ndarray
    value : float
        f(x).
    iterations : int
        Iterations run.
    converged : bool
        The tests above were met (or no descent was left: the gradient vanishes or the line
        search cannot lower f), not the iteration bound.
    """
    x = np.asarray(start, dtype=float).copy()
    diagonal = np.ones(len(x)) if scale is None else np.asarray(scale, dtype=float)
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
            direction = direction * diagonal * (float((s * y).sum())
                                                / float((y * diagonal * y).sum()))
        else:
            direction = direction * diagonal
            direction *= min(1.0, 0.5 / max(float(np.abs(direction).max()), 1e-300))
        for (s, y, rho), alpha in zip(pairs, reversed(alphas), strict=True):
            direction = direction + s * (alpha - rho * float((y * direction).sum()))
        slope = float((gradient * direction).sum())
        if not slope < 0:  # not a descent direction: restart from the scaled gradient
            pairs.clear()
            direction = -gradient * diagonal
            direction *= min(1.0, 0.5 / max(float(np.abs(direction).max()), 1e-300))
            slope = float((gradient * direction).sum())
            if not slope < 0:
                return x, value, done, True  # the gradient vanishes
        step = 1.0
        while True:
            trial, trial_gradient = function(x + step * direction)
            if trial <= value + 1e-4 * step * slope or step < 1e-8:
                break
            step *= 0.5
        if trial > value:
            return x, value, done, True  # no decrease left along a descent direction
        s, y = step * direction, trial_gradient - gradient
        curvature = float((s * y).sum())
        if curvature > 1e-12:
            pairs = [*pairs[-(memory - 1):], (s, y, 1.0 / curvature)]
        change = value - trial
        x, value, gradient = x + s, trial, trial_gradient
        size = float(np.abs(s).max()) if step_size is None else step_size(s)
        if change <= tolerance * max(abs(value), 1.0) and size <= step_tolerance:
            return x, value, done, True
    return x, value, done, False


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


def line_peaks(lines: AzimuthLines, phase: NDArray) -> tuple[NDArray, NDArray]:
    """Peak offset of every line image along its line [m] and its intensity, shape (P,) each.

    The brightest sample of ``|I_p(q)|^2`` (:meth:`AzimuthLines.images`), refined by the
    vertex of the parabola through it and its two neighbours (circular: a line is one alias
    period).
    """
    power = np.abs(lines.images(phase)) ** 2
    count, length = power.shape
    rows = np.arange(count)
    centre = np.argmax(power, axis=1)
    before = power[rows, (centre - 1) % length]
    after = power[rows, (centre + 1) % length]
    peak = power[rows, centre]
    curvature = before - 2 * peak + after
    fraction = np.where(curvature < 0, 0.5 * (before - after) / np.where(
        curvature < 0, curvature, -1.0), 0.0)
    spacing = lines.offsets[:, 1] - lines.offsets[:, 0] if length > 1 else np.zeros(count)
    return lines.offsets[rows, centre] + np.clip(fraction, -0.5, 0.5) * spacing, peak


def trend_weight(energy: NDArray, level_db: float) -> NDArray:
    """1 for the sweeps whose summed scatterer energy is within ``level_db`` of the largest,
    else 0: the sweeps whose estimated phases set the linear trend that is removed.

    The linear phase is unobservable and only shifts the image (:mod:`.phase`); taken over
    every covered sweep, the per-sweep phases of the beam's edges, where the scatterers are
    weak and a phase is set by few, faint samples, move the trend and so the image (measured
    on the traced room of docs/autofocus.md: the reflector at +1.6, +2.0, +2.7 cm from the
    error-free image with 30, 20, 10 iterations a stage; with the -10 dB sweeps -0.99 to
    -1.03 cm for all three and at convergence).
    """
    energy = np.asarray(energy, dtype=float)
    top = float(energy.max()) if energy.size else 0.0
    if top <= 0:
        return np.zeros(len(energy))
    return (energy >= top * 10 ** (-level_db / 10)).astype(float)


def estimate_entropy(source: NDArray | AzimuthLines, options: EntropyOptions,
                     check: NDArray | None = None, cell: float | None = None
                     ) -> tuple[NDArray, dict]:
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
    cell : float, optional
        The image's azimuth resolution [m]. With lines, the position check: the kept stage's
        line peaks (:func:`line_peaks`, intensity-weighted median of their moves) must lie
        within ``options.shift_cells`` cells of the previous stage's, or the estimate counts
        as not converged (``position_settled`` False: its scatterers may be shifted).

    Returns
    -------
    phase : ndarray, shape (S,)
        Estimated phase error per sweep [rad], constant and linear trend removed (over the
        sweeps within ``trend_db`` of the most energetic, :func:`trend_weight`); the raw
        sweeps are corrected by ``exp(-j phase)``.
    info : dict
        ``stages`` (sub-aperture counts), ``iterations`` (L-BFGS iterations, all stages),
        ``stage_iterations`` and ``stage_settled`` (per stage: iterations, and whether its
        search converged before the ``iterations`` bound), ``kept_stage`` (1-based stage
        whose estimate is returned, 0: none), ``converged`` (a stage lowered the entropy of
        the check chips and of the model, and the position check passed),
        ``kept_stage_settled``, ``position_shift_cells`` (the check's move, cells; 0 without
        it) and ``position_settled``, ``entropy_initial`` and ``entropy_final`` (of the model
        image, nats), ``check_entropy_initial`` / ``_final`` (of the check chips, or the
        model, nats), ``covered_sweeps``, ``trend_sweeps``.
    """
    lines = source if isinstance(source, AzimuthLines) else None
    terms = model_terms(source) if lines is not None else np.asarray(source)
    sweeps = len(terms)
    energy = (terms.real.astype(np.float64) ** 2 + terms.imag.astype(np.float64) ** 2).sum(
        axis=1)
    coverage = (energy > 0).astype(float)
    trend = trend_weight(energy, options.trend_db)
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
    estimates, scores = [phase], [sharpness(phase)]
    stage_iterations, stage_settled = [], []
    for count in stages:
        block = np.minimum((np.arange(len(rows)) * count) // len(rows), count - 1)
        starts = np.flatnonzero(np.diff(block, prepend=-1))
        rotated = active * np.exp(-1j * phase[rows]).astype(np.complex64)[:, None]
        sub_images = np.add.reduceat(rotated, starts, axis=0)
        centres = np.add.reduceat(np.arange(len(rows), dtype=float), starts) / np.diff(
            np.append(starts, len(rows)))
        theta, _, done, settled = minimise(
            lambda t, sub=sub_images: _entropy_and_gradient(t, sub), np.zeros(count),
            options.iterations, options.tolerance, options.phase_tolerance,
            lambda t, c=centres: _observable_size(t, c),
            scale=_scale(np.add.reduceat(energy[rows], starts)))
        stage_iterations.append(int(done))
        stage_settled.append(bool(settled))
        step = np.zeros(sweeps)
        step[rows] = theta[block]
        phase = remove_linear_phase(phase + step, trend)
        estimates.append(phase)
        scores.append(sharpness(phase))
    # the finest stage whose chips are within check_margin of the sharpest: a coarser stage
    # is kept only when it is clearly sharper (over-fitted per-sweep phases), not for noise
    best = min(scores)
    kept = max(n for n, score in enumerate(scores) if score <= best + options.check_margin)
    phase = estimates[kept]
    shift, finest = 0.0, len(estimates) - 1
    if lines is not None and cell and 0 < kept < finest:
        # a coarser stage kept over the finest (whose per-sweep phases out-sharpened the
        # model): both must put the scatterers at the same place, or where they are is
        # uncertain by the difference
        now, power = line_peaks(lines, phase)
        other, _ = line_peaks(lines, estimates[finest])
        spacing = lines.offsets[:, 1] - lines.offsets[:, 0] if lines.offsets.shape[1] > 1 \
            else np.zeros(len(now))
        period = np.where(spacing != 0, spacing * lines.offsets.shape[1], np.inf)
        moved = now - other
        moved -= np.where(np.isfinite(period), period * np.round(moved / period), 0.0)
        shift = float(_weighted_median(moved, power)) / cell  # within one alias period
    position_settled = abs(shift) <= options.shift_cells
    entropy_final = image_entropy(
        (active * np.exp(-1j * phase[rows]).astype(np.complex64)[:, None]).sum(axis=0))
    # converged: a stage sharpened the check chips (or the model) and the model, and did not
    # move the scatterers; a stage that stops on its iteration bound is recorded (the next
    # one starts from it) and only matters when it is the one kept
    converged = (kept > 0 and scores[kept] < scores[0] and entropy_final < entropy_initial
                 and position_settled and stage_settled[kept - 1])
    return phase, {"stages": stages, "iterations": int(sum(stage_iterations)),
                   "stage_iterations": stage_iterations, "stage_settled": stage_settled,
                   "converged": bool(converged), "kept_stage": kept,
                   "kept_stage_settled": bool(kept == 0 or stage_settled[kept - 1]),
                   "position_shift_cells": round(shift, 3),
                   "position_settled": bool(position_settled),
                   "entropy_initial": entropy_initial, "entropy_final": entropy_final,
                   "check_entropy_initial": float(scores[0]),
                   "check_entropy_final": float(scores[kept]),
                   "covered_sweeps": int(coverage.sum()), "trend_sweeps": int(trend.sum())}


def _scale(energy: NDArray) -> NDArray:
    """Diagonal initial inverse Hessian of the block phases: ``1 / energy`` of each block,
    normalised to a mean of 1 (the entropy's curvature in ``theta_m`` grows with the share of
    the image that block m forms)."""
    inverse = 1.0 / np.maximum(energy, energy.max() * 1e-6)
    return inverse / inverse.mean()


def _observable_size(step: NDArray, centres: NDArray) -> float:
    """Largest ``|step|`` after removing its least-squares line over the blocks' centre
    sweeps ``centres`` [rad] (the constant and linear phase do not change the entropy)."""
    if len(step) < 3:
        return 0.0
    slope, offset = np.polyfit(centres, step, 1)
    return float(np.abs(step - slope * centres - offset).max())


def _weighted_median(values: NDArray, weights: NDArray) -> float:
    """Median of ``values`` with non-negative ``weights`` (the smallest value holding half the
    weight)."""
    order = np.argsort(values)
    cumulative = np.cumsum(np.asarray(weights, dtype=float)[order])
    if cumulative[-1] <= 0:
        return float(np.median(values))
    return float(np.asarray(values)[order][np.searchsorted(cumulative, cumulative[-1] / 2)])
