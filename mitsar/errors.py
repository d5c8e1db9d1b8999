"""Error types shared by every mitsar module.

Every error raised for bad user input names where it happened, the parameter, what was
expected and what was found, so that a user can fix the input without reading the code.
"""

from __future__ import annotations

from typing import Any


class MitsarError(Exception):
    """Base class of all mitsar errors."""


class ParameterError(MitsarError, ValueError):
    """A parameter has a value that is invalid or physically impossible.

    Parameters
    ----------
    where : str
        The object or file the parameter belongs to, e.g. ``"Radar"`` or ``"exp.toml"``.
    name : str
        Name of the parameter, e.g. ``"prf"`` or ``"radar.prf"``.
    expected : str
        What a valid value looks like.
    found : Any
        The value that was given.
    """

    def __init__(self, where: str, name: str, expected: str, found: Any) -> None:
        self.where = where
        self.name = name
        self.expected = expected
        self.found = found
        super().__init__(f"{where}: parameter '{name}': expected {expected}, found {found!r}")


class MitsarWarning(UserWarning):
    """A valid but suspicious input or an empty result (e.g. raw data of exact zeros)."""


class SceneError(MitsarError):
    """A Mitsuba scene cannot be loaded or used; the message names the file and element."""


class MissingFileError(SceneError, FileNotFoundError):
    """A scene file, or a file it references (e.g. a PLY mesh), does not exist."""


class MemoryBudgetError(ParameterError):
    """A request would need more memory than the machine (or ``--memory-limit``) has.

    Raised before any work by :func:`mitsar.budget.require_memory`; a
    :class:`ParameterError` naming the parameter that drives the size, the need and what is
    available, and what to change (docs/reliability.md §2).
    """

    def __init__(self, where: str, name: str, needed: int, available: int, limit_source: str,
                 hint: str = "") -> None:
        self.needed = int(needed)
        self.available = int(available)
        found = f"a request of about {format_bytes(needed)}"
        expected = (f"a request that fits in the {format_bytes(available)} available "
                    f"({limit_source})")
        ParameterError.__init__(self, where, name, expected, found)
        tail = f"; {hint}" if hint else ""
        self.args = (f"{where}: parameter '{name}': needs about {format_bytes(needed)} of "
                     f"memory, {format_bytes(available)} available ({limit_source}){tail}",)

    def __str__(self) -> str:
        return str(self.args[0])


def format_bytes(count: float) -> str:
    """A byte count in binary units, e.g. ``format_bytes(2**40) == "1.00 TiB"``."""
    value = float(count)
    for unit in ("B", "KiB", "MiB", "GiB", "TiB", "PiB", "EiB"):
        if abs(value) < 1024.0 or unit == "EiB":
            return f"{value:.0f} {unit}" if unit == "B" else f"{value:.2f} {unit}"
        value /= 1024.0
    return f"{value:.2f} EiB"  # pragma: no cover (the loop returns)
