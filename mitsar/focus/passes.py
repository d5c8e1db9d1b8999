"""Several passes focused onto the same pixels or voxels and combined (tomographic BP).

A list of raw products given to :func:`mitsar.focus` is a set of passes: each is focused by
the same back-projection (:func:`mitsar.focus.bpa.focus_bpa`, or FFBP) onto the *same* world
positions (a :class:`~mitsar.focus.grid.VolumeGrid`, :class:`~mitsar.focus.grid.PlaneGrid` or
:class:`~mitsar.focus.grid.PointsGrid`: grids in the scene frame; a slant grid belongs to one
track and is refused), and the images are combined:

* ``combine="coherent"``: the mean of the complex images, ``I = (1/N) sum_n I_n``. Each
  pass's back-projection de-rotates every sweep by the carrier phase of the exact delay to the
  voxel (Meta 2007 §II-B), so a scatterer at the voxel adds in phase in every pass, and one
  displaced by ``s`` across the line of sight carries the phase ``4 pi b_n s / (lambda R)``
  of the pass's perpendicular position ``b_n``: the sum focuses the aperture the passes span
  in elevation (Reigber & Moreira 2000, IEEE TGRS 38(5), eqs. 3-4;
  :mod:`mitsar.model.geometry.tomography`). A point of amplitude ``a`` focuses to about
  ``a``, as in one pass. Needs navigation that is phase-stable across passes (a fraction of
  a wavelength): autofocus per pass is refused here, since each leaves its own constant phase.
* ``combine="incoherent"``: ``sqrt((1/N) sum_n |I_n|^2)``, a real amplitude image, for passes
  without phase-stable navigation; it averages speckle but has no elevation resolution
  beyond a single pass's.

Multi-channel passes (dim ``channel``, :mod:`mitsar.focus.channels`) are first combined over
their channels coherently (their mean): the channels are phase centres of one platform,
phase-stable by construction, and their offsets across the line of sight add to the elevation
aperture (``pass_baseline`` takes each channel's monostatic-equivalent centre, the midpoint of
its transmitter and receiver). Then the passes are combined as asked. To keep the channels
apart, focus each raw product alone (the single-product path is unchanged).

The product is an image product (:func:`mitsar.products.image.validate_image`) with the grid's
dims (``("z", "y", "x")`` for a volume) and, recording the passes:

``pass_position`` (pass, xyz) [m]
    Each pass's antenna at its aperture centre for the grid's centre (the sweep whose
    direction sine to the centre is nearest its Doppler centroid).
``pass_baseline`` (pass) [m]
    Perpendicular position ``b_n`` of each pass along the elevation axis (mean over its
    channels), from the mean pass position.
attributes
    ``passes`` (count), ``pass_combine``, ``pass_raw_seeds`` (each raw product's ``seed``: the
    scene's, shared by an experiment's passes), ``pass_noise_seeds`` (each pass's own noise
    seed, ``noise_seed`` or ``pass_seed``; -1 without), ``pass_names`` (the raw
    products' ``pass_name``, else their index), ``pass_channels`` (channels
    combined per pass, 1 without), and with two or more passes spread across the line of sight:
    ``elevation_axis`` (unit vector, world xyz), ``elevation_slant_range`` [m],
    ``perpendicular_aperture`` ``L_perp`` [m] (span x N/(N-1) over passes and channels),
    ``elevation_resolution`` ``lambda R / (2 L_perp)`` [m] and ``elevation_irw_predicted``
    [m] (the exact -3 dB width of the array factor), both for the coherent sum.
"""

from __future__ import annotations

from collections.abc import Callable, Sequence

import numpy as np
import xarray as xr

from mitsar.errors import ParameterError
from mitsar.focus.grid import Grid, PlaneGrid, PointsGrid, VolumeGrid, from_dict
from mitsar.model.geometry.aperture import phase_centres
from mitsar.model.geometry.tomography import (
    effective_aperture,
    elevation_irw,
    elevation_resolution,
    perpendicular_baselines,
)
from mitsar.products.image import validate_image
from mitsar.products.raw import radar_of

__all__ = ["COMBINE", "focus_passes", "pass_phase_centres"]

COMBINE = ("coherent", "incoherent")
"""How passes are combined (module docstring)."""

