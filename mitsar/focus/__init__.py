"""Image formation: range compression and focusing (BPA on any track; RDA, WDA, FSA on straight
ones).

:func:`focus` (in :mod:`mitsar.focus.dispatch`) is the one entry point.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.focus.compression import range_compress, range_spectrum
    from mitsar.focus.dispatch import ALGORITHMS, focus

__all__ = ["ALGORITHMS", "focus", "range_compress", "range_spectrum"]

_EXPORTS = {
    "ALGORITHMS": "mitsar.focus.dispatch",
    "focus": "mitsar.focus.dispatch",
    "range_compress": "mitsar.focus.compression",
    "range_spectrum": "mitsar.focus.compression",
}
"""Public names -> the module that defines each, imported on first use (PEP 562)."""


def __getattr__(name: str) -> Any:
    """Import a public name on first use (PEP 562) and keep it in the package's namespace."""
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = globals()[name] = getattr(importlib.import_module(_EXPORTS[name]), name)
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
