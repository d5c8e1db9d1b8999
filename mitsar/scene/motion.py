"""Moving shapes: rigid motion of scene shapes during an acquisition (docs/integrator.md
§Moving objects).

A shape moves from the state it was loaded in, which is its state at slow time 0: with a
constant ``velocity`` [m/s] every point of it is at ``x + v t``; with an angular velocity too it
turns about a centre (default the centre of its bounding box at load), and on a sampled path its
centre follows the path's positions and its attitude the path's attitudes
(:mod:`mitsar.model.geometry.rigid_motion`, eqs. 1-3). Motions come from the ``velocity``,
``angular_velocity_deg`` and ``rotation_centre`` properties of a ``<shape>`` in the XML (read by
:func:`mitsar.scene.load_scene`, :func:`scene_motion`), from a ``motion`` mapping of shape ids
given to the simulators (the experiment TOML's ``[motion.<id>]``), and from point targets whose
``pointtarget`` BSDF has a velocity (their marker shape moves with them, so it does not shadow
its own target once it has moved off its load position).

:class:`SceneMotion` moves the shapes of a loaded scene to their state at a time (Mitsuba's
``mi.traverse`` parameters: a mesh's ``vertex_positions``, an analytic shape's ``to_world``) so
that shadow and multipath rays see them where they are; the scatterers sampled on a moving
shape get its velocity (:func:`surface_velocities`), so the integrator evaluates their position
``p + v t`` and delay rate at every sweep, as it does for point targets. On a shape that rotates
or follows a path the scatterers are re-placed every sweep (:meth:`SceneMotion.scatterers_at`):
position, normal and rigid-body velocity at mid-sweep, linearised there for the in-sweep motion.
"""

from __future__ import annotations

import dataclasses
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.checks import vector
from mitsar.errors import ParameterError
from mitsar.model.geometry.rigid_motion import BodyPath, RigidMotion
from mitsar.model.scatterers import ScattererSet
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.scene.surfaces import scene_surfaces

__all__ = ["MOTION_KEYS", "MOTION_PROPERTIES", "PATH_KEYS", "SceneMotion", "ShapeMotion",
           "parse_motion", "register_scene_motion", "scene_motion", "surface_velocities"]

MOTION_PROPERTIES = ("velocity", "angular_velocity_deg", "rotation_centre")
"""Properties of a ``<shape>`` that mitsar reads (and removes before Mitsuba loads it)."""

MOTION_KEYS = ("velocity", "angular_velocity_deg", "centre", "path")
"""Keys of one shape's motion mapping (``motion={id: {...}}``, ``[motion.<id>]``)."""

PATH_KEYS = ("times", "positions", "attitude_deg", "rotation_vector")
"""Keys of a sampled path (:meth:`mitsar.model.geometry.rigid_motion.BodyPath.from_samples`)."""


@dataclass(frozen=True)
class ShapeMotion:
    """More than a constant translation: ``velocity`` [m/s] and ``angular_velocity_deg``
    [deg/s] (a vector: axis and rate, right-handed) about ``centre`` [m] (None: the shape's
    bounding-box centre at load), or a sampled ``path`` of the centre (then no velocity or
    angular velocity)."""

    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)
    angular_velocity_deg: tuple[float, float, float] = (0.0, 0.0, 0.0)
    centre: tuple[float, float, float] | None = None
    path: BodyPath | None = None

    def moves(self) -> bool:
        return self.path is not None or any(v != 0.0 for v in self.velocity
                                            + self.angular_velocity_deg)

    def rigid(self, centre: NDArray) -> RigidMotion:
        """The :class:`RigidMotion` with ``centre`` if none is given."""
        return RigidMotion(np.asarray(self.centre if self.centre is not None else centre, float),
                           np.asarray(self.velocity, float),
                           np.radians(np.asarray(self.angular_velocity_deg, float)), self.path)

    def describe(self) -> dict[str, Any]:
        """JSON-able summary (product attributes)."""
        out: dict[str, Any] = {}
        if self.path is None:
            out.update(velocity=list(self.velocity),
                       angular_velocity_deg=list(self.angular_velocity_deg))
        else:
            out["path"] = {"times": self.path.times.tolist(),
                           "positions": self.path.positions.tolist(),
                           "rotates": self.path.rotations is not None}
        if self.centre is not None:
            out["centre"] = list(self.centre)
        return out


Motion = tuple[float, ...] | ShapeMotion
"""One shape's motion: a velocity [m/s] or a :class:`ShapeMotion`."""

_LOADED_MOTION: dict[int, tuple[Any, dict[str, Motion]]] = {}
"""Velocities declared in the XML of recently loaded scenes: id(scene) -> (scene, motion). The
scene is held so that its id is not reused while the entry exists (Mitsuba scenes take no weak
references); at most :data:`_KEEP` entries."""