_SCENE_GRIDS = (VolumeGrid, PlaneGrid, PointsGrid)


def _check(raws: Sequence[xr.Dataset], grid: Grid | dict | None, combine: str,
           autofocus: str | None) -> Grid:
    """Refuse, before any focusing, what cannot be combined; return the grid."""
    if combine not in COMBINE:
        raise ParameterError("focus", "combine", f"one of {COMBINE}", combine)
    if len(raws) == 0:
        raise ParameterError("focus", "raw", "a raw product or a non-empty list of raw "
                             "products (passes)", "an empty list")
    for k, raw in enumerate(raws):
        if not isinstance(raw, xr.Dataset) or raw.attrs.get("product") != "raw":
            raise ParameterError("focus", f"raw[{k}]", "a raw product (xarray.Dataset with "
                                 "attribute product='raw')",
                                 raw.attrs.get("product") if isinstance(raw, xr.Dataset)
                                 else type(raw).__name__)
    if isinstance(grid, dict):
        grid = from_dict(grid)
    if not isinstance(grid, _SCENE_GRIDS):
        raise ParameterError("focus", "grid", "a grid in the scene frame for several passes "
                             "(VolumeGrid, PlaneGrid or PointsGrid: a slant grid belongs to one "
                             "track)", type(grid).__name__)
    if combine == "coherent":
        carriers = {float(radar_of(raw).carrier_frequency) for raw in raws}
        if len(carriers) > 1:
            raise ParameterError("focus", "raw", "passes of one carrier frequency for "
                                 "combine='coherent'", sorted(carriers))
        if autofocus is not None and len(raws) > 1:
            raise ParameterError("focus", "autofocus", "None with combine='coherent' (each "
                                 "pass's autofocus leaves its own constant phase; use "
                                 "combine='incoherent')", autofocus)
    return grid


def pass_phase_centres(raw: xr.Dataset, target: np.ndarray) -> np.ndarray:
    """Monostatic-equivalent phase centres of a pass at its aperture centre for ``target``.

    The aperture centre is the sweep whose direction sine ``v_hat . l`` to ``target`` is
    nearest its Doppler centroid ``v_hat . boresight`` (broadside: closest approach). Each
    channel's centre is the midpoint of its transmitter and receiver, placed on the track by the
    attitude (:func:`mitsar.model.geometry.aperture.phase_centres`).

    Returns
    -------
    ndarray, shape (C, 3)
        One row per channel (one without channels) [m].
    """
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    velocity = np.asarray(raw["platform_velocity"].values, dtype=float)
    boresight = np.asarray(raw["boresight"].values, dtype=float)
    speed = np.maximum(np.linalg.norm(velocity, axis=-1), 1e-12)
    sight = target - positions
    sight /= np.maximum(np.linalg.norm(sight, axis=-1), 1e-12)[:, None]
    offset = (np.einsum("si,si->s", sight, velocity)
              - np.einsum("si,si->s", boresight, velocity)) / speed
    k = int(np.argmin(np.abs(offset)))
    if "transmitter_offset" not in raw.variables:
        return positions[k:k + 1]
    middle = 0.5 * (np.asarray(raw["transmitter_offset"].values, dtype=float)
                    + np.asarray(raw["receiver_offset"].values, dtype=float))
    return phase_centres(positions[k:k + 1], raw["attitude"].values[k:k + 1], middle)[0]


