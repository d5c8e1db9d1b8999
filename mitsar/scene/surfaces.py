"""What the radar needs from a loaded scene: materials per shape, point targets, surface points.

Shapes are listed in a canonical order (by id, then kind and bounding box), because the order of
``scene.shapes()`` is not stable between loads; ``shape_index`` refers to that order.

Surface points come from one core (each shape's ``sample_position`` evaluated on a grid over its
parameter square, :func:`_sample_positions`) with two front ends:

- :func:`sample_surface_scatterers`: the tracer's fixed, seeded scatterers at a density, on a
  jittered grid, each with a frozen speckle phase, so that the returns stay coherent from
  sweep to sweep;
- :func:`sample_surface_points`: regularly spaced cell centres for the ambiguity maps.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mitsar.budget import require_memory
from mitsar.errors import ParameterError
from mitsar.model.doublelobe import DoubleLobe
from mitsar.plugins.kind import PluginKind, plugin_kind

__all__ = ["ScenePointTarget", "SceneSurface", "SurfaceSamples", "SurfaceScatterers",
           "regular_grid", "sample_surface_points", "sample_surface_scatterers",
           "scene_point_targets", "scene_surfaces", "unit_grid"]


class SceneSurface(NamedTuple):
    """One shape of a scene, in canonical order."""

    index: int
    """Position in :func:`scene_surfaces` (the ``shape_index`` of scatterers)."""
    id: str
    """XML id of the shape ("" if none)."""
    kind: str
    """Mitsuba shape class, e.g. ``"Rectangle"``, ``"PLYMesh"``, ``"Sphere"``."""
    shape: Any
    """The ``mitsuba.Shape``."""
    material: DoubleLobe | None
    """Its radar material; None for point targets, absorbers and non-radar BSDFs."""
    area: float
    """Surface area [m²]."""


class ScenePointTarget(NamedTuple):
    """An ideal point scatterer marked by the ``pointtarget`` material."""

    position: np.ndarray
    """Centre of the shape's bounding box, shape (3,) [m]."""
    rcs: float
    """Radar cross section [m²]."""
    velocity: np.ndarray
    """Velocity, shape (3,) [m/s]."""
    shape_id: str
    """XML id of the shape ("" if none)."""


def _canonical_shapes(scene: Any) -> list[Any]:
    def key(shape: Any) -> tuple:
        box = shape.bbox()
        return (shape.id(), shape.class_name(), tuple(float(v) for v in box.min),
                tuple(float(v) for v in box.max))

    return sorted(scene.shapes(), key=key)


def scene_surfaces(scene: Any) -> list[SceneSurface]:
    """Every shape of the scene with its radar material and area, in canonical order.

    Parameters
    ----------
    scene : mitsuba.Scene

    Returns
    -------
    list of SceneSurface
        ``material`` is the :class:`~mitsar.model.doublelobe.DoubleLobe` of a ``doublelobe`` BSDF,
        or None for point targets, absorbers (nothing comes back) and any other BSDF.
    """
    out = []
    for index, shape in enumerate(_canonical_shapes(scene)):
        bsdf = shape.bsdf()
        material = bsdf.material if plugin_kind(bsdf) is PluginKind.DOUBLELOBE else None
        if material is not None and material.is_absorber:
            material = None
        out.append(SceneSurface(index=index, id=shape.id(), kind=shape.class_name(),
                                shape=shape, material=material,
                                area=float(shape.surface_area()[0])))
    return out


def scene_point_targets(scene: Any) -> list[ScenePointTarget]:
    """The point targets of a scene: shapes whose BSDF is ``pointtarget``.

    Parameters
    ----------
    scene : mitsuba.Scene
        Loaded with mitsar's plugins registered (:func:`mitsar.scene.load_scene`).

    Returns
    -------
    list of ScenePointTarget
        In canonical shape order; position = centre of the shape's bounding box.
    """
    out = []
    for shape in _canonical_shapes(scene):
        bsdf = shape.bsdf()
        if plugin_kind(bsdf) is not PluginKind.POINTTARGET:
            continue
        box = shape.bbox()
        centre = 0.5 * (np.array([float(v) for v in box.min])
                        + np.array([float(v) for v in box.max]))
        out.append(ScenePointTarget(position=centre, rcs=float(bsdf.rcs),
                                    velocity=np.array(bsdf.velocity, dtype=np.float64),
                                    shape_id=shape.id()))
    return out


