"""The interferogram product: a channel pair's phase, coherence, heights and their noise.

Made by :func:`mitsar.interferometry.interferogram` from a multi-channel image product
(docs/interferometry.md); every variable lies on the image's (multilooked) grid, whose two
dims stand for ``row`` and ``col`` here, as in :mod:`mitsar.products.image`.

Layout (:data:`INTERFEROGRAM_SCHEMA`)
-------------------------------------
``interferogram`` complex, ``phase``, ``reference_phase``, ``unwrapped_phase`` [rad],
``coherence``, ``coherence_snr``, ``amplitude``, ``connected_component``, ``looks`` [1],
``height``, ``height_std`` [m] (row, col); ``position``, ``pixel_position`` (row, col, xyz) [m].
attributes
    ``product = "interferogram"``, ``pair``, ``wavelength`` [m], ``baseline`` [m],
    ``perpendicular_baseline`` [m], ``ambiguity_height`` [m], ``looks_azimuth``,
    ``looks_range``; optionally the layover/shadow masks of :mod:`mitsar.scene.masks`.
"""

from __future__ import annotations

import xarray as xr

from mitsar.products.schema import Schema, Variable, validate

__all__ = ["INTERFEROGRAM_SCHEMA", "validate_interferogram"]

_GRID = ("row", "col")

INTERFEROGRAM_SCHEMA = Schema(
    product="interferogram",
    variables={
        "interferogram": Variable(_GRID, "1", "multilooked flat interferogram s1 s2* (image "
                                  "units squared)"),
        "amplitude": Variable(_GRID, "1", "geometric mean amplitude of the two channels "
                              "(image units)"),
        "phase": Variable(_GRID, "rad", "wrapped flat interferometric phase"),
        "reference_phase": Variable(_GRID, "rad", "phase (2 pi / lambda)(L1 - L2) of the "
                                    "reference surface"),
        "coherence": Variable(_GRID, "1", "boxcar coherence estimate (biased upward for few "
                              "looks)"),
        "coherence_snr": Variable(_GRID, "1", "thermal-noise coherence predicted from the "
                                  "image's noise power"),
        "unwrapped_phase": Variable(_GRID, "rad", "unwrapped flat phase tied to the reference "
                                    "surface"),
        "connected_component": Variable(_GRID, "1", "SNAPHU connected component (0: none)"),
        "height": Variable(_GRID, "m", "world z of the scatterer"),
        "position": Variable((*_GRID, "xyz"), "m", "world position of the scatterer"),
        "pixel_position": Variable((*_GRID, "xyz"), "m", "world position of the (multilooked) "
                                   "pixel"),
        "height_std": Variable(_GRID, "m", "predicted height standard deviation "
                               "(Cramer-Rao)"),
        "looks": Variable(_GRID, "1", "number of valid pixels averaged"),
    },
    attrs={"product": "product type", "pair": "the channels (1, 2) of s1 s2*",
           "wavelength": "carrier wavelength [m]",
           "baseline": "effective baseline (t2 + r2) - (t1 + r1) at the scene centre [m]",
           "perpendicular_baseline": "its component across the line of sight [m]",
           "ambiguity_height": "height of one 2 pi cycle at the scene centre (exact) [m]",
           "looks_azimuth": "multilook window along the first grid dim [pixels]",
           "looks_range": "multilook window along the second grid dim [pixels]"},
)
"""The interferogram product's layout (module docstring); ``row`` and ``col`` stand for the
grid's own two dims."""


def validate_interferogram(product: xr.Dataset,
                           where: str = "interferogram product") -> xr.Dataset:
    """Check an interferogram product against :data:`INTERFEROGRAM_SCHEMA`, its grid dims
    standing for ``row`` and ``col`` (:func:`mitsar.products.schema.validate`)."""
    checked = product
    if product.attrs.get("product") == "interferogram" and "height" in product.variables \
            and product["height"].ndim == 2:
        rows, cols = map(str, product["height"].dims)
        if (rows, cols) != _GRID:
            checked = product.rename({rows: "row", cols: "col"})
    validate(checked, INTERFEROGRAM_SCHEMA, where)
    return product
