"""Resolution and ambiguity maps by the gradient method (paper §2; Moccia & Renga 2011).

For every point ``x`` of a set of surface points (sampled on the shapes of a Mitsuba scene, on
planar rectangles, or given as arrays of points and normals) and every platform state ``k`` of a
subsampling of the sweeps (antenna at ``p``, velocity ``v``), with ``u = (x - p) / R`` the unit
line of sight from the antenna to the point and ``R = |x - p|``:

* delay gradient ``grad tau = (2 / c) u``;
* Doppler gradient ``grad f_D = (2 / lambda) (v - (v . u) u) / R``
  (``f_D = (2 / lambda) v . u`` for a static point);
* both are projected on the local tangent plane of the surface, ``g_t = g - (g . n) n``;
* range resolution ``rho_r = 1 / (B |grad_t tau|)`` along ``grad_t tau``, azimuth resolution
  ``rho_a = 1 / (T_int |grad_t f_D|)`` along ``grad_t f_D``, and the angle ``Theta`` between
  the two projected gradients (folded into [0, 90] deg). The impulse response on the surface is
  ``sinc(B grad_t tau . dx) sinc(T_int grad_t f_D . dx)``; ``rho`` is its nominal width (the
  -3 dB width is 0.886 rho). The resolution cell is the parallelogram with sides
  ``rho_r / sin Theta`` (along the iso-Doppler line) and ``rho_a / sin Theta`` (along the
  iso-range line), area ``rho_r rho_a / sin Theta``.

A point is *illuminated* at a state when it is inside the beam (two-way pattern at least
``beam_threshold_db``, default -6 dB, i.e. inside the one-way half-power beam), within the
radar's ``max_range``, and not shadowed (``scene.ray_test`` from the point toward the antenna).
Surfaces are treated as two-sided; the normal is flipped toward the antenna.

Integration time ``T_int`` (the choices are discussed in ``docs/ambiguity.md``):

* ``None`` or ``"beam"`` (default): the time the point stays illuminated, i.e. the duration of
  the contiguous run of illuminated states holding the state (run ends interpolated linearly in
  two-way pattern power between states where the run ends at the beam edge);
* a number [s]: a fixed processed aperture time, capped by the illuminated run;
* ``"required"``: the aperture a processor would choose to reach ``required_resolution`` in the
  slant plane, ``T = 1 / (rho_req |grad f_D|)`` (unprojected gradient), capped by the run.

A point is *ambiguous* at an illuminated state when ``Theta < min_angle_deg`` or a resolution is
worse than ``required_resolution`` (``criterion="gradient"``: ``rho_r`` and ``rho_a``;
``criterion="cell"``: the cell sides ``rho / sin Theta``). It is *resolved* at that state
otherwise. Over the trajectory every point gets its best range and azimuth resolutions (with
when and from where), the single best state, and a status: never in the beam, in the beam but
always shadowed, observed only ambiguously, or resolved at least once.

Everything is vectorised over points x states with NumPy (chunked over points); shadow rays of
the in-beam pairs go to Mitsuba's ``ray_test`` in one wavefront per chunk.
"""

from __future__ import annotations

import json
import math
import os
import tomllib
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.version import __version__
from mitsar.errors import ParameterError
from mitsar.model.geometry.antenna import one_way_pattern
from mitsar.model.geometry.attitude import Look, antenna_frame
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import SPEED_OF_LIGHT, Radar

__all__ = [
    "OBSERVATION_MEANINGS",
    "STATUS_MEANINGS",
    "SurfacePoints",
    "ambiguity",
    "compare_trajectories",
    "comparison_from_products",
    "comparison_table",
    "delay_gradient",
    "doppler_gradient",
    "gradient_resolution",
    "load_ambiguity_experiment",
    "load_mitsuba_scene",
    "plane_points",
    "planes_scene",
    "plot_ambiguity",
    "plot_ambiguity_3d",
    "plot_ambiguity_maps",
    "plot_ambiguity_timeline",
    "plot_comparison",
    "run_ambiguity_experiment",
    "sample_surfaces",
    "surface_summary",
]

OBSERVATION_MEANINGS = ("outside_beam", "shadowed", "ambiguous", "resolved")
"""Meanings of the per-state ``observation`` codes 0..3."""

STATUS_MEANINGS = ("never_in_beam", "shadowed", "only_ambiguous", "resolved")
"""Meanings of the per-point ``status`` codes 0..3 (best observation over the trajectory)."""

INTEGRATION_MODES = ("beam", "required")
CRITERIA = ("gradient", "cell")
_STATUS_COLOURS = ("#bdbdbd", "#636363", "#e6550d", "#31a354")


# --------------------------------------------------------------------------------------------
# Physics: gradients and resolutions (pure NumPy)
# --------------------------------------------------------------------------------------------
def delay_gradient(points: ArrayLike, antenna: ArrayLike) -> NDArray[np.float64]:
    """Gradient of the two-way delay with respect to the point position [s/m].

    ``grad tau = (2 / c) (x - p) / |x - p|``; shapes broadcast, last axis xyz.
    """
    offset = np.asarray(points, dtype=float) - np.asarray(antenna, dtype=float)
    distance = np.linalg.norm(offset, axis=-1, keepdims=True)
    return 2.0 / SPEED_OF_LIGHT * offset / distance


def doppler_gradient(points: ArrayLike, antenna: ArrayLike, velocity: ArrayLike,
                     wavelength: float) -> NDArray[np.float64]:
    """Gradient of the Doppler frequency with respect to the point position [Hz/m].

    ``grad f_D = (2 / lambda) (v - (v . u) u) / R`` with ``u = (x - p) / R`` and
    ``f_D = (2 / lambda) v . u`` (static point, platform velocity ``v``).
    """
    offset = np.asarray(points, dtype=float) - np.asarray(antenna, dtype=float)
    distance = np.linalg.norm(offset, axis=-1, keepdims=True)
    unit = offset / distance
    velocity = np.asarray(velocity, dtype=float)
    radial = np.sum(velocity * unit, axis=-1, keepdims=True)
    return 2.0 / wavelength * (velocity - radial * unit) / distance


def _project(vectors: NDArray, normals: NDArray | None) -> NDArray:
    """Component of ``vectors`` in the tangent plane of unit ``normals`` (None: unchanged)."""
    if normals is None:
        return vectors
    return vectors - np.sum(vectors * normals, axis=-1, keepdims=True) * normals


