"""Phase gradient autofocus (PGA) in the pulse domain of back-projection.

PGA (Wahl, Eichel, Ghiglia & Jakowatz, IEEE TAES 30(3), 1994) estimates a phase error common to
all range lines from the brightest scatterers: each line's brightest pixel is circularly shifted
to the centre, a window around it keeps the scatterer and rejects clutter, an azimuth inverse FFT
gives the scatterer's phase history ``g_k``, and the phase gradient is estimated by
``arg sum_p g_k(p) conj(g_(k-1)(p))`` (the maximum-likelihood kernel of Jakowatz & Wahl 1993,
JOSA A 10(12)), integrated, stripped of its linear trend and applied; the window is set at
every iteration from the energy spread of the centred scatterers (:func:`energy_window`).

Back-projection has no azimuth FFT on a curved track, so here every step is written with the BP
geometry (:mod:`mitsar.focus.autofocus.contributions`):

* a "line" is the set of points ``x_p + delta_q a_p`` through a selected scatterer x_p along its
  azimuth direction a_p (:func:`azimuth_directions`), spaced at a fraction of the resolution
  ``lambda / (2 du)`` of the line's aperture (du: span of the direction sine ``a_p . l_k``);
* the line image is the exact back-projection of the scatterer's phase history
  ``h_k = w_k c_k(x_p) exp(-j phi_k)`` along it, ``I_p(q) = sum_k D_kpq h_k`` with
  ``D_kpq = exp(-j 2 pi f_c [tau_k(x_p + delta_q a_p) - tau_k(x_p)])`` (the range profile is
  read at x_p for the whole line: the polar-format approximation PGA itself makes);
* centring picks the brightest q; the window ``|q - q_c| <= W`` keeps the scatterer, and the
  adjoint ``g_k = D_k,p,qc sum_q conj(D_kpq) W_q I_p(q)`` returns to the pulse domain with the
  phase referred to the centre (the circular shift), for any track;
* the window is measured, not scheduled: at every iteration its half width is the one that
  holds ``window_energy`` of the dominant scatterers' energy above the clutter floor in the
  centred, line-summed intensity (:func:`energy_window`; Wahl et al. 1994 §III determine the
  width from that same sum), never below ``min_window_cells``. A defocused response is as wide
  as its phase error's spread of instantaneous frequencies (stationary phase: ``q u^2`` over
  ``u in [-1, 1]`` spreads a point uniformly over ``+-2 q / pi`` cells), so the first window
  holds the whole smear and later ones follow it as it contracts; the classic rule (start at the
  whole line, halve each iteration, floored at twice the -10 dB width) took no account of the
  smear and cut it when the error was large, or kept clutter when it was small.

All steps are array operations over sweeps, lines and line points; only iterations loop.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.focus.autofocus.contributions import PulseData
from mitsar.focus.autofocus.lines import azimuth_lines
from mitsar.focus.autofocus.phase import integrate_gradient, remove_linear_phase, wrap

__all__ = ["PGAOptions", "energy_window", "estimate_pga"]


@dataclass(frozen=True)
class PGAOptions:
    """Parameters of :func:`estimate_pga` (``autofocus_options`` of :func:`mitsar.focus.focus`).

    Attributes
    ----------
    scatterers : int
        Number of bright scatterers (lines) used, at most (default 32).
    dynamic_range_db : float
        Candidates must lie within this many dB of the brightest pixel (default 30 dB).
    separation_cells : float
        Candidates are local maxima within +- this many resolution cells along both image
        dimensions (default 0.5; 3 pixels before 2026-11).
    min_scr_db : float
        Scatterer-to-clutter ratio a candidate needs: its intensity over the median intensity
        within ``clutter_cells`` [dB] (default 15; :mod:`mitsar.focus.autofocus.selection`).
    clutter_cells : float
        Half size of the box the clutter median is taken over, resolution cells (default 8).
    iterations : int
        Largest number of PGA iterations (default 10).
    line_cells : float or None
        Half length of a line in resolution cells of its aperture, capped at half the azimuth
        extent the sweep spacing resolves without aliasing; default ``None``: that whole
        extent (a full azimuth line, as PGA's azimuth FFT).
    oversample : int
        Line points per resolution cell (default 2).
    window_energy : float
        Fraction of the scatterers' energy above the clutter floor that the window holds
        (default 0.99: a focused point's ``sinc^2`` leaves ``~1 / (pi^2 w)`` of its energy
        outside +-w cells, so 99 % keeps its sidelobes out to ~10 cells, whose phase carries
        the same error; 0.95 (+-2 cells) biased the point target of docs/autofocus.md to
        0.018 rad rms against 0.003; :func:`energy_window`). Replaces the classic ``shrink``
        factor (0.5 per iteration until 2026-11).
    min_window_cells : float
        Smallest window half width, resolution cells (default 4). The first iteration keeps
        the whole line (as PGA's first pass keeps the whole image): a random walk's white
        increments spread a point over the whole alias period, where no floor tells it from
        clutter (a measured first window of 48 cells left 1.7 rad rms on that point target).
    tolerance : float
        Stop when the rms of an iteration's correction falls below this [rad] (default 0.02),
        or when an update below twice the clutter's noise floor (:func:`_noise_floor`) did not
        sharpen the line images: on clutter the estimator's own spread can exceed the
        tolerance (traced room of docs/autofocus.md: updates of 0.05 rad rms against a floor
        of 0.048, growing again if iterated on).
    min_coherence : float
        Lines whose sweep-to-sweep phase differences agree with the estimated gradient less
        than this (coherence in [0, 1]) are left out of that iteration's estimate (default
        0.3; clutter gives about ``1/sqrt(sweeps)``; :func:`_consensus_gradient`).
    aperture : {"beam", "processed"}
        Sweeps a scatterer's phase history is taken over: all sweeps whose beam holds it
        (default; estimates the phase wherever a scatterer is seen) or only the focuser's
        processed aperture.
    fallback : bool
        Return the uncorrected image (with a warning) when the correction raises the whole
        image's entropy (default True); False returns the corrected one (with a warning).
    max_elements : int
        Bound on sweeps x lines x line points held at once (16 bytes each; default 2^23): the
        faintest scatterers are dropped beyond it.
    """

    scatterers: int = 32
    dynamic_range_db: float = 30.0
    separation_cells: float = 0.5
    min_scr_db: float = 15.0
    clutter_cells: float = 8.0
    iterations: int = 10
    line_cells: float | None = None
    oversample: int = 2
    window_energy: float = 0.99
    min_window_cells: float = 4.0
    tolerance: float = 0.02
    min_coherence: float = 0.3
    aperture: str = "beam"
    max_elements: int = 1 << 23
    fallback: bool = True

    def __post_init__(self) -> None:
        checks = {"scatterers": self.scatterers >= 1,
                  "dynamic_range_db": self.dynamic_range_db > 0,
                  "separation_cells": self.separation_cells >= 0,
                  "min_scr_db": bool(np.isfinite(self.min_scr_db)),
                  "clutter_cells": self.clutter_cells >= 1,
                  "iterations": self.iterations >= 1,
                  "line_cells": self.line_cells is None or self.line_cells >= 2,
                  "oversample": self.oversample >= 1, "window_energy": 0 < self.window_energy < 1,
                  "min_window_cells": self.min_window_cells > 0,
                  "tolerance": self.tolerance >= 0,
                  "min_coherence": 0 <= self.min_coherence <= 1,
                  "aperture": self.aperture in ("beam", "processed"),
                  "max_elements": self.max_elements >= 1}
        for name, good in checks.items():
            if not good:
                raise ParameterError("autofocus 'pga'", name, _EXPECTED[name],
                                     getattr(self, name))


_EXPECTED = {"scatterers": "an integer >= 1", "dynamic_range_db": "a level > 0 dB",
             "separation_cells": "a number of cells >= 0",
             "min_scr_db": "a finite ratio in dB", "clutter_cells": "a number of cells >= 1",
             "iterations": "an integer >= 1",
             "line_cells": "None or a number of cells >= 2", "oversample": "an integer >= 1",
             "window_energy": "a fraction in (0, 1)", "min_window_cells": "a number of cells > 0",
             "tolerance": "a phase >= 0 rad",
             "min_coherence": "a coherence in [0, 1]", "aperture": "'beam' or 'processed'",
             "max_elements": "an integer >= 1"}


def _entropy(power: NDArray) -> float:
    """Entropy ``-sum p ln p`` of the normalised intensity of all line images [nats]."""
    share = power.ravel() / max(float(power.sum()), 1e-300)
    return float(-np.sum(share * np.log(share + 1e-300)))


def energy_window(centred: NDArray, fraction: float) -> int:
    """Half width [line points] holding ``fraction`` of the scatterers' energy above the
    clutter floor in centred line intensities.

    ``centred[p, q]`` is line p's intensity circularly shifted so that its brightest point sits
    at ``q_c = Q // 2``. Each line is normalised to unit energy (one vote a scatterer, so one
    bright line cannot set the width for all) and the lines are summed, ``S(q)``, as Wahl et
    al. (1994, §III) sum the centred range lines to measure the width. The clutter floor ``b``
    is the mean of S over the outer half of the period (``|q - q_c| > Q / 4``), and the
    scatterers' energy within ``+-w`` is ``H(w) = sum_(|q - q_c| <= w) (S(q) - b)``, signed, so
    that the clutter's fluctuations about its mean cancel instead of adding up (a line spans
    the whole alias-free extent, and its clutter can hold as much energy as the scatterer).
    The width is the smallest ``w`` with ``H(w) >= fraction * max H``. Clutter within 30 dB
    of the peak makes H wander by about the last percent of it, so near ``fraction`` = 0.99
    the width grows with such clutter (measured: 10.5 -> 21 cells at 25 dB; unchanged at 35
    dB); the window is then wider, never narrower, than the response.

    Closed forms (tests/test_pga_window.py): a point focused through a rectangular aperture,
    ``S ~ sinc^2``, holds ``F(w) = (2 / pi) [Si(2 pi w) - sin^2(pi w) / (pi w)]`` within
    +-w cells: 90.3 % within its first nulls, 95 % within +-2.07 cells and 99 % within
    +-10.3; a quadratic phase error ``q u^2`` over ``u in [-1, 1]`` spreads it
    uniformly over ``+-2 q / pi`` cells (stationary phase), so the half width is about
    ``fraction * 2 q / pi`` cells.
    """
    centred = np.asarray(centred, dtype=float)
    length = centred.shape[-1]
    energy = centred.sum(axis=-1, keepdims=True)
    shares = centred / np.where(energy > 0, energy, 1.0)
    summed = np.median(shares, axis=0) if len(shares) >= 3 else shares.mean(axis=0)
    middle, inner = length // 2, max(1, length // 4)
    distance = np.abs(np.arange(length) - middle)
    outer = distance > inner
    floor = float(summed[outer].mean()) if outer.any() else 0.0
    excess = summed - floor  # signed: the clutter's fluctuations about its mean cancel
    # energy within +-w of the centre, w = 0 .. inner
    held = np.cumsum(np.bincount(np.minimum(distance, inner + 1), weights=excess,
                                 minlength=inner + 2))[: inner + 1]
    total = float(held.max())
    if total <= 0:
        return 0
    return int(np.argmax(held >= fraction * total))


def _sharper(entropy: list[float]) -> bool:
    """Whether the last line-image entropy is lower than the one before by more than 1e-4
    (relative) [nats]."""
    return entropy[-1] < entropy[-2] - 1e-4 * abs(entropy[-2])


def _noise_floor(pairs: NDArray, coverage: NDArray) -> float:
    """Rms [rad] of the update that the lines' disagreement alone would give.

    Per sweep, the ML gradient ``arg sum_p pairs[k, p]`` of P lines whose phase differences
    scatter about it has variance ``~ 2 (1 - R_k) / P`` (small-angle circular variance of
    the pairs about their resultant, ``R_k = |sum_p pairs| / sum_p |pairs|``, over P lines;
    Mardia & Jupp, *Directional Statistics*, 2000, §2.3.4), with ``R_k^2`` freed of its
    finite-sample bias, ``(P R^2 - 1) / (P - 1)``, and P the effective number of lines
    ``(sum |pairs|)^2 / sum |pairs|^2``. Integrated over the S covered
    sweeps and stripped of its linear phase as :func:`.phase.remove_linear_phase` does (the
    slope is the mean sweep-to-sweep difference, which ties the two ends: a Brownian bridge;
    then its mean), white gradient noise of variance v leaves a residual of rms
    ``sqrt(v S / 12)`` (a bridge's variance ``t (1 - t)`` averages 1/6 over the aperture,
    its mean's variance is 1/12).
    """
    magnitude = np.abs(pairs)
    size = magnitude.sum(axis=1)
    resultant = np.abs(pairs.sum(axis=1)) / np.maximum(size, 1e-300)
    lines = size**2 / np.maximum((magnitude**2).sum(axis=1), 1e-300)  # effective P
    # |mean| of P phasors is biased up by (1 - R^2) / P in its square: unbiased R^2
    squared = np.clip((lines * resultant**2 - 1) / np.maximum(lines - 1, 1e-12), 0.0, 1.0)
    variance = 2 * (1 - np.sqrt(squared)) / np.maximum(lines, 1.0)
    both = coverage[1:] * coverage[:-1]
    if both.sum() <= 0:
        return 0.0
    return float(np.sqrt(np.average(variance, weights=both) * coverage.sum() / 12))


def _consensus_gradient(pairs: NDArray, min_coherence: float) -> tuple[NDArray, NDArray]:
    """Phase gradient from the lines that agree with the others, and which lines those are.

    ``pairs[k, p] = g_(k+1)(p) conj(g_k(p))``. The maximum-likelihood gradient is
    ``arg sum_p pairs[k, p]`` (Jakowatz & Wahl 1993). A line's coherence is taken against the
    other lines, each with one vote (unit phasors ``u = pairs / |pairs|``, so a bright clutter
    line cannot carry the consensus, nor vote for itself):
    ``|sum_k pairs[k, p] conj(c_kp) / |c_kp|| / sum_k |pairs[k, p]|``, ``c_kp = sum_(p' != p)
    u[k, p']``. It is near 1 for a point scatterer that dominates its window and about
    ``1/sqrt(S)`` for clutter, whose sweep-to-sweep phase differences are random; lines below
    ``min_coherence`` are dropped and the ML gradient taken from the others (from all lines
    when none, or only one, would remain).
    """
    size = np.abs(pairs)
    unit = np.where(size > 0, pairs / np.where(size > 0, size, 1.0), 0.0)
    others = unit.sum(axis=1, keepdims=True) - unit
    others = np.where(np.abs(others) > 0, others / np.maximum(np.abs(others), 1e-300), 0.0)
    agreement = np.abs((pairs * others.conj()).sum(axis=0))
    magnitude = size.sum(axis=0)
    coherence = agreement / np.where(magnitude > 0, magnitude, 1.0)
    kept = coherence >= min_coherence
    if kept.sum() < 2:
        kept = np.ones(pairs.shape[1], dtype=bool)
    total = pairs[:, kept].sum(axis=1)
    return np.where(np.abs(total) > 0, np.angle(total), 0.0), kept


def estimate_pga(data: PulseData, points: NDArray, options: PGAOptions
                 ) -> tuple[NDArray, dict]:
    """Estimate the phase error per sweep from scatterers at ``points`` (module docstring).

    Parameters
    ----------
    data : PulseData
        Range profiles and geometry of the (uncorrected) raw product.
    points : ndarray, shape (P, 3)
        World positions of the selected scatterers [m].
    options : PGAOptions

    Returns
    -------
    phase : ndarray, shape (S,)
        Estimated phase error per sweep [rad], constant and linear trend removed; the raw
        sweeps are corrected by ``exp(-j phase)``.
    info : dict
        ``iterations`` (run), ``converged`` (bool), ``last_update_rms`` [rad, of the wrapped
        update], ``window_cells`` (half width of the last window) and ``windows_cells`` (of
        every iteration's, :func:`energy_window`), ``update_rms`` and ``noise_rms`` (per
        iteration: the update and the clutter's floor, :func:`_noise_floor`, rad),
        ``kept_iteration`` (the
        iterate returned: the one of sharpest line images, 0 = no correction),
        ``line_entropy_initial`` / ``line_entropy_final`` (of the line images before and with
        the returned estimate, nats), ``covered_sweeps``, ``scatterers`` (lines used),
        ``lines_kept`` (per iteration, the lines coherent with the gradient).
    """
    lines = azimuth_lines(data, points, aperture=options.aperture,
                          oversample=options.oversample, line_cells=options.line_cells,
                          max_elements=options.max_elements)
    history, shift, covered = lines.history, lines.kernel, lines.covered
    count, length = lines.offsets.shape
    coverage = lines.coverage
    total = np.zeros(len(history))
    minimum = options.min_window_cells * options.oversample
    voters = np.ones(count, dtype=bool)  # lines whose spread sets the window
    info = {"iterations": 0, "converged": False, "last_update_rms": float("nan")}
    rows = np.arange(count)
    # The estimate kept is the iterate whose line images are sharpest (lowest entropy, the
    # model image of the entropy method), the uncorrected one included: on clutter the
    # windowed projection is not exact (the lines are not unitary on a curved or jittered
    # track) and later iterations can undo a good first one.
    best = (np.inf, total.copy(), 0)
    line_entropy: list[float] = []
    pending = False
    for iteration in range(options.iterations):
        corrected = history * np.exp(-1j * total)[:, None]
        image = np.einsum("kpq,kp->pq", shift, corrected)  # line images I_p(q)
        power = np.abs(image) ** 2
        line_entropy.append(_entropy(power))
        if line_entropy[-1] < best[0]:
            best = (line_entropy[-1], total.copy(), iteration)
        if pending and not _sharper(line_entropy):
            info["converged"] = True  # an update within the noise that sharpened nothing
            break
        centre = np.argmax(power, axis=1)
        index = np.arange(length)[None, :]
        # the window from the energy spread of the centred lines (those coherent last time)
        rolled = power[rows[:, None], (index + centre[:, None] - length // 2) % length]
        half_window = float(length // 2) if iteration == 0 else max(
            minimum, float(energy_window(rolled[voters], options.window_energy)))
        info.setdefault("windows_cells", []).append(round(half_window / options.oversample, 2))
        distance = (index - centre[:, None]) % length  # circular: the line is one period
        distance = np.minimum(distance, length - distance)
        outside = np.where(distance <= half_window, 0.0, image)
        projected = corrected - np.einsum("kpq,pq->kp", shift.conj(), outside) / length
        projected *= shift[:, rows, centre] * covered  # phase about the centre (the shift)
        pairs = projected[1:] * projected[:-1].conj()  # (S - 1, P)
        gradient, kept = _consensus_gradient(pairs, options.min_coherence)
        voters = kept
        info.setdefault("lines_kept", []).append(int(kept.sum()))
        update = remove_linear_phase(integrate_gradient(gradient), coverage)
        total = remove_linear_phase(total + update, coverage)
        rms = float(np.sqrt(np.average(wrap(update) ** 2, weights=coverage)))
        floor = _noise_floor(pairs[:, kept], coverage)
        info.setdefault("noise_rms", []).append(round(floor, 4))
        info.setdefault("update_rms", []).append(round(rms, 4))
        info.update(iterations=iteration + 1, last_update_rms=rms,
                    window_cells=half_window / options.oversample)
        if rms < options.tolerance:
            info["converged"] = True
            break
        pending = rms < 2 * floor
    else:
        line_entropy.append(_entropy(np.abs(lines.images(total)) ** 2))
        info["converged"] = pending and not _sharper(line_entropy)
        line_entropy.pop()
    final = _entropy(np.abs(lines.images(total)) ** 2)
    line_entropy.append(final)
    if final < best[0]:
        best = (final, total, info["iterations"])
    total = best[1]
    info.update(kept_iteration=int(best[2]), line_entropy_initial=float(line_entropy[0]),
                line_entropy_final=float(best[0]))
    info.update(covered_sweeps=int(coverage.sum()), scatterers=int(count))
    return total, info
