"""Dr.Jit's side of the ``ops`` namespace (:mod:`mitsar.model.ops`) for the active variant.

Imported by the plugins only, after a Mitsuba variant is set (:func:`mitsar.scene.ensure_variant`).
"""

from __future__ import annotations

from typing import Any

import drjit as dr
import mitsuba as mi

from mitsar.model.ops import ArrayOps

__all__ = ["DRJIT_OPS"]


def _gather(table: Any, index: Any) -> Any:
    """``table[index]`` for a float index array of integral values."""
    return dr.gather(mi.Float, table, mi.UInt32(index))


def _sinc(x: Any) -> Any:
    """``sin(pi x) / (pi x)``; 1 where ``|pi x| < 1e-4`` (error below 2e-9 there)."""
    px = dr.pi * x
    return dr.select(dr.abs(px) < 1e-4, 1.0, dr.sin(px) / px)


DRJIT_OPS = ArrayOps(sqrt=dr.sqrt, maximum=dr.maximum, minimum=dr.minimum, arccos=dr.acos,
                     floor=dr.floor, where=dr.select, gather=_gather, sinc=_sinc)
"""Array operations for Dr.Jit arrays of the active Mitsuba variant."""
