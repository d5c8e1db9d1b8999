"""Geometric features of a scene's meshes, for the ground truth of a map (docs/features.md).

Straight edges where two planar faces meet (:func:`scene_features`), classified by the angle of
the air wedge between them (the side the normals point to; mitsar's scenes point them into the
room): a concave right angle is a ``"dihedral"``, any other concave angle a ``"concave_edge"``,
a convex fold a ``"convex_edge"``; a point where three mutually perpendicular dihedral edges
meet is a ``"trihedral"`` corner. Faces of different shapes count as meeting where one face's
edge lies on the other face within a tolerance (the canned rooms build their corners from
separate rectangles that share no mesh edge; a cabinet stands on a floor whose triangle it does
not share); a face lying back to back on another (a cabinet's bottom on the floor) is hidden and
makes no edge. :mod:`mitsar.features.truth` assembles the truth from these.
"""

from __future__ import annotations

import itertools
import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components
from scipy.spatial import cKDTree

from mitsar.errors import ParameterError
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.scene.loading import load_scene
from mitsar.scene.surfaces import scene_surfaces

__all__ = ["FEATURE_KINDS", "TruthFeatures", "point_segment_distance", "scene_features"]

FEATURE_KINDS = ("trihedral", "dihedral", "concave_edge", "convex_edge", "unoriented_edge")
"""Kinds of geometric feature. ``"unoriented_edge"``: two faces whose normals disagree about
the air side (one points towards the other face, the other away); reported, never scored."""


_KIND_CODE = {kind: code for code, kind in enumerate(FEATURE_KINDS)}
PAIR_CHUNK = 2_000_000
"""Pairs (edge x triangle, point x antenna position) evaluated per vectorised block."""


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


def unit_vectors(v: NDArray) -> NDArray:
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    return v / np.where(norm > 0, norm, 1.0)


def _edge_normals(tri: NDArray, normal: NDArray) -> NDArray:
    """In-plane unit normals of a triangle's edges pointing inside, shape (T, 3, 3)."""
    edges = np.roll(tri, -1, axis=1) - tri                    # edge m: vertex m -> m+1
    inward = unit_vectors(np.cross(normal[:, None, :], edges))  # left of a counter-clockwise edge
    return inward


def chunked_pairs(count_a: int, count_b: int, test: Any) -> tuple[NDArray, NDArray]:
    """Index pairs (i, j) where ``test(i_slice, all j)`` (a (len, count_b) bool array) holds."""
    rows = max(1, PAIR_CHUNK // max(count_b, 1))
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

    i, _ = chunked_pairs(len(tri), len(tri), test)
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

    k, j = chunked_pairs(len(a), count, test)
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
    direction = unit_vectors(p1 - p0)
    across = unit_vectors(np.cross(n_j, direction))
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
    direction = unit_vectors(p1 - p0)
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
    direction = unit_vectors(end - start)
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
