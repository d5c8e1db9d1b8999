"""Ground truth of a map, from the Mitsuba scene: surfaces, geometric features, what is observable.

mitsar owns what no real campaign has, the scene itself; a map made from its images can be
scored against it (:func:`mitsar.features.scores.map_scores`, docs/features.md "Map scores").
The truth has three parts:

- **surface samples**: points with normals about ``spacing`` apart on every shape but point
  targets, from the sampler the ambiguity maps use
  (:func:`mitsar.scene.surfaces.sample_surface_points`), each standing for its area;
- **geometric features** of the meshes (:func:`scene_features`): straight edges where two planar
  faces meet, classified by the angle of the air wedge between them (the side the normals point
  to; mitsar's scenes point them into the room): a concave right angle is a ``"dihedral"``, any
  other concave angle a ``"concave_edge"``, a convex fold a ``"convex_edge"``; a point where
  three mutually perpendicular dihedral edges meet is a ``"trihedral"`` corner. Faces of
  different shapes count as meeting where one face's edge lies on the other face within a
  tolerance (the canned rooms build their corners from separate rectangles that share no mesh
  edge; a cabinet stands on a floor whose triangle it does not share); a face lying back to back
  on another (a cabinet's bottom on the floor) is hidden and makes no edge;
- **observability** (:func:`observe_points`): a point is observable when, from at least one
  antenna position of the flight, it is inside the nominal beam (direction sines within half the
  beamwidths, the footprint's convention of :func:`mitsar.scene.footprint.beam_directions`, and
  within ``max_range``) and nothing in the scene blocks the segment between them (one batched
  Mitsuba ``ray_test``, :func:`mitsar.scene.facets.segments_visible`). A feature no pass
  observes is "not visible" in the scores, not "missed".
"""

from __future__ import annotations

import itertools
import math
from collections.abc import Sequence
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.model.radar import Radar
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.products.raw import look_of, radar_of
from mitsar.scene.facets import segments_visible
from mitsar.scene.loading import load_scene
from mitsar.scene.surfaces import sample_surface_points, scene_surfaces

__all__ = ["FEATURE_KINDS", "Observer", "SceneTruth", "TruthFeatures", "observe_points",
           "point_segment_distance",
           "observer_from_track", "scene_features", "scene_truth"]

FEATURE_KINDS = ("trihedral", "dihedral", "concave_edge", "convex_edge", "unoriented_edge")
"""Kinds of geometric feature. ``"unoriented_edge"``: two faces whose normals disagree about
the air side (one points towards the other face, the other away); reported, never scored."""

_KIND_CODE = {kind: code for code, kind in enumerate(FEATURE_KINDS)}
_CHUNK = 2_000_000
"""Pairs (edge x triangle, point x antenna position) evaluated per vectorised block."""


# --------------------------------------------------------------------------------------------
# Geometric features
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class TruthFeatures:
    """Geometric features of a scene (module docstring), one row per feature.

    Attributes
    ----------
    kind : numpy.ndarray of str, shape (F,)
        One of :data:`FEATURE_KINDS`.
    start, end : numpy.ndarray, shape (F, 3)
        Segment ends [m]; a trihedral's are both its corner.
    normals : numpy.ndarray, shape (F, 3, 3)
        Unit normals of the faces that meet (two for an edge, the third row NaN; three for a
        trihedral).
    angle_deg : numpy.ndarray, shape (F,)
        Angle of the air wedge between the faces [deg]: 90 for a dihedral (and a trihedral's
        faces), 270 for a box's convex edge.
    shapes : tuple of str
        Ids of the shapes whose faces meet, ``"|"``-joined, per feature.
    in_footprint, visible, observable : numpy.ndarray of bool, shape (F,)
        Some sample along the feature is inside the beam of some antenna position; inside it
        and not occluded from there (= ``observable``; ``visible`` is kept for reading).
        All True when no flight was given.
    observable_fraction : numpy.ndarray, shape (F,)
        Fraction of the feature's samples (about ``spacing`` apart) that are observable.
    """

    kind: NDArray[np.str_]
    start: NDArray[np.float64]
    end: NDArray[np.float64]
    normals: NDArray[np.float64]
    angle_deg: NDArray[np.float64]
    shapes: tuple[str, ...]
    in_footprint: NDArray[np.bool_]
    visible: NDArray[np.bool_]
    observable: NDArray[np.bool_]
    observable_fraction: NDArray[np.float64]

    def __len__(self) -> int:
        return int(self.kind.shape[0])

    @property
    def position(self) -> NDArray[np.float64]:
        """Corner (trihedral) or segment midpoint (edges), shape (F, 3) [m]."""
        return 0.5 * (self.start + self.end)

    @property
    def ids(self) -> tuple[str, ...]:
        """Labels ``"<kind>_<k>"``, ``k`` counting features of that kind in row order."""
        counts: dict[str, int] = {}
        out = []
        for kind in self.kind.tolist():
            out.append(f"{kind}_{counts.get(kind, 0)}")
            counts[kind] = counts.get(kind, 0) + 1
        return tuple(out)

    @property
    def reason(self) -> NDArray[np.str_]:
        """``"observable"``, ``"outside_footprint"`` or ``"occluded"`` per feature."""
        return np.where(self.observable, "observable",
                        np.where(self.in_footprint, "occluded", "outside_footprint"))

    def select(self, keep: NDArray[np.bool_]) -> TruthFeatures:
        """The features where ``keep`` is True."""
        keep = np.asarray(keep, dtype=bool)
        return TruthFeatures(self.kind[keep], self.start[keep], self.end[keep],
                             self.normals[keep], self.angle_deg[keep],
                             tuple(s for s, k in zip(self.shapes, keep, strict=True) if k),
                             self.in_footprint[keep], self.visible[keep], self.observable[keep],
                             self.observable_fraction[keep])

    def to_dataset(self) -> xr.Dataset:
        """The features as an ``xarray.Dataset`` with dims ``feature``, ``xyz``, ``face``."""
        return xr.Dataset(
            {"kind": ("feature", self.kind.astype(str)),
             "start": (("feature", "xyz"), self.start, {"units": "m"}),
             "end": (("feature", "xyz"), self.end, {"units": "m"}),
             "position": (("feature", "xyz"), self.position,
                          {"units": "m", "long_name": "corner or edge midpoint"}),
             "normals": (("feature", "face", "xyz"), self.normals,
                         {"units": "1", "long_name": "unit normals of the faces that meet"}),
             "angle": ("feature", self.angle_deg,
                       {"units": "deg", "long_name": "air-wedge angle between the faces"}),
             "shapes": ("feature", np.array(self.shapes, dtype=str)),
             "in_footprint": ("feature", self.in_footprint),
             "observable": ("feature", self.observable),
             "observable_fraction": ("feature", self.observable_fraction, {"units": "1"}),
             "reason": ("feature", self.reason.astype(str))},
            coords={"feature": list(self.ids), "xyz": ["x", "y", "z"], "face": [0, 1, 2]})