@dataclass(frozen=True)
class SurfaceScatterers:
    """A fixed set of surface scatterers (docs/design.md §5.4, mechanism 1).

    Attributes
    ----------
    positions : numpy.ndarray
        Shape (N, 3) [m].
    normals : numpy.ndarray
        Unit surface normals at the scatterers as the shapes define them, shape (N, 3).
    area : numpy.ndarray
        Area each scatterer stands for, shape (N,) [m²]; its RCS is ``σ⁰ · area``.
    shape_index : numpy.ndarray
        Index into :func:`scene_surfaces` (and ``surface_ids``), shape (N,), int32.
    phase : numpy.ndarray
        Fixed speckle phase in [0, 2π), shape (N,) [rad].
    surface_ids : tuple of str
        XML id of every shape in canonical order.
    materials : tuple
        The DoubleLobe (or None) of every shape in canonical order.
    density_per_m2 : float
        Requested density [1/m²].
    seed : int
        Seed of the draw.
    """

    positions: np.ndarray
    normals: np.ndarray
    area: np.ndarray
    shape_index: np.ndarray
    phase: np.ndarray
    surface_ids: tuple[str, ...]
    materials: tuple[DoubleLobe | None, ...]
    density_per_m2: float
    seed: int

    def __len__(self) -> int:
        return int(self.positions.shape[0])


def _sample_positions(shape: Any, u: Any, v: Any) -> tuple[np.ndarray, np.ndarray]:
    """Points and unit normals of ``shape.sample_position`` at parameters ``(u, v)`` in [0, 1]².

    Returns
    -------
    positions, normals : numpy.ndarray, shape (n, 3)
        Normals as the shape defines them (interpolated vertex normals on smooth meshes),
        broadcast to every point (planar shapes return one).
    """
    import mitsuba as mi  # lazy: importing Mitsuba loads its native libraries

    u = np.atleast_1d(np.asarray(u, dtype=np.float32))
    v = np.atleast_1d(np.asarray(v, dtype=np.float32))
    sample = shape.sample_position(0.0, mi.Point2f(mi.Float(u), mi.Float(v)))
    p = np.array(sample.p, dtype=np.float64).reshape(3, -1).T
    n = np.array(sample.n, dtype=np.float64).reshape(3, -1).T
    n = n / np.linalg.norm(n, axis=1, keepdims=True)
    return (np.broadcast_to(p, (u.size, 3)).copy(), np.broadcast_to(n, (u.size, 3)).copy())


def _parameter_lines(shape: Any, half: float) -> tuple[float, float]:
    """Chords [m] of the lines u and v through the centre of the parameter square.

    The line ``v = 0.5`` from ``u = 0.5 - half`` to ``0.5 + half`` and the line ``u = 0.5``
    likewise; ``half = 0.5`` gives the edge lengths of a rectangle, a small ``half`` the local
    stretch of the parametrisation.
    """
    p, _ = _sample_positions(shape, [0.5 - half, 0.5 + half, 0.5, 0.5],
                             [0.5, 0.5, 0.5 - half, 0.5 + half])
    return float(np.linalg.norm(p[1] - p[0])), float(np.linalg.norm(p[3] - p[2]))


def _parametric_aspect(shape: Any) -> float:
    """``|dp/du| / |dp/dv|`` of ``shape.sample_position`` at the centre (1 for meshes)."""
    import mitsuba as mi  # lazy: importing Mitsuba loads its native libraries

    if shape.shape_type() == int(mi.ShapeType.Mesh):
        return 1.0
    du, dv = _parameter_lines(shape, 1e-3)
    if not (du > 0.0 and dv > 0.0) or not math.isfinite(du / dv):
        return 1.0
    return float(du / dv)


