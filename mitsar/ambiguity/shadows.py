"""Shadowing for ambiguity maps: a Mitsuba scene of rectangles, and shadow rays.

A point is shadowed at a state when something in the scene blocks the segment from the point
to the antenna; :func:`visible` casts those segments with Mitsuba's ``ray_test``.
"""

from __future__ import annotations

from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.ambiguity.points import unit_rows
from mitsar.plugins.variant import import_mitsuba

__all__ = ["planes_scene", "visible"]


def planes_scene(planes: Sequence[Mapping[str, Any]]) -> Any:
    """A Mitsuba scene of rectangles ``{name, origin, axis_u, axis_v, size}`` (for shadowing)."""
    mi = import_mitsuba()
    content: dict[str, Any] = {"type": "scene"}
    for index, plane in enumerate(planes):
        u = unit_rows(np.asarray(plane["axis_u"], float))
        v = unit_rows(np.asarray(plane["axis_v"], float))
        su, sv = (float(s) for s in plane["size"])
        centre = np.asarray(plane["origin"], float) + 0.5 * (su * u + sv * v)
        matrix = np.eye(4)
        matrix[:3, 0], matrix[:3, 1], matrix[:3, 2] = 0.5 * su * u, 0.5 * sv * v, np.cross(u, v)
        matrix[:3, 3] = centre
        content[str(plane.get("name", f"plane{index}"))] = {
            "type": "rectangle", "to_world": mi.ScalarTransform4f(matrix.tolist())}
    return mi.load_dict(content, optimize=False)


def visible(scene: Any, points: NDArray, normals: NDArray | None, antennas: NDArray,
             chunk: int = 1 << 22) -> NDArray[np.bool_]:
    """True where nothing in ``scene`` blocks the segment from each point to its antenna."""
    mi = import_mitsuba()
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
