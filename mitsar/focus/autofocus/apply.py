"""Applying an autofocus phase: correct the raw sweeps, record the estimate in the image.

Sweep k of the raw product is multiplied by ``exp(-j phi_k)`` (a line-of-sight error ``d_k``
multiplies the dechirped echo of every scatterer by ``exp(j 4 pi d_k / lambda)``, docs/design.md
§4 sign convention: delay ``tau`` gives ``exp(+j 2 pi f_c tau)``), and the image product gets
``autofocus_phase`` (sweep) [rad] with the method's attributes.
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

__all__ = ["attach_phase", "correct_raw"]


def correct_raw(raw: xr.Dataset, phase: NDArray) -> xr.Dataset:
    """A copy of ``raw`` with sweep k multiplied by ``exp(-j phase_k)`` (phase in radians)."""
    corrected = raw.copy()
    corrected["raw"] = raw["raw"] * xr.DataArray(np.exp(-1j * np.asarray(phase)), dims="sweep")
    corrected["raw"].attrs = dict(raw["raw"].attrs)
    return corrected


def attach_phase(image: xr.Dataset, raw: xr.Dataset, phase: NDArray,
                 attrs: dict[str, Any]) -> xr.Dataset:
    """Add ``autofocus_phase`` (sweep) [rad] and ``autofocus_*`` attributes to an image.

    Dict and list attribute values are stored as JSON (netCDF attributes are flat).
    """
    image = image.copy()
    image["autofocus_phase"] = xr.DataArray(
        np.asarray(phase, dtype=float), dims="sweep",
        coords={"sweep": raw["sweep"].values},
        attrs={"units": "rad", "long_name": "estimated phase error per sweep (raw corrected by "
               "exp(-j autofocus_phase)); constant and linear trend removed"})
    for key, value in attrs.items():
        if isinstance(value, dict | list | tuple):
            value = json.dumps(value)
        elif isinstance(value, bool | np.bool_):
            value = int(value)
        image.attrs[f"autofocus_{key}"] = value
    return image
