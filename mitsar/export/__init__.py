"""NGA standard products: SICD images and CPHD phase history, through sarkit (optional).

``pip install mitsar[nga]`` installs sarkit; the modules here import it only when a writer or
reader runs (:mod:`mitsar.export.optional`). Details: ``docs/products.md``.
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.export.cphd import read_cphd, write_cphd
    from mitsar.export.frame import DEFAULT_ORIGIN, LabOrigin
    from mitsar.export.sicd import sicd_pixels, write_sicd

__all__ = ["DEFAULT_ORIGIN", "LabOrigin", "read_cphd", "sicd_pixels", "write_cphd",
           "write_sicd"]

_EXPORTS = {
    "DEFAULT_ORIGIN": "mitsar.export.frame",
    "LabOrigin": "mitsar.export.frame",
    "read_cphd": "mitsar.export.cphd",
    "sicd_pixels": "mitsar.export.sicd",
    "write_cphd": "mitsar.export.cphd",
    "write_sicd": "mitsar.export.sicd",
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