def _mesh_triangles(scene: Any) -> tuple[NDArray, NDArray, tuple[str, ...]]:
    """World triangles (T, 3, 3) [m] of every mesh but point targets, their shape index, names."""
    triangles, owner, names = [np.zeros((0, 3, 3))], [np.zeros(0, dtype=np.int64)], []
    for surface in scene_surfaces(scene):                     # one read per shape
        shape = surface.shape
        if not shape.is_mesh() or plugin_kind(shape.bsdf()) is PluginKind.POINTTARGET:
            continue
        vertices = np.asarray(shape.vertex_positions_buffer(), float).reshape(-1, 3)
        faces = np.asarray(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        triangles.append(vertices[faces])
        owner.append(np.full(len(faces), len(names), dtype=np.int64))
        names.append(surface.id or f"shape{surface.index}")
    return np.concatenate(triangles), np.concatenate(owner), tuple(names)


def _unit(v: NDArray) -> NDArray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0, norm, 1.0)


def _edge_normals(tri: NDArray, normal: NDArray) -> NDArray:
    """In-plane unit normals of a triangle's edges pointing inside, shape (T, 3, 3)."""
    edges = np.roll(tri, -1, axis=1) - tri                    # edge m: vertex m -> m+1
    inward = _unit(np.cross(normal[:, None, :], edges))       # left of a counter-clockwise edge
    return inward


