"""Fast factorised back-projection of a volume: one horizontal plane of voxels at a time.

FFBP's sub-aperture images are polar grids on the *image plane*, the plane that holds the
output pixels (:mod:`mitsar.focus.ffbp`: ``_image_plane``, a least-squares fit through them):
voxels spread over a volume are not on one plane, so the polar grids could not hold them. A
:class:`~mitsar.focus.grid.VolumeGrid` is therefore focused as the stack of its horizontal
slices ``z = z_k``, each a plane of ``(y, x)`` pixels that FFBP focuses exactly as a
:class:`~mitsar.focus.grid.PlaneGrid` (same nodes, same error against BPA, docs/focusing.md §
FFBP). BPA needs no such split: its per-pixel sum takes any positions
(:func:`mitsar.focus.bpa.focus_bpa`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.focus.ffbp import focus_ffbp

__all__ = ["focus_ffbp_volume"]


def focus_ffbp_volume(raw: xr.Dataset, layout: dict, **options: Any
                      ) -> tuple[NDArray, NDArray, dict]:
    """FFBP of a resolved volume layout, slice by slice (module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product.
    layout : dict
        A resolved :class:`~mitsar.focus.grid.VolumeGrid` (``position`` of shape
        (nz, ny, nx, 3) [m]).
    **options
        The keyword arguments of :func:`mitsar.focus.ffbp.focus_ffbp`.

    Returns
    -------
    values : ndarray, shape (nz * ny * nx,), complex
    coverage : ndarray, shape (nz * ny * nx,)
    extra : dict
        The first slice's processing attributes, with ``ffbp_volume_slices``.
    """
    position = np.asarray(layout["position"], dtype=float)
    values, coverage, extra = [], [], {}
    for plane in position:  # a loop over slices; every slice is one vectorised FFBP
        slice_values, slice_coverage, slice_extra = focus_ffbp(raw, {"position": plane},
                                                               **options)
        values.append(slice_values)
        coverage.append(slice_coverage)
        extra = extra or slice_extra
    return (np.concatenate(values), np.concatenate(coverage),
            {**extra, "ffbp_volume_slices": len(position)})
