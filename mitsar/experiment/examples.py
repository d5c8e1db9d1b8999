"""The bundled example experiments (``examples/*.toml`` of a checkout) and where to find them."""

from __future__ import annotations

import os
import sys
from pathlib import Path

from mitsar.errors import MitsarError

__all__ = ["example_path", "examples_dir"]


def examples_dir() -> Path:
    """The folder of the bundled example experiments.

    Searched in order: ``$MITSAR_EXAMPLES``, ``examples/`` next to the ``mitsar`` package
    (a source checkout or editable install), ``<prefix>/share/mitsar/examples`` (a copy
    installed as data files).

    Raises
    ------
    MitsarError
        If none of them exists.
    """
    candidates = []
    if os.environ.get("MITSAR_EXAMPLES"):
        candidates.append(Path(os.environ["MITSAR_EXAMPLES"]))
    candidates.append(Path(__file__).resolve().parents[2] / "examples")
    candidates.append(Path(sys.prefix) / "share" / "mitsar" / "examples")
    for candidate in candidates:
        if candidate.is_dir():
            return candidate
    raise MitsarError("bundled examples not found; looked in "
                      + ", ".join(str(c) for c in candidates)
                      + " (set MITSAR_EXAMPLES to the examples folder of a mitsar checkout)")


def example_path(name: str = "paper_point_target") -> Path:
    """Path of a bundled example experiment, by name (with or without ``.toml``).

    Raises
    ------
    MitsarError
        If there is no such example (the message lists the available ones).
    """
    folder = examples_dir()
    path = folder / (name if name.endswith(".toml") else f"{name}.toml")
    if not path.is_file():
        available = sorted(p.stem for p in folder.glob("*.toml"))
        raise MitsarError(f"no bundled example {name!r} in {folder}; available: "
                          f"{', '.join(available) or 'none'}")
    return path
