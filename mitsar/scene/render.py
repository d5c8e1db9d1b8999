"""A camera view of a scene, rendered by Mitsuba itself (for previews).

:func:`render_view` renders a perspective camera with Mitsuba's stock ``aov`` integrator
(depth, geometric normal and shape index per pixel), so the picture is what Mitsuba sees of the
XML — shapes, transforms, meshes and all. :func:`project` maps world points into that picture
with the same pinhole model (Mitsuba's ``look_at`` frame and horizontal field of view), so
trajectories and footprints can be drawn over it. :func:`shape_kinds` names what each shape is
made of, to colour the picture by material kind.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.plugins.kind import PluginKind, plugin_kind

__all__ = ["Camera", "View", "project", "render_view", "shape_kinds", "stand_in_scene",
           "unobstructed"]


@dataclass(frozen=True)
class Camera:
    """A pinhole camera: position, look-at point, up vector [m], horizontal field of view
    [deg], the picture size [pixels] and the near clip distance [m] (nothing nearer is seen:
    a view from above can look through a ceiling)."""

    origin: tuple[float, float, float]
    target: tuple[float, float, float]
    up: tuple[float, float, float] = (0.0, 0.0, 1.0)
    fov_deg: float = 60.0
    width: int = 640
    height: int = 480
    near_clip: float = 0.01

    def frame(self) -> tuple[NDArray, NDArray, NDArray]:
        """Unit vectors (left, up, forward) of Mitsuba's ``look_at``."""
        forward = np.asarray(self.target, float) - np.asarray(self.origin, float)
        norm = np.linalg.norm(forward)
        if not norm > 0:
            raise ParameterError("Camera", "target", "a point away from the origin",
                                 list(self.target))
        forward /= norm
        left = np.cross(np.asarray(self.up, float), forward)
        if not np.linalg.norm(left) > 1e-9:
            raise ParameterError("Camera", "up", "a direction not along the view", list(self.up))
        left /= np.linalg.norm(left)
        return left, np.cross(forward, left), forward


@dataclass(frozen=True)
class View:
    """A rendered view: per pixel ``depth`` [m] (inf: nothing), ``normal`` (3) and ``shape``
    (index into ``scene.shapes()``, -1: nothing), with its :class:`Camera`."""

    camera: Camera
    depth: NDArray[np.float64]
    normal: NDArray[np.float64]
    shape: NDArray[np.int64]


def render_view(scene: Any, camera: Camera) -> View:
    """Render ``camera``'s view of a loaded scene with Mitsuba's ``aov`` integrator."""
    import mitsuba as mi  # lazy: the caller loaded the scene, so a variant is set

    sensor = mi.load_dict({
        "type": "perspective", "fov": float(camera.fov_deg), "fov_axis": "x",
        "near_clip": float(camera.near_clip), "far_clip": float(camera.near_clip) + 1e4,
        "to_world": mi.ScalarTransform4f().look_at(origin=list(camera.origin),
                                                   target=list(camera.target),
                                                   up=list(camera.up)),
        "film": {"type": "hdrfilm", "width": int(camera.width), "height": int(camera.height),
                 "rfilter": {"type": "box"},
                 # mono variants develop luminance; asked for, Mitsuba does not warn of it
                 "pixel_format": "luminance" if "mono" in mi.variant() else "rgb"},
        "sampler": {"type": "independent", "sample_count": 1}})
    integrator = mi.load_dict({"type": "aov", "aovs": "dd:depth,nn:geo_normal,si:shape_index"})
    mi.render(scene, sensor=sensor, integrator=integrator, spp=1)
    data = np.array(sensor.film().bitmap(raw=True), dtype=np.float64)
    # Channels R, G, B, weight, depth, normal xyz, shape index (+1; 0 where nothing is hit).
    data = data / np.where(data[..., 3:4] > 0, data[..., 3:4], 1.0)
    hit = np.rint(data[..., 8]) > 0
    depth = np.where(hit, data[..., 4], np.inf)
    return View(camera=camera, depth=depth, normal=data[..., 5:8],
                shape=np.where(hit, _pixel_shapes(scene, sensor, camera), -1))


def _pixel_shapes(scene: Any, sensor: Any, camera: Camera) -> NDArray[np.int64]:
    """Index in ``scene.shapes()`` of what each pixel centre sees (-1: nothing).

    The aov integrator's shape index follows Mitsuba's internal registry, not the order of
    ``scene.shapes()``; the pixels' own rays, cast again, name the shape itself.
    """
    import drjit as dr  # lazy: as Mitsuba
    import mitsuba as mi  # lazy: the caller loaded the scene, so a variant is set

    rows, columns = np.mgrid[0:camera.height, 0:camera.width]
    position = mi.Point2f(mi.Float((columns.ravel() + 0.5) / camera.width),
                          mi.Float((rows.ravel() + 0.5) / camera.height))
    ray, _ = sensor.sample_ray(0.0, 0.5, position, mi.Point2f(0.5, 0.5))
    found = scene.ray_intersect(ray)
    ids = np.array(dr.reinterpret_array(mi.UInt32, found.shape), dtype=np.int64)
    registry = np.array([int(dr.reinterpret_array(mi.UInt32, mi.ShapePtr(shape))[0])
                         for shape in scene.shapes()], dtype=np.int64)
    order = np.argsort(registry)
    slot = np.clip(np.searchsorted(registry[order], ids), 0, len(registry) - 1)
    known = registry[order][slot] == ids
    valid = np.array(found.is_valid(), dtype=bool) & known
    return np.where(valid, order[slot], -1).reshape(camera.height, camera.width)


