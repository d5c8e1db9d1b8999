"""Image formation: range compression and focusing (BPA on any track; RDA, WDA, FSA on straight
ones).

:func:`focus` (in :mod:`mitsar.focus.dispatch`) is the one entry point.
"""

from __future__ import annotations

from mitsar.focus.compression import range_compress, range_spectrum
from mitsar.focus.dispatch import ALGORITHMS, focus

__all__ = ["ALGORITHMS", "focus", "range_compress", "range_spectrum"]
