"""Planar polygons in 3-D, batched: area vectors, projection along a direction, convex clipping.

The geometry under the physical-optics apertures of ``docs/physical_optics.md`` §3: the part of
the last facet of a bounce chain lit through the chain is the last facet intersected with the
earlier facets projected along the reflected directions. Everything here is NumPy, vectorised
over a batch of polygons (e.g. one per incidence direction); the only Python loops run over the
vertices of one polygon (a handful), never over the batch.

Storage convention. A batch of polygons is ``points`` of shape ``(B, M, d)`` and ``count`` of
shape ``(B,)``: polygon ``b`` has the vertices ``points[b, :count[b]]`` in order; the slots
beyond ``count`` repeat vertex 0 (an empty polygon is all zeros). Repeating vertex 0 keeps every
edge formula valid without masks: the closing edge runs from the last vertex to vertex 0 and
the padded edges have zero length, so they add nothing to an edge sum (Gordon's formula, the
area vector) nor cut anything when used as a clipping edge.
"""

from __future__ import annotations

from collections.abc import Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError

__all__ = ["area_vector", "clip_convex", "clip_halfspace", "pad_polygons", "project_to_plane",
           "subdivide_triangles", "triangulate"]


def pad_polygons(polygons: Sequence[Any]) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Stack polygons of different vertex counts into the batch convention of this module.

    Parameters
    ----------
    polygons : sequence of array_like, each of shape (M_i, 3)
        Vertices of each polygon in order [m].

    Returns
    -------
    points : numpy.ndarray, shape (B, max M_i, 3)
        Vertices, padded by repeating vertex 0.
    count : numpy.ndarray of int, shape (B,)
        Number of vertices of each polygon.
    """
    arrays = [np.asarray(p, dtype=np.float64) for p in polygons]
    for i, a in enumerate(arrays):
        if a.ndim != 2 or a.shape[1] != 3 or a.shape[0] < 3 or not np.all(np.isfinite(a)):
            raise ParameterError("pad_polygons", f"polygons[{i}]",
                                 "an array of >= 3 finite vertices of shape (M, 3) [m]",
                                 f"shape {a.shape}")
    size = max(a.shape[0] for a in arrays)
    points = np.empty((len(arrays), size, 3))
    for i, a in enumerate(arrays):   # one copy per polygon at set-up, not a hot path
        points[i] = a[0]
        points[i, :a.shape[0]] = a
    return points, np.array([a.shape[0] for a in arrays], dtype=np.int64)


def area_vector(points: NDArray) -> NDArray[np.float64]:
    """Area vector ``(1/2) sum_m v_m x v_(m+1)`` of planar polygons (Newell's formula) [m²].

    Its length is the area and its direction the normal for which the vertices run
    counter-clockwise. Padded slots (repeated vertex 0) add nothing.

    Parameters
    ----------
    points : numpy.ndarray, shape (..., M, 3)
        Vertices [m].
    """
    points = np.asarray(points, dtype=np.float64)
    origin = points[..., :1, :]          # relative coordinates: exact for far-away polygons
    rel = points - origin
    return 0.5 * np.cross(rel, np.roll(rel, -1, axis=-2)).sum(axis=-2)


def project_to_plane(points: NDArray, direction: NDArray, plane_point: NDArray,
                     plane_normal: NDArray) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Move points along ``direction`` onto a plane: ``q + t d`` with ``(q + t d - p)·n = 0``.

    Parameters
    ----------
    points : numpy.ndarray, shape (B, M, 3)
        Points [m].
    direction : numpy.ndarray, shape (B, 3)
        Direction of travel (need not be unit; ``d·n`` must not vanish) [-].
    plane_point, plane_normal : numpy.ndarray, shape (3,) or (B, 3)
        A point of the plane [m] and its normal [-].

    Returns
    -------
    projected : numpy.ndarray, shape (B, M, 3)
        The points moved onto the plane [m].
    t : numpy.ndarray, shape (B, M)
        Parameters of the move, in units of ``|d|`` [m].
    """
    direction = np.asarray(direction, dtype=np.float64)
    normal = np.broadcast_to(plane_normal, direction.shape)
    anchor = np.broadcast_to(plane_point, direction.shape)
    dn = np.einsum("bi,bi->b", direction, normal)
    t = np.einsum("bmi,bi->bm", anchor[:, None, :] - points, normal) / dn[:, None]
    return points + t[:, :, None] * direction[:, None, :], t


def clip_halfspace(points: NDArray, count: NDArray, values: NDArray
                   ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Keep the part of each polygon where a linear function is >= 0 (Sutherland–Hodgman).

    Parameters
    ----------
    points : numpy.ndarray, shape (B, M, d)
        Polygons in the convention of this module.
    count : numpy.ndarray of int, shape (B,)
        Vertex counts.
    values : numpy.ndarray, shape (B, M)
        The linear function at each vertex (e.g. a signed distance to a plane); linear along
        edges, so the crossing of an edge is where it interpolates to zero.

    Returns
    -------
    points, count
        The clipped polygons (at most ``2 M`` slots, trimmed to the largest count).
    """
    points = np.asarray(points, dtype=np.float64)
    count = np.asarray(count, dtype=np.int64)
    size = points.shape[1]
    index = np.arange(size)
    real = index[None, :] < count[:, None]
    nxt = (index[None, :] + 1) % np.maximum(count, 1)[:, None]
    p_next = np.take_along_axis(points, nxt[:, :, None], axis=1)
    v_next = np.take_along_axis(values, nxt, axis=1)
    inside = values >= 0.0
    crossing = real & (inside != (v_next >= 0.0))
    with np.errstate(divide="ignore", invalid="ignore"):
        t = np.where(crossing, values / np.where(crossing, values - v_next, 1.0), 0.0)
    cross_point = points + t[:, :, None] * (p_next - points)
    slots = np.stack([points, cross_point], axis=2).reshape(points.shape[0], 2 * size, -1)
    keep = np.stack([real & inside, crossing], axis=2).reshape(points.shape[0], 2 * size)
    order = np.argsort(~keep, axis=1, kind="stable")
    slots = np.take_along_axis(slots, order[:, :, None], axis=1)
    new_count = keep.sum(axis=1)
    width = max(int(new_count.max(initial=0)), 1)
    slots = slots[:, :width]
    pad = np.arange(width)[None, :] >= new_count[:, None]
    slots = np.where(pad[:, :, None], slots[:, :1], slots)
    slots[new_count == 0] = 0.0
    return slots, new_count


def clip_convex(points: NDArray, count: NDArray, clip: NDArray
                ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Intersect coplanar polygons with convex polygons (Sutherland–Hodgman, edge by edge).

    Parameters
    ----------
    points : numpy.ndarray, shape (B, M, 3)
        Subject polygons [m], in the plane of ``clip`` (any orientation, convex or not).
    count : numpy.ndarray of int, shape (B,)
        Their vertex counts.
    clip : numpy.ndarray, shape (K, 3) or (B, K, 3)
        The convex clipping polygon, one for all or one per subject [m], vertices in order
        (either orientation; padded slots repeating vertex 0 clip nothing).

    Returns
    -------
    points, count
        The intersections, in the convention of this module.
    """
    clip = np.asarray(clip, dtype=np.float64)
    points = np.asarray(points, dtype=np.float64)
    lanes = (points.shape[0], 3)
    normal = np.broadcast_to(area_vector(clip), lanes)
    size = clip.shape[-2]
    for j in range(size):                     # the edges of one polygon (a handful)
        a = np.broadcast_to(clip[..., j, :], lanes)
        b = np.broadcast_to(clip[..., (j + 1) % size, :], lanes)
        inward = np.cross(normal, b - a)      # points into the polygon (CCW about normal)
        values = np.einsum("bmi,bi->bm", points - a[:, None, :], inward)
        points, count = clip_halfspace(points, count, values)
    return points, count


def triangulate(points: NDArray, count: NDArray) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Fan triangles ``(v_0, v_m, v_(m+1))`` of convex polygons.

    Returns
    -------
    triangles : numpy.ndarray, shape (T, 3, 3)
        The non-degenerate triangles [m].
    parent : numpy.ndarray of int, shape (T,)
        Index of the polygon each comes from.
    """
    points = np.asarray(points, dtype=np.float64)
    size = points.shape[1]
    m = np.arange(1, max(size - 1, 1))
    tri = np.stack([np.broadcast_to(points[:, :1], (points.shape[0], m.size, 3)),
                    points[:, m], points[:, (m + 1) % size]], axis=2)      # (B, M-2, 3, 3)
    valid = (m[None, :] + 1) < np.asarray(count)[:, None]
    parent = np.broadcast_to(np.arange(points.shape[0])[:, None], valid.shape)
    return tri[valid], parent[valid]


def subdivide_triangles(triangles: NDArray, pieces: int) -> NDArray[np.float64]:
    """Split each triangle into ``pieces²`` congruent triangles (a barycentric grid).

    Parameters
    ----------
    triangles : numpy.ndarray, shape (T, 3, 3)
        Triangles [m].
    pieces : int
        Divisions along each edge (>= 1).

    Returns
    -------
    numpy.ndarray, shape (T * pieces², 3, 3)
        Sub-triangles with the orientation of their parent [m]; each parent's pieces are
        contiguous.
    """
    n = int(pieces)
    i, j = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
    up = i + j <= n - 1                    # (i, j), (i+1, j), (i, j+1)
    down = i + j <= n - 2                  # (i+1, j), (i+1, j+1), (i, j+1)
    corners_up = np.stack([np.stack([i[up], j[up]], -1), np.stack([i[up] + 1, j[up]], -1),
                           np.stack([i[up], j[up] + 1], -1)], axis=1)
    corners_down = np.stack([np.stack([i[down] + 1, j[down]], -1),
                             np.stack([i[down] + 1, j[down] + 1], -1),
                             np.stack([i[down], j[down] + 1], -1)], axis=1)
    grid = np.concatenate([corners_up, corners_down]) / n      # (n², 3 corners, 2)
    a = triangles[:, None, None, 0, :]
    e1 = triangles[:, None, None, 1, :] - triangles[:, None, None, 0, :]
    e2 = triangles[:, None, None, 2, :] - triangles[:, None, None, 0, :]
    out = a + grid[None, :, :, 0:1] * e1 + grid[None, :, :, 1:2] * e2
    return out.reshape(-1, 3, 3)
