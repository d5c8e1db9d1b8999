"""Image formation: range compression and focusing (BPA on any track; RDA, WDA, FSA on straight
ones).

:func:`focus` (in :mod:`mitsar.focus.dispatch`) is the one entry point.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mitsar.lazy import lazy_exports

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


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), __all__)
