"""NGA standard products: SICD images and CPHD phase history, through sarkit (optional).

``pip install mitsar[nga]`` installs sarkit; the modules here import it only when a writer or
reader runs (:mod:`mitsar.export.optional`). Details: ``docs/products.md``.
"""

from mitsar.export.cphd import read_cphd, write_cphd
from mitsar.export.frame import DEFAULT_ORIGIN, LabOrigin
from mitsar.export.sicd import sicd_pixels, write_sicd

__all__ = ["DEFAULT_ORIGIN", "LabOrigin", "read_cphd", "sicd_pixels", "write_cphd",
           "write_sicd"]