def _chunked_pairs(count_a: int, count_b: int, test: Any) -> tuple[NDArray, NDArray]:
    """Index pairs (i, j) where ``test(i_slice, all j)`` (a (len, count_b) bool array) holds."""
    rows = max(1, _CHUNK // max(count_b, 1))
    ia, jb = [np.zeros(0, dtype=np.int64)], [np.zeros(0, dtype=np.int64)]
    for start in range(0, count_a, rows):                     # blocks of pairs, not points
        i, j = np.nonzero(test(slice(start, min(start + rows, count_a))))
        ia.append(i + start)
        jb.append(j)
    return np.concatenate(ia), np.concatenate(jb)


def _hidden(tri: NDArray, normal: NDArray, tolerance: float, cos_fold: float) -> NDArray:
    """Triangles lying back to back on another (anti-parallel, coplanar, centroid inside)."""
    centroid = tri.mean(axis=1)
    inward = _edge_normals(tri, normal)

    offset = np.einsum("jk,jk->j", tri[:, 0], normal)          # plane of j: n_j . x = offset_j

    def test(rows: slice) -> NDArray:
        c = centroid[rows]
        anti = normal[rows] @ normal.T < -cos_fold
        plane = np.abs(c @ normal.T - offset[None, :])
        inside = np.all(np.einsum("ik,jmk->ijm", c, inward)
                        - np.einsum("jmk,jmk->jm", tri, inward)[None] >= -tolerance, axis=2)
        return anti & (plane <= tolerance) & inside

    i, _ = _chunked_pairs(len(tri), len(tri), test)
    hidden = np.zeros(len(tri), dtype=bool)
    hidden[i] = True
    return hidden


def _junction_pieces(tri: NDArray, normal: NDArray, tolerance: float, cos_fold: float
                     ) -> dict[str, NDArray]:
    """Pieces of triangle edges lying on another, non-parallel triangle, with both faces' sides.

    Each triangle edge ``a -> b`` (owner ``t``, inward direction ``d`` in ``t``'s plane) is
    tested against every triangle ``j`` whose normal differs by more than the fold threshold:
    both ends within ``tolerance`` of ``j``'s plane, then clipped to ``j`` (its three edge
    half-planes, widened by ``tolerance``). ``j``'s side ``d'`` is its inward edge normal where
    the piece lies on ``j``'s boundary, else the in-plane direction across the piece on the
    side of ``t``'s normal (the part of ``j`` in front of ``t``).
    """
    count = len(tri)
    a = tri.reshape(-1, 3)                                    # edge m of triangle t: row 3t+m
    b = np.roll(tri, -1, axis=1).reshape(-1, 3)
    owner = np.repeat(np.arange(count), 3)
    d = _edge_normals(tri, normal).reshape(-1, 3)
    offset = np.einsum("jk,jk->j", tri[:, 0], normal)          # plane of j: n_j . x = offset_j

    def test(rows: slice) -> NDArray:
        fold = np.abs(normal[owner[rows]] @ normal.T) < cos_fold
        da = np.abs(a[rows] @ normal.T - offset[None, :])
        db = np.abs(b[rows] @ normal.T - offset[None, :])
        return fold & (da <= tolerance) & (db <= tolerance)

    k, j = _chunked_pairs(len(a), count, test)
    inward = _edge_normals(tri, normal)[j]                     # (pairs, 3, 3)
    base = np.einsum("pmk,pmk->pm", tri[j], inward)
    ga = np.einsum("pk,pmk->pm", a[k], inward) - base          # (pairs, 3)
    gb = np.einsum("pk,pmk->pm", b[k], inward) - base
    slope = gb - ga
    flat = np.abs(slope) < 1e-12
    with np.errstate(divide="ignore", invalid="ignore"):
        root = (-tolerance - ga) / np.where(flat, 1.0, slope)
    lower = np.where(flat, np.where(ga >= -tolerance, 0.0, np.inf), np.where(slope > 0, root, 0.0))
    upper = np.where(flat, np.where(ga >= -tolerance, 1.0, -np.inf),
                     np.where(slope < 0, root, 1.0))
    lo = np.clip(lower.max(axis=1), 0.0, 1.0)
    hi = np.clip(upper.min(axis=1), 0.0, 1.0)
    length = np.linalg.norm(b[k] - a[k], axis=1)
    # Pieces shorter than ten tolerances are slivers where the widened half-planes let a
    # segment that only touches a triangle's vertex in; real junctions are longer.
    keep = (hi - lo) * length > 10.0 * tolerance
    k, j, lo, hi, inward = k[keep], j[keep], lo[keep], hi[keep], inward[keep]
    ga, gb = ga[keep], gb[keep]
    p0 = a[k] + lo[:, None] * (b[k] - a[k])
    p1 = a[k] + hi[:, None] * (b[k] - a[k])
    g0 = ga + lo[:, None] * (gb - ga)
    g1 = ga + hi[:, None] * (gb - ga)
    on_edge = (np.abs(g0) <= tolerance) & (np.abs(g1) <= tolerance)     # (pairs, 3)
    boundary = on_edge.any(axis=1)
    edge_index = np.argmax(on_edge, axis=1)
    t = owner[k]
    n_t, n_j = normal[t], normal[j]
    direction = _unit(p1 - p0)
    across = _unit(np.cross(n_j, direction))
    across *= np.where(np.einsum("pk,pk->p", across, n_t) >= 0, 1.0, -1.0)[:, None]
    d_j = np.where(boundary[:, None], inward[np.arange(len(k)), edge_index], across)
    return {"p0": p0, "p1": p1, "t": t, "j": j, "d_t": d[k], "d_j": d_j, "n_t": n_t, "n_j": n_j}


def _classify(pieces: dict[str, NDArray], angle_tolerance_deg: float
              ) -> tuple[NDArray, NDArray]:
    """Kind code and air-wedge angle [deg] of each junction piece (module docstring)."""
    front_j = np.einsum("pk,pk->p", pieces["d_j"], pieces["n_t"])  # j lies in front of t
    front_t = np.einsum("pk,pk->p", pieces["d_t"], pieces["n_j"])  # t lies in front of j
    opening = np.degrees(np.arccos(np.clip(np.einsum("pk,pk->p", pieces["d_t"],
                                                     pieces["d_j"]), -1.0, 1.0)))
    concave = (front_j > 0) & (front_t > 0)
    convex = (front_j < 0) & (front_t < 0)
    angle = np.where(convex, 360.0 - opening, opening)
    right = np.abs(angle - 90.0) <= angle_tolerance_deg
    kind = np.where(concave & right, _KIND_CODE["dihedral"],
                    np.where(concave, _KIND_CODE["concave_edge"],
                             np.where(convex, _KIND_CODE["convex_edge"],
                                      _KIND_CODE["unoriented_edge"])))
    return kind, angle


def _merge_pieces(pieces: dict[str, NDArray], kind: NDArray, angle: NDArray,
                  names: tuple[str, ...], owner_shape: NDArray, tolerance: float
                  ) -> dict[str, Any]:
    """Merge collinear, overlapping pieces of the same kind and face pair into edges."""
    p0, p1 = pieces["p0"], pieces["p1"]
    direction = _unit(p1 - p0)
    foot = p0 - np.einsum("pk,pk->p", p0, direction)[:, None] * direction  # line's closest pt
    outer = np.einsum("pi,pj->pij", direction, direction).reshape(-1, 9)
    pair_sum = pieces["n_t"] + pieces["n_j"]
    key = np.hstack([foot, outer, pair_sum, 10.0 * kind[:, None]])
    pairs = cKDTree(key).query_pairs(r=tolerance, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(key), len(key)))
    _, group = connected_components(graph, directed=False)
    # One reference direction per group (the first piece's), intervals along it.
    first = np.unique(group, return_index=True)[1]             # first piece of each group
    axis = direction[first][group]
    axis_point = foot[first][group]
    s0 = np.einsum("pk,pk->p", p0 - axis_point, axis)
    s1 = np.einsum("pk,pk->p", p1 - axis_point, axis)
    lo, hi = np.minimum(s0, s1), np.maximum(s0, s1)
    order = np.lexsort((lo, group))
    group, lo, hi = group[order], lo[order], hi[order]
    reach = np.maximum.accumulate(hi + group * 1e9) - group * 1e9   # running max per group
    new = np.ones(len(group), dtype=bool)
    new[1:] = (group[1:] != group[:-1]) | (lo[1:] > reach[:-1] + tolerance)
    run = np.cumsum(new) - 1
    starts = np.flatnonzero(new)
    run_lo = np.minimum.reduceat(lo, starts)
    run_hi = np.maximum.reduceat(hi, starts)
    ref = order[starts]
    start = axis_point[ref] + run_lo[:, None] * axis[ref]
    end = axis_point[ref] + run_hi[:, None] * axis[ref]
    n_a, n_b = pieces["n_t"][ref], pieces["n_j"][ref]
    normals = np.full((len(ref), 3, 3), np.nan)
    normals[:, 0], normals[:, 1] = n_a, n_b
    piece_shapes = np.stack([owner_shape[pieces["t"][order]],
                             owner_shape[pieces["j"][order]]], axis=1)
    shapes = []
    for r in range(len(starts)):                                # one per feature, not point
        members = np.unique(piece_shapes[run == r])
        shapes.append("|".join(sorted(names[m] for m in members)))
    return {"kind": kind[ref], "start": start, "end": end, "normals": normals,
            "angle": angle[ref], "shapes": shapes}


