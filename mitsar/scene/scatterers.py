"""The scatterers of a loaded scene, collected into one flat :class:`ScattererSet`.

What the radar integrator traces for direct backscatter (docs/design.md §5.4 mechanism 1): the
area-sampled surface scatterers of :func:`mitsar.scene.surfaces.sample_surface_scatterers` (one
area share and one frozen speckle phase each, σ⁰ from their material's monostatic table) and the
scene's point targets (their RCS, their velocity). The set itself is a model type
(:mod:`mitsar.model.scatterers`); this module reads it off a Mitsuba scene.
"""

from __future__ import annotations

import warnings
from typing import Any

import numpy as np

from mitsar.model.doublelobe import TABLE_SIZE, monostatic_sigma0_table
from mitsar.model.scatterers import POINT_TARGET_MARGIN, ScattererSet
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.scene.surfaces import sample_surface_scatterers, scene_point_targets, scene_surfaces

__all__ = ["collect_scatterers"]


def collect_scatterers(scene: Any, density: float, seed: int) -> ScattererSet:
    """Surface scatterers and point targets of a loaded scene.

    Parameters
    ----------
    scene : mitsuba.Scene
        With mitsar's plugins registered (:func:`mitsar.scene.load_scene`).
    density : float
        Surface scatterers per m².
    seed : int
        Seed of the scatterer draw and the speckle phases.
    """
    surf = sample_surface_scatterers(scene, density, seed)
    targets = scene_point_targets(scene)
    surfaces = scene_surfaces(scene)
    radii = [_bounding_radius(s.shape) for s in surfaces
             if plugin_kind(s.shape.bsdf()) is PluginKind.POINTTARGET]
    foreign = [s.id or f"shape {s.index}" for s in surfaces
               if plugin_kind(s.shape.bsdf()) is None]
    if foreign:
        # Shapes with a non-radar BSDF (e.g. Mitsuba's default diffuse) block rays but return
        # nothing; usually a forgotten <bsdf type="doublelobe">.
        warnings.warn("radar integrator: shapes without a radar material (doublelobe or "
                      f"pointtarget) return no echo and only block rays: {', '.join(foreign)}",
                      stacklevel=3)
    materials = list(surf.materials)
    tables = np.vstack([monostatic_sigma0_table(materials, TABLE_SIZE),
                        np.ones((1, TABLE_SIZE))])
    point_row = len(materials)
    m, p = len(surf), len(targets)
    return ScattererSet(
        position=np.vstack([surf.positions, np.array([t.position for t in targets]
                                                     ).reshape(p, 3)]),
        normal=np.vstack([surf.normals, np.zeros((p, 3))]),
        velocity=np.vstack([np.zeros((m, 3)), np.array([t.velocity for t in targets]
                                                       ).reshape(p, 3)]),
        weight=np.concatenate([surf.area, [t.rcs for t in targets]]),
        phase=np.concatenate([surf.phase / (2 * np.pi), np.zeros(p)]),
        table_row=np.concatenate([surf.shape_index.astype(np.int64),
                                  np.full(p, point_row, dtype=np.int64)]),
        stop=np.concatenate([np.zeros(m), POINT_TARGET_MARGIN * np.asarray(radii, float)]),
        tables=tables, surface_count=m, point_target_count=p, density=float(density),
        seed=int(seed))


def _bounding_radius(shape: Any) -> float:
    box = shape.bbox()
    lo = np.array([float(v) for v in box.min])
    hi = np.array([float(v) for v in box.max])
    return float(0.5 * np.linalg.norm(hi - lo))
