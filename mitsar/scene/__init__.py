"""Scenes: Mitsuba variant and plugins, XML loading, point targets and surface scatterers.

- :mod:`mitsar.scene.variant`: :func:`ensure_variant`, :func:`register_plugins`.
- :mod:`mitsar.scene.loading`: :func:`load_scene` (a path or a canned scene name).
- :mod:`mitsar.scene.surfaces`: :func:`scene_surfaces`, :func:`scene_point_targets`,
  :func:`sample_surface_scatterers` and the regular grid :func:`sample_surface_points`.
- :mod:`mitsar.scene.scatterers`: :class:`ScattererSet`, :func:`collect_scatterers` (what the
  radar integrator traces for direct backscatter).
- :mod:`mitsar.scene.meshes`: :func:`box_mesh`, :func:`write_ply`.
- :mod:`mitsar.scene.motion`: moving shapes (:class:`~mitsar.scene.motion.SceneMotion`).
- :mod:`mitsar.scene.canned`: the bundled XML scenes.
"""

from mitsar.scene.loading import load_scene
from mitsar.scene.meshes import box_mesh, write_ply
from mitsar.scene.scatterers import (
    ScattererSet,
    collect_scatterers,
    empty_scatterers,
    range_limits,
)
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
from mitsar.scene.variant import (
    DEFAULT_VARIANT,
    GPU_VARIANT,
    SUPPORTED_VARIANTS,
    ensure_variant,
    import_mitsuba,
    register_plugins,
)

__all__ = ["DEFAULT_VARIANT", "GPU_VARIANT", "SUPPORTED_VARIANTS", "ScattererSet",
           "ScenePointTarget", "SceneSurface", "SurfaceSamples", "SurfaceScatterers", "box_mesh",
           "collect_scatterers", "empty_scatterers", "ensure_variant", "import_mitsuba",
           "load_scene", "range_limits", "register_plugins", "sample_surface_points",
           "sample_surface_scatterers", "scene_point_targets", "scene_surfaces", "write_ply"]