def _elevation(raws: Sequence[xr.Dataset], centre: np.ndarray) -> tuple[dict, dict]:
    """Pass variables and elevation attributes of the combined product (module docstring)."""
    centres = [pass_phase_centres(raw, centre) for raw in raws]
    stacked = np.concatenate(centres)
    velocity = np.concatenate([raw["platform_velocity"].values for raw in raws])
    along = (velocity / np.maximum(np.linalg.norm(velocity, axis=-1), 1e-12)[:, None]).mean(0)
    baselines, axis, slant_range = perpendicular_baselines(stacked, centre, along)
    counts = np.cumsum([0] + [len(c) for c in centres])
    per_pass = np.array([baselines[a:b].mean() for a, b in zip(counts[:-1], counts[1:],
                                                                  strict=True)])
    variables = {
        "pass_position": (("pass", "xyz"), np.array([c.mean(axis=0) for c in centres]),
                          {"units": "m", "long_name": "antenna at the aperture centre for the "
                           "grid centre (mean over channels)"}),
        "pass_baseline": (("pass",), per_pass,
                          {"units": "m", "long_name": "perpendicular position along the "
                           "elevation axis, from the mean pass position"})}
    if len(baselines) < 2 or np.ptp(baselines) <= 1e-9:
        return variables, {}
    wavelength = radar_of(raws[0]).wavelength
    aperture = effective_aperture(baselines)
    attrs = {"elevation_axis": [float(v) for v in axis],
             "elevation_slant_range": slant_range,
             "perpendicular_aperture": aperture,
             "elevation_resolution": elevation_resolution(wavelength, slant_range, aperture),
             "elevation_irw_predicted": elevation_irw(baselines, wavelength, slant_range)}
    return variables, attrs


def focus_passes(raws: Sequence[xr.Dataset], algorithm: str, grid: Grid | dict | None,
                 combine: str, focus_one: Callable[[xr.Dataset, Grid], xr.Dataset],
                 autofocus: str | None = None) -> xr.Dataset:
    """Focus every pass onto the same grid and combine them (module docstring).

    Parameters
    ----------
    raws : sequence of xarray.Dataset
        The passes' raw products.
    algorithm : str
        The focuser (recorded; "bpa" or "ffbp" on a volume, any on a plane).
    grid : VolumeGrid, PlaneGrid, PointsGrid or dict
        Scene-frame output grid.
    combine : {"coherent", "incoherent"}
        Mean of the complex images, or root mean square amplitude.
    focus_one : callable
        ``focus_one(raw, grid) -> image``: :func:`mitsar.focus` with the caller's options.
    autofocus : str or None
        The caller's autofocus (refused with ``combine="coherent"`` for several passes).

    Returns
    -------
    xarray.Dataset
        Image product with the grid's dims, ``pass_position``, ``pass_baseline`` and the
        pass and elevation attributes (module docstring).
    """
    grid = _check(raws, grid, combine, autofocus)
    total, coverage, first, channels = None, None, None, []
    for raw in raws:  # a loop over passes; each is one vectorised back-projection
        image = focus_one(raw, grid)
        values = image["image"].values
        if "channel" in image["image"].dims:  # channels of one platform: phase-stable
            channels.append(image.sizes["channel"])
            values = values.mean(axis=image["image"].dims.index("channel"))
        else:
            channels.append(1)
        term = values if combine == "coherent" else np.abs(values) ** 2
        total = term.astype(complex if combine == "coherent" else float) if total is None \
            else total + term
        coverage = image["coverage"].values if coverage is None \
            else coverage + image["coverage"].values
        first = image if first is None else first
    count = len(raws)
    combined = total / count if combine == "coherent" else np.sqrt(total / count)
    dims = tuple(d for d in first["image"].dims if d != "channel")
    product = xr.Dataset(
        {"image": (dims, combined, first["image"].attrs),
         "position": first["position"], "coverage": (dims, coverage / count,
                                                     first["coverage"].attrs)},
        coords={name: first[name] for name in dims if name in first.coords})
    product = product.assign_coords(xyz=first["xyz"])
    product.attrs = dict(first.attrs)
    centre = first["position"].values.reshape(-1, 3).mean(axis=0)
    variables, attrs = _elevation(raws, centre)
    for name, value in variables.items():
        product[name] = value
    product = product.assign_coords({"pass": np.arange(count)})
    product.attrs.update(attrs)
    product.attrs.update(
        passes=count, pass_combine=combine, pass_channels=[int(c) for c in channels],
        pass_raw_seeds=[int(raw.attrs.get("seed", -1)) for raw in raws],
        # each pass's own noise seed (an experiment's passes share the scene seed ``seed``)
        pass_noise_seeds=[int(raw.attrs.get("noise_seed", raw.attrs.get("pass_seed", -1)))
                          for raw in raws],
        pass_names=[str(raw.attrs.get("pass_name", k)) for k, raw in enumerate(raws)],
        algorithm=algorithm)
    product.attrs.pop("channel", None)
    return validate_image(product, "focus")