_KEEP = 8


def parse_motion(where: str, motion: Mapping[str, Any] | None) -> dict[str, Motion]:
    """Validate ``{shape id: motion}``: a velocity (3 floats [m/s]) or a mapping with the keys
    of :data:`MOTION_KEYS` (``velocity`` [m/s], ``angular_velocity_deg`` [deg/s], ``centre``
    [m], ``path``: a :class:`BodyPath` or a mapping with the keys of :data:`PATH_KEYS`) or a
    :class:`ShapeMotion`. A pure translation stays a velocity tuple."""
    if motion is None:
        return {}
    if not isinstance(motion, Mapping):
        raise ParameterError(where, "motion", "a mapping {shape id: velocity [vx, vy, vz] m/s "
                             "or {velocity, angular_velocity_deg, centre, path}}", motion)
    out: dict[str, Motion] = {}
    for shape_id, value in motion.items():
        name = f"motion.{shape_id}"
        if isinstance(value, ShapeMotion):
            out[str(shape_id)] = value
            continue
        if not isinstance(value, Mapping):
            out[str(shape_id)] = _vector3(where, f"{name}.velocity", value,
                                          "a velocity [vx, vy, vz] in m/s")
            continue
        unknown = set(value) - set(MOTION_KEYS)
        if unknown:
            raise ParameterError(where, f"{name}.{sorted(unknown)[0]}",
                                 f"only the keys {MOTION_KEYS}", sorted(unknown))
        path = value.get("path")
        if path is not None:
            if "velocity" in value or "angular_velocity_deg" in value:
                raise ParameterError(where, f"{name}.path", "a path without velocity or "
                                     "angular_velocity_deg (the path gives both)",
                                     sorted(set(value) & {"velocity", "angular_velocity_deg"}))
            path = _path(where, f"{name}.path", path)
        spec = ShapeMotion(
            velocity=_vector3(where, f"{name}.velocity", value.get("velocity", (0, 0, 0)),
                              "a velocity [vx, vy, vz] in m/s"),
            angular_velocity_deg=_vector3(where, f"{name}.angular_velocity_deg",
                                          value.get("angular_velocity_deg", (0, 0, 0)),
                                          "an angular velocity [wx, wy, wz] in deg/s"),
            centre=(None if value.get("centre") is None else _vector3(
                where, f"{name}.centre", value["centre"], "a rotation centre [x, y, z] in m")),
            path=path)
        pure = spec.path is None and spec.centre is None and not any(spec.angular_velocity_deg)
        out[str(shape_id)] = spec.velocity if pure else spec
    return out


def _vector3(where: str, name: str, value: Any, expected: str) -> tuple[float, float, float]:
    return tuple(float(v) for v in vector(where, name, value, 3, expected))  # type: ignore


def _path(where: str, name: str, value: Any) -> BodyPath:
    if isinstance(value, BodyPath):
        return value
    if not isinstance(value, Mapping):
        raise ParameterError(where, name, "a mitsar BodyPath or a mapping {times, positions, "
                             "attitude_deg | rotation_vector}", value)
    unknown = set(value) - set(PATH_KEYS)
    if unknown:
        raise ParameterError(where, f"{name}.{sorted(unknown)[0]}", f"only the keys {PATH_KEYS}",
                             sorted(unknown))
    for key in ("times", "positions"):
        if key not in value:
            raise ParameterError(where, f"{name}.{key}", f"{key} of the path", "nothing")
    return BodyPath.from_samples(where, name, value["times"], value["positions"],
                                 value.get("attitude_deg"), value.get("rotation_vector"))


def register_scene_motion(scene: Any, motion: dict[str, Motion]) -> None:
    """Record the motions declared in a scene's XML (called by the loader)."""
    while len(_LOADED_MOTION) >= _KEEP:
        _LOADED_MOTION.pop(next(iter(_LOADED_MOTION)))
    _LOADED_MOTION[id(scene)] = (scene, dict(motion))


def scene_motion(scene: Any) -> dict[str, Motion]:
    """Motions of the shapes of a loaded scene: from its XML and its moving point targets."""
    entry = _LOADED_MOTION.get(id(scene))
    out = dict(entry[1]) if entry is not None and entry[0] is scene else {}
    for surface in scene_surfaces(scene):
        bsdf = surface.shape.bsdf()
        velocity = getattr(bsdf, "velocity", None)
        if plugin_kind(bsdf) is PluginKind.POINTTARGET and surface.id \
                and velocity is not None and any(v != 0.0 for v in velocity):
            out.setdefault(surface.id, tuple(float(v) for v in velocity))
    return out


