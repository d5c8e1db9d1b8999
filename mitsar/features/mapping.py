"""From the raw products of several passes and the scene to a 3-D map and its scores.

:func:`map_scene` chains what the stages below it provide (docs/features.md "Mapping the
control volume"):

1. **the volume**: by default (:func:`map_grid`) the box around the *lit* surfaces of the scene,
   the surface samples (:func:`mitsar.scene.surfaces.sample_surface_points`) that some antenna
   position of the passes has in its beam, unoccluded (:func:`mitsar.features.truth.
   observe_points`), padded by two resolution extents (eq. M1); voxel steps of half the
   resolution cell along each world axis (below);
2. **the resolution cell** (:func:`map_resolution`) at the volume's centre, seen from the
   passes: range ``rho_r = c / (2 B)`` along the line of sight ``w_r``; the processed azimuth
   resolution ``rho_a`` along the track's component normal to it, ``w_a``; the elevation
   resolution of the stack ``rho_e = lambda R / (2 L_perp)`` (Reigber & Moreira 2000, eq. 4;
   docs/focusing.md eq. T2) along ``w_e = w_a x w_r``, or for passes with no spread across the
   line of sight the beam's elevation extent ``R beta_el`` (one pass does not resolve
   elevation). Its extent along world axis ``d`` (the resolution the CFAR window and the
   position uncertainty use, as :func:`mitsar.features.cfar.cfar` projects it) is

   ``rho_d = sqrt(sum_p (rho_p (w_p . e_d))^2)``                                         (M1)

   and the width of the response on a cut along ``d`` (a sampling bound: the spectrum's
   extent along ``k_d`` is ``sum_p`` of the ``1/rho_p`` bands projected) is

   ``c_d = 1 / sqrt(sum_p ((w_p . e_d) / rho_p)^2)``,   default step ``c_d / 2``         (M2)

   (the grids' half-cell step);
3. **focusing**: :func:`mitsar.focus` of every pass onto the voxels, combined coherently
   (tomographic back-projection, :mod:`mitsar.focus.passes`), with the processed azimuth
   resolution ``rho_a`` (default the range resolution: a cell as long in azimuth as in range,
   the paper's 0.10 m processing);
4. **detection**: :func:`mitsar.detect` (CA- or OS-CFAR at ``pfa``, clusters located in 3-D),
   with the resolution of (M1) along the grid's dims;
5. **scores**: :func:`mitsar.features.scores.map_scores` against the scene's truth cut to the
   volume, observability from the passes (a corner no pass sees is "not_visible", not
   "missed").

**Memory and tiles.** Before anything is focused, the peak memory of one tile,
``MAP_VOXEL_BYTES`` a voxel (the focus product's :data:`mitsar.focus.grid.PIXEL_BYTES` plus the
CFAR map's arrays), is checked against the budget (:func:`mitsar.budget.require_memory`), and
a volume of more than ``tile_voxels`` voxels is split along its longest axis into slabs. Each
slab is focused with a margin of the CFAR window's half-width on each side, so that every
tested voxel of its core sees the same training cells as in the whole volume; the detected
cells of the cores are clustered together (26-connected, as :func:`mitsar.features.clusters.
point_features`), so a tiled map equals the untiled one (``tests/test_mapping_control_volume
.py``). Slabs holding no lit surface sample (within a resolution cell) are not focused: the
map covers the lit part of the box.
"""

from __future__ import annotations

import math
from collections.abc import Iterator, Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from mitsar.budget import require_memory
from mitsar.errors import ParameterError
from mitsar.features.cfar import Window, cfar, default_window, make_window
from mitsar.features.clusters import peak_position_sigma, point_features
from mitsar.features.scores import SCORED_KINDS, map_scores
from mitsar.features.truth import SceneTruth, observe_points, observer_from_track, scene_truth
from mitsar.focus.dispatch import focus
from mitsar.focus.grid import PIXEL_BYTES, VolumeGrid
from mitsar.focus.passes import pass_phase_centres
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.model.geometry.tomography import effective_aperture, elevation_resolution
from mitsar.products.raw import radar_of
from mitsar.scene.loading import load_scene
from mitsar.scene.surfaces import sample_surface_points

__all__ = ["MAP_VOXEL_BYTES", "MapResolution", "SceneMap", "lit_bounds", "map_grid",
           "map_resolution", "map_scene", "pass_weights",
           "window_broadening"]

