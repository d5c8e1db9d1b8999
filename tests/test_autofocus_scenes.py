"""Autofocus that says when it fails (issue 24 item 4): the warning's content and the fallback.

The scene case (a traced room with a reflector, a curved track and navigation errors) is
measured in docs/autofocus.md, "Trust"; these tests check the decision and the text that
``run_autofocus`` raises as a ``MitsarWarning``.
"""

from __future__ import annotations

import numpy as np

from mitsar.focus.autofocus.driver import assess, warning_text
from mitsar.focus.autofocus.entropy import EntropyOptions
from mitsar.focus.autofocus.pga import PGAOptions

PGA_INFO = {"converged": False, "last_update_rms": 1.3, "iterations": 10, "kept_iteration": 4,
            "line_entropy_initial": 7.76, "line_entropy_final": 6.03}


def test_a_converged_sharper_image_gives_no_warning():
    problems = assess("pga", PGAOptions(), {**PGA_INFO, "converged": True}, 8.9, 7.6)
    assert problems == {"not_converged": False, "degraded": False}
    assert warning_text("pga", PGAOptions(), PGA_INFO, 8.9, 7.6, problems, True) is None


def test_pga_non_convergence_names_the_update_the_iterate_kept_and_what_to_try():
    problems = assess("pga", PGAOptions(), PGA_INFO, 8.9, 7.6)
    text = warning_text("pga", PGAOptions(), PGA_INFO, 8.9, 7.6, problems, True)
    assert problems["not_converged"] and not problems["degraded"]
    for part in ("did not converge", "1.3 rad", "iteration 4", "corrected image is returned",
                 "autofocus='entropy'"):
        assert part in text, part


def test_a_degrading_correction_is_refused_and_said():
    info = {"converged": True, "iterations": 120, "stages": [2, 4], "entropy_initial": 7.0,
            "entropy_final": 6.0}
    problems = assess("entropy", EntropyOptions(), info, 7.60, 7.70)
    assert problems["degraded"]
    text = warning_text("entropy", EntropyOptions(), info, 7.60, 7.70, problems, False)
    for part in ("made the image worse", "7.600 -> 7.700", "uncorrected image is returned",
                 "autofocus_applied = 0", "autofocus='pga'"):
        assert part in text, part


def test_speckle_alone_offers_no_scatterer_and_a_point_over_it_is_found():
    """Fully developed speckle (exponential intensity, median ln 2 <t>): a pixel exceeds its
    median by 15 dB with probability exp(-31.6 ln 2) = 3e-10, so none of 65536 passes; a
    point set 25 dB over the median is found first, its ratio read back within 1 dB (the
    median of the 17 x 17-cell box is estimated from ~290 speckle pixels: ~0.3 dB rms)."""
    from mitsar.focus.autofocus.selection import select_scatterers

    rng = np.random.default_rng(24)
    power = rng.exponential(1.0, (256, 256))
    found, _ = select_scatterers(np.sqrt(power), 8, 30.0, 0.5, min_scr_db=15.0)
    assert len(found) == 0
    power[100, 140] = 10 ** 2.5 * np.log(2)  # 25 dB over the median ln 2
    found, scr = select_scatterers(np.sqrt(power), 8, 30.0, 0.5, min_scr_db=15.0)
    assert found[0] == np.ravel_multi_index((100, 140), power.shape)
    assert abs(scr[0] - 25.0) < 1.0


def test_lines_that_disagree_with_the_gradient_are_left_out():
    """Three lines share a phase gradient; two more are clutter (random phase each sweep,
    coherence ~ 1/sqrt(S) = 0.07 for S = 200): the clutter lines are dropped and the gradient
    is the shared one to float precision."""
    from mitsar.focus.autofocus.pga import _consensus_gradient

    rng = np.random.default_rng(7)
    sweeps = 200
    truth = np.cumsum(rng.normal(0, 0.5, sweeps))
    point = np.exp(1j * truth)[:, None] * np.array([1.0, 0.8, 0.6])
    clutter = 2.0 * np.exp(2j * np.pi * rng.random((sweeps, 2)))  # brighter than the points
    history = np.concatenate([point, clutter], axis=1)
    pairs = history[1:] * history[:-1].conj()
    gradient, kept = _consensus_gradient(pairs, 0.3)
    assert kept.tolist() == [True, True, True, False, False]
    assert np.allclose(gradient, np.angle(np.exp(1j * np.diff(truth))), atol=1e-12)


def test_entropy_non_convergence_names_the_bound_or_the_position():
    """A kept stage stopped by its iteration bound, or kept over a finest stage that puts the
    scatterers elsewhere: the warning says which, with the numbers."""
    base = {"converged": False, "iterations": 90, "stages": [2, 8, 32, 128, 300],
            "entropy_initial": 6.18, "entropy_final": 3.23, "kept_stage": 5}
    options = EntropyOptions(iterations=20)
    bound = {**base, "kept_stage_settled": False, "position_settled": True}
    problems = assess("entropy", options, bound, 7.3, 5.7)
    text = warning_text("entropy", options, bound, 7.3, 5.7, problems, True)
    for part in ("did not converge", "stage 5 (kept) stopped at its bound of 20 iterations",
                 "phase step below 0.02 rad", "corrected image is returned"):
        assert part in text, part
    moved = {**base, "kept_stage": 4, "kept_stage_settled": True, "position_settled": False,
             "position_shift_cells": -0.74}
    text = warning_text("entropy", options, moved, 7.3, 5.7, problems, True)
    assert "0.74 resolution cells apart" in text and "stage 4" in text