def point_segment_distance(points: NDArray, start: NDArray, end: NDArray) -> NDArray:
    """Distances (P, S) [m] from points to segments."""
    seg = end - start
    length2 = np.maximum(np.einsum("sk,sk->s", seg, seg), 1e-300)
    rel = points[:, None, :] - start[None, :, :]
    s = np.clip(np.einsum("psk,sk->ps", rel, seg) / length2, 0.0, 1.0)
    return np.linalg.norm(rel - s[..., None] * seg[None], axis=-1)


def _trihedrals(edges: dict[str, Any], tolerance: float, angle_tolerance_deg: float
                ) -> dict[str, Any]:
    """Points where three mutually perpendicular dihedral edges meet (module docstring)."""
    dihedral = np.flatnonzero(edges["kind"] == _KIND_CODE["dihedral"])
    empty = {"corner": np.zeros((0, 3)), "normals": np.zeros((0, 3, 3)), "shapes": []}
    if len(dihedral) < 3:
        return empty
    start, end = edges["start"][dihedral], edges["end"][dihedral]
    ends = np.vstack([start, end])
    tree = cKDTree(ends)
    pairs = tree.query_pairs(r=tolerance, output_type="ndarray")
    graph = coo_matrix((np.ones(len(pairs)), (pairs[:, 0], pairs[:, 1])),
                       shape=(len(ends), len(ends)))
    _, label = connected_components(graph, directed=False)
    candidates = np.stack([np.bincount(label, ends[:, i]) for i in range(3)], axis=1)
    candidates /= np.bincount(label)[:, None]
    incident = point_segment_distance(candidates, start, end) <= tolerance
    direction = _unit(end - start)
    sin_tol = math.sin(math.radians(angle_tolerance_deg))
    corners, normals, shapes = [], [], []
    for c in np.flatnonzero(incident.sum(axis=1) >= 3):         # one per candidate corner
        through = np.flatnonzero(incident[c])
        for triple in itertools.combinations(through, 3):
            dirs = direction[list(triple)]
            if np.any(np.abs(dirs @ dirs.T - np.eye(3)) > sin_tol):
                continue
            faces = edges["normals"][dihedral[list(triple)], :2].reshape(-1, 3)
            unique = faces[np.unique(np.round(faces, 3) + 0.0, axis=0,   # -0.0 -> 0.0
                                     return_index=True)[1]]
            if len(unique) != 3 or np.any(np.abs(unique @ unique.T - np.eye(3)) > sin_tol):
                continue
            # Each face's plane from the ends of the edges it bounds; the corner is where the
            # three planes meet.
            ends3 = np.stack([start[list(triple)], end[list(triple)]], axis=1)   # (3, 2, 3)
            on_face = np.abs(np.einsum("fk,ek->fe", unique,
                                       edges["normals"][dihedral[list(triple)], 0])) > 0.999
            on_face |= np.abs(np.einsum("fk,ek->fe", unique,
                                        edges["normals"][dihedral[list(triple)], 1])) > 0.999
            level = np.einsum("fk,epk->fep", unique, ends3).mean(axis=2)       # (face, edge)
            offsets = (level * on_face).sum(axis=1) / np.maximum(on_face.sum(axis=1), 1)
            corners.append(np.linalg.solve(unique, offsets))
            normals.append(unique)
            names = {part for t in triple for part in edges["shapes"][dihedral[t]].split("|")}
            shapes.append("|".join(sorted(names)))
            break
    if not corners:
        return empty
    corner = np.array(corners)
    # One corner per point (two triples can share it when more than three edges meet).
    keep = np.ones(len(corner), dtype=bool)
    for i, j in cKDTree(corner).query_pairs(r=tolerance):
        keep[max(i, j)] = False
    return {"corner": corner[keep], "normals": np.array(normals)[keep],
            "shapes": [s for s, k in zip(shapes, keep, strict=True) if k]}