WHERE = "map_scene"

MAP_VOXEL_BYTES = PIXEL_BYTES + 128
"""Peak bytes a voxel of one tile: the focus product (:data:`mitsar.focus.grid.PIXEL_BYTES`)
and the CFAR map beside it (power, noise, threshold, training cells, flags: about 128)."""

DEFAULT_TILE_VOXELS = 2**21
"""Voxels of one tile (2 Mi: about 0.6 GB at :data:`MAP_VOXEL_BYTES`)."""

_DIMS = ("z", "y", "x")
"""Dims of a :class:`~mitsar.focus.grid.VolumeGrid` image; world axis of each: 2, 1, 0."""


@dataclass(frozen=True)
class MapResolution:
    """The resolution cell of a set of passes at a point (module docstring, eqs. M1-M2).

    Attributes
    ----------
    cells : numpy.ndarray, shape (3,)
        ``rho_r``, ``rho_a``, ``rho_e`` [m]: range, azimuth and elevation resolution.
    axes : numpy.ndarray, shape (3, 3)
        Rows ``w_r``, ``w_a``, ``w_e``: their world unit directions (orthonormal).
    slant_range : float
        Distance from the passes' mean aperture centre to the point [m].
    elevation_resolved : bool
        Whether the passes spread across the line of sight (else ``rho_e`` is the beam's
        elevation extent ``R beta_el``).
    pass_baselines : numpy.ndarray, shape (N,)
        Each pass's position along ``w_e`` from the passes' mean [m] (mean over its channels).
    pass_weights : numpy.ndarray, shape (N,)
        The elevation window's weight of each pass (:func:`pass_weights`; ones: none).
    """

    cells: NDArray[np.float64]
    axes: NDArray[np.float64]
    slant_range: float
    elevation_resolved: bool
    pass_baselines: NDArray[np.float64] = field(default_factory=lambda: np.zeros(1))
    pass_weights: NDArray[np.float64] = field(default_factory=lambda: np.ones(1))

    @property
    def extent(self) -> NDArray[np.float64]:
        """``rho_d`` along world x, y, z [m] (eq. M1)."""
        return np.sqrt(np.square(self.cells[:, None] * self.axes).sum(axis=0))

    @property
    def cut_width(self) -> NDArray[np.float64]:
        """``c_d`` along world x, y, z [m] (eq. M2)."""
        return 1.0 / np.sqrt(np.square(self.axes / self.cells[:, None]).sum(axis=0))

    def components(self, offset: Any) -> NDArray[np.float64]:
        """An offset (..., 3) [m] in resolution cells along range, azimuth and elevation."""
        return (np.asarray(offset, dtype=float) @ self.axes.T) / self.cells

    def within(self, offset: Any) -> NDArray[np.bool_]:
        """Whether offsets lie inside the resolution ellipsoid ``sum_p (o . w_p / rho_p)^2
        <= 1`` (one resolution cell in 3-D)."""
        return np.sum(np.square(self.components(offset)), axis=-1) <= 1.0


def _raws(raws: Any) -> list[xr.Dataset]:
    products = [raws] if isinstance(raws, xr.Dataset) else list(raws)
    if not products or not all(isinstance(r, xr.Dataset) and r.attrs.get("product") == "raw"
                               for r in products):
        raise ParameterError(WHERE, "raws", "a raw product or a non-empty list of raw "
                             "products (one per pass)", type(raws).__name__)
    return [_strided(raw) for raw in products]


def _strided(raw: xr.Dataset) -> xr.Dataset:
    """The product with ``sweep_stride`` recorded when it holds every s-th sweep (s > 1) of
    its acquisition and does not say so (``simulate_scene(sweeps=slice(0, None, s))``):
    back-projection's Doppler band selection samples the aperture at ``prf / sweep_stride``
    (:func:`mitsar.products.raw.sweep_rate`), and at the PRF it would select the wrong band."""
    sweeps = np.asarray(raw["sweep"].values, dtype=np.int64)
    if "sweep_stride" in raw.attrs or len(sweeps) < 2:
        return raw
    steps = np.unique(np.diff(sweeps))
    if len(steps) != 1 or steps[0] <= 1:
        return raw
    return raw.assign_attrs(sweep_stride=int(steps[0]))


