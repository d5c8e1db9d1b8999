"""Dr.Jit's side of the ``ops`` namespace against NumPy (float64 references)."""

import numpy as np
import pytest

from mitsar.plugins.variant import register_plugins

mi = pytest.importorskip("mitsuba")


def test_sincos_turns_matches_float64_to_float32_rounding():
    """sin/cos of 2πx by quarter-turn reduction and two short polynomials: within 1.5e-7 of
    float64 over ±300 turns (the block kernel's phases reach a few tens of turns), every
    quadrant and its boundaries included; the float32 rounding of x itself is the input."""
    register_plugins()
    from mitsar.plugins.ops import sincos_turns

    x = np.concatenate([np.linspace(-300.0, 300.0, 1_200_001),
                        np.arange(-16, 17) / 8.0,  # quarter and eighth turns
                        np.random.default_rng(3).uniform(-40.0, 40.0, 200_000)]
                       ).astype(np.float32)
    sin, cos = sincos_turns(mi.Float(x))
    angle = 2.0 * np.pi * x.astype(np.float64)
    assert np.abs(np.asarray(sin) - np.sin(angle)).max() < 1.5e-7
    assert np.abs(np.asarray(cos) - np.cos(angle)).max() < 1.5e-7
