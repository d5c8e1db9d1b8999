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

__all__ = ["MAGNITUDE_BOUNDS", "MAX_ANGLE_DEG", "MAX_DB", "MAX_DURATION", "MAX_FREQUENCY",
           "MAX_LENGTH", "MAX_LEVEL_DB", "MAX_RCS", "MAX_SEED", "MAX_SPEED", "KnownFields",
           "check_units",
           "bounded", "boolean", "finite", "integer", "is_real", "level_db", "positive", "rcs",
           "seed", "vector"]

MAX_LEVEL_DB = 100.0
"""Highest RCS or sigma0 level accepted [dB re 1 m² or m²/m²]: 1e10 m², far above any indoor
target; 10^(level/10) overflows a float near 3080 dB (docs/reliability.md §1)."""


MAX_LENGTH = 1.0e4
"""Largest length or coordinate accepted in an experiment or a trace request [m]: 10 km, far
beyond any indoor scene, flight or the receiver's ``max_range`` (tens of metres), and far below
where squares of positions overflow (1e300 m passed unchecked: docs/reliability.md §1)."""


MAX_SPEED = 1.0e3
"""Largest platform or target speed accepted [m/s]: 1 km/s, far beyond any drone or walker
(metres per second) and still far below where squares of velocities overflow; velocities of
1e300 m/s passed ``Trajectory`` unchecked (issue 27, docs/reliability.md §1)."""

MAX_DURATION = 1.0e6
"""Longest time accepted [s] (a flight, a hover, a navigation log's span): about 11.6 days,
far beyond any indoor flight (minutes); durations of 1e300 s passed unchecked (issue 27)."""

MAX_ANGLE_DEG = 1.0e6
"""Largest angle or angular rate accepted [deg, deg/s]: an unwrapped heading of 2,777 turns;
beyond it sin and cos of a float lose every digit (issue 27)."""

MAX_DB = 1.0e3
"""Largest magnitude of a dB quantity in an experiment file: 10^(±100), beyond any gain, loss
or level (and below the ~3080 dB where 10^(L/10) overflows a float)."""

MAX_FREQUENCY = 1.0e13
"""Largest frequency accepted in an experiment file [Hz]: 10 THz, the radar's carrier bound
(``mitsar.model.radar``)."""

MAGNITUDE_BOUNDS: dict[str, float] = {
    "m": MAX_LENGTH, "m, body frame": MAX_LENGTH, "m/sqrt(s)": MAX_LENGTH,
    "direction": MAX_LENGTH, "m/s": MAX_SPEED, "m/s^2": 1.0e4, "s": MAX_DURATION,
    "deg": MAX_ANGLE_DEG, "deg/s": MAX_ANGLE_DEG, "deg/sqrt(s)": MAX_ANGLE_DEG,
    "rad": math.radians(MAX_ANGLE_DEG), "dB": MAX_DB, "Hz": MAX_FREQUENCY,
    "1/m^2": 1.0e8, "beamwidths": 100.0,
}
"""Largest magnitude of a value by its unit (experiment files, ``Table``; docs/reliability.md
§1): an acceleration of 1e4 m/s² is 1000 g; a scatterer density of 1e8 per m² puts ~1000
scatterers in a wavelength square at 94 GHz; a ray fan of 100 beamwidths covers any beam.
Values beyond mean a typing error, not an experiment, and overflow later computations."""


def bounded(where: str, name: str, values: Any, unit: str, expected: str) -> None:
    """Refuse finite ``values`` (a number or an array) whose magnitude exceeds the bound of
    ``unit`` in :data:`MAGNITUDE_BOUNDS` (units without a bound pass)."""
    bound = MAGNITUDE_BOUNDS.get(unit)
    array = np.abs(np.asarray(values, dtype=float))
    if bound is not None and array.size and not np.all(array <= bound):
        shown = values.tolist() if isinstance(values, np.ndarray) else values
        shown_unit = "" if unit == "direction" else " " + unit.split(",")[0]
        raise ParameterError(where, name, f"{expected}, within ±{bound:g}{shown_unit} (indoor "
                             "scenes and drone flights)", shown)


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


def level_db(where: str, name: str, value: Any, allow_minus_inf: bool = False,
             maximum: float = MAX_LEVEL_DB) -> float:
    """``value`` as a float if it is a level in dB below ``maximum`` (and finite, or ``-inf``
    when ``allow_minus_inf``: nothing at all); refuses levels whose power 10^(level/10)
    overflows or means nothing physical."""
    floor = "finite or -inf" if allow_minus_inf else "finite"
    expected = f"a level in dB <= {maximum:g} ({floor})"
    if not is_real(value):
        raise ParameterError(where, name, expected, value)
    level = float(value)
    if math.isnan(level) or level > maximum or (level == -math.inf and not allow_minus_inf):
        raise ParameterError(where, name, expected, value)
    return level


MAX_RCS = 10.0 ** (MAX_LEVEL_DB / 10.0)
"""Largest radar cross section accepted [m²] (:data:`MAX_LEVEL_DB`)."""


def rcs(where: str, name: str, value: Any) -> float:
    """``value`` as a float if it is a radar cross section in (0, :data:`MAX_RCS`] m²."""
    expected = f"a radar cross section > 0 and <= {MAX_RCS:.0e} m² (finite)"
    if not is_real(value) or not 0.0 < float(value) <= MAX_RCS:
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


MAX_SEED = 2**63 - 1
"""Largest seed: products record it as a signed 64-bit integer."""


def seed(where: str, name: str, value: Any) -> int:
    """``value`` as an int if it is an integer seed in [0, :data:`MAX_SEED`] (not a bool)."""
    if (not isinstance(value, numbers.Integral) or isinstance(value, bool | np.bool_)
            or not 0 <= value <= MAX_SEED):
        raise ParameterError(where, name, f"an integer seed in [0, {MAX_SEED}] (recorded as "
                             "64 bits)", value)
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



def check_units(where: str, record: Any, units: dict[str, str], prefix: str = "") -> None:
    """Refuse the finite fields of a parameter record (a dataclass) beyond the bound of their
    unit (:data:`MAGNITUDE_BOUNDS`), as the experiment files refuse them at load: the Python
    API as strict as the files (issue 27). Fields that are None, or not finite (whose meaning
    the class's own checks decide, e.g. ``-inf`` dB: nothing), pass.

    Parameters
    ----------
    where : str
        The class named in the error.
    record : object
        The record, its fields already converted by the class's own checks.
    units : dict
        Field name -> unit (a key of :data:`MAGNITUDE_BOUNDS`).
    prefix : str
        Prefix of the parameter's name in the error (``"vibration."``).
    """
    for name, unit in units.items():
        value = getattr(record, name)
        if value is None:
            continue
        array = np.asarray(value, dtype=float)
        finite_values = (array[np.isfinite(array)] if array.ndim
                         else float(array) if np.isfinite(array) else [])
        bounded(where, prefix + name, finite_values, unit,
                f"{'a value' if array.ndim == 0 else f'{array.size} values'} [{unit}]")