def scene_features(scene: Any, *, tolerance: float = 1e-3, angle_tolerance_deg: float = 5.0,
                   min_fold_deg: float = 20.0) -> TruthFeatures:
    """Geometric features of a scene's meshes: dihedral, concave and convex edges, trihedrals.

    Every planar shape of mitsar's scenes is a Mitsuba mesh (rectangles and cubes are meshes
    of two and twelve triangles; PLY meshes are read as they are); spheres, disks and point
    targets make no features.

    Parameters
    ----------
    scene : mitsuba.Scene or str
        A loaded scene, or a path / canned scene name for :func:`mitsar.scene.load_scene`.
    tolerance : float
        Distance [m] within which a face's edge counts as lying on another face and edge pieces
        and corners are merged (default 1 mm).
    angle_tolerance_deg : float
        Largest departure from 90 deg [deg] of a ``"dihedral"`` edge's air wedge, and from
        perpendicular of a trihedral's edges and faces (default 5 deg).
    min_fold_deg : float
        Faces whose normals differ by less make no edge [deg] (default 20 deg: a tessellated
        curved surface is not a row of edges).

    Returns
    -------
    TruthFeatures
        Trihedrals first, then edges; observability all True (see :func:`scene_truth`).
    """
    for name, value, low, high in (("tolerance", tolerance, 0.0, math.inf),
                                   ("angle_tolerance_deg", angle_tolerance_deg, 0.0, 45.0),
                                   ("min_fold_deg", min_fold_deg, 0.0, 90.0)):
        if not (isinstance(value, int | float) and low < value < high):
            raise ParameterError("scene_features", name, f"a number in ({low}, {high})", value)
    if isinstance(scene, str):
        scene = load_scene(scene)
    tri, owner_shape, names = _mesh_triangles(scene)
    cross = np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0])
    area2 = np.linalg.norm(cross, axis=1)
    good = area2 > 0
    tri, owner_shape, normal = tri[good], owner_shape[good], cross[good] / area2[good, None]
    cos_fold = math.cos(math.radians(min_fold_deg))
    visible = ~_hidden(tri, normal, tolerance, 0.999)
    tri, owner_shape, normal = tri[visible], owner_shape[visible], normal[visible]
    pieces = _junction_pieces(tri, normal, tolerance, cos_fold)
    if len(pieces["t"]):
        kind, angle = _classify(pieces, angle_tolerance_deg)
        edges = _merge_pieces(pieces, kind, angle, names, owner_shape, tolerance)
    else:
        edges = {"kind": np.zeros(0, dtype=np.int64), "start": np.zeros((0, 3)),
                 "end": np.zeros((0, 3)), "normals": np.zeros((0, 3, 3)),
                 "angle": np.zeros(0), "shapes": []}
    corners = _trihedrals(edges, tolerance, angle_tolerance_deg)
    count = len(corners["corner"])
    kinds = np.array(["trihedral"] * count + [FEATURE_KINDS[k] for k in edges["kind"]],
                     dtype=str)
    total = len(kinds)
    return TruthFeatures(
        kind=kinds,
        start=np.vstack([corners["corner"], edges["start"]]),
        end=np.vstack([corners["corner"], edges["end"]]),
        normals=np.concatenate([corners["normals"].reshape(-1, 3, 3), edges["normals"]]),
        angle_deg=np.concatenate([np.full(count, 90.0), edges["angle"]]),
        shapes=tuple(corners["shapes"]) + tuple(edges["shapes"]),
        in_footprint=np.ones(total, dtype=bool), visible=np.ones(total, dtype=bool),
        observable=np.ones(total, dtype=bool), observable_fraction=np.ones(total))


# --------------------------------------------------------------------------------------------
# Observability from the flight
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class Observer:
    """Antenna positions and frames of a flight, and the beam they carry.

    Attributes
    ----------
    positions : numpy.ndarray, shape (P, 3)
        Antenna phase centres [m].
    frames : numpy.ndarray, shape (P, 3, 3)
        Antenna-to-world rotations (columns: azimuth axis, elevation axis, boresight).
    azimuth_beamwidth, elevation_beamwidth : float
        Full beamwidths as direction sines [rad] (``lambda / D``).
    max_range : float
        Largest range the receiver holds [m].
    cover : float
        Half-width of the beam counted as the footprint, in half beamwidths (1: the nominal
        -3.9 dB one-way edge of :func:`mitsar.scene.footprint.beam_directions`).
    passes : int
        Number of passes the positions come from.
    """

    positions: NDArray[np.float64]
    frames: NDArray[np.float64]
    azimuth_beamwidth: float
    elevation_beamwidth: float
    max_range: float
    cover: float = 1.0
    passes: int = 1


