"""Argument checks shared by every mitsar module: vectors, finite and positive numbers, integers.

Each check returns the value converted (a float, an int, a float array) or raises
:class:`~mitsar.errors.ParameterError` naming the object (``where``), the parameter (``name``),
what was expected and what was found. ``expected`` can be given to word the expectation for the
quantity at hand (e.g. ``"a finite speed > 0 m/s"``); the defaults are the generic wording.
"""

from __future__ import annotations

import math
import numbers
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError

__all__ = ["KnownFields", "boolean", "finite", "integer", "is_real", "positive", "vector"]


def is_real(value: object) -> bool:
    """A real number (Python or NumPy scalar, or a 0-d real array), not a bool."""
    if isinstance(value, np.ndarray) and value.ndim == 0:
        value = value[()]
    return isinstance(value, numbers.Real) and not isinstance(value, bool | np.bool_)


def finite(where: str, name: str, value: Any, expected: str = "a finite number") -> float:
    """``value`` as a float if it is a finite real number.

    Parameters
    ----------
    where, name : str
        Object (or file) and parameter named in the error.
    value : object
        The value to check.
    expected : str
        Wording of the expectation in the error.

    Raises
    ------
    ParameterError
        If ``value`` is not a real number (bools refused) or is NaN or infinite.
    """
    if not is_real(value) or not math.isfinite(float(value)):
        raise ParameterError(where, name, expected, value)
    return float(value)


def positive(where: str, name: str, value: Any, expected: str = "a finite number > 0") -> float:
    """``value`` as a float if it is a finite real number > 0 (see :func:`finite`)."""
    if not is_real(value) or not math.isfinite(float(value)) or not float(value) > 0:
        raise ParameterError(where, name, expected, value)
    return float(value)


def integer(where: str, name: str, value: Any, minimum: int | None = None,
            expected: str | None = None) -> int:
    """``value`` as an int if it is an integer (Python or NumPy, not a bool) >= ``minimum``.

    The default wording is ``"an integer"``, with ``" >= minimum"`` when a minimum is given.
    """
    if expected is None:
        expected = "an integer" + (f" >= {minimum}" if minimum is not None else "")
    if (not isinstance(value, numbers.Integral) or isinstance(value, bool | np.bool_)
            or (minimum is not None and value < minimum)):
        raise ParameterError(where, name, expected, value)
    return int(value)


def boolean(where: str, name: str, value: Any, expected: str = "true or false") -> bool:
    """``value`` if it is a bool (Python or NumPy)."""
    if not isinstance(value, bool | np.bool_):
        raise ParameterError(where, name, expected, value)
    return bool(value)


def vector(where: str, name: str, value: Any, length: int = 3,
           expected: str | None = None) -> NDArray[np.float64]:
    """``value`` as a float array of shape ``(length,)`` if all its entries are finite.

    The default wording is ``"<length> finite numbers"`` (e.g. ``"3 finite numbers"``).
    """
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = np.full(0, np.nan)
    if array.shape != (length,) or not np.all(np.isfinite(array)):
        raise ParameterError(where, name, expected or f"{length} finite numbers", value)
    return array


class KnownFields(type):
    """Metaclass of mitsar's parameter records (dataclasses): a keyword that is not a field is
    refused with a :class:`ParameterError` naming it and the fields there are, instead of
    Python's bare ``TypeError``."""

    def __call__(cls, *args: Any, **kwargs: Any) -> Any:
        fields = getattr(cls, "__dataclass_fields__", {})
        known = [name for name in fields if not name.startswith("_")]
        unknown = sorted(set(kwargs) - set(fields))
        if unknown:
            raise ParameterError(cls.__name__, unknown[0], f"one of {known}", kwargs[unknown[0]])
        return super().__call__(*args, **kwargs)
