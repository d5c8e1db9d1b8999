"""Scenes: XML loading, point targets and surface scatterers, meshes, moving shapes.

- :mod:`mitsar.scene.loading`: :func:`load_scene` (a path or a canned scene name; it registers
  the plugins, :func:`mitsar.plugins.variant.register_plugins`).
- :mod:`mitsar.scene.surfaces`: :func:`scene_surfaces`, :func:`scene_point_targets`,
  :func:`sample_surface_scatterers` and the regular grid :func:`sample_surface_points`.
- :mod:`mitsar.scene.scatterers`: :func:`collect_scatterers`, the scene's
  :class:`~mitsar.model.scatterers.ScattererSet` (what the radar integrator traces for direct
  backscatter).
- :mod:`mitsar.scene.meshes`: :func:`box_mesh`, :func:`write_ply`.
- :mod:`mitsar.scene.masks`: :func:`layover_shadow_masks`, an image's layover and shadow masks
  from the scene's geometry (docs/interferometry.md).
- :mod:`mitsar.scene.motion`: moving shapes (:class:`~mitsar.scene.motion.SceneMotion`).
- :mod:`mitsar.scene.canned`: the bundled XML scenes by name (the files: ``scenes/``).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mitsar.lazy import lazy_exports

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.scene.loading import load_scene
    from mitsar.scene.masks import layover_shadow_masks
    from mitsar.scene.meshes import box_mesh, write_ply
    from mitsar.scene.scatterers import collect_scatterers
    from mitsar.scene.surfaces import (
        ScenePointTarget,
        SceneSurface,
        SurfaceSamples,
        SurfaceScatterers,
        sample_surface_points,
        sample_surface_scatterers,
        scene_point_targets,
        scene_surfaces,
    )

__all__ = ["ScenePointTarget", "SceneSurface", "SurfaceSamples", "SurfaceScatterers", "box_mesh",
           "collect_scatterers", "layover_shadow_masks", "load_scene", "sample_surface_points",
           "sample_surface_scatterers", "scene_point_targets", "scene_surfaces", "write_ply"]

_EXPORTS = {
    "ScenePointTarget": "mitsar.scene.surfaces",
    "SceneSurface": "mitsar.scene.surfaces",
    "SurfaceSamples": "mitsar.scene.surfaces",
    "SurfaceScatterers": "mitsar.scene.surfaces",
    "box_mesh": "mitsar.scene.meshes",
    "collect_scatterers": "mitsar.scene.scatterers",
    "layover_shadow_masks": "mitsar.scene.masks",
    "load_scene": "mitsar.scene.loading",
    "sample_surface_points": "mitsar.scene.surfaces",
    "sample_surface_scatterers": "mitsar.scene.surfaces",
    "scene_point_targets": "mitsar.scene.surfaces",
    "scene_surfaces": "mitsar.scene.surfaces",
    "write_ply": "mitsar.scene.meshes",
}
"""Public names -> the module that defines each, imported on first use (PEP 562)."""


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), __all__)