def _as_observer(track: Any, samples: int | None, cover: float) -> Observer:
    if isinstance(track, Observer):
        return track
    return observer_from_track(track, samples=samples, cover=cover)


def observer_from_track(track: xr.Dataset | Sequence[xr.Dataset], samples: int | None = None,
                        cover: float = 1.0) -> Observer:
    """The antenna positions of one or more raw products (passes), a few per pass.

    Parameters
    ----------
    track : xarray.Dataset or sequence of them
        Raw (or histogram) products: ``platform_position``, ``attitude``, the look and radar
        attributes (:data:`mitsar.products.raw.RAW_SCHEMA`); the recorded (navigation) track.
    samples : int, optional
        Positions per pass, evenly spaced over its sweeps, ends included. Default: as many as
        keep consecutive positions within half the azimuth footprint at 1 m range
        (``0.5 · beta_az · 1 m``), between 2 and 256.
    cover : float
        See :class:`Observer`.

    Returns
    -------
    Observer
    """
    products = [track] if isinstance(track, xr.Dataset) else list(track)
    if not products or not all(isinstance(p, xr.Dataset) and "platform_position" in p
                               for p in products):
        raise ParameterError("observer_from_track", "track",
                             "a raw product or a list of them (one per pass)", type(track))
    if not (isinstance(cover, int | float) and cover > 0):
        raise ParameterError("observer_from_track", "cover", "a number > 0", cover)
    positions, frames = [], []
    radars: list[Radar] = []
    for product in products:                                 # one per pass
        radar = radar_of(product)
        radars.append(radar)
        pos = np.asarray(product["platform_position"].values, dtype=float).reshape(-1, 3)
        attitude = np.asarray(product["attitude"].values, dtype=float).reshape(-1, 3)
        count = samples
        if count is None:
            length = float(np.sum(np.linalg.norm(np.diff(pos, axis=0), axis=1)))
            count = int(np.clip(math.ceil(length / (0.5 * radar.azimuth_beamwidth)) + 1, 2, 256))
        if isinstance(count, bool) or not isinstance(count, int | np.integer) or count < 1:
            raise ParameterError("observer_from_track", "samples", "an integer >= 1", samples)
        chosen = np.unique(np.round(np.linspace(0, len(pos) - 1, int(count))).astype(int))
        positions.append(pos[chosen])
        frames.append(antenna_frame(look_of(product), *attitude[chosen].T).reshape(-1, 3, 3))
    return Observer(np.vstack(positions), np.vstack(frames),
                    azimuth_beamwidth=max(r.azimuth_beamwidth for r in radars),
                    elevation_beamwidth=max(r.elevation_beamwidth for r in radars),
                    max_range=max(r.max_range for r in radars), cover=float(cover),
                    passes=len(products))


def observe_points(scene: Any, points: ArrayLike, normals: ArrayLike, observer: Observer
                   ) -> tuple[NDArray[np.bool_], NDArray[np.bool_]]:
    """Which points some antenna position has in its beam, and sees unoccluded.

    Parameters
    ----------
    scene : mitsuba.Scene
    points, normals : array_like, shape (N, 3)
        Points [m] and the unit normals of the surface they lie on (for the ray's offset off
        it; :func:`mitsar.scene.facets.segments_visible`).
    observer : Observer

    Returns
    -------
    in_footprint : numpy.ndarray of bool, shape (N,)
        Inside the beam (direction sines within ``cover`` half beamwidths, in front of the
        antenna, within ``max_range``) of at least one position.
    observable : numpy.ndarray of bool, shape (N,)
        Inside the beam of, and unoccluded from, at least one position.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    normals = np.asarray(normals, dtype=float).reshape(-1, 3)
    pos, frames = observer.positions, observer.frames
    half_az = observer.cover * observer.azimuth_beamwidth / 2
    half_el = observer.cover * observer.elevation_beamwidth / 2

    # Antenna-frame coordinates of every (point, position) pair by one matrix product:
    # local = F_p^T (x - p_p), the rows of F_p^T stacked over positions.
    # Single precision (1e-7 of the range at the beam's edge) halves the memory traffic.
    axes = np.transpose(frames, (0, 2, 1)).reshape(-1, 3)              # (3P, 3)
    shift = np.einsum("pk,pck->pc", pos, np.transpose(frames, (0, 2, 1))).reshape(-1)
    origin = pos.mean(axis=0)                                         # keep float32 local
    shift = (shift - axes @ origin).astype(np.float32)
    axes32 = axes.T.astype(np.float32)
    centred = (points - origin).astype(np.float32)

    def test(rows: slice) -> NDArray:
        local = (centred[rows] @ axes32 - shift).reshape(-1, len(pos), 3)
        distance = np.sqrt(np.einsum("npk,npk->np", local, local))
        # Direction sines (mitsar.model.geometry.antenna.direction_sines) without dividing:
        # |u| <= h  <=>  |local| <= h * distance.
        return ((local[..., 2] > 0) & (np.abs(local[..., 0]) <= half_az * distance)
                & (np.abs(local[..., 1]) <= half_el * distance)
                & (distance <= observer.max_range))

    i, p = _chunked_pairs(len(points), len(pos), test)
    in_footprint = np.zeros(len(points), dtype=bool)
    in_footprint[i] = True
    observable = np.zeros(len(points), dtype=bool)
    for start in range(0, len(i), _CHUNK):                    # blocks of rays
        block = slice(start, start + _CHUNK)
        seen = segments_visible(scene, points[i[block]], normals[i[block]], pos[p[block]])
        observable[i[block][seen]] = True
    return in_footprint, observable


def _feature_samples(features: TruthFeatures, spacing: float, offset: float
                     ) -> tuple[NDArray, NDArray, NDArray]:
    """Points about ``spacing`` apart along every feature, moved ``offset`` into the air along
    the bisector of its faces' normals; their normals and the feature each belongs to."""
    length = np.linalg.norm(features.end - features.start, axis=1)
    count = np.maximum(1, np.ceil(length / spacing).astype(int) + 1)
    owner = np.repeat(np.arange(len(features)), count)
    first = np.cumsum(count) - count
    step = np.arange(len(owner)) - first[owner]
    fraction = np.where(count[owner] > 1, step / np.maximum(count[owner] - 1, 1), 0.5)
    points = features.start[owner] + fraction[:, None] * (features.end - features.start)[owner]
    bisector = _unit(np.nansum(features.normals, axis=1))[owner]
    return points + offset * bisector, bisector, owner