def _positive(name: str, value: Any, unit: str = "m") -> float:
    if isinstance(value, bool) or not isinstance(value, int | float) \
            or not (math.isfinite(value) and value > 0):
        raise ParameterError(WHERE, name, f"a finite value > 0 {unit}", value)
    return float(value)


def _irw(weights: NDArray[np.float64], positions: NDArray[np.float64]) -> float:
    """-3 dB width of ``|sum_n w_n exp(-j 2 pi b_n f)|^2`` in ``f`` (units of 1/b), the
    first crossing of half the peak from ``f = 0`` on a fine grid (linear interpolation)."""
    span = float(np.ptp(positions)) or 1.0
    f = np.linspace(0.0, 2.0 / span, 4097)
    power = np.abs(np.exp(-2j * np.pi * np.outer(f, positions)) @ weights) ** 2
    power /= power[0]
    k = int(np.argmax(power < 0.5))
    return 2.0 * float(np.interp(0.5, power[k::-1], f[k::-1]))


def window_broadening(name: str | None) -> float:
    """Ratio of a window's -3 dB impulse-response width to the rectangular window's
    (:mod:`mitsar.focus.windows`; Hamming 1.47, Harris 1978 Table 1: 1.30 / 0.89 bins)."""
    coefficients = window_coefficients(name or "rect")
    x = (np.arange(256) + 0.5) / 256
    return _irw(evaluate_window(coefficients, x), x) / _irw(np.ones(256), x)


def map_resolution(raws: Any, point: Any, azimuth_resolution: float | None = None, *,
                   window: str | None = None, range_window: str | None = None,
                   elevation_window: str | None = None) -> MapResolution:
    """The resolution cell of the passes ``raws`` at ``point`` (module docstring).

    Parameters
    ----------
    raws : xarray.Dataset or sequence of them
        Raw products, one per pass.
    point : array_like, shape (3,)
        Where [m] (e.g. the volume's centre).
    azimuth_resolution : float, optional
        Processed azimuth resolution [m]; default the range resolution ``c / (2 B)``.
    window, range_window, elevation_window : str, optional
        Windows of the azimuth (and range, unless ``range_window``) processing
        (:func:`mitsar.focus`) and across the passes (:func:`map_scene`): each widens its
        cell by :func:`window_broadening` (the elevation one from the stack's own array
        factor, eq. T1 with the pass weights).

    Returns
    -------
    MapResolution
    """
    products = _raws(raws)
    point = np.asarray(point, dtype=float)
    radar = radar_of(products[0])
    rho_a = (radar.range_resolution if azimuth_resolution is None
             else _positive("azimuth_resolution", azimuth_resolution))
    per_pass = [pass_phase_centres(raw, point) for raw in products]
    centres = np.concatenate(per_pass)
    mean = centres.mean(axis=0)
    w_r = point - mean
    slant_range = float(np.linalg.norm(w_r))
    w_r /= max(slant_range, 1e-12)
    velocity = np.concatenate([raw["platform_velocity"].values for raw in products]).mean(0)
    v_perp = velocity - (velocity @ w_r) * w_r
    if not np.linalg.norm(v_perp) > 1e-9:
        raise ParameterError(WHERE, "raws", "passes whose track is not along the line of sight "
                             "to the volume", velocity.tolist())
    w_a = v_perp / np.linalg.norm(v_perp)
    w_e = np.cross(w_a, w_r)
    if w_e[2] < 0 or (w_e[2] == 0 and w_e[1] < 0):
        w_e = -w_e
    baselines = (centres - mean) @ w_e
    resolved = len(baselines) > 1 and float(np.ptp(baselines)) > 1e-9
    by_pass = np.array([float(np.mean((c - mean) @ w_e)) for c in per_pass])
    weights = pass_weights(by_pass, elevation_window)
    if resolved:
        rho_e = elevation_resolution(radar.wavelength, slant_range,
                                     effective_aperture(baselines))
        # The window widens the array factor (eq. T1 with the pass weights, each pass's
        # channels sharing its weight).
        counts = [len(c) for c in per_pass]
        each = np.repeat(weights, counts)
        rho_e *= _irw(each, baselines) / _irw(np.ones_like(baselines), baselines)
    else:
        rho_e = slant_range * radar.elevation_beamwidth
    rho_r = radar.range_resolution * window_broadening(range_window or window)
    return MapResolution(np.array([rho_r, rho_a * window_broadening(window), rho_e]),
                         np.array([w_r, w_a, w_e]), slant_range, bool(resolved), by_pass,
                         weights)