def gradient_resolution(points: ArrayLike, normals: ArrayLike | None, antenna: ArrayLike,
                        velocity: ArrayLike, radar: Radar,
                        integration_time: ArrayLike) -> dict[str, NDArray]:
    """Gradient-method resolutions of points seen from one or more platform states.

    Parameters
    ----------
    points : array_like, shape (..., 3)
        Points on a surface [m].
    normals : array_like, shape (..., 3), or None
        Unit surface normals; ``None`` keeps the 3-D gradients (slant plane).
    antenna, velocity : array_like, shape (..., 3)
        Antenna phase centre [m] and platform velocity [m/s]; broadcast against ``points``.
    radar : Radar
    integration_time : array_like
        Integration time T_int [s], broadcast against the leading shape.

    Returns
    -------
    dict
        ``range_resolution`` and ``azimuth_resolution`` [m] (inf where the projected gradient
        vanishes), ``angle`` between the projected gradients [rad, 0..pi/2], ``range_direction``
        and ``azimuth_direction`` (unit vectors of the projected gradients), ``delay_gradient``
        and ``doppler_gradient`` (projected, s/m and Hz/m).

    Examples
    --------
    Broadside over a flat floor: ground-range resolution c / (2 B sin theta_inc).

    >>> r = gradient_resolution([0, 4, 0], [0, 0, 1], [0, 0, 3], [0.5, 0, 0], Radar(), 0.16)
    >>> round(float(r["range_resolution"]), 4), round(float(np.degrees(r["angle"])), 1)
    (0.1249, 90.0)
    """
    points = np.asarray(points, dtype=float)
    normals = None if normals is None else np.asarray(normals, dtype=float)
    g_tau = _project(delay_gradient(points, antenna), normals)
    g_fd = _project(doppler_gradient(points, antenna, velocity, radar.wavelength), normals)
    n_tau = np.linalg.norm(g_tau, axis=-1)
    n_fd = np.linalg.norm(g_fd, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho_r = 1.0 / (radar.bandwidth * n_tau)
        rho_a = 1.0 / (np.asarray(integration_time, dtype=float) * n_fd)
        cosine = np.abs(np.sum(g_tau * g_fd, axis=-1)) / (n_tau * n_fd)
        angle = np.arccos(np.clip(np.where(np.isfinite(cosine), cosine, 1.0), 0.0, 1.0))
        range_direction = g_tau / n_tau[..., None]
        azimuth_direction = g_fd / n_fd[..., None]
    return {"range_resolution": rho_r, "azimuth_resolution": rho_a, "angle": angle,
            "range_direction": range_direction, "azimuth_direction": azimuth_direction,
            "delay_gradient": g_tau, "doppler_gradient": g_fd}


# --------------------------------------------------------------------------------------------
# Surface points
# --------------------------------------------------------------------------------------------
def _unit_rows(vectors: NDArray) -> NDArray:
    norm = np.linalg.norm(vectors, axis=-1, keepdims=True)
    return vectors / np.where(norm > 0, norm, 1.0)


def _map_axes(normal: NDArray) -> tuple[NDArray, NDArray]:
    """In-plane axes of an unfolded map: x/y for horizontal surfaces, horizontal/up otherwise."""
    normal = normal / max(np.linalg.norm(normal), 1e-12)
    if abs(normal[2]) > 0.7:
        e1 = np.array([1.0, 0.0, 0.0]) - normal[0] * normal
        e1 /= np.linalg.norm(e1)
        e2 = np.cross(normal, e1)
        if e2[1] < 0:
            e2 = -e2
        return e1, e2
    e1 = np.array([-normal[1], normal[0], 0.0])
    e1 /= np.linalg.norm(e1)
    if e1[np.argmax(np.abs(e1))] < 0:
        e1 = -e1
    e2 = np.array([0.0, 0.0, 1.0]) - normal[2] * normal
    e2 /= np.linalg.norm(e2)
    return e1, e2


def _direction_label(normal: NDArray) -> str:
    """``+x``, ``-z``, ... for axis-aligned normals, else the rounded vector."""
    axis = int(np.argmax(np.abs(normal)))
    if abs(normal[axis]) > 0.95:
        return ("+" if normal[axis] > 0 else "-") + "xyz"[axis]
    return "(" + ", ".join(f"{c:.1f}" for c in normal) + ")"


def _facets(position: NDArray, normal: NDArray | None, surface: NDArray,
            names: Sequence[str], max_facets: int = 6) -> tuple[NDArray, tuple[str, ...],
                                                                   NDArray]:
    """Group each surface's points into planar facets by normal; unfold every facet.

    Points whose normals agree within 18 deg form one facet (a box has six); a surface with
    more than ``max_facets`` orientations (a curved mesh) is one facet mapped on the plane of
    least variance.

    Returns
    -------
    facet : ndarray of int, shape (n,)
    facet_names : tuple of str
    map_uv : ndarray, shape (n, 2)
        In-plane coordinates [m] of each point in its facet's map.
    """
    facet = np.zeros(len(position), dtype=int)
    labels: list[str] = []
    uv = np.zeros((len(position), 2))
    for index, name in enumerate(names):
        members = np.flatnonzero(surface == index)
        if members.size == 0:
            continue
        groups: list[NDArray] = []
        if normal is not None:
            remaining = members
            while remaining.size and len(groups) <= max_facets:
                reference = normal[remaining[0]]
                inside = normal[remaining] @ reference > 0.95
                groups.append(remaining[inside])
                remaining = remaining[~inside]
            if remaining.size or len(groups) > max_facets:
                groups = [members]
        else:
            groups = [members]
        for group in groups:
            mean = normal[group].mean(axis=0) if normal is not None else np.zeros(3)
            if np.linalg.norm(mean) < 0.9:  # curved or closed: plane of least variance
                centred = position[group] - position[group].mean(axis=0)
                mean = (np.linalg.svd(centred, full_matrices=False)[2][-1] if len(group) >= 3
                        else np.array([0.0, 0.0, 1.0]))
                label = name
            else:
                mean = mean / np.linalg.norm(mean)
                label = name if len(groups) == 1 else f"{name} {_direction_label(mean)}"
            e1, e2 = _map_axes(mean)
            facet[group] = len(labels)
            labels.append(label)
            uv[group] = np.stack([position[group] @ e1, position[group] @ e2], axis=-1)
    return facet, tuple(labels), uv


@dataclass(frozen=True)
class SurfacePoints:
    """Points on surfaces, with normals, area weights, and the surface each belongs to.

    Build with :meth:`from_arrays`, :func:`plane_points` or :func:`sample_surfaces`.

    Attributes
    ----------
    position : ndarray, shape (n, 3)
        Points [m].
    normal : ndarray, shape (n, 3), or None
        Unit normals (None: no surface, 3-D gradients).
    area : ndarray, shape (n,)
        Area represented by each point [m^2] (weights of the per-surface fractions).
    surface : ndarray of int, shape (n,)
        Index of each point's surface (shape) in ``names``.
    names : tuple of str
        Surface (shape) names.
    facet : ndarray of int, shape (n,)
        Index of each point's planar facet in ``facet_names`` (a box shape has six).
    facet_names : tuple of str
    map_uv : ndarray, shape (n, 2)
        Unfolded in-plane coordinates of each point in its facet's map [m].
    """

    position: NDArray
    normal: NDArray | None
    area: NDArray
    surface: NDArray
    names: tuple[str, ...]
    facet: NDArray
    facet_names: tuple[str, ...]
    map_uv: NDArray

    @classmethod
    def from_arrays(cls, position: ArrayLike, normal: ArrayLike | None = None,
                    area: ArrayLike | None = None, surface: ArrayLike | None = None,
                    names: Sequence[str] | None = None) -> SurfacePoints:
        """Points from arrays.

        Parameters
        ----------
        position : array_like, shape (n, 3)
        normal : array_like, shape (n, 3) or (3,), optional
            Normals (normalised here); one vector applies to every point (e.g. ``(0, 0, 1)``
            projects volume points on horizontal planes). None keeps 3-D gradients.
        area : array_like, shape (n,) or scalar, optional
            Area per point [m^2]; default 1.
        surface : array_like of int, shape (n,), optional
            Surface index of each point; default 0.
        names : sequence of str, optional
            Surface names; default ``surface0``, ``surface1``, ...
        """
        where = "SurfacePoints"
        position = np.asarray(position, dtype=float)
        if position.shape == (3,):
            position = position[None]
        if position.ndim != 2 or position.shape[1] != 3 or len(position) == 0:
            raise ParameterError(where, "position", "an array of shape (n, 3), n >= 1",
                                 position.shape)
        if not np.all(np.isfinite(position)):
            raise ParameterError(where, "position", "finite coordinates [m]", "non-finite")
        n = len(position)
        if normal is not None:
            normal = np.asarray(normal, dtype=float)
            if normal.shape not in ((3,), (n, 3)):
                raise ParameterError(where, "normal", f"shape (3,) or ({n}, 3)", normal.shape)
            normal = np.broadcast_to(normal, (n, 3)).copy()
            norm = np.linalg.norm(normal, axis=-1)
            if not np.all(np.isfinite(norm)) or np.any(norm <= 0):
                raise ParameterError(where, "normal", "non-zero finite normals", "zero/NaN")
            normal = normal / norm[:, None]
        area = np.asarray(1.0 if area is None else area, dtype=float)
        if area.shape not in ((), (n,)):
            raise ParameterError(where, "area", f"a scalar or shape ({n},)", area.shape)
        area = np.broadcast_to(area, (n,)).copy()
        if np.any(~np.isfinite(area)) or np.any(area < 0):
            raise ParameterError(where, "area", "areas >= 0 [m^2]", "negative/NaN")
        surface = np.zeros(n, int) if surface is None else np.asarray(surface)
        if surface.shape != (n,) or surface.dtype.kind not in "iu" or surface.min() < 0:
            raise ParameterError(where, "surface", f"{n} integer indices >= 0",
                                 f"shape {surface.shape}, dtype {surface.dtype}")
        surface = surface.astype(int)
        count = int(surface.max()) + 1
        names = (tuple(str(s) for s in names) if names is not None
                 else tuple(f"surface{i}" for i in range(count)))
        if len(names) < count:
            raise ParameterError(where, "names", f"at least {count} names", len(names))
        facet, facet_names, uv = _facets(position, normal, surface, names)
        return cls(position, normal, area, surface, names, facet, facet_names, uv)

    def __len__(self) -> int:
        return len(self.position)

    @classmethod
    def concatenate(cls, parts: Sequence[SurfacePoints]) -> SurfacePoints:
        """Join point sets; surfaces and facets are renumbered, names kept in order."""
        if not parts:
            raise ParameterError("SurfacePoints.concatenate", "parts", "at least one", 0)
        normals = [p.normal for p in parts]
        if any(n is None for n in normals) and not all(n is None for n in normals):
            raise ParameterError("SurfacePoints.concatenate", "normal",
                                 "all parts with normals or none", "a mix")
        surface_offsets = np.cumsum([0] + [len(p.names) for p in parts[:-1]])
        facet_offsets = np.cumsum([0] + [len(p.facet_names) for p in parts[:-1]])
        return cls(
            np.vstack([p.position for p in parts]),
            None if normals[0] is None else np.vstack(normals),
            np.concatenate([p.area for p in parts]),
            np.concatenate([p.surface + o for p, o in zip(parts, surface_offsets,
                                                          strict=True)]),
            tuple(name for p in parts for name in p.names),
            np.concatenate([p.facet + o for p, o in zip(parts, facet_offsets, strict=True)]),
            tuple(name for p in parts for name in p.facet_names),
            np.vstack([p.map_uv for p in parts]))


def plane_points(origin: ArrayLike, axis_u: ArrayLike, axis_v: ArrayLike,
                 size: ArrayLike, spacing: float, name: str = "plane") -> SurfacePoints:
    """A regular grid of points on the rectangle ``origin + s axis_u + t axis_v``.

    Parameters
    ----------
    origin : array_like, shape (3,)
        A corner [m].
    axis_u, axis_v : array_like, shape (3,)
        Orthogonal edge directions (normalised here).
    size : array_like, shape (2,)
        Extent along ``axis_u`` and ``axis_v`` [m].
    spacing : float
        Grid step [m]; points sit at cell centres.
    name : str
        Surface name.
    """
    origin = np.asarray(origin, dtype=float)
    u, v = _unit_rows(np.asarray(axis_u, float)), _unit_rows(np.asarray(axis_v, float))
    size = np.asarray(size, dtype=float)
    if origin.shape != (3,) or u.shape != (3,) or v.shape != (3,) or size.shape != (2,):
        raise ParameterError("plane_points", "origin/axis_u/axis_v/size",
                             "3, 3, 3 and 2 numbers", (origin.shape, u.shape, v.shape,
                                                       size.shape))
    if abs(u @ v) > 1e-6 or np.linalg.norm(u) == 0 or np.linalg.norm(v) == 0:
        raise ParameterError("plane_points", "axis_u/axis_v", "orthogonal non-zero vectors",
                             (u.tolist(), v.tolist()))
    if np.any(size <= 0) or not spacing > 0:
        raise ParameterError("plane_points", "size/spacing", "positive sizes and spacing [m]",
                             (size.tolist(), spacing))
    nu, nv = (max(1, int(round(s / spacing))) for s in size)
    su = (np.arange(nu) + 0.5) * size[0] / nu
    sv = (np.arange(nv) + 0.5) * size[1] / nv
    grid_u, grid_v = np.meshgrid(su, sv, indexing="ij")
    position = origin + grid_u.reshape(-1, 1) * u + grid_v.reshape(-1, 1) * v
    normal = np.cross(u, v)
    area = size[0] * size[1] / (nu * nv)
    return SurfacePoints.from_arrays(position, normal, area, names=[name])


# --------------------------------------------------------------------------------------------
# Mitsuba: scenes, surface sampling, shadow rays
# --------------------------------------------------------------------------------------------
def _mitsuba() -> Any:
    """Import Mitsuba with a supported variant set.

    :func:`mitsar.scene.scene.ensure_variant` picks it (``llvm_ad_mono``; ``cuda_ad_mono`` with a GPU)
    and checks the LLVM backend; without the scene module, ``llvm_ad_mono`` after
    :func:`mitsar.backend.require_llvm`.
    """
    import mitsuba as mi

    try:
        from mitsar.scene.scene import ensure_variant
    except ImportError:
        ensure_variant = None
    if ensure_variant is not None:
        ensure_variant()
    elif mi.variant() is None:
        from mitsar.backend import require_llvm

        require_llvm()
        mi.set_variant("llvm_ad_mono")
    return mi


def load_mitsuba_scene(scene: Any) -> Any:
    """A Mitsuba scene from a scene object, an XML path or a canned scene name.

    Uses :func:`mitsar.scene.scene.load_scene` (plugin registration, scene defaults) when available,
    else ``mitsuba.load_file``.
    """
    mi = _mitsuba()
    if isinstance(scene, mi.Scene):
        return scene
    if not isinstance(scene, str | os.PathLike):
        raise ParameterError("ambiguity", "scene", "a Mitsuba scene, an XML path or a canned "
                             "scene name", type(scene).__name__)
    try:
        from mitsar.scene.scene import load_scene  # the scene module (plugins registered there)
    except ImportError:
        load_scene = None
    if load_scene is not None:
        return load_scene(scene)
    path = Path(scene).expanduser()
    if not path.exists():
        from mitsar.scene.canned import path as canned_path

        path = canned_path(str(scene))
    return mi.load_file(str(path))


def _shape_name(shape: Any, index: int) -> str:
    name = shape.id()
    return name if name else f"shape{index}"


def _triangle_points(vertices: NDArray, faces: NDArray, spacing: float,
                     rng: np.random.Generator) -> tuple[NDArray, NDArray, NDArray]:
    """Points about ``spacing`` apart on a triangle mesh, with face normals and area weights.

    Each triangle gets a grid along its two edges from the vertex opposite its longest edge
    (a right-angle vertex for rectangle halves); cell centres inside the triangle are kept and
    share its area. Triangles smaller than one cell keep their centroid with probability
    ``area / spacing^2`` (weight ``spacing^2``), so fine meshes are not oversampled.
    """
    a, b, c = (vertices[faces[:, i]] for i in range(3))
    lengths = np.stack([np.linalg.norm(c - b, axis=1), np.linalg.norm(a - c, axis=1),
                        np.linalg.norm(b - a, axis=1)], axis=1)  # opposite a, b, c
    apex = np.argmax(lengths, axis=1)
    corners = np.stack([a, b, c], axis=1)
    rows = np.arange(len(faces))
    origin = corners[rows, apex]
    edge_1 = corners[rows, (apex + 1) % 3] - origin
    edge_2 = corners[rows, (apex + 2) % 3] - origin
    cross = np.cross(edge_1, edge_2)
    double_area = np.linalg.norm(cross, axis=1)
    keep = double_area > 0
    normal = cross / np.where(keep, double_area, 1.0)[:, None]
    # Orientation from the original winding (the apex rotation keeps it).
    area = 0.5 * double_area
    n1 = np.maximum(1, np.ceil(np.linalg.norm(edge_1, axis=1) / spacing)).astype(int)
    n2 = np.maximum(1, np.ceil(np.linalg.norm(edge_2, axis=1) / spacing)).astype(int)
    small = keep & (area < spacing**2)
    positions, normals, weights = [], [], []
    chosen = small & (rng.random(len(faces)) < area / spacing**2)
    if np.any(chosen):
        positions.append(origin[chosen] + (edge_1[chosen] + edge_2[chosen]) / 3)
        normals.append(normal[chosen])
        weights.append(np.full(int(chosen.sum()), spacing**2))
    large = keep & ~small
    for m1, m2 in {(int(i), int(j)) for i, j in zip(n1[large], n2[large], strict=True)}:
        group = np.flatnonzero(large & (n1 == m1) & (n2 == m2))
        s, t = np.meshgrid((np.arange(m1) + 0.5) / m1, (np.arange(m2) + 0.5) / m2,
                           indexing="ij")
        inside = s + t <= 1.0 + 1e-9
        s, t = s[inside], t[inside]
        if s.size == 0:
            s, t = np.array([1 / 3]), np.array([1 / 3])
        pts = (origin[group, None, :] + s[None, :, None] * edge_1[group, None, :]
               + t[None, :, None] * edge_2[group, None, :])
        positions.append(pts.reshape(-1, 3))
        normals.append(np.repeat(normal[group], s.size, axis=0))
        weights.append(np.repeat(area[group] / s.size, s.size))
    if not positions:
        return np.zeros((0, 3)), np.zeros((0, 3)), np.zeros(0)
    return np.vstack(positions), np.vstack(normals), np.concatenate(weights)


def sample_surfaces(scene: Any, spacing: float = 0.25, *, shapes: Sequence[str] | None = None,
                    exclude: Sequence[str] = (), min_area: float = 0.0,
                    seed: int = 0) -> SurfacePoints:
    """Points with normals on the surfaces of a Mitsuba scene, about ``spacing`` apart.

    Rectangle-like shapes (whose ``sample_position`` maps the unit square affinely onto them)
    get a regular grid of cell centres with a step close to ``spacing`` along each edge; other
    triangle meshes get per-triangle grids (:func:`_triangle_points`); analytic shapes
    (sphere, disk, ...) get ``area / spacing^2`` seeded uniform samples. Shapes are taken in
    the order of their ids.

    Parameters
    ----------
    scene : mitsuba.Scene, path or canned scene name
    spacing : float
        Target point spacing [m].
    shapes : sequence of str, optional
        Only these shape ids.
    exclude : sequence of str
        Shape ids to skip (e.g. point-target spheres).
    min_area : float
        Skip shapes smaller than this [m^2].
    seed : int
        Seed of the random samples.
    """
    if not (isinstance(spacing, int | float) and spacing > 0):
        raise ParameterError("sample_surfaces", "spacing", "a spacing > 0 m", spacing)
    mi = _mitsuba()
    scene = load_mitsuba_scene(scene)
    rng = np.random.default_rng(seed)
    named = sorted(((_shape_name(shape, i), shape) for i, shape in enumerate(scene.shapes())),
                   key=lambda item: item[0])
    found = [name for name, _ in named]
    if shapes is not None:
        unknown = sorted(set(shapes) - set(found))
        if unknown:
            raise ParameterError("sample_surfaces", "shapes", f"shape ids among {found}",
                                 unknown)
    parts = []
    for name, shape in named:
        if (shapes is not None and name not in shapes) or name in exclude:
            continue
        if getattr(shape.bsdf(), "MITSAR_KIND", None) == "pointtarget":
            continue  # an ideal point scatterer, not a surface
        area = float(np.asarray(shape.surface_area()).reshape(-1)[0])
        if area <= min_area or area <= 0:
            continue

        def at(s: NDArray, t: NDArray, shape: Any = shape) -> tuple[NDArray, NDArray]:
            sample = shape.sample_position(0.0, mi.Point2f(mi.Float(s.astype(np.float32)),
                                                           mi.Float(t.astype(np.float32))))
            shape_out = (len(s), 3)
            return (np.broadcast_to(np.asarray(sample.p, dtype=float).reshape(3, -1).T,
                                    shape_out).copy(),
                    np.broadcast_to(np.asarray(sample.n, dtype=float).reshape(3, -1).T,
                                    shape_out).copy())

        probe, _ = at(np.array([0.0, 1.0, 0.5, 0.5, 0.0, 1.0]),
                      np.array([0.5, 0.5, 0.0, 1.0, 0.0, 1.0]))
        extent_u = np.linalg.norm(probe[1] - probe[0])
        extent_v = np.linalg.norm(probe[3] - probe[2])
        diagonal = np.linalg.norm(probe[5] - probe[4])
        affine = (abs(extent_u * extent_v - area) <= 1e-3 * area
                  and abs(math.hypot(extent_u, extent_v) - diagonal) <= 1e-3 * diagonal)
        if affine:
            nu = max(1, int(round(extent_u / spacing)))
            nv = max(1, int(round(extent_v / spacing)))
            su, sv = np.meshgrid((np.arange(nu) + 0.5) / nu, (np.arange(nv) + 0.5) / nv,
                                 indexing="ij")
            position, normal = at(su.reshape(-1), sv.reshape(-1))
            weight = np.full(len(position), area / len(position))
        elif shape.is_mesh():
            vertices = np.asarray(shape.vertex_positions_buffer(), float).reshape(-1, 3)
            faces = np.asarray(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
            position, normal, weight = _triangle_points(vertices, faces, spacing, rng)
            if len(position) == 0:
                continue
            weight = weight * area / weight.sum()
        else:
            count = max(1, int(round(area / spacing**2)))
            position, normal = at(rng.random(count), rng.random(count))
            weight = np.full(count, area / count)
        parts.append(SurfacePoints.from_arrays(position, normal, weight, names=[name]))
    if not parts:
        raise ParameterError("sample_surfaces", "shapes", f"shape ids among {found}",
                             list(shapes) if shapes is not None else found)
    return SurfacePoints.concatenate(parts)


def planes_scene(planes: Sequence[Mapping[str, Any]]) -> Any:
    """A Mitsuba scene of rectangles ``{name, origin, axis_u, axis_v, size}`` (for shadowing)."""
    mi = _mitsuba()
    content: dict[str, Any] = {"type": "scene"}
    for index, plane in enumerate(planes):
        u = _unit_rows(np.asarray(plane["axis_u"], float))
        v = _unit_rows(np.asarray(plane["axis_v"], float))
        su, sv = (float(s) for s in plane["size"])
        centre = np.asarray(plane["origin"], float) + 0.5 * (su * u + sv * v)
        matrix = np.eye(4)
        matrix[:3, 0], matrix[:3, 1], matrix[:3, 2] = 0.5 * su * u, 0.5 * sv * v, np.cross(u, v)
        matrix[:3, 3] = centre
        content[str(plane.get("name", f"plane{index}"))] = {
            "type": "rectangle", "to_world": mi.ScalarTransform4f(matrix.tolist())}
    return mi.load_dict(content, optimize=False)


def _visible(scene: Any, points: NDArray, normals: NDArray | None, antennas: NDArray,
             chunk: int = 1 << 22) -> NDArray[np.bool_]:
    """True where nothing in ``scene`` blocks the segment from each point to its antenna."""
    mi = _mitsuba()
    out = np.empty(len(points), dtype=bool)
    for start in range(0, len(points), chunk):
        x = points[start:start + chunk]
        p = antennas[start:start + chunk]
        to = p - x
        distance = np.linalg.norm(to, axis=-1)
        direction = to / distance[:, None]
        eps = 1e-3 + 2e-6 * np.abs(x).max(axis=-1)
        if normals is not None:
            n = normals[start:start + chunk]
            facing = np.where(np.sum(n * to, axis=-1) >= 0, 1.0, -1.0)
            origin = x + (facing * eps)[:, None] * n
        else:
            origin = x + eps[:, None] * direction
        remaining = np.linalg.norm(p - origin, axis=-1) * (1 - 1e-6) - 1e-4

        def f(a: NDArray) -> Any:
            return mi.Float(np.ascontiguousarray(a, dtype=np.float32))

        ray = mi.Ray3f(mi.Point3f(f(origin[:, 0]), f(origin[:, 1]), f(origin[:, 2])),
                       mi.Vector3f(f(direction[:, 0]), f(direction[:, 1]),
                                   f(direction[:, 2])))
        ray.maxt = f(np.maximum(remaining, 0.0))
        out[start:start + chunk] = ~np.asarray(scene.ray_test(ray), dtype=bool)
    return out


# --------------------------------------------------------------------------------------------
# The ambiguity analysis
# --------------------------------------------------------------------------------------------
@dataclass(frozen=True)
class _States:
    sweep: NDArray
    time: NDArray
    interval: NDArray  # (S, 2) time span each state stands for
    position: NDArray
    velocity: NDArray
    boresight: NDArray
    frame: NDArray
    step: int


def _states(radar: Radar, trajectory: Trajectory, look: Look, sweep_step: int | None,
            max_states: int) -> _States:
    from mitsar.model.signal import sweep_count

    sweeps = sweep_count(radar, trajectory.duration)
    if sweeps < 1:
        raise ParameterError("ambiguity", "trajectory.duration",
                             f">= one sweep ({radar.sweep_duration:g} s)", trajectory.duration)
    if sweep_step is None:
        step = max(1, math.ceil(sweeps / max_states))
    else:
        if isinstance(sweep_step, bool) or int(sweep_step) != sweep_step or sweep_step < 1:
            raise ParameterError("ambiguity", "sweep_step", "an integer >= 1 (sweeps)",
                                 sweep_step)
        step = int(sweep_step)
    sweep = np.arange(0, sweeps, step)
    time = (sweep + 0.5) / radar.prf
    interval = np.stack([sweep / radar.prf, np.minimum(sweep + step, sweeps) / radar.prf], -1)
    attitude = trajectory.attitude_at(time)
    frame = antenna_frame(look, attitude[:, 0], attitude[:, 1], attitude[:, 2])
    return _States(sweep, time, interval, trajectory.position(time), trajectory.velocity(time),
                   frame[..., 2], frame, step)


def _run_durations(lit: NDArray, margin: NDArray, states: _States) -> NDArray:
    """Duration [s] of the contiguous illuminated run holding each illuminated state.

    A run ends between two states; where one of them is inside and the other outside the beam
    (``margin`` = two-way pattern minus threshold, finite, changing sign) the end is
    interpolated linearly in ``margin``, else it is the edge of the state's interval.
    """
    count, size = lit.shape
    time = states.time
    index = np.broadcast_to(np.arange(size), lit.shape)
    previous = np.zeros_like(lit)
    previous[:, 1:] = lit[:, :-1]
    following = np.zeros_like(lit)
    following[:, :-1] = lit[:, 1:]
    starts = lit & ~previous
    ends = lit & ~following

    start_time = np.broadcast_to(states.interval[:, 0], lit.shape).copy()
    end_time = np.broadcast_to(states.interval[:, 1], lit.shape).copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        # Interpolated start between state s-1 (outside) and s (inside).
        m_out, m_in = margin[:, :-1], margin[:, 1:]
        fraction = -m_out / (m_in - m_out)
        ok = np.isfinite(m_out) & (m_out < 0) & (m_in >= 0)
        crossing = time[:-1] + fraction * (time[1:] - time[:-1])
        start_time[:, 1:] = np.where(ok, crossing, start_time[:, 1:])
        # Interpolated end between state s (inside) and s+1 (outside).
        m_in, m_out = margin[:, :-1], margin[:, 1:]
        fraction = m_in / (m_in - m_out)
        ok = np.isfinite(m_out) & (m_out < 0) & (m_in >= 0)
        crossing = time[:-1] + fraction * (time[1:] - time[:-1])
        end_time[:, :-1] = np.where(ok, crossing, end_time[:, :-1])

    first = np.maximum.accumulate(np.where(starts, index, -1), axis=1)
    last = np.minimum.accumulate(np.where(ends, index, size)[:, ::-1], axis=1)[:, ::-1]
    first = np.clip(first, 0, size - 1)
    last = np.clip(last, 0, size - 1)
    duration = (np.take_along_axis(end_time, last, axis=1)
                - np.take_along_axis(start_time, first, axis=1))
    return np.where(lit, np.maximum(duration, 0.0), 0.0)


def _requirement(value: Any) -> tuple[float, float]:
    """Required (range, azimuth) resolution [m] from a number or a pair."""
    pair = (value, value) if isinstance(value, int | float) else value
    try:
        pair = tuple(pair)
    except TypeError:
        pair = ()
    if (len(pair) != 2 or any(isinstance(r, bool) or not isinstance(r, int | float)
                              or not (r > 0 and math.isfinite(r)) for r in pair)):
        raise ParameterError("ambiguity", "required_resolution",
                             "a resolution > 0 m, or a (range, azimuth) pair of them", value)
    return float(pair[0]), float(pair[1])


def _check_options(radar: Radar, trajectory: Trajectory, look: Look,
                   required_resolution: float, integration_time: Any, beam_threshold_db: float,
                   min_angle_deg: float, criterion: str) -> tuple[str, float | None]:
    if not isinstance(radar, Radar):
        raise ParameterError("ambiguity", "radar", "a mitsar.Radar", type(radar).__name__)
    if not isinstance(trajectory, Trajectory):
        raise ParameterError("ambiguity", "trajectory", "a mitsar.Trajectory",
                             type(trajectory).__name__)
    if not isinstance(look, Look):
        raise ParameterError("ambiguity", "look", "a mitsar.Look", type(look).__name__)
    _requirement(required_resolution)
    if not (isinstance(beam_threshold_db, int | float) and beam_threshold_db < 0):
        raise ParameterError("ambiguity", "beam_threshold_db",
                             "a two-way pattern level < 0 dB", beam_threshold_db)
    if not (isinstance(min_angle_deg, int | float) and 0 <= min_angle_deg < 90):
        raise ParameterError("ambiguity", "min_angle_deg", "an angle in [0, 90) deg",
                             min_angle_deg)
    if criterion not in CRITERIA:
        raise ParameterError("ambiguity", "criterion", f"one of {CRITERIA}", criterion)
    if integration_time is None or integration_time == "beam":
        return "beam", None
    if integration_time == "required":
        return "required", None
    if (isinstance(integration_time, int | float) and not isinstance(integration_time, bool)
            and integration_time > 0 and math.isfinite(integration_time)):
        return "fixed", float(integration_time)
    raise ParameterError("ambiguity", "integration_time",
                         "None/'beam', 'required' or a time > 0 s", integration_time)


def _as_points(scene_or_grid: Any, spacing: float, shapes: Sequence[str] | None,
               exclude: Sequence[str], scene: Any) -> tuple[SurfacePoints, Any]:
    """The surface points to analyse and the Mitsuba scene for shadowing (or None)."""
    if isinstance(scene_or_grid, SurfacePoints):
        points = scene_or_grid
    elif isinstance(scene_or_grid, Mapping):
        points = SurfacePoints.from_arrays(
            scene_or_grid["position"], scene_or_grid.get("normal"), scene_or_grid.get("area"),
            scene_or_grid.get("surface"), scene_or_grid.get("names"))
    elif isinstance(scene_or_grid, tuple) and len(scene_or_grid) == 2:
        points = SurfacePoints.from_arrays(*scene_or_grid)
    elif isinstance(scene_or_grid, np.ndarray):
        points = SurfacePoints.from_arrays(scene_or_grid)
    else:
        loaded = load_mitsuba_scene(scene_or_grid)
        points = sample_surfaces(loaded, spacing, shapes=shapes, exclude=exclude)
        scene = loaded if scene is None else scene
    if scene is not None:
        scene = load_mitsuba_scene(scene)
    return points, scene


def _beam_pattern(ux: NDArray, uy: NDArray, uz: NDArray, frame: NDArray,
                  radar: Radar) -> NDArray:
    """Two-way pattern of unit directions (components (P, S)) in per-state antenna frames."""
    def local(axis: int) -> NDArray:
        f = frame[:, :, axis]
        return f[None, :, 0] * ux + f[None, :, 1] * uy + f[None, :, 2] * uz

    return one_way_pattern(local(0), local(1), radar.azimuth_beamwidth,
                           radar.elevation_beamwidth, local(2)) ** 2


def _pair_resolutions(x: NDArray, n: NDArray | None, p: NDArray, v: NDArray,
                      radar: Radar) -> dict[str, NDArray]:
    """Gradient quantities of matched (point, state) pairs, arrays of shape (L, 3)."""
    offset = x - p
    distance = np.linalg.norm(offset, axis=-1)
    unit = offset / distance[:, None]
    radial = np.sum(v * unit, axis=-1)
    g_tau = _project(2.0 / SPEED_OF_LIGHT * unit, n)
    g_fd_3d = 2.0 / radar.wavelength * (v - radial[:, None] * unit) / distance[:, None]
    g_fd = _project(g_fd_3d, n)
    n_tau = np.linalg.norm(g_tau, axis=-1)
    n_fd = np.linalg.norm(g_fd, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        cosine = np.abs(np.sum(g_tau * g_fd, axis=-1)) / (n_tau * n_fd)
        rho_r = 1.0 / (radar.bandwidth * n_tau)
    angle = np.degrees(np.arccos(np.clip(np.nan_to_num(cosine, nan=1.0), 0.0, 1.0)))
    incidence = (np.full(len(x), np.nan) if n is None else
                 np.degrees(np.arccos(np.clip(np.abs(np.sum(unit * n, axis=-1)), 0, 1))))
    return {"rho_r": rho_r, "n_fd": n_fd, "n_fd_3d": np.linalg.norm(g_fd_3d, axis=-1),
            "angle": angle, "incidence": incidence}


def _evaluate(points: SurfacePoints, rows: slice, states: _States, radar: Radar,
              options: dict, scene: Any) -> dict[str, NDArray]:
    """Per-state quantities of the points ``rows`` (chunk) x all states.

    Beam and range are tested on every pair (component arrays of shape (P, S)); shadow rays and
    gradients only on the pairs inside the beam.
    """
    x = points.position[rows]
    p = states.position
    ox = x[:, 0, None] - p[None, :, 0]
    oy = x[:, 1, None] - p[None, :, 1]
    oz = x[:, 2, None] - p[None, :, 2]
    distance = np.sqrt(ox * ox + oy * oy + oz * oz)
    safe = np.where(distance > 0, distance, 1.0)
    pattern = _beam_pattern(ox / safe, oy / safe, oz / safe, states.frame, radar)
    threshold = 10 ** (options["beam_threshold_db"] / 10)
    in_range = (distance > 0) & (distance <= radar.max_range)
    in_beam = (pattern >= threshold) & in_range
    lit = in_beam.copy()
    if scene is not None and options["shadowing"] and np.any(in_beam):
        i, k = np.nonzero(in_beam)
        normals = None if points.normal is None else points.normal[rows][i]
        lit[i, k] = _visible(scene, x[i], normals, p[k])
    margin = np.where(in_range, pattern - threshold, np.nan)
    run = _run_durations(lit, margin, states)

    # Gradients and resolutions of the illuminated pairs.
    i, k = np.nonzero(lit)
    pair = _pair_resolutions(x[i], None if points.normal is None else points.normal[rows][i],
                             p[k], states.velocity[k], radar)
    t_int = run[i, k]
    if options["mode"] == "fixed":
        t_int = np.minimum(t_int, options["integration_time"])
    elif options["mode"] == "required":
        with np.errstate(divide="ignore"):
            t_int = np.minimum(t_int, 1.0 / (options["required_azimuth"] * pair["n_fd_3d"]))
    with np.errstate(divide="ignore", invalid="ignore"):
        rho_a = 1.0 / (t_int * pair["n_fd"])
        sine = np.sin(np.radians(pair["angle"]))
        if options["criterion"] == "cell":
            check_r, check_a = pair["rho_r"] / sine, rho_a / sine
        else:
            check_r, check_a = pair["rho_r"], rho_a
    angle_ok = pair["angle"] >= options["min_angle_deg"]
    good = angle_ok & (check_r <= options["required_range"]) & (
        check_a <= options["required_azimuth"])

    def full(values: NDArray, fill: Any = np.nan) -> NDArray:
        out = np.full(lit.shape, fill, dtype=np.asarray(values).dtype if fill is not np.nan
                      else float)
        out[i, k] = values
        return out

    observation = np.where(in_beam, 1, 0).astype(np.int8)
    observation[i, k] = np.where(good, 3, 2)
    return {"range_resolution": full(pair["rho_r"]), "azimuth_resolution": full(rho_a),
            "angle": full(pair["angle"]), "incidence": full(pair["incidence"]),
            "integration_time": full(t_int), "observation": observation,
            "check_r": full(check_r), "check_a": full(check_a),
            "angle_ok": full(angle_ok, False)}


def _argmin_rows(values: NDArray) -> tuple[NDArray, NDArray]:
    """Row-wise argmin ignoring NaN and the minimum; (-1, NaN) for all-NaN rows."""
    filled = np.where(np.isnan(values), np.inf, values)
    index = np.argmin(filled, axis=1)
    best = filled[np.arange(len(filled)), index]
    valid = np.any(~np.isnan(values), axis=1)
    return np.where(valid, index, -1), np.where(valid, best, np.nan)


def _aggregate(chunk: dict[str, NDArray], states: _States) -> dict[str, NDArray]:
    """Per-point summaries over the trajectory."""
    count = len(chunk["observation"])
    out: dict[str, NDArray] = {}
    lit = chunk["observation"] >= 2

    def take(index: NDArray, values: NDArray) -> NDArray:
        return np.where(index >= 0, values[np.clip(index, 0, None)], np.nan)

    def take_position(index: NDArray) -> NDArray:
        return np.where((index >= 0)[:, None], states.position[np.clip(index, 0, None)], np.nan)

    for name in ("range", "azimuth"):
        index, best = _argmin_rows(chunk[f"{name}_resolution"])
        out[f"best_{name}_resolution"] = best
        out[f"best_{name}_time"] = take(index, states.time)
        out[f"best_{name}_platform_position"] = take_position(index)

    # The single best state: smallest max(range, azimuth) measure with an acceptable angle.
    score = np.maximum(chunk["check_r"], chunk["check_a"])
    score = np.where(lit, score, np.nan)
    preferred = np.where(chunk["angle_ok"], score, np.nan)
    index, _ = _argmin_rows(preferred)
    fallback, _ = _argmin_rows(score)
    index = np.where(index >= 0, index, fallback)
    rows = np.arange(count)
    safe = np.clip(index, 0, None)
    out["best_time"] = take(index, states.time)
    out["best_platform_position"] = take_position(index)
    for name in ("range_resolution", "azimuth_resolution", "angle", "integration_time"):
        out[f"best_state_{name}"] = np.where(index >= 0, chunk[name][rows, safe], np.nan)

    status = chunk["observation"].max(axis=1)
    out["status"] = status.astype(np.int8)
    dt = states.interval[:, 1] - states.interval[:, 0]
    out["observed_time"] = (lit * dt).sum(axis=1)
    resolved = chunk["observation"] == 3
    out["resolved_time"] = (resolved * dt).sum(axis=1)
    first = np.argmax(resolved, axis=1)
    out["first_resolved_time"] = np.where(resolved.any(axis=1), states.time[first], np.nan)
    return out


def ambiguity(radar: Radar, trajectory: Trajectory, look: Look, scene_or_grid: Any,
              required_resolution: float = 0.10, *, sweep_step: int | None = None,
              integration_time: float | str | None = None, spacing: float = 0.25,
              shapes: Sequence[str] | None = None, exclude: Sequence[str] = (),
              scene: Any = None, beam_threshold_db: float = -6.0, min_angle_deg: float = 30.0,
              criterion: str = "gradient", shadowing: bool = True, max_states: int = 600,
              per_state: bool = True, chunk_pairs: int = 1 << 20,
              progress: bool = False) -> xr.Dataset:
    """Resolution and ambiguity of surface points along a trajectory (gradient method).

    Parameters
    ----------
    radar, trajectory, look : Radar, Trajectory, Look
    scene_or_grid : mitsuba.Scene, path, scene name, SurfacePoints, mapping, tuple or array
        A scene (its surfaces are sampled every ``spacing`` m, and it shadows), or points:
        :class:`SurfacePoints`, a mapping with ``position`` and optional ``normal``, ``area``,
        ``surface``, ``names``, a tuple ``(position, normal)``, or an (n, 3) array (3-D
        gradients).
    required_resolution : float or (float, float)
        Required resolution [m], or a (range, azimuth) pair. Paper Table 1 gives 0.10 m in
        slant range and azimuth; note that the range resolution projected on a surface is
        ``c / (2 B sin theta_inc)``, coarser than 0.10 m everywhere but at grazing incidence.
    sweep_step : int, optional
        Evaluate every ``sweep_step``-th sweep (mid-sweep states); default so that at most
        ``max_states`` states are evaluated.
    integration_time : None, "beam", "required" or float
        Integration time model (module docstring; default: time in the beam).
    spacing : float
        Point spacing on scene surfaces [m].
    shapes, exclude : sequence of str, optional
        Shape ids to sample / to skip.
    scene : mitsuba.Scene, path or name, optional
        Scene for shadowing when ``scene_or_grid`` is a point set.
    beam_threshold_db : float
        Two-way pattern level that bounds the beam [dB] (-6 dB: one-way half power).
    min_angle_deg : float
        Angle between the projected gradients below which a state is ambiguous [deg].
    criterion : {"gradient", "cell"}
        Resolutions compared with the requirement: along the gradients, or the resolution
        cell sides ``rho / sin Theta``.
    shadowing : bool
        Test visibility with ``ray_test`` (needs a scene).
    max_states : int
        Bound on the number of states when ``sweep_step`` is not given.
    per_state : bool
        Keep the (point, state) maps in the result (21 bytes per point-state pair).
    chunk_pairs : int
        Point-state pairs evaluated at once (memory bound).
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        ``product = "ambiguity"``; see ``docs/ambiguity.md`` for every variable.
    """
    mode, fixed = _check_options(radar, trajectory, look, required_resolution,
                                 integration_time, beam_threshold_db, min_angle_deg, criterion)
    points, scene = _as_points(scene_or_grid, spacing, shapes, exclude, scene)
    states = _states(radar, trajectory, look, sweep_step, max_states)
    required_range, required_azimuth = _requirement(required_resolution)
    options = {"mode": mode, "integration_time": fixed, "beam_threshold_db": beam_threshold_db,
               "min_angle_deg": float(min_angle_deg), "criterion": criterion,
               "shadowing": bool(shadowing), "required_range": required_range,
               "required_azimuth": required_azimuth}
    size = len(states.time)
    rows_per_chunk = max(1, int(chunk_pairs) // size)
    per_state_names = ("range_resolution", "azimuth_resolution", "angle", "incidence",
                       "integration_time", "observation")
    maps: dict[str, list] = {name: [] for name in per_state_names}
    summaries: list[dict[str, NDArray]] = []
    chunks = range(0, len(points), rows_per_chunk)
    if progress:
        from tqdm.auto import tqdm

        chunks = tqdm(chunks, desc="ambiguity", unit="chunk")
    observed_area = np.zeros(size)
    resolved_area = np.zeros(size)
    for start in chunks:
        rows = slice(start, min(start + rows_per_chunk, len(points)))
        chunk = _evaluate(points, rows, states, radar, options, scene)
        summaries.append(_aggregate(chunk, states))
        weights = points.area[rows][:, None]
        observed_area += np.sum((chunk["observation"] >= 2) * weights, axis=0)
        resolved_area += np.sum((chunk["observation"] == 3) * weights, axis=0)
        if per_state:
            for name in per_state_names:
                values = chunk[name]
                maps[name].append(values if name == "observation"
                                  else values.astype(np.float32))
    summary = {key: np.concatenate([s[key] for s in summaries]) for key in summaries[0]}
    return _product(points, states, summary, maps if per_state else None, observed_area,
                    resolved_area, radar, trajectory, look, options, spacing, scene_or_grid)


def _product(points: SurfacePoints, states: _States, summary: dict, maps: dict | None,
             observed_area: NDArray, resolved_area: NDArray, radar: Radar,
             trajectory: Trajectory, look: Look, options: dict, spacing: float,
             source: Any) -> xr.Dataset:
    """Assemble the ambiguity product."""
    m, s, deg, none = {"units": "m"}, {"units": "s"}, {"units": "deg"}, {"units": "1"}
    point_dims, state_dims = ("point", "state"), ("state", "xyz")
    total_area = float(points.area.sum())
    data: dict[str, Any] = {
        "position": (("point", "xyz"), points.position, {**m, "long_name": "surface point"}),
        "area": ("point", points.area, {"units": "m^2", "long_name": "area per point"}),
        "surface_index": ("point", points.surface.astype(np.int32),
                          {"long_name": "index into the surface dimension"}),
        "facet_index": ("point", points.facet.astype(np.int32),
                        {"long_name": "index into the facet dimension (planar part of a "
                                      "surface, for maps)"}),
        "map_u": ("point", points.map_uv[:, 0], {**m, "long_name": "unfolded map abscissa"}),
        "map_v": ("point", points.map_uv[:, 1], {**m, "long_name": "unfolded map ordinate"}),
        "platform_position": (state_dims, states.position, m),
        "platform_velocity": (state_dims, states.velocity, {"units": "m/s"}),
        "boresight": (state_dims, states.boresight, none),
        "observed_fraction": ("state", observed_area / total_area, {
            **none, "long_name": "area fraction illuminated at this state"}),
        "resolved_fraction": ("state", resolved_area / total_area, {
            **none, "long_name": "area fraction resolved (unambiguous) at this state"}),
    }
    if points.normal is not None:
        data["normal"] = (("point", "xyz"), points.normal, none)
    descriptions = {
        "best_range_resolution": (m, "best range resolution 1/(B|grad tau|) over the track"),
        "best_range_time": (s, "time of the best range resolution"),
        "best_range_platform_position": (m, "platform position at the best range resolution"),
        "best_azimuth_resolution": (m, "best azimuth resolution 1/(T_int|grad f_D|)"),
        "best_azimuth_time": (s, "time of the best azimuth resolution"),
        "best_azimuth_platform_position": (m, "platform position at the best azimuth "
                                              "resolution"),
        "best_time": (s, "time of the best state (smallest max(range, azimuth) measure with "
                         "an acceptable gradient angle)"),
        "best_platform_position": (m, "platform position of the best state"),
        "best_state_range_resolution": (m, "range resolution at the best state"),
        "best_state_azimuth_resolution": (m, "azimuth resolution at the best state"),
        "best_state_angle": (deg, "angle between projected gradients at the best state"),
        "best_state_integration_time": (s, "integration time at the best state"),
        "observed_time": (s, "total time illuminated"),
        "resolved_time": (s, "total time resolved"),
        "first_resolved_time": (s, "first time resolved"),
    }
    for name, (units, long_name) in descriptions.items():
        values = summary[name]
        dims = ("point", "xyz") if values.ndim == 2 else ("point",)
        data[name] = (dims, values, {**units, "long_name": long_name})
    status = summary["status"]
    data["status"] = ("point", status, {
        "flag_values": np.arange(4, dtype=np.int8), "flag_meanings": " ".join(STATUS_MEANINGS),
        "long_name": "best observation over the trajectory"})
    data["never_observed"] = ("point", status <= 1, {"long_name": "never illuminated"})
    data["only_ambiguous"] = ("point", status == 2, {
        "long_name": "illuminated, but never unambiguous at the required resolution"})
    data["resolved"] = ("point", status == 3, {
        "long_name": "unambiguous at the required resolution at least once"})
    if maps is not None:
        units = {"range_resolution": m, "azimuth_resolution": m, "angle": deg,
                 "incidence": deg, "integration_time": s}
        for name, unit in units.items():
            data[name] = (point_dims, np.concatenate(maps[name]), dict(unit))
        data["observation"] = (point_dims, np.concatenate(maps["observation"]), {
            "flag_values": np.arange(4, dtype=np.int8),
            "flag_meanings": " ".join(OBSERVATION_MEANINGS)})
        data["range_resolution"][2]["long_name"] = "range resolution 1/(B|grad_t tau|)"
        data["azimuth_resolution"][2]["long_name"] = "azimuth resolution 1/(T_int|grad_t f_D|)"
        data["angle"][2]["long_name"] = "angle between the projected gradients"
        data["incidence"][2]["long_name"] = "incidence angle on the surface"
        data["integration_time"][2]["long_name"] = "integration time T_int"

    # Cumulative coverage along the track.
    first = summary["first_resolved_time"]
    order = np.searchsorted(states.time, np.where(np.isnan(first), np.inf, first))
    cumulative = np.cumsum(np.bincount(order, weights=points.area,
                                       minlength=len(states.time) + 1))[:len(states.time)]
    data["cumulative_resolved_fraction"] = ("state", cumulative / total_area, {
        **none, "long_name": "area fraction resolved at least once so far"})

    product = xr.Dataset(data, coords={
        "point": np.arange(len(points)), "state": np.arange(len(states.time)),
        "time": ("state", states.time, {**s, "long_name": "mid-sweep time of the state"}),
        "sweep": ("state", states.sweep), "xyz": ["x", "y", "z"],
        "surface": list(points.names), "facet": list(points.facet_names)})
    table = surface_summary(product)
    for name in table.data_vars:
        product[name] = table[name]
    product.attrs.update(radar.to_attrs())
    product.attrs.update(
        product="ambiguity", mitsar_version=__version__,
        look_off_nadir_deg=look.off_nadir_deg, look_squint_deg=look.squint_deg,
        required_resolution=max(options["required_range"], options["required_azimuth"]),
        required_range_resolution=options["required_range"],
        required_azimuth_resolution=options["required_azimuth"],
        min_angle_deg=options["min_angle_deg"], beam_threshold_db=options["beam_threshold_db"],
        integration_time_mode=options["mode"],
        integration_time=-1.0 if options["integration_time"] is None
        else options["integration_time"],
        criterion=options["criterion"], shadowing=int(options["shadowing"]),
        sweep_step=states.step, state_interval=states.step / radar.prf,
        spacing=float(spacing), normals=int(points.normal is not None),
        trajectory=json.dumps(trajectory.describe()),
        source=str(source) if isinstance(source, str | os.PathLike) else type(source).__name__)
    return product


def surface_summary(product: xr.Dataset) -> xr.Dataset:
    """Area fractions per surface: resolved, observed, only ambiguous, shadowed, outside beam.

    Returns
    -------
    xarray.Dataset
        Variables on the ``surface`` dimension: ``surface_area`` [m^2], ``fraction_resolved``
        (observed at the required resolution without ambiguity at least once),
        ``fraction_observed``, ``fraction_only_ambiguous``, ``fraction_shadowed``,
        ``fraction_outside_beam``.
    """
    surfaces = product["surface"].values
    index = product["surface_index"].values
    area = product["area"].values
    status = product["status"].values
    count = len(surfaces)
    total = np.bincount(index, weights=area, minlength=count)
    safe = np.where(total > 0, total, 1.0)

    def fraction(mask: NDArray) -> NDArray:
        return np.bincount(index, weights=area * mask, minlength=count) / safe

    none = {"units": "1"}
    return xr.Dataset({
        "surface_area": ("surface", total, {"units": "m^2"}),
        "fraction_resolved": ("surface", fraction(status == 3), {
            **none, "long_name": "area fraction resolved at the required resolution"}),
        "fraction_observed": ("surface", fraction(status >= 2), {
            **none, "long_name": "area fraction illuminated at least once"}),
        "fraction_only_ambiguous": ("surface", fraction(status == 2), {
            **none, "long_name": "area fraction observed only ambiguously"}),
        "fraction_shadowed": ("surface", fraction(status == 1), {
            **none, "long_name": "area fraction in the beam but always shadowed"}),
        "fraction_outside_beam": ("surface", fraction(status == 0), {
            **none, "long_name": "area fraction never in the beam"}),
    }, coords={"surface": surfaces})


def _overall(product: xr.Dataset) -> dict[str, float]:
    area = product["area"].values
    status = product["status"].values
    total = float(area.sum())
    return {"surface_area": total,
            "fraction_resolved": float(area[status == 3].sum() / total),
            "fraction_observed": float(area[status >= 2].sum() / total),
            "fraction_only_ambiguous": float(area[status == 2].sum() / total),
            "fraction_shadowed": float(area[status == 1].sum() / total),
            "fraction_outside_beam": float(area[status == 0].sum() / total)}


# --------------------------------------------------------------------------------------------
# Guidance: several trajectories side by side
# --------------------------------------------------------------------------------------------
def compare_trajectories(radar: Radar, look: Look | Mapping[str, Look], scene: Any,
                         trajectories: Mapping[str, Trajectory],
                         required_resolution: float = 0.10, *, spacing: float = 0.25,
                         return_products: bool = False,
                         **options: Any) -> xr.Dataset | tuple[xr.Dataset, dict]:
    """Compare candidate trajectories on the same surface points.

    Parameters
    ----------
    radar : Radar
    look : Look or mapping name -> Look
        One antenna mounting for all, or one per trajectory.
    scene : scene, path, name or point set
        As ``scene_or_grid`` of :func:`ambiguity`; a scene is sampled once.
    trajectories : mapping name -> Trajectory
    required_resolution : float
    spacing : float
        Point spacing on scene surfaces [m].
    return_products : bool
        Also return the per-trajectory ambiguity products.
    **options
        Passed to :func:`ambiguity` (``per_state`` defaults to False here).

    Returns
    -------
    xarray.Dataset
        ``product = "ambiguity_comparison"``: per (trajectory, surface) the fractions of
        :func:`surface_summary`; per trajectory the overall fractions (``total_*``); per
        (trajectory, point) ``status`` and the best resolutions; per point ``position``,
        ``surface_index``, ``area``, ``map_u``, ``map_v``; and ``union_fraction_resolved``
        (surface): the area resolved by at least one trajectory.
    """
    if not trajectories:
        raise ParameterError("compare_trajectories", "trajectories",
                             "at least one name -> Trajectory", trajectories)
    points, shadow_scene = _as_points(scene, spacing, options.pop("shapes", None),
                                      options.pop("exclude", ()), options.pop("scene", None))
    options.setdefault("per_state", False)
    products = {}
    for name, trajectory in trajectories.items():
        this_look = look[name] if isinstance(look, Mapping) else look
        products[name] = ambiguity(radar, trajectory, this_look, points, required_resolution,
                                   scene=shadow_scene, spacing=spacing, **options)
    out = comparison_from_products(products)
    if return_products:
        return out, products
    return out


def comparison_from_products(products: Mapping[str, xr.Dataset]) -> xr.Dataset:
    """The comparison dataset of :func:`compare_trajectories` from ambiguity products.

    The products must share their surface points (same ``position``).
    """
    names = list(products)
    if not names:
        raise ParameterError("comparison_from_products", "products", "at least one product",
                             0)
    first = products[names[0]]
    for name in names[1:]:
        if not np.array_equal(products[name]["position"].values, first["position"].values):
            raise ParameterError("comparison_from_products", name,
                                 "a product on the same surface points", "other points")
    tables = [surface_summary(products[name]) for name in names]
    table = xr.concat(tables, dim=xr.DataArray(names, dims="trajectory", name="trajectory"))
    overall = [_overall(products[name]) for name in names]
    out = xr.Dataset(coords={"trajectory": names, "surface": first["surface"].values,
                             "facet": first["facet"].values, "point": first["point"].values,
                             "xyz": ["x", "y", "z"]})
    for key in table.data_vars:
        out[key] = table[key] if key != "surface_area" else table[key].isel(trajectory=0,
                                                                            drop=True)
    for key in overall[0]:
        if key != "surface_area":
            out[f"total_{key}"] = ("trajectory", [o[key] for o in overall], {"units": "1"})
    for key in ("status", "best_range_resolution", "best_azimuth_resolution", "best_time"):
        out[key] = xr.concat([products[n][key] for n in names], dim="trajectory")
    for key in ("position", "surface_index", "facet_index", "area", "map_u", "map_v"):
        out[key] = first[key]
    resolved_any = (out["status"] == 3).any("trajectory").values
    index = first["surface_index"].values
    area = first["area"].values
    total = np.bincount(index, weights=area, minlength=out.sizes["surface"])
    out["union_fraction_resolved"] = ("surface", np.bincount(
        index, weights=area * resolved_any, minlength=out.sizes["surface"])
        / np.where(total > 0, total, 1.0), {
            "units": "1", "long_name": "area fraction resolved by at least one trajectory"})
    out["total_union_fraction_resolved"] = ((), float(area @ resolved_any / area.sum()),
                                            {"units": "1"})
    out.attrs.update({k: v for k, v in first.attrs.items()
                      if k.startswith(("radar_", "look_")) or k in (
                          "required_resolution", "required_range_resolution",
                          "required_azimuth_resolution", "min_angle_deg", "beam_threshold_db",
                          "integration_time_mode", "integration_time", "criterion",
                          "shadowing", "spacing", "mitsar_version")})
    out.attrs.update(
        product="ambiguity_comparison",
        trajectories=json.dumps({n: json.loads(products[n].attrs["trajectory"])
                                 for n in names}),
        looks=json.dumps({n: [products[n].attrs["look_off_nadir_deg"],
                              products[n].attrs["look_squint_deg"]] for n in names}),
        tracks=json.dumps({n: products[n]["platform_position"].values.tolist()
                           for n in names}))
    return out


def comparison_table(comparison: xr.Dataset) -> str:
    """The comparison as a Markdown table (percent of area resolved per surface)."""
    names = [str(n) for n in comparison["trajectory"].values]
    surfaces = [str(s) for s in comparison["surface"].values]
    header = "| surface | area [m^2] | " + " | ".join(names) + " | any |"
    lines = [header, "|" + "---|" * (len(names) + 3)]
    for j, surface in enumerate(surfaces):
        values = [f"{100 * comparison['fraction_resolved'].values[i, j]:.1f}"
                  for i in range(len(names))]
        lines.append(f"| {surface} | {comparison['surface_area'].values[j]:.1f} | "
                     + " | ".join(values)
                     + f" | {100 * comparison['union_fraction_resolved'].values[j]:.1f} |")
    totals = [f"{100 * v:.1f}" for v in comparison["total_fraction_resolved"].values]
    area = comparison["area"].values
    union = float(comparison["total_union_fraction_resolved"])
    lines.append(f"| **all** | {area.sum():.1f} | " + " | ".join(totals)
                 + f" | {100 * union:.1f} |")
    return "\n".join(lines) + "\n"


# --------------------------------------------------------------------------------------------
# Figures
# --------------------------------------------------------------------------------------------
def _requirement_text(attrs: Mapping[str, Any]) -> str:
    required = float(attrs.get("required_resolution", 0.1))
    r = float(attrs.get("required_range_resolution", required))
    a = float(attrs.get("required_azimuth_resolution", required))
    return f"{r:g} m" if r == a else f"{r:g} m (range) x {a:g} m (azimuth)"


def _pyplot() -> Any:
    import matplotlib

    matplotlib.use("Agg")
    import matplotlib.pyplot as plt

    return plt


def _save(figure: Any, path: str | os.PathLike, overwrite: bool) -> Path:
    from mitsar.io import atomic_output

    path = Path(path)
    with atomic_output(path, overwrite) as tmp:
        figure.savefig(tmp, format=path.suffix.lstrip(".") or "png", dpi=120)
    _pyplot().close(figure)
    return path


def _status_colormap() -> tuple[Any, Any]:
    from matplotlib.colors import BoundaryNorm, ListedColormap

    return ListedColormap(_STATUS_COLOURS), BoundaryNorm(np.arange(-0.5, 4.5), 4)


def _marker_size(u: NDArray, v: NDArray, area: NDArray, width_in: float) -> float:
    extent = max(np.ptp(u), np.ptp(v), 1e-6)
    step = math.sqrt(max(float(np.median(area)), 1e-12))
    points = width_in * 72 * step / (extent + step)
    return max(1.0, points**2)


def plot_ambiguity_maps(product: xr.Dataset, path: str | os.PathLike | None = None, *,
                        overwrite: bool = False, max_facets: int = 8) -> Any:
    """Unfolded maps per planar facet: status, best range and best azimuth resolution.

    One row per facet (a wall, the floor, a face of a box), the ``max_facets`` largest ones.
    """
    plt = _pyplot()
    from matplotlib.colors import LogNorm

    required = float(product.attrs.get("required_resolution", 0.1))
    required_by_key = {
        "best_range_resolution": float(product.attrs.get("required_range_resolution",
                                                         required)),
        "best_azimuth_resolution": float(product.attrs.get("required_azimuth_resolution",
                                                           required))}
    index = product["facet_index"].values
    facet_area = np.bincount(index, weights=product["area"].values,
                             minlength=product.sizes["facet"])
    chosen = [int(i) for i in np.argsort(-facet_area, kind="stable")[:max_facets]
              if facet_area[i] > 0]
    cmap, norm = _status_colormap()
    res_norm = LogNorm(vmin=required / 3, vmax=required * 30)
    figure, axes = plt.subplots(len(chosen), 3, figsize=(13, 2.6 * len(chosen) + 0.6),
                                squeeze=False, layout="constrained")
    for row, facet in enumerate(chosen):
        mask = index == facet
        u, v = product["map_u"].values[mask], product["map_v"].values[mask]
        size = _marker_size(u, v, product["area"].values[mask], 3.8)
        name = str(product["facet"].values[facet])
        ax = axes[row, 0]
        im = ax.scatter(u, v, c=product["status"].values[mask], cmap=cmap, norm=norm, s=size,
                        marker="s", linewidths=0)
        ax.set_title(f"{name}: status")
        bar = figure.colorbar(im, ax=ax, ticks=range(4))
        bar.ax.set_yticklabels([m.replace("_", " ") for m in STATUS_MEANINGS], fontsize=7)
        for col, key in ((1, "best_range_resolution"), (2, "best_azimuth_resolution")):
            ax = axes[row, col]
            values = product[key].values[mask]
            missing = ~np.isfinite(values)
            ax.scatter(u[missing], v[missing], c="#dddddd", s=size, marker="s", linewidths=0)
            im = ax.scatter(u[~missing], v[~missing], c=values[~missing], cmap="viridis_r",
                            norm=res_norm, s=size, marker="s", linewidths=0)
            ax.set_title(f"{name}: {key.replace('_', ' ')} [m]")
            bar = figure.colorbar(im, ax=ax)
            bar.ax.axhline(required_by_key[key], color="red", linewidth=2)
        for ax in axes[row]:
            ax.set_aspect("equal", adjustable="datalim")
            ax.set_xlabel("map u [m]")
            ax.set_ylabel("map v [m]")
    figure.suptitle(f"Gradient method: required {_requirement_text(product.attrs)}, min "
                    "angle "
                    f"{product.attrs.get('min_angle_deg', 0):g} deg; grey: not observed; "
                    "red line: requirement")
    if path is not None:
        return _save(figure, path, overwrite)
    return figure


def plot_ambiguity_3d(product: xr.Dataset, path: str | os.PathLike | None = None, *,
                      overwrite: bool = False, max_points: int = 40000) -> Any:
    """A 3-D view: surface points coloured by status, and the platform track."""
    plt = _pyplot()
    cmap, norm = _status_colormap()
    position = product["position"].values
    step = max(1, len(position) // max_points)
    figure = plt.figure(figsize=(9, 7), layout="constrained")
    ax = figure.add_subplot(projection="3d")
    im = ax.scatter(*position[::step].T, c=product["status"].values[::step], cmap=cmap,
                    norm=norm, s=3, depthshade=False)
    track = product["platform_position"].values
    ax.plot(*track.T, color="black", linewidth=2, label="track")
    ax.scatter(*track[0], color="black", marker="o", s=30, label="start")
    mid = len(track) // 2
    reach = 0.3 * float(np.ptp(position, axis=0).max() or 1.0)
    ax.quiver(*track[mid], *(product["boresight"].values[mid] * reach), color="red",
              label="boresight (mid)")
    span = np.ptp(np.vstack([position, track]), axis=0)
    ax.set_box_aspect(np.maximum(span, 0.05 * span.max()))
    ax.set_xlabel("x [m]")
    ax.set_ylabel("y [m]")
    ax.set_zlabel("z [m]")
    bar = figure.colorbar(im, ax=ax, ticks=range(4), shrink=0.6)
    bar.ax.set_yticklabels([m.replace("_", " ") for m in STATUS_MEANINGS])
    ax.legend(loc="upper left")
    ax.set_title("Observation status over the trajectory")
    if path is not None:
        return _save(figure, path, overwrite)
    return figure


def plot_ambiguity_timeline(product: xr.Dataset, path: str | os.PathLike | None = None, *,
                            overwrite: bool = False) -> Any:
    """Along the track: area illuminated and resolved, and median resolutions, vs time."""
    plt = _pyplot()
    time = product["time"].values
    rows = 2 if "range_resolution" in product else 1
    figure, axes = plt.subplots(rows, 1, figsize=(9, 3.2 * rows), sharex=True, squeeze=False,
                                layout="constrained")
    ax = axes[0, 0]
    ax.plot(time, 100 * product["observed_fraction"].values, label="illuminated")
    ax.plot(time, 100 * product["resolved_fraction"].values, label="resolved (unambiguous)")
    ax.plot(time, 100 * product["cumulative_resolved_fraction"].values,
            label="resolved so far", linestyle="--")
    ax.set_ylabel("area [%]")
    ax.legend()
    ax.grid(alpha=0.3)
    if rows == 2:
        ax = axes[1, 0]
        lit = product["observation"].values >= 2
        for key, label in (("range_resolution", "range"), ("azimuth_resolution", "azimuth")):
            values = np.where(lit, product[key].values, np.nan)
            with np.errstate(all="ignore"):
                finite = np.where(np.isfinite(values), values, np.nan)
                counts = np.sum(~np.isnan(finite), axis=0)
                median = np.full(len(time), np.nan)
                has = counts > 0
                median[has] = np.nanmedian(finite[:, has], axis=0)
            ax.semilogy(time, median, label=f"median {label} resolution (illuminated)")
        attrs = product.attrs
        required = float(attrs.get("required_resolution", 0.1))
        ax.axhline(float(attrs.get("required_range_resolution", required)), color="C0",
                   linestyle=":", label="required (range)")
        ax.axhline(float(attrs.get("required_azimuth_resolution", required)), color="C1",
                   linestyle=":", label="required (azimuth)")
        ax.set_ylabel("resolution [m]")
        ax.legend()
        ax.grid(alpha=0.3, which="both")
    axes[-1, 0].set_xlabel("time [s]")
    figure.suptitle("Resolution and observation along the trajectory")
    if path is not None:
        return _save(figure, path, overwrite)
    return figure


def plot_ambiguity(product: xr.Dataset, out_dir: str | os.PathLike, prefix: str = "ambiguity",
                   *, overwrite: bool = False, suffix: str = ".png") -> list[Path]:
    """Write the maps, the 3-D view and the time line of a product into ``out_dir``."""
    out_dir = Path(out_dir)
    return [plot_ambiguity_maps(product, out_dir / f"{prefix}_maps{suffix}",
                                overwrite=overwrite),
            plot_ambiguity_3d(product, out_dir / f"{prefix}_3d{suffix}", overwrite=overwrite),
            plot_ambiguity_timeline(product, out_dir / f"{prefix}_timeline{suffix}",
                                    overwrite=overwrite)]


def plot_comparison(comparison: xr.Dataset, path: str | os.PathLike | None = None, *,
                    overwrite: bool = False) -> Any:
    """Candidate trajectories side by side: resolved area per surface and overall status."""
    plt = _pyplot()
    names = [str(n) for n in comparison["trajectory"].values]
    surfaces = [str(s) for s in comparison["surface"].values]
    figure = plt.figure(figsize=(max(9, 1.2 * len(surfaces) + 4), 4 + 3.6), layout="constrained")
    grid = figure.add_gridspec(2, max(2, len(names)))
    ax = figure.add_subplot(grid[0, :])
    width = 0.8 / len(names)
    x = np.arange(len(surfaces) + 1)
    for i, name in enumerate(names):
        values = list(100 * comparison["fraction_resolved"].values[i])
        values.append(100 * float(comparison["total_fraction_resolved"].values[i]))
        ax.bar(x - 0.4 + width * (i + 0.5), values, width, label=name)
    ax.set_xticks(x, surfaces + ["all"], rotation=20)
    ax.set_ylabel("area resolved [%]")
    ax.set_ylim(0, 100)
    ax.legend()
    ax.grid(alpha=0.3, axis="y")
    ax.set_title(f"Area observed at {_requirement_text(comparison.attrs)} without ambiguity")
    cmap, norm = _status_colormap()
    tracks = json.loads(comparison.attrs.get("tracks", "{}"))
    position = comparison["position"].values
    order = np.argsort(-position[:, 2], kind="stable")  # top view: the lowest drawn last
    extent = np.vstack([position[:, :2]] + [np.asarray(t)[:, :2] for t in tracks.values()])
    low, high = extent.min(axis=0), extent.max(axis=0)
    margin = 0.03 * float(np.max(high - low) or 1.0)
    for i, name in enumerate(names):
        axis = figure.add_subplot(grid[1, i])
        axis.scatter(position[order, 0], position[order, 1],
                     c=comparison["status"].values[i][order], cmap=cmap, norm=norm, s=2,
                     linewidths=0)
        if name in tracks:
            track = np.asarray(tracks[name])
            axis.plot(track[:, 0], track[:, 1], color="black", linewidth=1.5)
            axis.plot(track[0, 0], track[0, 1], "ko", markersize=4)
        axis.set_xlim(low[0] - margin, high[0] + margin)
        axis.set_ylim(low[1] - margin, high[1] + margin)
        axis.set_aspect("equal")
        axis.set_title(f"{name}: status (top view)", fontsize=9)
        axis.set_xlabel("x [m]")
        axis.set_ylabel("y [m]")
    from matplotlib.patches import Patch

    figure.legend(handles=[Patch(color=c, label=m.replace("_", " "))
                           for c, m in zip(_STATUS_COLOURS, STATUS_MEANINGS, strict=True)],
                  loc="lower center", ncols=4, fontsize=8)
    if path is not None:
        return _save(figure, path, overwrite)
    return figure


# --------------------------------------------------------------------------------------------
# TOML experiments
# --------------------------------------------------------------------------------------------
_AMBIGUITY_KEYS = ("spacing", "surfaces", "exclude", "sweep_step", "max_states",
                   "integration_time", "beam_threshold_db", "min_angle_deg", "criterion",
                   "shadowing", "per_state")


def _parse_ambiguity_options(t: Any) -> dict[str, Any]:
    options: dict[str, Any] = {}
    options["spacing"] = t.number("spacing", 0.25, unit="m", gt=0)
    surfaces = t.data.get("surfaces")
    t.seen.add("surfaces")
    if surfaces is not None:
        if not (isinstance(surfaces, list) and all(isinstance(s, str) for s in surfaces)):
            raise t.error("surfaces", "an array of shape ids (strings)", surfaces)
        options["shapes"] = surfaces
    exclude = t.data.get("exclude", [])
    t.seen.add("exclude")
    if not (isinstance(exclude, list) and all(isinstance(s, str) for s in exclude)):
        raise t.error("exclude", "an array of shape ids (strings)", exclude)
    options["exclude"] = exclude
    options["sweep_step"] = t.integer("sweep_step", None, ge=1)
    options["max_states"] = t.integer("max_states", 600, ge=2)
    t.seen.add("integration_time")
    value = t.data.get("integration_time", "beam")
    if isinstance(value, str):
        if value not in INTEGRATION_MODES:
            raise t.error("integration_time", "'beam', 'required' or a time > 0 [s]", value)
    elif isinstance(value, bool) or not isinstance(value, int | float) or not value > 0:
        raise t.error("integration_time", "'beam', 'required' or a time > 0 [s]", value)
    options["integration_time"] = float(value) if not isinstance(value, str) else value
    options["beam_threshold_db"] = t.number("beam_threshold_db", -6.0, unit="dB", lt=0)
    options["min_angle_deg"] = t.number("min_angle_deg", 30.0, unit="deg", ge=0, lt=90)
    options["criterion"] = t.string("criterion", "gradient", choices=CRITERIA)
    options["shadowing"] = t.boolean("shadowing", True)
    options["per_state"] = t.boolean("per_state", True)
    t.finish()
    return options


def _parse_planes(tables: list) -> list[dict[str, Any]]:
    planes = []
    for i, t in enumerate(tables):
        name = t.string("name", f"surface{i}")
        origin = t.vector("origin", 3, unit="m")
        axis_u = t.vector("axis_u", 3)
        axis_v = t.vector("axis_v", 3)
        size = t.vector("size", 2, unit="m")
        t.finish()
        u, v = np.asarray(axis_u), np.asarray(axis_v)
        if np.linalg.norm(u) == 0 or np.linalg.norm(v) == 0 or abs(
                u @ v) > 1e-6 * np.linalg.norm(u) * np.linalg.norm(v):
            raise t.error("axis_v", "a non-zero vector orthogonal to axis_u", list(axis_v))
        if min(size) <= 0:
            raise t.error("size", "2 sizes > 0 [m]", list(size))
        planes.append({"name": name, "origin": origin, "axis_u": axis_u, "axis_v": axis_v,
                       "size": size})
    return planes


def load_ambiguity_experiment(path: str | os.PathLike) -> dict[str, Any]:
    """Read and validate an ambiguity TOML file (format in ``docs/ambiguity.md``).

    Returns
    -------
    dict
        ``name``, ``description``, ``radar``, ``look`` (Look or dict name -> Look),
        ``trajectories`` (dict name -> Trajectory), ``required_resolution``, ``scene`` (path
        or name, or None), ``planes`` (list), ``options`` (keywords of :func:`ambiguity`),
        ``outputs`` (``figures``, ``format``), ``config`` (the effective values).
    """
    from mitsar.experiment.config import _parse_look, _parse_radar, _parse_trajectory, _Table

    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise ParameterError(where, "file", "an existing TOML file", str(path))
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as error:
        raise ParameterError(where, "file", "valid TOML", str(error)) from error
    top = _Table(data, "", where, path.resolve().parent)
    out: dict[str, Any] = {}
    out["name"] = top.string("name", path.stem)
    out["description"] = top.string("description", "")
    top.seen.add("required_resolution")
    required = top.data.get("required_resolution", 0.10)
    try:
        _requirement(required)
    except ParameterError as error:
        raise top.error("required_resolution", error.expected, required) from error
    out["required_resolution"] = (tuple(float(r) for r in required)
                                  if isinstance(required, list) else float(required))
    scene = top.string("scene", None)
    if scene is not None:
        candidate = Path(scene).expanduser()
        if not candidate.is_absolute() and (top.base / candidate).exists():
            scene = str((top.base / candidate).resolve())
    out["scene"] = scene
    radar_table = top.table("radar") or _Table({}, "radar", where, top.base)
    out["radar"] = _parse_radar(radar_table)
    look_table = top.table("look", required=True)
    out["look"] = _parse_look(look_table)
    trajectories: dict[str, Any] = {}
    looks: dict[str, Look] = {}
    single = top.table("trajectory")
    multiple = top.table("trajectories")
    if (single is None) == (multiple is None):
        raise top.error("trajectory", "exactly one of [trajectory] or [trajectories.NAME]",
                        "both" if single is not None else "neither")
    if single is not None:
        trajectories[out["name"] or "trajectory"] = _parse_trajectory(single)
    else:
        for name in multiple.data:
            t = multiple.table(name)
            if "look" in t.data:
                look_override = _Table(t.data.pop("look"), t.key("look"), where, top.base)
                looks[name] = _parse_look(look_override)
            trajectories[name] = _parse_trajectory(t)
        multiple.finish()
        if not trajectories:
            raise top.error("trajectories", "at least one [trajectories.NAME] table", "none")
    out["trajectories"] = trajectories
    if looks:
        out["look"] = {name: looks.get(name, out["look"]) for name in trajectories}
    ambiguity_table = top.table("ambiguity") or _Table({}, "ambiguity", where, top.base)
    out["options"] = _parse_ambiguity_options(ambiguity_table)
    out["planes"] = _parse_planes(top.tables("surfaces"))
    if scene is None and not out["planes"]:
        raise top.error("scene", "a scene (name or XML path) or at least one [[surfaces]] "
                        "rectangle", "neither")
    if scene is not None and out["planes"]:
        raise top.error("surfaces", "either a scene or [[surfaces]], not both", "both")
    output_table = top.table("output") or _Table({}, "output", where, top.base)
    out["outputs"] = {"figures": output_table.boolean("figures", True),
                      "format": output_table.string("format", "png",
                                                    choices=("png", "pdf", "svg"))}
    output_table.finish()
    top.finish()
    out["config"] = json.loads(json.dumps(data, default=str))
    return out


def run_ambiguity_experiment(path: str | os.PathLike, out_dir: str | os.PathLike, *,
                             overwrite: bool = False, figures: bool | None = None,
                             progress: bool = False) -> dict[str, Any]:
    """Run an ambiguity TOML file and write its products into ``out_dir``.

    One trajectory: ``ambiguity.nc``, ``ambiguity_maps``, ``ambiguity_3d`` and
    ``ambiguity_timeline`` figures, ``summary.json``. Several (``[trajectories.NAME]``): one
    ``ambiguity_NAME.nc`` and figure set each, plus ``comparison.nc``, ``comparison.md``
    (table), ``comparison`` figure and ``summary.json``.

    Returns
    -------
    dict
        The summary written to ``summary.json`` (per-trajectory, per-surface fractions) with
        the list of written ``files``.
    """
    spec = load_ambiguity_experiment(path)
    from mitsar.io import save, write_json

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    options = dict(spec["options"])
    shapes, exclude = options.pop("shapes", None), options.pop("exclude", ())
    spacing = options.pop("spacing")
    if spec["scene"] is not None:
        scene = load_mitsuba_scene(spec["scene"])
        points = sample_surfaces(scene, spacing, shapes=shapes, exclude=exclude)
    else:
        planes = spec["planes"]
        points = SurfacePoints.concatenate([
            plane_points(p["origin"], p["axis_u"], p["axis_v"], p["size"], spacing, p["name"])
            for p in planes])
        scene = planes_scene(planes) if options.get("shadowing", True) else None
    make_figures = spec["outputs"]["figures"] if figures is None else figures
    suffix = "." + spec["outputs"]["format"]
    files: list[str] = []
    summary: dict[str, Any] = {"name": spec["name"], "description": spec["description"],
                               "required_resolution": spec["required_resolution"],
                               "trajectories": {}}
    several = len(spec["trajectories"]) > 1
    products = {}
    for name, trajectory in spec["trajectories"].items():
        look = spec["look"][name] if isinstance(spec["look"], dict) else spec["look"]
        product = ambiguity(spec["radar"], trajectory, look, points,
                            spec["required_resolution"], scene=scene, spacing=spacing,
                            progress=progress, **options)
        product.attrs["config"] = json.dumps(spec["config"])
        products[name] = product
        prefix = f"ambiguity_{name}" if several else "ambiguity"
        files.append(str(save(product, out_dir / f"{prefix}.nc", overwrite=overwrite)))
        if make_figures:
            files.extend(str(p) for p in plot_ambiguity(product, out_dir, prefix,
                                                        overwrite=overwrite, suffix=suffix))
        table = surface_summary(product)
        summary["trajectories"][name] = {
            "overall": _overall(product),
            "surfaces": {str(s): {k: float(table[k].values[j]) for k in table.data_vars}
                         for j, s in enumerate(table["surface"].values)}}
    if several:
        comparison = comparison_from_products(products)
        comparison.attrs["config"] = json.dumps(spec["config"])
        files.append(str(save(comparison, out_dir / "comparison.nc", overwrite=overwrite)))
        markdown = comparison_table(comparison)
        from mitsar.io import atomic_output

        with atomic_output(out_dir / "comparison.md", overwrite) as tmp:
            tmp.write_text(markdown, encoding="utf-8")
        files.append(str(out_dir / "comparison.md"))
        if make_figures:
            files.append(str(plot_comparison(comparison, out_dir / f"comparison{suffix}",
                                             overwrite=overwrite)))
        summary["comparison_table"] = markdown
    summary["files"] = files + [str(out_dir / "summary.json")]
    write_json(summary, out_dir / "summary.json", overwrite=overwrite)
    return summary
