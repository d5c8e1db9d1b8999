"""NGA standard products: SICD images and CPHD phase history, through sarkit (optional).

``pip install mitsar[nga]`` installs sarkit; the modules here import it only when a writer or
reader runs (:mod:`mitsar.export.optional`). Details: ``docs/products.md``.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mitsar.lazy import lazy_exports

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


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), __all__)
