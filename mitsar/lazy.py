"""Public names of a package imported on first use (PEP 562, docs/design.md §3).

Every sub-package that exports lazily builds its module ``__getattr__`` and ``__dir__`` here
from its table of public names -> defining modules, so that importing the package loads none
of its stages (nor Mitsuba, Dr.Jit or Matplotlib behind them) until a name is used.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from typing import Any

__all__ = ["lazy_exports"]


def lazy_exports(package: str, exports: Mapping[str, str], namespace: dict[str, Any],
                 public: list[str]) -> tuple[Callable[[str], Any], Callable[[], list[str]]]:
    """The ``__getattr__`` and ``__dir__`` of package ``package`` (its ``__name__``).

    Parameters
    ----------
    package : str
        The package's ``__name__``.
    exports : mapping of str to str
        Public name -> the module that defines it.
    namespace : dict
        The package's ``globals()``: a name is kept there once imported.
    public : list of str
        The package's ``__all__``.
    """

    def __getattr__(name: str) -> Any:
        """Import a public name on first use and keep it in the package's namespace."""
        if name not in exports:
            raise AttributeError(f"module {package!r} has no attribute {name!r}")
        value = namespace[name] = getattr(importlib.import_module(exports[name]), name)
        return value

    def __dir__() -> list[str]:
        return sorted(set(namespace) | set(public))

    return __getattr__, __dir__