# --------------------------------------------------------------------------------------------
# The truth
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SceneTruth:
    """Ground truth of a map: surface samples, features and what the flight observes.

    Attributes
    ----------
    points, normals : numpy.ndarray, shape (N, 3)
        Surface samples [m] and their unit normals.
    area : numpy.ndarray, shape (N,)
        Area each sample stands for [m²].
    surface : numpy.ndarray of int, shape (N,)
        Index of each sample's shape in ``names``.
    names : tuple of str
        Ids of the sampled shapes.
    in_footprint, observable : numpy.ndarray of bool, shape (N,)
        Per sample, as :func:`observe_points` (all True without a flight).
    features : TruthFeatures
    spacing : float
        Sample spacing [m].
    seed : int
        Seed of the sampler (random samples on analytic shapes and small triangles only).
    bounds : numpy.ndarray or None
        Box ``[[x0, y0, z0], [x1, y1, z1]]`` [m] the truth was cut to, None for the whole scene.
    observed : bool
        Whether observability comes from a flight (False: everything counts as observable).
    tolerance : float
        Geometric tolerance of the feature extraction [m].
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    area: NDArray[np.float64]
    surface: NDArray[np.int64]
    names: tuple[str, ...]
    in_footprint: NDArray[np.bool_]
    observable: NDArray[np.bool_]
    features: TruthFeatures
    spacing: float
    seed: int
    bounds: NDArray[np.float64] | None = None
    observed: bool = False
    tolerance: float = 1e-3
    attrs: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.points.shape[0])

    def to_dataset(self) -> xr.Dataset:
        """Surface samples (dim ``sample``) and features (dim ``feature``) as one Dataset."""
        data = self.features.to_dataset().rename({"kind": "feature_kind",
                                                  "position": "feature_position",
                                                  "in_footprint": "feature_in_footprint",
                                                  "observable": "feature_observable"})
        data["sample_position"] = (("sample", "xyz"), self.points, {"units": "m"})
        data["sample_normal"] = (("sample", "xyz"), self.normals, {"units": "1"})
        data["sample_area"] = ("sample", self.area, {"units": "m2"})
        data["sample_surface"] = ("sample", np.array(self.names, dtype=str)[self.surface])
        data["sample_in_footprint"] = ("sample", self.in_footprint)
        data["sample_observable"] = ("sample", self.observable)
        data.attrs.update(spacing=self.spacing, seed=self.seed, observed=int(self.observed),
                          tolerance=self.tolerance, **self.attrs)
        if self.bounds is not None:
            data.attrs["bounds"] = self.bounds.ravel().tolist()
        return data


def _check_bounds(bounds: Any) -> NDArray | None:
    """A (2, 3) box [m] from an array, a grid with ``axes()`` (``VolumeGrid``: its voxel
    centres' extent) or an image product (its ``position`` extent)."""
    if bounds is None:
        return None
    if hasattr(bounds, "axes") and callable(bounds.axes):
        axes = bounds.axes()
        bounds = [[float(np.min(a)) for a in axes], [float(np.max(a)) for a in axes]]
    elif isinstance(bounds, xr.Dataset) and "position" in bounds.variables:
        position = bounds["position"]
        flat = position.transpose(*[d for d in position.dims if d != "xyz"], "xyz").values
        flat = flat.reshape(-1, 3)
        bounds = [np.nanmin(flat, axis=0), np.nanmax(flat, axis=0)]
    box = np.asarray(bounds, dtype=float)
    if box.shape != (2, 3) or not np.all(np.isfinite(box)) or not np.all(box[1] > box[0]):
        raise ParameterError("scene_truth", "bounds", "[[x0, y0, z0], [x1, y1, z1]] with "
                             "x1 > x0, y1 > y0, z1 > z0 [m]", bounds)
    return box


def _clip_segments(start: NDArray, end: NDArray, box: NDArray, tolerance: float
                   ) -> tuple[NDArray, NDArray, NDArray]:
    """Segments clipped to a box (slab method), and which keep a part."""
    seg = end - start
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (box[0] - tolerance - start) / seg
        t1 = (box[1] + tolerance - start) / seg
    parallel = np.abs(seg) < 1e-12
    inside = (start >= box[0] - tolerance) & (start <= box[1] + tolerance)
    low = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(t0, t1))
    high = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(t0, t1))
    lo = np.clip(low.max(axis=1), 0.0, 1.0)
    hi = np.clip(high.min(axis=1), 0.0, 1.0)
    keep = (hi >= lo) & ~((parallel & ~inside).any(axis=1))
    return start + lo[:, None] * seg, start + hi[:, None] * seg, keep


