"""Public names of a package imported on first use (PEP 562, docs/design.md §3).

Every sub-package that exports lazily builds its module ``__getattr__`` and ``__dir__`` here
from its table of public names -> defining modules, so that importing the package loads none
of its stages (nor Mitsuba, Dr.Jit or Matplotlib behind them) until a name is used.
"""

from __future__ import annotations

import importlib
from collections.abc import Callable, Mapping
from types import ModuleType
from typing import Any

__all__ = ["LazyModule", "lazy_exports"]


class LazyModule(ModuleType):
    """A module imported on its first attribute access (every access then reads the imported
    module's attribute, so that a test's ``monkeypatch`` of the module is seen through it):
    ``from mitsar.backend import drjit as dr`` at a kernel
    module's top keeps ``dr.`` in its code while a NumPy-only path (a campaign rerun, the
    analytic simulator in NumPy, metrics) never loads Dr.Jit's native libraries; a mitsar
    module that needs a heavy stage only for its compute (a campaign's no-op rerun needs no
    focuser) names it ``LazyModule("mitsar....")`` at its top (docs/design.md §3;
    ``tests/test_layout.py`` counts the name as an import).

    Parameters
    ----------
    name : str
        The module's import name, e.g. ``"drjit"``.
    """

    def __getattr__(self, attribute: str) -> Any:
        if attribute.startswith("__"):
            raise AttributeError(attribute)
        module = self.__dict__.get("__lazy_module__")
        if module is None:
            module = self.__dict__["__lazy_module__"] = importlib.import_module(self.__name__)
        return getattr(module, attribute)


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
