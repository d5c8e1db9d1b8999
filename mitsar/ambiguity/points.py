"""Surface points of an ambiguity map: positions, normals, area weights, surfaces and facets.

:class:`SurfacePoints` holds them; build it from arrays, on rectangles (:func:`plane_points`)
or on the shapes of a Mitsuba scene (:func:`sample_surfaces`, the regular front end of
:mod:`mitsar.scene.surfaces`). Each surface is split into planar facets by normal (a box has
six), each unfolded into an in-plane map for the figures.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.scene.loading import load_scene
from mitsar.scene.surfaces import regular_grid, sample_surface_points

__all__ = ["SurfacePoints", "plane_points", "sample_surfaces", "unit_rows"]


def unit_rows(vectors: NDArray) -> NDArray:
    """Vectors scaled to unit length along the last axis (zero vectors stay zero)."""
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
    u, v = unit_rows(np.asarray(axis_u, float)), unit_rows(np.asarray(axis_v, float))
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
    s, t = regular_grid(size[0], size[1], spacing)
    position = origin + (s * size[0])[:, None] * u + (t * size[1])[:, None] * v
    normal = np.cross(u, v)
    area = size[0] * size[1] / len(s)
    return SurfacePoints.from_arrays(position, normal, area, names=[name])


def sample_surfaces(scene: Any, spacing: float = 0.25, *, shapes: Sequence[str] | None = None,
                    exclude: Sequence[str] = (), min_area: float = 0.0,
                    seed: int = 0) -> SurfacePoints:
    """Points with normals on the surfaces of a Mitsuba scene, about ``spacing`` apart.

    Rectangle-like shapes get a regular grid of cell centres with a step close to ``spacing``
    along each edge; other triangle meshes per-triangle grids; analytic shapes (sphere, disk,
    ...) ``area / spacing^2`` seeded uniform samples (:func:`mitsar.scene.sample_surface_points`).
    Point targets are skipped; shapes are taken in canonical order (by id).

    Parameters
    ----------
    scene : mitsuba.Scene, path or canned scene name
        Loaded with :func:`mitsar.scene.load_scene`.
    spacing, shapes, exclude, min_area, seed
        As for :func:`mitsar.scene.sample_surface_points` (spacing [m], shape ids to keep and
        to skip, smallest shape area [m^2], seed of the random samples).
    """
    samples = sample_surface_points(load_scene(scene), spacing, shapes=shapes, exclude=exclude,
                                    min_area=min_area, seed=seed)
    return SurfacePoints.from_arrays(samples.positions, samples.normals, samples.area,
                                     samples.surface, samples.names)
