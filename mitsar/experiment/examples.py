"""The bundled example experiments (``examples/*.toml`` of a checkout) and where to find them.

The folder ``examples/`` at the top of the checkout is installed as the data package
``mitsar._examples`` (pyproject.toml's package-dir): :mod:`importlib.resources` finds it in an
installed wheel and, through the editable install's finder, in a checkout.
"""

from __future__ import annotations

import importlib.resources
import os
from pathlib import Path

from mitsar.errors import MitsarError

__all__ = ["example_path", "example_names", "examples_dir"]

PACKAGE = "mitsar._examples"
"""The data package of the examples."""


def _package_dir() -> Path | None:
    """The folder of :data:`PACKAGE` on disk, or None where it is not installed."""
    try:
        folder = importlib.resources.files(PACKAGE)
    except ModuleNotFoundError:
        return None
    return folder if isinstance(folder, Path) and folder.is_dir() else None


def examples_dir() -> Path:
    """The folder of the bundled example experiments.

    Searched in order: ``$MITSAR_EXAMPLES``; the data package ``mitsar._examples`` (an
    installed wheel, or ``examples/`` of a checkout installed editable); ``examples/`` beside
    the ``mitsar`` package (a source tree on ``PYTHONPATH``, not installed).

    Raises
    ------
    MitsarError
        If none of them exists.
    """
    candidates: list[Path | None] = []
    if os.environ.get("MITSAR_EXAMPLES"):
        candidates.append(Path(os.environ["MITSAR_EXAMPLES"]))
    candidates.append(_package_dir())
    candidates.append(Path(__file__).resolve().parents[2] / "examples")
    for candidate in candidates:
        if candidate is not None and candidate.is_dir():
            return candidate
    raise MitsarError("bundled examples not found; looked in the package "
                      f"{PACKAGE} and in "
                      + ", ".join(str(c) for c in candidates if c is not None)
                      + " (set MITSAR_EXAMPLES to the examples folder of a mitsar checkout)")


def example_names() -> list[str]:
    """Names of the bundled example experiments (``*.toml`` stems), sorted."""
    return sorted(p.stem for p in examples_dir().glob("*.toml"))


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
        raise MitsarError(f"no bundled example {name!r} in {folder}; available: "
                          f"{', '.join(example_names()) or 'none'}")
    return path
