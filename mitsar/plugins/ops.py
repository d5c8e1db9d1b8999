"""Dr.Jit's side of the ``ops`` namespace (:mod:`mitsar.model.ops`) for the active variant.

Imported by the plugins only, after a Mitsuba variant is set
(:func:`mitsar.plugins.variant.ensure_variant`).
"""

from __future__ import annotations

from typing import Any

import drjit as dr
import mitsuba as mi

from mitsar.model.ops import ArrayOps

__all__ = ["DRJIT_OPS", "sincos_turns"]


def _gather(table: Any, index: Any) -> Any:
    """``table[index]`` for a float index array of integral values."""
    return dr.gather(mi.Float, table, mi.UInt32(index))


def _sinc(x: Any) -> Any:
    """``sin(pi x) / (pi x)``; 1 where ``|pi x| < 1e-4`` (error below 2e-9 there)."""
    px = dr.pi * x
    return dr.select(dr.abs(px) < 1e-4, 1.0, dr.sin(px) / px)


_SIN = (1.0, -0.16666637361049652, 0.008331583812832832, -0.00019462037016637623)
_COS = (1.0, -0.5, 0.04166661575436592, -0.0013886617962270975, 2.4379858587053604e-05)
"""Odd (sin) and even (cos) polynomials in ``theta`` on [-pi/4, pi/4]: least-squares fits at
4001 Chebyshev points, rounded to float32; largest error 1e-7 (tests/test_ops.py)."""


def sincos_turns(turns: Any) -> tuple[Any, Any]:
    """``sin(2 pi x)`` and ``cos(2 pi x)`` of a Float32 phase ``x`` in turns (cycles).

    The quarter turn ``q = round(4x)`` is taken out exactly and the rest ``r = x - q/4`` (|r| <=
    1/8) goes through two short polynomials (:data:`_SIN`, :data:`_COS`); the quarter turn
    swaps and negates them (``sin(θ + qπ/2)``). About half the instructions of ``dr.sincos``
    on an argument in radians, which needs a three-part Cody-Waite reduction for any range;
    error ~1e-7 plus the float32 rounding of ``x`` itself (``|x|`` up to a few hundred turns).
    """
    quarter = dr.round(4.0 * turns)
    theta = (2.0 * dr.pi) * dr.fma(quarter, -0.25, turns)
    t2 = theta * theta
    sin = theta * dr.fma(t2, dr.fma(t2, dr.fma(t2, _SIN[3], _SIN[2]), _SIN[1]), _SIN[0])
    cos = dr.fma(t2, dr.fma(t2, dr.fma(t2, dr.fma(t2, _COS[4], _COS[3]), _COS[2]), _COS[1]),
                 _COS[0])
    q = mi.Int32(quarter)
    odd = (q & 1) != 0
    sin, cos = dr.select(odd, cos, sin), dr.select(odd, sin, cos)
    return dr.select((q & 2) != 0, -sin, sin), dr.select(((q + 1) & 2) != 0, -cos, cos)


DRJIT_OPS = ArrayOps(sqrt=dr.sqrt, maximum=dr.maximum, minimum=dr.minimum, arccos=dr.acos,
                     floor=dr.floor, where=dr.select, gather=_gather, sinc=_sinc)
"""Array operations for Dr.Jit arrays of the active Mitsuba variant."""
