"""Planar facets of a loaded scene's shapes, for physical optics (docs/physical_optics.md §5).

Every planar shape of mitsar's scenes is a Mitsuba mesh (rectangles and cubes are meshes of
two and twelve triangles; PLY meshes are read as they are), so a shape's facets are its
triangles in world coordinates. Coplanar triangles are not merged: Gordon's formula works on
triangles, and their PO integrals add coherently to the polygon's
(:func:`mitsar.model.physical_optics.facet_integral` is linear in the domain). Each facet
carries the index of its shape, whose radar material gives the specular field factor
``Γ(θ_i) R`` the ray tracer also uses (``DoubleLobe.specular_field``, docs/design.md §5.3).

Which shapes: physical optics is opt-in (``physical_optics=`` of
:func:`mitsar.raw.traced.simulate_scene`, TOML ``[simulation] physical_optics``), either
``True`` (every mesh with a radar material) or a list of shape ids.
"""

from __future__ import annotations

from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.model.doublelobe import DoubleLobe
from mitsar.plugins.variant import import_mitsuba
from mitsar.scene.surfaces import scene_surfaces

__all__ = ["FacetSet", "scene_facets", "segments_visible"]


@dataclass(frozen=True)
class FacetSet:
    """Triangles of the shapes that use physical optics."""

    triangles: NDArray[np.float64]
    """Vertices, shape (F, 3, 3) [m], in the mesh's winding."""
    shape: NDArray[np.int64]
    """Index into :attr:`materials` / :attr:`shape_ids` of each triangle, shape (F,)."""
    materials: tuple[DoubleLobe, ...]
    """Radar material of each selected shape."""
    shape_ids: tuple[str, ...]
    """XML id of each selected shape ("" if none: Mitsuba merges unnamed meshes that share a
    material)."""
    shapes: tuple[Any, ...] = ()
    """The Mitsuba shapes themselves (the multipath rays stop on them, docs/physical_optics.md
    §5)."""
    surface_index: tuple[int, ...] = ()
    """Row of each selected shape in :func:`mitsar.scene.surfaces.scene_surfaces` (e.g. of
    :func:`mitsar.scene.motion.surface_velocities`)."""

    def __len__(self) -> int:
        return len(self.triangles)

    def reflection(self, cos_theta_i: NDArray, shape: NDArray) -> NDArray[np.float64]:
        """Specular field factor ``Γ(θ_i) R`` of each facet's material [-].

        Parameters
        ----------
        cos_theta_i : numpy.ndarray
            Incidence cosines (``|n·d|``) [-].
        shape : numpy.ndarray of int
            Index of the facet's shape, broadcast against ``cos_theta_i``.
        """
        cos_theta_i, shape = np.broadcast_arrays(np.asarray(cos_theta_i, float), shape)
        out = np.zeros(cos_theta_i.shape)
        for index, material in enumerate(self.materials):   # a few materials
            sel = shape == index
            out[sel] = np.broadcast_to(material.specular_field(cos_theta_i[sel]),
                                       (int(sel.sum()),))
        return out


def scene_facets(scene: Any, shapes: bool | Sequence[str] = True) -> FacetSet:
    """The triangles of the scene's shapes chosen for physical optics.

    Parameters
    ----------
    scene : mitsuba.Scene
        A loaded scene.
    shapes : bool or sequence of str
        ``True``: every mesh with a radar material; ``False``: none; or the ids of the shapes
        (each must be a mesh with a radar material).

    Returns
    -------
    FacetSet

    Raises
    ------
    ParameterError
        For an id that is not in the scene, or names a shape without a radar material or that
        is not a mesh (spheres, disks and cylinders are not planar facets).
    """
    surfaces = scene_surfaces(scene)
    if isinstance(shapes, bool | np.bool_):
        chosen = [s for s in surfaces if shapes and s.material is not None and s.shape.is_mesh()]
    else:
        if isinstance(shapes, str) or not all(isinstance(s, str) for s in shapes):
            raise ParameterError("physical_optics", "physical_optics",
                                 "true, false or a list of shape ids", shapes)
        by_id = {s.id: s for s in surfaces}
        chosen = []
        for name in shapes:
            surface = by_id.get(name)
            if surface is None:
                raise ParameterError("physical_optics", "physical_optics",
                                     f"ids of shapes of the scene {sorted(by_id)}", name)
            if surface.material is None or not surface.shape.is_mesh():
                raise ParameterError("physical_optics", "physical_optics",
                                     "shapes that are meshes (rectangle, cube, PLY) with a "
                                     "radar material; remove it from the list", name)
            chosen.append(surface)
    triangles, owner = [np.zeros((0, 3, 3))], [np.zeros(0, dtype=np.int64)]
    for index, surface in enumerate(chosen):               # one read per shape at set-up
        vertices = np.asarray(surface.shape.vertex_positions_buffer(), float).reshape(-1, 3)
        faces = np.asarray(surface.shape.faces_buffer(), dtype=np.int64).reshape(-1, 3)
        tri = vertices[faces]
        double_area = np.linalg.norm(np.cross(tri[:, 1] - tri[:, 0], tri[:, 2] - tri[:, 0]),
                                     axis=1)
        tri = tri[double_area > 0]
        triangles.append(tri)
        owner.append(np.full(len(tri), index, dtype=np.int64))
    return FacetSet(np.concatenate(triangles), np.concatenate(owner),
                    tuple(s.material for s in chosen), tuple(s.id for s in chosen),
                    tuple(s.shape for s in chosen), tuple(s.index for s in chosen))


def segments_visible(scene: Any, points: NDArray, normals: NDArray, antennas: NDArray
                     ) -> NDArray[np.bool_]:
    """True where nothing in ``scene`` blocks the segment from an antenna to a surface point.

    The segment ends ``ε = 2·10⁻⁵ (1 + max|q|)`` off the surface on the antenna's side and a
    relative 10⁻⁶ short of it (docs/integrator.md, "Shadow rays"), so the point's own planar
    facet never occludes it while anything else crossing the segment does. One batched
    ``ray_test`` (Mitsuba) for all segments.

    Parameters
    ----------
    scene : mitsuba.Scene
    points, normals, antennas : numpy.ndarray, shape (N, 3)
        Surface points [m], their facets' normals [-] and the antenna positions [m].
    """
    mi = import_mitsuba()
    points = np.asarray(points, dtype=np.float64)
    antennas = np.asarray(antennas, dtype=np.float64)
    if len(points) == 0:
        return np.zeros(0, dtype=bool)
    eps = 2e-5 * (1.0 + np.abs(points).max())
    side = np.where(np.einsum("ni,ni->n", normals, antennas - points) >= 0, 1.0, -1.0)
    end = points + (eps * side)[:, None] * normals
    offset = end - antennas
    distance = np.linalg.norm(offset, axis=-1)
    direction = offset / distance[:, None]

    def f(a: NDArray) -> Any:
        return mi.Float(np.ascontiguousarray(a, dtype=np.float32))

    ray = mi.Ray3f(mi.Point3f(*(f(antennas[:, i]) for i in range(3))),
                   mi.Vector3f(*(f(direction[:, i]) for i in range(3))))
    ray.maxt = f(distance * (1.0 - 1e-6))
    return ~np.asarray(scene.ray_test(ray), dtype=bool)