def surface_velocities(scene: Any, motion: Mapping[str, Motion]) -> NDArray:
    """Velocity of every shape of :func:`mitsar.scene.surfaces.scene_surfaces` (rows in its
    ``index`` order, the ``shape_index`` of surface scatterers) [m/s]; for a
    :class:`ShapeMotion` its constant ``velocity`` (the centre's; rotating shapes and paths are
    re-placed per sweep by :meth:`SceneMotion.scatterers_at`)."""
    surfaces = scene_surfaces(scene)
    out = np.zeros((len(surfaces), 3))
    for surface in surfaces:
        if surface.id in motion:
            value = motion[surface.id]
            out[surface.index] = value.velocity if isinstance(value, ShapeMotion) else value
    return out


def _moves(value: Motion) -> bool:
    return value.moves() if isinstance(value, ShapeMotion) else any(v != 0.0 for v in value)


def _bbox(shape: Any) -> tuple[NDArray, NDArray]:
    box = shape.bbox()
    return (np.array([float(v) for v in box.min]), np.array([float(v) for v in box.max]))


class SceneMotion:
    """Moves the moving shapes of a loaded scene to their state at a time (module docstring).

    Parameters
    ----------
    where : str
        Caller, for errors.
    scene : mitsuba.Scene
    motion : mapping
        ``{shape id: velocity or ShapeMotion}`` (:func:`parse_motion`), on top of
        :func:`scene_motion`.
    duration : float, optional
        Length of the acquisition [s]: sampled paths must cover ``[0, duration]``, and
        :meth:`max_speed` looks within it (default 1 s, no coverage check).
    """

    def __init__(self, where: str, scene: Any, motion: Mapping[str, Motion],
                 duration: float | None = None) -> None:
        import mitsuba as mi  # lazy: only scenes with moving shapes need Mitsuba's parameters

        self.motion = {**scene_motion(scene), **dict(motion)}
        surfaces = {s.id: s for s in scene_surfaces(scene) if s.id}
        unknown = sorted(set(self.motion) - set(surfaces))
        if unknown:
            raise ParameterError(where, "motion", f"ids of the scene's shapes "
                                 f"({sorted(surfaces)})", unknown)
        self.motion = {key: value for key, value in self.motion.items() if _moves(value)}
        self.duration = 1.0 if duration is None else float(duration)
        # every moving shape as a rigid motion about its centre (translations: no rotation)
        self.rigid: dict[str, RigidMotion] = {}
        self.radius: dict[str, float] = {}
        self.index: dict[str, int] = {}
        for shape_id, value in self.motion.items():
            lo, hi = _bbox(surfaces[shape_id].shape)
            centre = 0.5 * (lo + hi)
            self.rigid[shape_id] = (value.rigid(centre) if isinstance(value, ShapeMotion)
                                    else RigidMotion(centre, np.asarray(value, float)))
            corners = np.array(np.meshgrid(*zip(lo, hi, strict=True), indexing="ij")
                               ).reshape(3, -1).T
            self.radius[shape_id] = float(np.linalg.norm(
                corners - self.rigid[shape_id].centre, axis=1).max())
            self.index[shape_id] = surfaces[shape_id].index
            if self.rigid[shape_id].rotates and plugin_kind(
                    surfaces[shape_id].shape.bsdf()) is PluginKind.POINTTARGET:
                raise ParameterError(where, f"motion.{shape_id}", "a velocity only for a point "
                                     "target's shape (point targets move with constant "
                                     "velocity)", "an angular velocity or a path")
            path = self.rigid[shape_id].path
            if duration is not None and path is not None and (
                    path.times[0] > 0.0 or path.times[-1] < self.duration):
                raise ParameterError(where, f"motion.{shape_id}.path.times", f"times covering "
                                     f"the acquisition [0, {self.duration:g}] s",
                                     f"[{path.times[0]:g}, {path.times[-1]:g}]")
        self.rotating = any(r.rotates for r in self.rigid.values())
        self._max_speed: float | None = None
        self._mi = mi
        self.params = mi.traverse(scene) if self.motion else None
        self._initial: dict[str, tuple[str, Any]] = {}
        for shape_id in self.motion:
            if f"{shape_id}.vertex_positions" in self.params:
                key = f"{shape_id}.vertex_positions"
                self._initial[shape_id] = (key, np.array(self.params[key], dtype=np.float64))
            elif f"{shape_id}.to_world" in self.params:
                key = f"{shape_id}.to_world"
                # a copy: the parameter is a view of the shape's transform, which set_time
                # overwrites (without it the shifts of successive times would add up)
                self._initial[shape_id] = (key, type(self.params[key])(self.params[key]))
            else:
                raise ParameterError(where, f"motion.{shape_id}", "a mesh or an analytic shape "
                                     "with a to_world transform", "a shape Mitsuba cannot move")
        self.time: float | None = None   # None: as loaded
        self._rows: dict[int, dict[str, NDArray]] = {}

    @property
    def moving(self) -> bool:
        """Whether any shape moves."""
        return bool(self.motion)

    def describe(self) -> dict[str, Any]:
        """JSON-able ``{shape id: velocity list or ShapeMotion.describe()}``."""
        return {key: value.describe() if isinstance(value, ShapeMotion) else list(value)
                for key, value in self.motion.items()}

    def max_speed(self) -> float:
        """Largest speed of a point of a moving shape [m/s] (0 without moving shapes)."""
        if self._max_speed is None:
            self._max_speed = max((rigid.max_speed(self.radius[key], 0.0, self.duration)
                                   for key, rigid in self.rigid.items()), default=0.0)
        return self._max_speed

    def shape_motions(self, shape_ids: Any) -> list[RigidMotion | None]:
        """The rigid motion of each of ``shape_ids`` (None: static)."""
        return [self.rigid.get(key) for key in shape_ids]

    def range_span(self, positions: NDArray, times: NDArray) -> tuple[float, float]:
        """(nearest, farthest) distance [m] from the antenna ``positions`` (S, 3) at ``times``
        (S,) to any point of a rotating shape or a shape on a path (its bounding sphere about
        its centre's track); (inf, -inf) without such shapes."""
        nearest, farthest = np.inf, -np.inf
        for key, rigid in self.rigid.items():
            if not rigid.rotates:
                continue
            distance = np.linalg.norm(positions - rigid.state(times)[0], axis=-1)
            nearest = min(nearest, float(distance.min()) - self.radius[key])
            farthest = max(farthest, float(distance.max()) + self.radius[key])
        return nearest, farthest

    def scatterers_at(self, scatterers: ScattererSet, time: float) -> ScattererSet:
        """The surface scatterers of rotating shapes (or shapes on paths) placed at ``time``
        [s]: normal ``R n0``, rigid-body velocity ``v`` of eq. (2) and position ``x(time) − v
        time``, so that the kernel's ``p + v t`` is exact at ``time`` (mid-sweep) and first
        order around it. Other rows as given; a new set (its device arrays are uploaded
        again)."""
        if not self.rotating:
            return scatterers
        rows = self._rows.get(id(scatterers))
        if rows is None:   # the rows of each rotating shape, once per scatterer set
            table = scatterers.table_row[:scatterers.surface_count]
            rows = {key: np.flatnonzero(table == self.index[key])
                    for key, rigid in self.rigid.items() if rigid.rotates}
            self._rows = {id(scatterers): rows}
        position, velocity = scatterers.position.copy(), scatterers.velocity.copy()
        normal = scatterers.normal.copy()
        for key, sel in rows.items():   # the rotating shapes (a few), not the scatterers
            rigid = self.rigid[key]
            now = rigid.move(scatterers.position[sel], time)
            speed = rigid.point_velocity(now, time)
            position[sel] = now - speed * time
            velocity[sel] = speed
            normal[sel] = rigid.rotate(scatterers.normal[sel], time)
        # a bound on the speeds (the kernels' margins), not a norm over every row each sweep
        bound = max(scatterers.max_speed(), self.max_speed())
        return dataclasses.replace(scatterers, position=position, velocity=velocity,
                                   normal=normal, device={"max_speed": bound})

    def set_time(self, time: float) -> None:
        """Put every moving shape where it is at ``time`` [s] (eq. 1 of
        :mod:`mitsar.model.geometry.rigid_motion`; ``x + v time`` for translations) and update
        the scene's acceleration structure."""
        if not self.moving or time == self.time:
            return
        mi = self._mi
        for shape_id, (key, initial) in self._initial.items():
            rigid = self.rigid[shape_id]
            if key.endswith("vertex_positions"):
                moved = rigid.move(initial.reshape(-1, 3), time).ravel()
                self.params[key] = mi.Float(moved.astype(np.float32))
            else:
                position, rotation, _, _ = rigid.state(time)
                matrix = np.eye(4)
                matrix[:3, :3] = rotation
                matrix[:3, 3] = position - rotation @ rigid.centre
                self.params[key] = mi.Transform4f(matrix.tolist()) @ initial
        self.params.update()
        self.time = float(time)

    def reset(self) -> None:
        """Back to the state at load."""
        if not self.moving or self.time is None:
            return
        for key, initial in self._initial.values():
            self.params[key] = (self._mi.Float(initial.astype(np.float32))
                                if key.endswith("vertex_positions") else
                                type(initial)(initial))
        self.params.update()
        self.time = None