def _stratified_unit_square(n: int, aspect: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` jittered-grid samples in [0,1)², the grid shaped to ``aspect`` (shape (2, n))."""
    nx = int(min(n, max(1, round(math.sqrt(n * aspect)))))
    ny = math.ceil(n / nx)
    cells = rng.choice(nx * ny, size=n, replace=False) if nx * ny > n else np.arange(n)
    cells = np.sort(cells)
    ix, iy = cells % nx, cells // nx
    jitter = rng.random((2, n))
    return np.stack([(ix + jitter[0]) / nx, (iy + jitter[1]) / ny])


SCATTERER_BYTES = 256
"""Peak bytes per surface scatterer: its NumPy record (68 bytes), the sampler's temporaries,
the device copies and the beam-culling lanes of the tracer."""


def sample_surface_scatterers(scene: Any, density_per_m2: float,
                              seed: int = 0) -> SurfaceScatterers:
    """Sample a fixed set of scatterers on every radar surface of a scene (docs/design.md §5.4).

    Each shape with a radar material (:func:`scene_surfaces`) gets ``round(density · area)``
    scatterers from ``shape.sample_position`` fed with a jittered grid over its parameter domain
    (area-uniform for rectangles, disks, spheres and meshes; the grid's aspect ratio follows the
    parametrisation, so a 30 m × 6 m wall gets a 5:1 grid). Each scatterer stands for
    ``area / count`` of its shape and has a uniform random speckle phase, fixed by ``seed``.

    Parameters
    ----------
    scene : mitsuba.Scene
    density_per_m2 : float
        Scatterers per m² (> 0). The paper uses at least 9 per resolution cell, e.g. 9/(0.1 m)² =
        900 per m².
    seed : int
        Seed (>= 0); the same seed gives the same scatterers.

    Returns
    -------
    SurfaceScatterers
    """
    density = float(density_per_m2)
    if not (math.isfinite(density) and density > 0.0):
        raise ParameterError("sample_surface_scatterers", "density_per_m2",
                             "a finite density > 0 per m²", density_per_m2)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError("sample_surface_scatterers", "seed", "an integer >= 0", seed)
    surfaces = scene_surfaces(scene)
    total = sum(density * s.area for s in surfaces if s.material is not None and s.area > 0)
    require_memory("sample_surface_scatterers", "scatterer_density",
                   total * SCATTERER_BYTES, f"{total:.3g} scatterers (density "
                   f"{density:g} per m² x the radar surfaces' area): lower the density")
    pos, nrm, area, index, phase = [], [], [], [], []
    for surface in surfaces:
        if surface.material is None or surface.area <= 0.0:
            continue
        count = int(round(density * surface.area))
        if count == 0:
            continue
        rng = np.random.default_rng([int(seed), surface.index])
        uv = _stratified_unit_square(count, _parametric_aspect(surface.shape), rng)
        p, n = _sample_positions(surface.shape, uv[0], uv[1])
        if _has_vertex_normals(surface.shape):
            n = _geometric_normals(scene, p, n)
        pos.append(p)
        nrm.append(n)
        area.append(np.full(count, surface.area / count))
        index.append(np.full(count, surface.index, dtype=np.int32))
        phase.append(rng.uniform(0.0, 2.0 * math.pi, count))

    def cat(parts: list[np.ndarray], shape: tuple[int, ...], dtype: Any = np.float64
            ) -> np.ndarray:
        return np.concatenate(parts) if parts else np.zeros(shape, dtype=dtype)

    return SurfaceScatterers(
        positions=cat(pos, (0, 3)), normals=cat(nrm, (0, 3)), area=cat(area, (0,)),
        shape_index=cat(index, (0,), np.int32), phase=cat(phase, (0,)),
        surface_ids=tuple(s.id for s in surfaces),
        materials=tuple(s.material for s in surfaces),
        density_per_m2=density, seed=int(seed))


def _has_vertex_normals(shape: Any) -> bool:
    """Whether a shape is a mesh whose sampled normals are interpolated vertex normals."""
    try:
        return bool(shape.is_mesh() and shape.has_vertex_normals())
    except AttributeError:  # pragma: no cover - older Mitsuba
        return False


def _geometric_normals(scene: Any, positions: np.ndarray, shading: np.ndarray) -> np.ndarray:
    """Face normals at sampled mesh points, oriented like the interpolated ``shading`` normals.

    A mesh loaded without ``face_normals`` samples smoothed vertex normals (tens of degrees off
    on a box), which would read sigma0 at the wrong incidence; a short ray cast back onto each
    point returns the geometric normal of the triangle it lies on.
    """
    import mitsuba as mi  # lazy: importing Mitsuba loads its native libraries

    offset = 1e-4
    origins = positions + offset * shading
    rays = mi.Ray3f(mi.Point3f(*origins.T.astype(np.float32)),
                    mi.Vector3f(*(-shading).T.astype(np.float32)))
    hit = scene.ray_intersect(rays)
    valid = np.array(hit.is_valid(), dtype=bool)
    normals = np.array(hit.n, dtype=np.float64).T
    normals = np.where(valid[:, None], normals, shading)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    flip = np.einsum("ij,ij->i", normals, shading) < 0
    normals[flip] *= -1.0
    return normals


# --------------------------------------------------------------------------------------------
# Regularly spaced surface points (the ambiguity maps)
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class SurfaceSamples:
    """Points about ``spacing`` apart on the surfaces of a scene.

    Attributes
    ----------
    positions, normals, area : numpy.ndarray
        Points (N, 3) [m], unit normals (N, 3) (face normals on meshes that are not rectangles)
        and the area each point stands for (N,) [m²], adding up to each shape's area.
    surface : numpy.ndarray
        Index of each point's shape in ``names``, shape (N,), int.
    names : tuple of str
        Id of every sampled shape (``shape<i>`` for a shape without id, ``i`` its index in
        :func:`scene_surfaces`), in canonical order.
    """

    positions: np.ndarray
    normals: np.ndarray
    area: np.ndarray
    surface: np.ndarray
    names: tuple[str, ...]


POINT_BYTES = 256
"""Peak bytes per surface point of a regular grid: its coordinates, normal, area and the
per-point maps of the ambiguity products."""


def unit_grid(count_u: int, count_v: int) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres of a ``count_u`` × ``count_v`` grid on the unit square, v running fastest.

    Returns
    -------
    s, t : numpy.ndarray, shape (count_u · count_v,)
    """
    s, t = np.meshgrid((np.arange(count_u) + 0.5) / count_u,
                       (np.arange(count_v) + 0.5) / count_v, indexing="ij")
    return s.reshape(-1), t.reshape(-1)


def regular_grid(extent_u: float, extent_v: float, spacing: float
                 ) -> tuple[np.ndarray, np.ndarray]:
    """Cell centres on the unit square of a rectangle ``extent_u`` × ``extent_v`` [m].

    The counts are ``max(1, round(extent / spacing))`` per edge, so the step is close to
    ``spacing`` [m] and every cell has the same area; see :func:`unit_grid`.
    """
    count_u, count_v = (max(1.0, round(extent / spacing)) for extent in (extent_u, extent_v))
    require_memory("regular_grid (surface points)", "spacing", count_u * count_v * POINT_BYTES,
                   f"{count_u * count_v:.3g} points on a {extent_u:g} m x {extent_v:g} m "
                   f"surface at {spacing:g} m: a coarser spacing")
    return unit_grid(int(count_u), int(count_v))


def _triangle_points(vertices: np.ndarray, faces: np.ndarray, spacing: float,
                     rng: np.random.Generator) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
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
        s, t = unit_grid(m1, m2)
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


def _regular_shape_points(shape: Any, area: float, spacing: float, rng: np.random.Generator
                          ) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Points, normals and area weights about ``spacing`` apart on one shape.

    A shape whose ``sample_position`` maps the unit square affinely onto it (a rectangle, or
    a mesh of one) gets a :func:`regular_grid`; another mesh per-triangle grids
    (:func:`_triangle_points`); an analytic shape (sphere, disk, ...) ``area / spacing²``
    seeded uniform samples.
    """
    extent_u, extent_v = _parameter_lines(shape, 0.5)
    corners, _ = _sample_positions(shape, [0.0, 1.0], [0.0, 1.0])
    diagonal = np.linalg.norm(corners[1] - corners[0])
    if (abs(extent_u * extent_v - area) <= 1e-3 * area
            and abs(math.hypot(extent_u, extent_v) - diagonal) <= 1e-3 * diagonal):
        position, normal = _sample_positions(shape, *regular_grid(extent_u, extent_v, spacing))
        return position, normal, np.full(len(position), area / len(position))
    if shape.is_mesh():
        vertices = np.asarray(shape.vertex_positions_buffer(), float).reshape(-1, 3)
        faces = np.asarray(shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        position, normal, weight = _triangle_points(vertices, faces, spacing, rng)
        return position, normal, weight * area / max(weight.sum(), 1e-300)
    count = max(1, int(round(area / spacing**2)))
    position, normal = _sample_positions(shape, rng.random(count), rng.random(count))
    return position, normal, np.full(count, area / count)


def sample_surface_points(scene: Any, spacing: float, *, shapes: Sequence[str] | None = None,
                          exclude: Sequence[str] = (), min_area: float = 0.0,
                          seed: int = 0) -> SurfaceSamples:
    """Points with normals about ``spacing`` apart on the shapes of a loaded scene.

    Every shape of :func:`scene_surfaces` but point targets, whatever its material, in
    canonical order; see :func:`_regular_shape_points` for the grids.

    Parameters
    ----------
    scene : mitsuba.Scene
    spacing : float
        Target point spacing [m].
    shapes : sequence of str, optional
        Only these shape ids.
    exclude : sequence of str
        Shape ids to skip (e.g. point-target spheres).
    min_area : float
        Skip shapes smaller than this [m²].
    seed : int
        Seed of the random samples (analytic shapes, triangles smaller than a cell).

    Returns
    -------
    SurfaceSamples
    """
    if not (isinstance(spacing, int | float) and spacing > 0):
        raise ParameterError("sample_surface_points", "spacing", "a spacing > 0 m", spacing)
    rng = np.random.default_rng(seed)
    named = [(s.id or f"shape{s.index}", s) for s in scene_surfaces(scene)]
    found = sorted(name for name, _ in named)
    if shapes is not None and (unknown := sorted(set(shapes) - set(found))):
        raise ParameterError("sample_surface_points", "shapes", f"shape ids among {found}",
                             unknown)
    total = sum(s.area for _, s in named if s.area > 0) / float(spacing) ** 2
    require_memory("sample_surface_points", "spacing", total * POINT_BYTES,
                   f"{total:.3g} points (the scene's area / spacing²): a coarser spacing")
    pos, nrm, area, index, names = [], [], [], [], []
    for name, surface in named:
        if ((shapes is not None and name not in shapes) or name in exclude
                or plugin_kind(surface.shape.bsdf()) is PluginKind.POINTTARGET  # a point
                or surface.area <= min_area or surface.area <= 0):
            continue
        p, n, w = _regular_shape_points(surface.shape, surface.area, spacing, rng)
        if len(p) == 0:
            continue
        pos.append(p)
        nrm.append(n)
        area.append(w)
        index.append(np.full(len(p), len(names)))
        names.append(name)
    if not names:
        raise ParameterError("sample_surface_points", "shapes", f"shape ids among {found}",
                             list(shapes) if shapes is not None else found)
    return SurfaceSamples(np.vstack(pos), np.vstack(nrm), np.concatenate(area),
                          np.concatenate(index), tuple(names))