def pass_weights(baselines: Any, window: str | None) -> NDArray[np.float64]:
    """Weights of the passes across the stack, mean 1: the window (:mod:`mitsar.focus.windows`)
    at each pass's place in the aperture, ``x_n = (b_n - b_min) / (b_max - b_min) (N - 1) / N
    + 1 / (2 N)`` (the centre of its cell of a uniform stack, eq. T1 with weights: the
    coherent sum then has the window's lower elevation sidelobes and wider main lobe)."""
    b = np.asarray(baselines, dtype=float)
    if window in (None, "rect") or len(b) < 2 or not np.ptp(b) > 0:
        return np.ones(len(b))
    n = len(b)
    x = (b - b.min()) / np.ptp(b) * (n - 1) / n + 0.5 / n
    weights = evaluate_window(window_coefficients(window), x)
    return weights / weights.mean()


def lit_bounds(raws: Any, scene: Any, spacing: float = 0.1, *, seed: int = 0
               ) -> NDArray[np.float64] | None:
    """Box ``[[x0, y0, z0], [x1, y1, z1]]`` [m] of the surface samples some pass observes.

    Samples about ``spacing`` apart (:func:`mitsar.scene.surfaces.sample_surface_points`,
    ``seed`` for analytic shapes); observed = in the nominal beam of, and unoccluded from, an
    antenna position of a pass (:func:`mitsar.features.truth.observe_points`). None when
    nothing is lit.
    """
    scene = load_scene(scene) if isinstance(scene, str) else scene
    samples = sample_surface_points(scene, _positive("spacing", spacing), seed=seed)
    _, seen = observe_points(scene, samples.positions, samples.normals,
                             observer_from_track(_raws(raws)))
    if not seen.any():
        return None
    lit = samples.positions[seen]
    return np.array([lit.min(axis=0), lit.max(axis=0)])


def map_grid(raws: Any, scene: Any, *, azimuth_resolution: float | None = None,
             step: Any = None, margin: Any = None, seed: int = 0,
             windows: dict[str, str | None] | None = None) -> VolumeGrid:
    """Default volume of a map: the lit surfaces' box padded by two resolution extents.

    Parameters
    ----------
    raws : xarray.Dataset or sequence of them
        The passes.
    scene : mitsuba.Scene or str
    azimuth_resolution : float, optional
        Processed azimuth resolution [m] (default the range resolution).
    step : float or sequence of 3 float, optional
        Voxel step along x, y, z [m]; default half the cut width ``c_d`` (eq. M2) at the lit
        box's centre.
    margin : float or sequence of 3 float, optional
        Padding of the lit box along x, y, z [m]; default twice the resolution extent
        ``rho_d`` (eq. M1): a scatterer on the lit box's edge keeps its main lobe and first
        sidelobes inside, so its cluster is not cut.
    seed : int
        Seed of the surface sampler (analytic shapes).
    windows : dict, optional
        ``window``, ``range_window``, ``elevation_window`` of :func:`map_resolution`.

    Returns
    -------
    VolumeGrid
        Refused (:class:`~mitsar.errors.ParameterError`) when no pass lights any surface.
    """
    products = _raws(raws)
    radar = radar_of(products[0])
    box = lit_bounds(products, scene, radar.range_resolution, seed=seed)
    if box is None:
        raise ParameterError(WHERE, "raws", "passes whose beam lights some surface of the "
                             "scene (none does: give a grid)", len(products))
    cell = map_resolution(products, box.mean(axis=0), azimuth_resolution, **(windows or {}))
    steps = 0.5 * cell.cut_width if step is None else _triple("step", step)
    pad = 2.0 * cell.extent if margin is None else _triple("margin", margin, minimum=0.0)
    low, high = box[0] - pad, box[1] + pad
    # Whole steps from the padded box's low corner (stop included on the step).
    count = np.ceil((high - low) / steps - 1e-9)
    return VolumeGrid(*([float(low[a]), float(low[a] + count[a] * steps[a]), float(steps[a])]
                        for a in range(3)))


