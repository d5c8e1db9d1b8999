"""The strict TOML table reader behind experiment files.

A :class:`Table` wraps one TOML table, reads typed keys from it (numbers with bounds, integers,
booleans, strings from a set of choices, vectors, file paths, sub-tables), records the effective
values (defaults filled in) and refuses unknown keys. Every error is a
:class:`~mitsar.errors.ParameterError` naming the file, the key path (e.g. ``radar.prf`` or
``targets[1].position``), what was expected and what was found.
"""

from __future__ import annotations

import difflib
import math
from collections.abc import Iterator
from contextlib import contextmanager
from pathlib import Path
from typing import Any

from mitsar.checks import bounded
from mitsar.errors import ParameterError

__all__ = ["MISSING", "Table", "prefixed"]

MISSING = object()
"""Default meaning "required key": reading an absent key raises."""


def _describe(value: Any) -> Any:
    """A short description of a found value for error messages."""
    if isinstance(value, dict):
        return f"a table with keys {sorted(value)}"
    return value


def _type_name(value: Any) -> str:
    return {bool: "boolean", int: "integer", float: "number", str: "string", list: "array",
            dict: "table"}.get(type(value), type(value).__name__)


class Table:
    """A TOML table being validated; records the keys read and the effective values.

    Parameters
    ----------
    data : mapping
        The table's content.
    path : str
        Its key path (``"radar"``, ``"targets[0]"``, ``""`` for the top level).
    where : str
        The file name (or ``"experiment"``) used in error messages.
    base : Path
        Folder against which relative file paths are resolved.
    """

    def __init__(self, data: Any, path: str, where: str, base: Path) -> None:
        if not isinstance(data, dict):
            raise ParameterError(where, path, "a table", _describe(data))
        self.data = data
        self.path = path
        self.where = where
        self.base = base
        self.seen: set[str] = set()
        self.out: dict[str, Any] = {}

    # helpers
    def key(self, name: str) -> str:
        """Full key path of ``name``."""
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, expected: str, found: Any) -> ParameterError:
        """A ParameterError for key ``name`` of this table."""
        return ParameterError(self.where, self.key(name), expected, _describe(found))

    def has(self, name: str) -> bool:
        """True if the key is present."""
        return name in self.data

    def _absent(self, name: str, default: Any, expected: str) -> bool:
        """Mark ``name`` as read; True if it is absent (and optional, else raise)."""
        self.seen.add(name)
        if name in self.data:
            return False
        if default is MISSING:
            raise self.error(name, f"{expected} (required key)", "nothing")
        if default is not None:
            self.out[name] = list(default) if isinstance(default, tuple) else default
        return True

    # scalar readers
    def number(self, name: str, default: Any = MISSING, unit: str = "",
               gt: float | None = None, ge: float | None = None, lt: float | None = None,
               le: float | None = None) -> float | None:
        """A finite number (TOML integer or float), with optional bounds."""
        expected = _number_expectation(unit, gt, ge, lt, le)
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(name, expected, f"{value!r} ({_type_name(value)})")
        value = float(value)
        if not math.isfinite(value) or not _in_bounds(value, gt, ge, lt, le):
            raise self.error(name, expected, value)
        self._check_length(name, expected, (value,), unit)
        self.out[name] = value
        return value

    def _check_length(self, name: str, expected: str, values: Any, unit: str) -> None:
        """Refuse a value beyond the bound of its unit (:data:`mitsar.checks.MAGNITUDE_BOUNDS`:
        lengths and positions 10 km, speeds 1 km/s, times 1e6 s, dB 1000, ...)."""
        try:
            bounded(self.where, self.key(name), list(values), unit, expected)
        except ParameterError as error:
            raise self.error(name, error.expected, list(values) if len(values) > 1
                             else values[0]) from None

    def integer(self, name: str, default: Any = MISSING, ge: int | None = None) -> int | None:
        """An integer, with an optional lower bound."""
        expected = "an integer" + (f" >= {ge}" if ge is not None else "")
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(name, expected, f"{value!r} ({_type_name(value)})")
        if ge is not None and value < ge:
            raise self.error(name, expected, value)
        self.out[name] = value
        return value

    def boolean(self, name: str, default: Any = MISSING) -> bool | None:
        """A TOML boolean (true/false)."""
        if self._absent(name, default, "true or false"):
            return default
        value = self.data[name]
        if not isinstance(value, bool):
            raise self.error(name, "true or false", f"{value!r} ({_type_name(value)})")
        self.out[name] = value
        return value

    def string(self, name: str, default: Any = MISSING,
               choices: tuple[str, ...] | None = None) -> str | None:
        """A string, optionally one of ``choices``."""
        expected = ("one of " + ", ".join(repr(c) for c in choices)) if choices else "a string"
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if not isinstance(value, str) or (choices and value not in choices):
            shown = value if isinstance(value, str) else f"{value!r} ({_type_name(value)})"
            raise self.error(name, expected, shown)
        self.out[name] = value
        return value

    # vectors
    def vector(self, name: str, length: int, default: Any = MISSING,
               unit: str = "") -> tuple[float, ...] | None:
        """A list of ``length`` finite numbers."""
        expected = f"an array of {length} numbers" + (f" [{unit}]" if unit else "")
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        vec = _as_vector(value, length)
        if vec is None:
            raise self.error(name, expected, _found_array(value))
        self._check_length(name, expected, vec, unit)
        self.out[name] = list(vec)
        return vec

    def vectors(self, name: str, length: int, min_count: int = 1, default: Any = MISSING,
                unit: str = "") -> list[tuple[float, ...]] | None:
        """A list of at least ``min_count`` vectors of ``length`` numbers."""
        expected = (f"an array of at least {min_count} arrays of {length} numbers"
                    + (f" [{unit}]" if unit else ""))
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if not isinstance(value, list) or len(value) < min_count:
            raise self.error(name, expected, _found_array(value))
        out = []
        for i, item in enumerate(value):
            vec = _as_vector(item, length)
            if vec is None:
                raise self.error(f"{name}[{i}]", f"an array of {length} numbers"
                                 + (f" [{unit}]" if unit else ""), _found_array(item))
            self._check_length(f"{name}[{i}]", expected, vec, unit)
            out.append(vec)
        self.out[name] = [list(v) for v in out]
        return out

    def numbers(self, name: str, min_count: int = 1, default: Any = MISSING,
                unit: str = "") -> list[float] | None:
        """A list of at least ``min_count`` finite numbers."""
        expected = f"an array of at least {min_count} numbers" + (f" [{unit}]" if unit else "")
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        vec = _as_vector(value, len(value)) if isinstance(value, list) else None
        if vec is None or len(vec) < min_count:
            raise self.error(name, expected, _found_array(value))
        self._check_length(name, expected, vec, unit)
        self.out[name] = list(vec)
        return list(vec)

    def path_value(self, name: str, default: Any = None) -> Path | None:
        """A file path, resolved against the experiment file's folder."""
        value = self.string(name, default)
        if value is None:
            return None
        path = Path(value).expanduser()
        if not path.is_absolute():
            path = (self.base / path).resolve()
        self.out[name] = str(path)
        return path

    # sub-tables
    def table(self, name: str, required: bool = False) -> Table | None:
        """A sub-table, or ``None`` when absent and not required."""
        self.seen.add(name)
        if name not in self.data:
            if required:
                raise self.error(name, "a table (required)", "nothing")
            return None
        return Table(self.data[name], self.key(name), self.where, self.base)

    def tables(self, name: str) -> list[Table]:
        """An array of tables (``[[name]]``); empty when absent."""
        self.seen.add(name)
        value = self.data.get(name, [])
        if not isinstance(value, list):
            raise self.error(name, "an array of tables ([[" + self.key(name) + "]])",
                             _describe(value))
        return [Table(item, f"{self.key(name)}[{i}]", self.where, self.base)
                for i, item in enumerate(value)]

    def finish(self) -> dict[str, Any]:
        """Refuse unknown keys; return the effective values."""
        for name in self.data:
            if name not in self.seen:
                known = sorted(self.seen)
                close = difflib.get_close_matches(name, known, n=1)
                hint = f" (did you mean '{close[0]}'?)" if close else ""
                where = f"[{self.path}]" if self.path else "the top level"
                raise self.error(name, f"one of the keys of {where}: {', '.join(known)}{hint}",
                                 self.data[name])
        return self.out


