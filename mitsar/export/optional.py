"""The optional dependency of NGA export: sarkit, imported only when a writer or reader runs.

mitsar's core never needs sarkit; ``pip install mitsar[nga]`` installs it. The NGA modules
(:mod:`mitsar.export.sicd`, :mod:`mitsar.export.cphd`) call :func:`require_sarkit` inside their
functions, so ``import mitsar`` works without it (docs/design.md §3, lazy imports).
"""

from __future__ import annotations

import importlib
from types import ModuleType

from mitsar.errors import MitsarError

__all__ = ["SARKIT_REQUIREMENT", "require_sarkit"]

SARKIT_REQUIREMENT = "sarkit>=1.8,<1.9 (the last series for Python 3.11; mitsar pins 1.8.1)"
"""The sarkit release mitsar's NGA export is written and tested against."""


def require_sarkit(module: str = "sarkit") -> ModuleType:
    """Import a sarkit module, or raise a :class:`MitsarError` that says how to install it.

    Parameters
    ----------
    module : str
        Dotted name, e.g. ``"sarkit.cphd"`` (or ``"lxml.etree"``, which sarkit brings).

    Raises
    ------
    MitsarError
        When sarkit is not installed.
    """
    try:
        return importlib.import_module(module)  # lazy: optional dependency (mitsar[nga])
    except ImportError as error:
        raise MitsarError(f"NGA export needs {SARKIT_REQUIREMENT}, which is not installed "
                          f"({error}); install it with: pip install mitsar[nga]") from error
