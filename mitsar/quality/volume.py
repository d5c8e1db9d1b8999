"""Elevation response of a focused volume: its cut, IRW and whether two targets are resolved.

A volume focused from several passes (:mod:`mitsar.focus.passes`) records the elevation axis
``e`` (normal to the track and the line of sight) and the predicted resolution
``lambda R / (2 L_perp)`` and IRW (:mod:`mitsar.model.geometry.tomography`). Here they are
measured:

* :func:`elevation_cut`: the volume's samples through its peak voxel along the grid dim most
  aligned with ``e``;
* :func:`measure_elevation`: the -3 dB width of that cut (:func:`mitsar.quality.cuts.irw`,
  Cumming & Wong 2005 §2.6: half-power crossings interpolated linearly, peak refined by a
  parabola), converted to metres along ``e``: ``w_e = w_d |e . d|`` for the cut's direction
  ``d``, exact when ``d = e`` (a stack of passes whose line of sight is normal to a grid
  axis) and first order otherwise (the range and azimuth responses, wider and narrower, then
  enter the cut too);
* :func:`dip_db` / :func:`resolved`: the dip criterion of two equal targets, the depth of the
  power minimum between the two highest peaks of a cut below the weaker of them; two targets are
  resolved when it reaches 3 dB. That is stricter than Rayleigh's criterion (two sinc^2
  responses one null apart, adding in power, dip by 19 %, 0.9 dB; Born & Wolf, *Principles of
  Optics*, §7.6.3): two equal targets adding in power reach 3 dB at 1.2 ``rho_e`` and 7.5 dB
  at 1.5 ``rho_e``; in phase, their amplitudes add and the dip is 2.2 dB at 1.5 ``rho_e``.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.products.image import vector_attr
from mitsar.quality.cuts import irw
from mitsar.quality.upsample import check_factor, upsample_cut

__all__ = ["RESOLVED_DIP_DB", "dip_db", "elevation_cut", "measure_elevation", "resolved"]

RESOLVED_DIP_DB = 3.0
"""Dip [dB] between two peaks from which they count as resolved (module docstring)."""

_DIMS = {"x": 0, "y": 1, "z": 2}


def _volume(volume: xr.Dataset, where: str) -> None:
    if not isinstance(volume, xr.Dataset) or volume.attrs.get("grid_kind") != "volume":
        raise ParameterError(where, "volume", "a volume image product (mitsar.focus with a "
                             "VolumeGrid)", getattr(volume, "attrs", {}).get("grid_kind",
                                                                              type(volume)))
    if "elevation_axis" not in volume.attrs:
        raise ParameterError(where, "volume", "a volume focused from two or more passes "
                             "spread across the line of sight (attribute 'elevation_axis')",
                             "no elevation axis")


def elevation_cut(volume: xr.Dataset, target: ArrayLike | None = None,
                  search: float | None = None) -> dict[str, Any]:
    """The volume's complex samples through its peak along the dim nearest the elevation axis.

    Parameters
    ----------
    volume : xarray.Dataset
        Volume image product from several passes (``elevation_axis`` attribute).
    target : array_like, shape (3,), optional
        Look for the peak within ``search`` metres of this world point (default: the whole
        volume's brightest voxel).
    search : float, optional
        Search radius around ``target`` [m]; default the predicted elevation resolution.

    Returns
    -------
    dict
        ``cut`` (complex samples), ``dim`` (the grid dim cut along), ``step`` [m] (sample
        spacing), ``cosine`` (``|e . d|``), ``peak`` (voxel indices (z, y, x)) and
        ``position`` (its world position [m]).
    """
    _volume(volume, "elevation_cut")
    axis = vector_attr(volume, "elevation_axis")
    image = volume["image"].values
    power = np.abs(image) ** 2
    if target is not None:
        radius = float(volume.attrs["elevation_resolution"]) if search is None else float(search)
        distance = np.linalg.norm(volume["position"].values - np.asarray(target, float), axis=-1)
        power = np.where(distance <= radius, power, -1.0)
        if not np.any(power >= 0):
            raise ParameterError("elevation_cut", "target", f"a point within {radius:.3g} m of "
                                 "a voxel", np.asarray(target).tolist())
    peak = np.unravel_index(int(np.argmax(power)), power.shape)
    dim = max(_DIMS, key=lambda name: abs(axis[_DIMS[name]]))
    index = volume["image"].dims.index(dim)
    take = list(peak)
    take[index] = slice(None)
    coords = volume[dim].values
    return {"cut": image[tuple(take)], "dim": dim, "step": float(np.mean(np.diff(coords))),
            "cosine": float(abs(axis[_DIMS[dim]])), "peak": tuple(int(i) for i in peak),
            "position": volume["position"].values[peak]}


def measure_elevation(volume: xr.Dataset, target: ArrayLike | None = None, *,
                      upsample: int = 1, search: float | None = None) -> dict[str, Any]:
    """Measured elevation IRW of a volume's point response, beside the predicted one.

    Parameters
    ----------
    volume : xarray.Dataset
        Volume image product from several passes.
    target : array_like, shape (3,), optional
        Where to look for the peak (:func:`elevation_cut`).
    upsample : int
        Band-limited upsampling of the cut before the IRW (1: none; sample the volume at a
        fraction of the predicted IRW then).
    search : float, optional
        Peak search radius around ``target`` [m].

    Returns
    -------
    dict
        ``irw`` [m] along the elevation axis (module docstring), ``irw_predicted`` and
        ``resolution`` [m] (the product's ``elevation_irw_predicted`` and
        ``elevation_resolution``), ``ratio`` (measured / predicted), ``dim``, ``position``.
    """
    found = elevation_cut(volume, target, search)
    factor = check_factor(upsample)
    cut = found["cut"] if factor == 1 else upsample_cut(found["cut"], factor)
    width = irw(cut, 1.0) * found["step"] / factor * found["cosine"]
    predicted = float(volume.attrs["elevation_irw_predicted"])
    return {"irw": width, "irw_predicted": predicted, "ratio": width / predicted,
            "resolution": float(volume.attrs["elevation_resolution"]), "dim": found["dim"],
            "position": found["position"]}


def _power(cut: ArrayLike) -> NDArray[np.float64]:
    values = np.asarray(cut)
    if values.ndim != 1 or values.size < 3:
        raise ParameterError("dip_db", "cut", "a 1-D cut of at least 3 samples", values.shape)
    return np.abs(values) ** 2 if np.iscomplexobj(values) else np.abs(values.astype(float))


def dip_db(cut: ArrayLike, floor_db: float = -6.0) -> float:
    """Depth [dB] of the power minimum between the two highest peaks of a cut.

    Parameters
    ----------
    cut : array_like, shape (N,)
        Complex amplitude or non-negative power samples.
    floor_db : float
        Only local maxima within this many dB of the highest count as peaks (sidelobes of one
        target, -13 dB for a rect aperture, are not a second target).

    Returns
    -------
    float
        ``10 log10(min(P_1, P_2) / P_min)`` for the two highest peaks ``P_1``, ``P_2`` and the
        lowest sample ``P_min`` between them; 0 when the cut has one peak.
    """
    p = _power(cut)
    inner = np.flatnonzero((p[1:-1] > p[:-2]) & (p[1:-1] >= p[2:])) + 1
    inner = inner[p[inner] >= p.max() * 10.0 ** (floor_db / 10.0)]
    if inner.size < 2:
        return 0.0
    first, second = np.sort(inner[np.argsort(p[inner])[-2:]])
    lowest = float(p[first:second + 1].min())
    weaker = float(min(p[first], p[second]))
    return float(10.0 * np.log10(weaker / max(lowest, 1e-300)))


def resolved(cut: ArrayLike, dip: float = RESOLVED_DIP_DB) -> bool:
    """Whether a cut through two equal targets shows them apart: two peaks with a dip of at
    least ``dip`` dB between them (:func:`dip_db`; module docstring)."""
    return dip_db(cut) >= dip