def _number_expectation(unit: str, gt: float | None, ge: float | None, lt: float | None,
                        le: float | None) -> str:
    parts = ["a number" + (f" [{unit}]" if unit else "")]
    for op, bound in ((">", gt), (">=", ge), ("<", lt), ("<=", le)):
        if bound is not None:
            parts.append(f"{op} {bound:g}")
    return " ".join(parts[:1]) + ((" " + " and ".join(parts[1:])) if parts[1:] else "")


def _in_bounds(value: float, gt: float | None, ge: float | None, lt: float | None,
               le: float | None) -> bool:
    return ((gt is None or value > gt) and (ge is None or value >= ge)
            and (lt is None or value < lt) and (le is None or value <= le))


def _as_vector(value: Any, length: int) -> tuple[float, ...] | None:
    """``value`` as ``length`` finite floats, or ``None`` if it is not such a list."""
    if not isinstance(value, list) or len(value) != length:
        return None
    if any(isinstance(v, bool) or not isinstance(v, int | float) for v in value):
        return None
    vec = tuple(float(v) for v in value)
    return vec if all(math.isfinite(v) for v in vec) else None


def _found_array(value: Any) -> Any:
    if isinstance(value, list):
        return f"{value!r} ({len(value)} items)"
    return f"{_describe(value)!r} ({_type_name(value)})"


@contextmanager
def prefixed(table: Table, prefix: str | None = None) -> Iterator[None]:
    """Re-raise a core class's ParameterError with the file name and key path."""
    try:
        yield
    except ParameterError as error:
        if error.where == table.where:
            raise
        key = f"{prefix if prefix is not None else table.path}.{error.name}".lstrip(".")
        raise ParameterError(table.where, key, error.expected, error.found) from error

