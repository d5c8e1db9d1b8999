"""Autofocus that says when it fails (issue 24 item 4): the warning's content and the fallback.

The scene case (a traced room with a reflector, a curved track and navigation errors) is
measured in docs/autofocus.md, "Trust"; these tests check the decision and the text that
``run_autofocus`` raises as a ``MitsarWarning``.
"""

from __future__ import annotations

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