def scene_truth(scene: Any, spacing: float = 0.05, *, track: Any = None,
                bounds: Any = None, seed: int = 0, samples: int | None = None,
                cover: float = 1.0, tolerance: float = 1e-3, angle_tolerance_deg: float = 5.0,
                min_fold_deg: float = 20.0, feature_offset: float = 0.01) -> SceneTruth:
    """The ground truth of a map of ``scene``, and what a flight over it observes.

    Parameters
    ----------
    scene : mitsuba.Scene or str
        A loaded scene, or a path / canned scene name.
    spacing : float
        Surface sample spacing [m] (default 5 cm; the scores' threshold ``tau`` or finer).
    track : raw product, sequence of raw products, or Observer, optional
        The flight (one raw product per pass, :func:`observer_from_track`); without it every
        sample and feature counts as observable.
    bounds : array_like of shape (2, 3), VolumeGrid or image product, optional
        Keep the truth inside this box [m]: ``[[x0, y0, z0], [x1, y1, z1]]``, or the extent of
        a grid's voxel centres or of an image's ``position`` (the focused volume).
    seed : int
        Seed of :func:`mitsar.scene.surfaces.sample_surface_points` (recorded).
    samples, cover
        Antenna positions per pass and beam cover (:func:`observer_from_track`).
    tolerance, angle_tolerance_deg, min_fold_deg
        Feature extraction (:func:`scene_features`).
    feature_offset : float
        Distance [m] a feature's samples are moved into the air (along the bisector of its
        faces' normals) before the ray tests, so that the faces that make the corner do not
        hide it (default 1 cm).

    Returns
    -------
    SceneTruth
    """
    if not (isinstance(spacing, int | float) and math.isfinite(spacing) and spacing > 0):
        raise ParameterError("scene_truth", "spacing", "a spacing > 0 m", spacing)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError("scene_truth", "seed", "an integer >= 0", seed)
    box = _check_bounds(bounds)
    if isinstance(scene, str):
        scene = load_scene(scene)
    surface = sample_surface_points(scene, float(spacing), seed=int(seed))
    keep = np.ones(len(surface.positions), dtype=bool)
    if box is not None:
        keep = np.all((surface.positions >= box[0]) & (surface.positions <= box[1]), axis=1)
    points, normals = surface.positions[keep], surface.normals[keep]
    features = scene_features(scene, tolerance=tolerance, angle_tolerance_deg=angle_tolerance_deg,
                              min_fold_deg=min_fold_deg)
    if box is not None:
        start, end, inside = _clip_segments(features.start, features.end, box, tolerance)
        features = TruthFeatures(features.kind, start, end, features.normals,
                                 features.angle_deg, features.shapes, features.in_footprint,
                                 features.visible, features.observable,
                                 features.observable_fraction).select(inside)
    in_footprint = observable = np.ones(len(points), dtype=bool)
    attrs: dict[str, Any] = {"observer_positions": 0, "passes": 0}
    if track is not None:
        observer = _as_observer(track, samples, cover)
        in_footprint, observable = observe_points(scene, points, normals, observer)
        fpoints, fnormals, owner = _feature_samples(features, float(spacing),
                                                    float(feature_offset))
        f_in, f_seen = observe_points(scene, fpoints, fnormals, observer)
        count = np.maximum(np.bincount(owner, minlength=len(features)), 1)
        fraction = np.bincount(owner, f_seen, minlength=len(features)) / count
        f_in_any = np.bincount(owner, f_in, minlength=len(features)) > 0
        features = TruthFeatures(features.kind, features.start, features.end, features.normals,
                                 features.angle_deg, features.shapes, f_in_any, fraction > 0,
                                 fraction > 0, fraction)
        attrs = {"observer_positions": len(observer.positions), "passes": observer.passes,
                 "beam_cover": observer.cover}
    return SceneTruth(points=points, normals=normals, area=surface.area[keep],
                      surface=surface.surface[keep], names=surface.names,
                      in_footprint=in_footprint, observable=observable, features=features,
                      spacing=float(spacing), seed=int(seed), bounds=box,
                      observed=track is not None, tolerance=float(tolerance), attrs=attrs)