def _fit(window: Window, shape: tuple[int, ...], default: bool) -> Window:
    """The default CFAR window, narrowed where it is wider than the volume: as many training
    cells as fit (at least one), then guard cells (a pass far from the volume has a
    resolution cell larger than it). A window given by the caller is kept (and refused by
    :func:`mitsar.features.cfar.cfar` if it does not fit)."""
    if not default:
        return window
    guard, training = list(window.guard), list(window.training)
    for d, n in enumerate(shape):
        if 2 * (guard[d] + training[d]) + 1 > n:
            training[d] = max(1, min(training[d], (n - 1) // 2))
            guard[d] = max(0, (n - 1) // 2 - training[d])
    return Window(tuple(guard), tuple(training))


def _triple(name: str, value: Any, minimum: float | None = None) -> NDArray[np.float64]:
    array = np.atleast_1d(np.asarray(value, dtype=float))
    array = np.repeat(array, 3) if array.size == 1 else array
    ok = array.shape == (3,) and np.all(np.isfinite(array))
    ok = ok and (np.all(array > 0) if minimum is None else np.all(array >= minimum))
    if not ok:
        raise ParameterError(WHERE, name, "a length [m] or three (x, y, z), "
                             + ("> 0" if minimum is None else f">= {minimum}"), value)
    return array


# --------------------------------------------------------------------------------------------
# Tiles
# --------------------------------------------------------------------------------------------


def _tiles(axes: tuple[NDArray, ...], tile_voxels: int, half: tuple[int, ...]
           ) -> list[tuple[int, slice, slice]]:
    """Slabs of at most ``tile_voxels`` voxels along the longest axis (0, 1, 2 = x, y, z):
    ``(axis, core, extended)`` index slices, ``extended`` the core plus the CFAR window's
    half-width ``half`` (in (z, y, x) order) on each side, and at least two voxels (a grid
    axis needs two coordinates)."""
    sizes = [len(a) for a in axes]
    axis = int(np.argmax(sizes))
    other = math.prod(sizes) // sizes[axis]
    width = max(2, tile_voxels // max(other, 1))
    pad = half[2 - axis]
    out = []
    for a in range(0, sizes[axis], width):
        core = slice(a, min(a + width, sizes[axis]))
        start, stop = max(0, a - pad), min(a + width + pad, sizes[axis])
        out.append((axis, core, slice(max(0, min(start, stop - 2)), stop)))
    return out


def _sub_grid(grid: VolumeGrid, axes: tuple[NDArray, ...], axis: int, part: slice
              ) -> VolumeGrid:
    """The slab ``part`` of ``grid`` along world axis ``axis`` (the other axes as given)."""
    specs = [grid.x, grid.y, grid.z]
    specs[axis] = axes[axis][part]
    return VolumeGrid(*specs)


def _clusters(flat: NDArray[np.int64], shape: tuple[int, ...], power: NDArray,
              noise: NDArray, position: NDArray, attrs: dict) -> xr.Dataset:
    """:func:`mitsar.features.clusters.point_features` of detected cells given sparsely: flat
    indices (ascending) into a volume of ``shape``, their power, noise and position; clusters
    26-connected, numbered by their first cell in scan order, as ``ndimage.label`` does."""
    n = len(flat)
    index = np.array(np.unravel_index(flat, shape)).T                       # (n, 3)
    rows, cols = [np.arange(n)], [np.arange(n)]
    for offset in np.array(np.meshgrid(*[[-1, 0, 1]] * 3, indexing="ij")).reshape(3, -1).T:
        if not offset.any():
            continue
        other = index + offset
        valid = np.all((other >= 0) & (other < shape), axis=1)
        key = np.ravel_multi_index(tuple(np.where(valid[:, None], other, 0).T), shape)
        at = np.clip(np.searchsorted(flat, key), 0, max(n - 1, 0))
        hit = valid & (flat[at] == key) if n else valid
        rows.append(np.flatnonzero(hit))
        cols.append(at[hit])
    graph = coo_matrix((np.ones(sum(map(len, rows))), (np.concatenate(rows),
                                                        np.concatenate(cols))), shape=(n, n))
    count, label = connected_components(graph, directed=False) if n else (0, np.zeros(0, int))
    first = np.full(count, n)
    np.minimum.at(first, label, np.arange(n))          # cells are in scan order
    relabel = np.empty(count, dtype=int)
    relabel[np.argsort(first, kind="stable")] = np.arange(count)
    label = relabel[label]
    weight = np.bincount(label, power, minlength=count)
    centroid = np.stack([np.bincount(label, power * position[:, c], minlength=count)
                         for c in range(3)], axis=-1) / np.maximum(
                             weight, np.finfo(float).tiny)[:, None]
    # Peak: the largest power of each cluster, its first cell in scan order on ties.
    order = np.lexsort((np.arange(n), -power, label))
    peak = order[np.searchsorted(label[order], np.arange(count))]
    peak_power = power[peak]
    snr = np.maximum(peak_power / noise[peak] - 1.0, np.finfo(float).tiny)
    sizes = np.bincount(label, minlength=count)
    resolution = np.asarray(attrs["resolution"], float)
    axes = np.asarray(attrs["axes"], float).reshape(3, 3)
    uncertainty = np.sqrt(np.square(peak_position_sigma(resolution[None, :], snr[:, None]))
                          @ np.square(axes))
    rank = np.argsort(-peak_power, kind="stable")
    rank_of = np.empty(count, dtype=int)
    rank_of[rank] = np.arange(count)
    template = point_features(_EMPTY_MAP)               # variable attributes and dims
    data = {
        "position": centroid[rank], "amplitude": np.sqrt(peak_power[rank]), "snr": snr[rank],
        "snr_db": 10.0 * np.log10(snr[rank]), "uncertainty": uncertainty[rank],
        "cells": sizes[rank], "cell_position": position, "cell_amplitude": np.sqrt(power),
        "cell_snr": power / noise - 1.0, "cell_detection": rank_of[label]}
    out = xr.Dataset({name: (template[name].dims, value, template[name].attrs)
                      for name, value in data.items()}, coords={"xyz": ["x", "y", "z"]})
    out.attrs.update({k: v for k, v in attrs.items() if k != "product"},
                     product="detections")
    return out


_EMPTY_MAP = xr.Dataset(
    {"power": (_DIMS, np.zeros((1, 1, 1))), "noise": (_DIMS, np.ones((1, 1, 1))),
     "detected": (_DIMS, np.zeros((1, 1, 1), bool)),
     "position": (_DIMS + ("xyz",), np.zeros((1, 1, 1, 3)))},
    attrs={"product": "cfar", "dims": list(_DIMS), "resolution": [1.0, 1.0, 1.0],
           "axes": np.eye(3).ravel().tolist()})
"""A one-voxel CFAR map with nothing detected: :func:`point_features` of it gives the
detections' variables, dims and attributes for :func:`_clusters` to fill."""


# --------------------------------------------------------------------------------------------
# The map
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SceneMap:
    """A map of a scene from several passes and its scores (:func:`map_scene`).

    Unpacks as ``volume, detections, scores = map_scene(...)``.

    Attributes
    ----------
    volume : xarray.Dataset or None
        The focused volume (:func:`mitsar.focus` of the passes on ``grid``); None when it was
        focused in several tiles (``tiles`` > 1: only the detections are kept).
    detections : xarray.Dataset
        :func:`mitsar.detect` of the volume (point features and every detected cell).
    scores : dict
        :func:`mitsar.features.scores.map_scores` against the truth.
    grid : VolumeGrid
    resolution : MapResolution
        The resolution cell at the grid's centre.
    truth : SceneTruth
    tiles : int
        Slabs focused (1: the whole volume at once).
    tiles_skipped : int
        Slabs not focused: no lit surface in them.
    """

    volume: xr.Dataset | None
    detections: xr.Dataset
    scores: dict[str, Any]
    grid: VolumeGrid
    resolution: MapResolution
    truth: SceneTruth
    tiles: int = 1
    tiles_skipped: int = 0
    attrs: dict[str, Any] = field(default_factory=dict)

    def __iter__(self) -> Iterator[Any]:
        return iter((self.volume, self.detections, self.scores))


def map_scene(raws: Any, scene: Any, grid: VolumeGrid | None = None, *, pfa: float = 1e-6,
              method: str = "ca", tau: float = 0.05, combine: str = "coherent",
              azimuth_resolution: float | None = None, kinds: Sequence[str] = SCORED_KINDS,
              spacing: float | None = None, seed: int = 0,
              tile_voxels: int = DEFAULT_TILE_VOXELS, guard: Any = None, training: Any = None,
              elevation_window: str | None = None,
              focus_options: dict[str, Any] | None = None) -> SceneMap:
    """Map a scene from the raw products of one or more passes, and score the map.

    Steps, equations and the tiling in the module docstring (docs/features.md "Mapping the
    control volume").

    Parameters
    ----------
    raws : xarray.Dataset or sequence of them
        Raw products, one per pass (:func:`mitsar.simulate_scene`, ...), combined as
        ``combine`` says (:mod:`mitsar.focus.passes`).
    scene : mitsuba.Scene or str
        The scene they were simulated from (loaded, a path or a canned name): the truth.
    grid : VolumeGrid, optional
        The volume; default :func:`map_grid` (the lit surfaces' box, half-cell steps).
    pfa : float
        CFAR false-alarm probability per voxel (:func:`mitsar.detect`).
    method : {"ca", "os"}
        CFAR method.
    tau : float
        Distance threshold of the scores [m] (default 5 cm, half the paper radar's range
        resolution).
    combine : {"coherent", "incoherent"}
        How passes are summed (:func:`mitsar.focus`).
    azimuth_resolution : float, optional
        Processed azimuth resolution [m] (default the range resolution ``c / (2 B)``).
    kinds : sequence of str
        Feature kinds scored (default trihedral and dihedral).
    spacing : float, optional
        Truth sample spacing [m] (default ``tau``).
    seed : int
        Seed of the truth's surface sampler (recorded in the scores).
    tile_voxels : int
        Largest slab focused at once [voxels] (module docstring).
    guard, training : int or sequence of 3 int, optional
        CFAR window per dim (z, y, x); default one resolution cell of guard (eq. M1 over the
        steps) and as much training (docs/features.md §2).
    elevation_window : str, optional
        Window across the passes ("hamming", ...; :func:`pass_weights`): each pass's raw
        samples are scaled by its weight before the coherent sum, lowering the elevation
        sidelobes of the stack's array factor (eq. T1) and widening ``rho_e`` by as much as
        the weighted array factor is wider (:func:`map_resolution`). Default none.
    focus_options : dict, optional
        More keywords of :func:`mitsar.focus` (``window``, ``backend``, ...); ``window`` and
        ``range_window`` widen the resolution cell (:func:`window_broadening`).

    Returns
    -------
    SceneMap
        ``volume, detections, scores`` (it unpacks so), the grid, the resolution cell, the
        truth and the tiling.

    Raises
    ------
    ParameterError
        Bad arguments; passes that light no surface (without a grid).
    MemoryBudgetError
        A tile that would not fit in memory (before anything is focused).
    """
    products = _raws(raws)
    if isinstance(tile_voxels, bool) or not isinstance(tile_voxels, int | np.integer) \
            or tile_voxels < 1:
        raise ParameterError(WHERE, "tile_voxels", "an integer >= 1", tile_voxels)
    options = dict(focus_options or {})
    for name in ("grid", "combine", "azimuth_resolution", "algorithm"):
        if name in options:
            raise ParameterError(WHERE, f"focus_options[{name!r}]", f"{name} as map_scene's "
                                 "own argument (bpa is the algorithm)", options[name])
    windows = {"window": options.get("window"), "range_window": options.get("range_window"),
               "elevation_window": elevation_window}
    if elevation_window is not None and combine != "coherent":
        raise ParameterError(WHERE, "elevation_window", "None with combine='incoherent' (a "
                             "window across the passes shapes their coherent sum)",
                             elevation_window)
    scene = load_scene(scene) if isinstance(scene, str) else scene
    if grid is None:
        grid = map_grid(products, scene, azimuth_resolution=azimuth_resolution, seed=seed,
                        windows=windows)
    if not isinstance(grid, VolumeGrid):
        raise ParameterError(WHERE, "grid", "a VolumeGrid (or None: the lit surfaces' box)",
                             type(grid).__name__)
    axes = grid.axes()                       # refused here if the voxels alone do not fit
    centre = np.array([a.mean() for a in axes])
    cell = map_resolution(products, centre, azimuth_resolution, **windows)
    steps = np.array([np.diff(a).mean() if len(a) > 1 else cell.extent[k]
                      for k, a in enumerate(axes)])
    resolution = cell.extent[::-1]            # along the dims (z, y, x)
    window = _fit(make_window(3, guard, training,
                              default_window(resolution, steps[::-1], True)),
                  tuple(len(axes[k]) for k in (2, 1, 0)), guard is None and training is None)
    tiles = _tiles(axes, int(tile_voxels), window.half)
    largest = max(math.prod(len(a) for a in axes) // len(axes[t[0]])
                  * (t[2].stop - t[2].start) for t in tiles)
    require_memory(WHERE, "grid", float(largest) * MAP_VOXEL_BYTES,
                   f"{largest:.3g} voxels a tile: a smaller tile_voxels, a coarser step or a "
                   "smaller volume")
    rho_a = cell.cells[1] / window_broadening(windows["window"])   # the processed one
    if elevation_window is not None:         # scale each pass by its weight (mean 1)
        products = [raw.assign(raw=raw["raw"].copy(data=raw["raw"].values * weight))
                    for raw, weight in zip(products, cell.pass_weights, strict=True)]
    detect = {"pfa": pfa, "method": method, "guard": window.guard,
              "training": window.training, "resolution": resolution}
    volume = None
    if len(tiles) == 1:
        volume = focus(products, "bpa", grid, azimuth_resolution=rho_a, combine=combine,
                       **options)
        found = point_features(volume, **detect)
        skipped = 0
    else:
        found, skipped = _tiled(products, scene, grid, axes, tiles, cell, detect,
                                dict(options, azimuth_resolution=rho_a, combine=combine), seed)
    truth = scene_truth(scene, float(spacing) if spacing is not None else tau, track=products,
                        bounds=grid, seed=seed)
    scores = map_scores(found, truth, tau, kinds=kinds)
    attrs = {"pfa": float(pfa), "method": method, "tau": float(tau), "combine": combine,
             "azimuth_resolution": float(rho_a), "truth_seed": int(seed),
             "elevation_window": elevation_window or "rect",
             "pass_weights": [float(w) for w in cell.pass_weights],
             "passes": len(products),
             "pass_raw_seeds": [int(r.attrs.get("seed", -1)) for r in products]}
    return SceneMap(volume, found, scores, grid, cell, truth, len(tiles) - skipped, skipped,
                    attrs)


def _tiled(products: list[xr.Dataset], scene: Any, grid: VolumeGrid,
           axes: tuple[NDArray, ...],
           tiles: list[tuple[int, slice, slice]], cell: MapResolution, detect: dict,
           options: dict, seed: int) -> tuple[xr.Dataset, int]:
    """Focus and test slab by slab; cluster the cores' detected cells together."""
    shape = tuple(len(axes[k]) for k in (2, 1, 0))
    radar = radar_of(products[0])
    samples = sample_surface_points(scene, radar.range_resolution, seed=seed)
    _, seen = observe_points(scene, samples.positions, samples.normals,
                             observer_from_track(products))
    lit_points = samples.positions[seen]
    flats, powers, noises, positions = [], [], [], []
    attrs: dict[str, Any] = {}
    pad = cell.extent[tiles[0][0]]
    lit = [bool(np.any((lit_points[:, axis] >= axes[axis][core.start] - pad)
                       & (lit_points[:, axis] <= axes[axis][core.stop - 1] + pad)))
           for axis, core, _ in tiles]
    lit[0] = lit[0] or not any(lit)          # nothing lit: one slab still says so (no cells)
    for (axis, core, extended), keep_tile in zip(tiles, lit, strict=True):
        if not keep_tile:                    # a loop over slabs; each is one focus and CFAR
            continue
        volume = focus(products, "bpa", _sub_grid(grid, axes, axis, extended), **options)
        cmap = cfar(volume, **detect)
        attrs = attrs or dict(cmap.attrs)
        detected = cmap["detected"].transpose(*_DIMS).values
        keep = np.zeros_like(detected)
        dim = 2 - axis
        inner = [slice(None)] * 3
        inner[dim] = slice(core.start - extended.start, core.stop - extended.start)
        keep[tuple(inner)] = detected[tuple(inner)]
        local = np.nonzero(keep)
        index = list(local)
        index[dim] = index[dim] + extended.start
        flats.append(np.ravel_multi_index(tuple(index), shape))
        powers.append(cmap["power"].transpose(*_DIMS).values[local])
        noises.append(cmap["noise"].transpose(*_DIMS).values[local])
        positions.append(cmap["position"].transpose(*_DIMS, "xyz").values[local])
    flat = np.concatenate(flats)
    order = np.argsort(flat, kind="stable")
    return (_clusters(flat[order], shape, np.concatenate(powers)[order],
                      np.concatenate(noises)[order], np.concatenate(positions)[order], attrs),
            len(tiles) - sum(lit))
