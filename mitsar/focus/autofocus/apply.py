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


ALIGNMENT = 64
"""Byte alignment of the corrected samples (a cache line)."""


def correct_raw(raw: xr.Dataset, phase: NDArray) -> xr.Dataset:
    """A copy of ``raw`` with sweep k multiplied by ``exp(-j phase_k)`` (phase in radians).

    The corrected samples are written into a buffer aligned to :data:`ALIGNMENT` bytes.
    Measured on benchmarks/bench_autofocus.py's room (same grid, alternately, load 3): the
    focus of a product built by xarray's multiplication (samples 48 bytes off a cache line)
    took 1.15-1.9 s against 0.6-1.4 s for the uncorrected product; from the aligned buffer
    1.07-1.6 s against 0.83-1.34 s. The cause (Dr.Jit kernels keyed on the alignment of an
    input, docs: :func:`mitsar.focus.backprojection.jit_array`, or a NumPy path) is not
    pinned down; the refocus is still up to 1.3x the plain focus.
    """
    samples = raw["raw"]
    product = (samples * xr.DataArray(np.exp(-1j * np.asarray(phase, dtype=float)),
                                      dims="sweep")).transpose(*samples.dims).values
    buffer = np.empty(product.nbytes + ALIGNMENT, dtype=np.uint8)
    offset = (-buffer.ctypes.data) % ALIGNMENT
    aligned = buffer[offset:offset + product.nbytes].view(product.dtype).reshape(product.shape)
    aligned[...] = product
    corrected = raw.copy()
    corrected["raw"] = xr.DataArray(aligned, dims=samples.dims, coords=samples.coords,
                                    attrs=dict(samples.attrs))
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
