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


class SceneError(MitsarError):
    """A Mitsuba scene cannot be loaded or used; the message names the file and element."""


class MissingFileError(SceneError, FileNotFoundError):
    """A scene file, or a file it references (e.g. a PLY mesh), does not exist."""