def project(camera: Camera, points: ArrayLike) -> tuple[NDArray, NDArray]:
    """Pixel coordinates (column, row; row 0 at the top) of world points, and whether each is in
    front of the camera."""
    left, up, forward = camera.frame()
    offset = np.asarray(points, dtype=float).reshape(-1, 3) - np.asarray(camera.origin, float)
    z = offset @ forward
    scale = 1.0 / math.tan(math.radians(camera.fov_deg) / 2)
    safe = np.where(z > 1e-9, z, 1.0)
    x = -(offset @ left) / safe * scale  # image x grows to the right, opposite to "left"
    y = (offset @ up) / safe * scale * camera.width / camera.height
    column = (x + 1.0) * camera.width / 2 - 0.5
    row = (1.0 - y) * camera.height / 2 - 0.5
    return np.stack([column, row], axis=-1), z > 1e-9


def shape_kinds(scene: Any) -> list[str]:
    """What each shape of ``scene.shapes()`` is, for colouring: ``"radar surface"``,
    ``"absorber"``, ``"point target"`` or ``"no radar material"``."""
    kinds = []
    for shape in scene.shapes():
        bsdf = shape.bsdf()
        kind = plugin_kind(bsdf)
        if kind is PluginKind.POINTTARGET:
            kinds.append("point target")
        elif kind is PluginKind.DOUBLELOBE:
            material = getattr(bsdf, "material", None)
            absorber = material is not None and material.is_absorber
            kinds.append("absorber" if absorber else "radar surface")
        else:
            kinds.append("no radar material")
    return kinds


def stand_in_scene(planes: list[dict] = (), points: ArrayLike = (), radius: float = 0.05
                   ) -> Any:
    """A Mitsuba scene for experiments without an XML scene: rectangles and small spheres.

    Parameters
    ----------
    planes : list of dict
        Rectangles with ``origin`` (a corner), ``axis_u``, ``axis_v`` (edge directions) and
        ``size`` ([along u, along v]) [m], as ambiguity files' ``[[surfaces]]``.
    points : array_like, shape (n, 3)
        Point targets [m], drawn as spheres of ``radius``.

    The shapes carry Mitsuba's plain ``diffuse`` material (kind "no radar material"); the
    scene is for pictures and footprints only.
    """
    import mitsuba as mi  # lazy: the caller has set a variant (plugins.variant.import_mitsuba)

    content: dict[str, Any] = {"type": "scene"}
    for i, plane in enumerate(planes):
        u = np.asarray(plane["axis_u"], float)
        v = np.asarray(plane["axis_v"], float)
        u, v = u / np.linalg.norm(u), v / np.linalg.norm(v)
        half_u, half_v = 0.5 * float(plane["size"][0]), 0.5 * float(plane["size"][1])
        centre = np.asarray(plane["origin"], float) + half_u * u + half_v * v
        matrix = np.eye(4)
        matrix[:3, 0], matrix[:3, 1] = half_u * u, half_v * v
        matrix[:3, 2], matrix[:3, 3] = np.cross(u, v), centre
        content[f"plane{i}"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(matrix)}
    for i, point in enumerate(np.asarray(points, dtype=float).reshape(-1, 3)):
        content[f"target{i}"] = {"type": "sphere", "center": point.tolist(),
                                 "radius": float(radius)}
    return mi.load_dict(content)


def unobstructed(scene: Any, target: ArrayLike, origin: ArrayLike, keep: float = 0.9
                 ) -> tuple[float, float, float]:
    """``origin`` moved toward ``target`` until nothing of the scene stands between them (a
    camera inside a closed room instead of behind its wall): ``keep`` of the free distance."""
    import mitsuba as mi  # lazy: the caller loaded the scene, so a variant is set

    target, origin = np.asarray(target, float), np.asarray(origin, float)
    offset = origin - target
    distance = float(np.linalg.norm(offset))
    if not distance > 0:
        return tuple(origin)
    direction = offset / distance
    ray = mi.Ray3f(mi.Point3f(*(float(v) for v in target)),
                   mi.Vector3f(*(float(v) for v in direction)))
    hit = scene.ray_intersect(ray)
    if bool(np.array(hit.is_valid()).ravel()[0]):
        free = float(np.array(hit.t).ravel()[0])
        if free < distance:
            return tuple(target + keep * free * direction)
    return tuple(origin)
