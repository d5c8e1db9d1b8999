"""The array namespace that lets one formula run on NumPy and on Dr.Jit (the ``ops`` pattern).

Physics in :mod:`mitsar.model` is written once, as small pure functions that take an ``ops``
argument for the few operations whose names differ between the array libraries (``np.sinc`` and
a Dr.Jit sinc, ``np.where`` and ``dr.select``, ...). :data:`NUMPY_OPS` fills the namespace with
NumPy and is the default of every such function, so tests call them with NumPy inputs;
``mitsar.plugins.ops.DRJIT_OPS`` fills it with Dr.Jit for the kernels of the Mitsuba plugins
(``docs/design.md`` §3). Arithmetic operators, ``abs`` and comparisons are shared by both array
types and are used directly.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any, NamedTuple

import numpy as np

__all__ = ["ArrayOps", "NUMPY_OPS"]


class ArrayOps(NamedTuple):
    """The array operations the generic formulas need, one field per operation."""

    sqrt: Callable[[Any], Any]
    maximum: Callable[[Any, Any], Any]
    minimum: Callable[[Any, Any], Any]
    arccos: Callable[[Any], Any]
    floor: Callable[[Any], Any]
    where: Callable[[Any, Any, Any], Any]
    gather: Callable[[Any, Any], Any]
    """``gather(table, index)``: ``table[index]`` for a float array of integral values."""
    sinc: Callable[[Any], Any]
    """Normalised ``sinc(x) = sin(pi x) / (pi x)``, 1 at 0."""


def _numpy_gather(table: np.ndarray, index: np.ndarray) -> np.ndarray:
    return np.asarray(table)[np.asarray(index).astype(np.intp)]


NUMPY_OPS = ArrayOps(sqrt=np.sqrt, maximum=np.maximum, minimum=np.minimum, arccos=np.arccos,
                     floor=np.floor, where=np.where, gather=_numpy_gather, sinc=np.sinc)
"""Array operations for NumPy inputs (the default ``ops`` of every generic formula)."""
