"""Autofocus of back-projection images: phase gradient (PGA) and minimum entropy.

The error model is an unknown phase ``phi_k`` per sweep, the same for every pixel of a small
scene: what a line-of-sight navigation error ``d_k`` does, ``phi_k = 4 pi d_k / lambda``. Both
methods estimate it in the pulse domain with the back-projection geometry, on any track, and the
raw sweeps are corrected by ``exp(-j phi_k)`` and refocused by the caller's focuser
(:func:`run_autofocus`; ``mitsar.focus(..., autofocus="pga" | "entropy")``). Details, defaults
and measured numbers: ``docs/autofocus.md``.

Modules: :mod:`~mitsar.focus.autofocus.contributions` (the per-sweep BP terms ``c_k(x)``),
:mod:`~mitsar.focus.autofocus.selection` (scatterers that stand out of their clutter),
:mod:`~mitsar.focus.autofocus.lines` (azimuth lines through scatterers),
:mod:`~mitsar.focus.autofocus.phase` (gradient integration, trend removal),
:mod:`~mitsar.focus.autofocus.pga`, :mod:`~mitsar.focus.autofocus.entropy`,
:mod:`~mitsar.focus.autofocus.apply` (correct the raw, record the phase),
:mod:`~mitsar.focus.autofocus.driver` (the whole loop).
"""

from __future__ import annotations

from mitsar.focus.autofocus.apply import attach_phase, correct_raw
from mitsar.focus.autofocus.contributions import PulseSettings
from mitsar.focus.autofocus.driver import METHODS, make_options, run_autofocus
from mitsar.focus.autofocus.entropy import EntropyOptions, image_entropy
from mitsar.focus.autofocus.pga import PGAOptions

__all__ = ["METHODS", "EntropyOptions", "PGAOptions", "PulseSettings", "attach_phase",
           "correct_raw", "image_entropy", "make_options", "run_autofocus"]
