"""Moving shapes: rigid translation of scene shapes during an acquisition (docs/integrator.md
§Moving objects).

A shape moves with a constant ``velocity`` [m/s] from the state it was loaded in, which is its
state at slow time 0: at time t every point of it is at ``x + v t``. Velocities come from the
``velocity`` property of a ``<shape>`` in the XML (read by :func:`mitsar.scene.load_scene`,
:func:`scene_motion`), from a ``motion`` mapping of shape ids given to the simulators (the
experiment TOML's ``[scene.motion]``), and from point targets whose ``pointtarget`` BSDF has a
velocity (their marker shape moves with them, so it does not shadow its own target once it has
moved off its load position).

:class:`SceneMotion` moves the shapes of a loaded scene to their state at a time (Mitsuba's
``mi.traverse`` parameters: a mesh's ``vertex_positions``, an analytic shape's ``to_world``) so
that shadow and multipath rays see them where they are; the scatterers sampled on a moving
shape get its velocity (:func:`surface_velocities`), so the integrator evaluates their position
``p + v t`` and delay rate at every sweep, as it does for point targets.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.checks import vector
from mitsar.errors import ParameterError
from mitsar.scene.surfaces import scene_surfaces

__all__ = ["MOTION_PROPERTIES", "SceneMotion", "parse_motion", "register_scene_motion",
           "scene_motion", "surface_velocities"]

MOTION_PROPERTIES = ("velocity",)
"""Properties of a ``<shape>`` that mitsar reads (and removes before Mitsuba loads it)."""

_LOADED_MOTION: dict[int, tuple[Any, dict[str, tuple[float, float, float]]]] = {}
"""Velocities declared in the XML of recently loaded scenes: id(scene) -> (scene, motion). The
scene is held so that its id is not reused while the entry exists (Mitsuba scenes take no weak
references); at most :data:`_KEEP` entries."""

_KEEP = 8


def parse_motion(where: str, motion: Mapping[str, Any] | None) -> dict[str, tuple[float, ...]]:
    """Validate ``{shape id: velocity}``, a velocity being 3 floats [m/s] or ``{"velocity":
    [vx, vy, vz]}`` (the TOML form)."""
    if motion is None:
        return {}
    if not isinstance(motion, Mapping):
        raise ParameterError(where, "motion", "a mapping {shape id: velocity [vx, vy, vz] m/s}",
                             motion)
    out = {}
    for shape_id, value in motion.items():
        if isinstance(value, Mapping):
            unknown = set(value) - set(MOTION_PROPERTIES)
            if unknown:
                raise ParameterError(where, f"motion.{shape_id}",
                                     f"only the keys {MOTION_PROPERTIES}", sorted(unknown))
            value = value.get("velocity", (0.0, 0.0, 0.0))
        out[str(shape_id)] = tuple(float(v) for v in vector(
            where, f"motion.{shape_id}.velocity", value, 3, "a velocity [vx, vy, vz] in m/s"))
    return out


def register_scene_motion(scene: Any, motion: dict[str, tuple[float, float, float]]) -> None:
    """Record the velocities declared in a scene's XML (called by the loader)."""
    while len(_LOADED_MOTION) >= _KEEP:
        _LOADED_MOTION.pop(next(iter(_LOADED_MOTION)))
    _LOADED_MOTION[id(scene)] = (scene, dict(motion))


def scene_motion(scene: Any) -> dict[str, tuple[float, float, float]]:
    """Velocities of the shapes of a loaded scene: from its XML and its moving point targets."""
    entry = _LOADED_MOTION.get(id(scene))
    out = dict(entry[1]) if entry is not None and entry[0] is scene else {}
    for surface in scene_surfaces(scene):
        bsdf = surface.shape.bsdf()
        velocity = getattr(bsdf, "velocity", None)
        if getattr(bsdf, "MITSAR_KIND", None) == "pointtarget" and surface.id \
                and velocity is not None and any(v != 0.0 for v in velocity):
            out.setdefault(surface.id, tuple(float(v) for v in velocity))
    return out


def surface_velocities(scene: Any, motion: Mapping[str, tuple[float, ...]]) -> NDArray:
    """Velocity of every shape of :func:`mitsar.scene.surfaces.scene_surfaces` (rows in its
    ``index`` order, the ``shape_index`` of surface scatterers) [m/s]."""
    surfaces = scene_surfaces(scene)
    out = np.zeros((len(surfaces), 3))
    for surface in surfaces:
        if surface.id in motion:
            out[surface.index] = motion[surface.id]
    return out


class SceneMotion:
    """Moves the moving shapes of a loaded scene to their state at a time (module docstring).

    Parameters
    ----------
    where : str
        Caller, for errors.
    scene : mitsuba.Scene
    motion : mapping
        ``{shape id: velocity}`` [m/s] (:func:`parse_motion`), on top of :func:`scene_motion`.
    """

    def __init__(self, where: str, scene: Any, motion: Mapping[str, tuple[float, ...]]) -> None:
        import mitsuba as mi  # lazy: only scenes with moving shapes need Mitsuba's parameters

        self.motion = {**scene_motion(scene), **dict(motion)}
        ids = sorted(s.id for s in scene_surfaces(scene) if s.id)
        unknown = sorted(set(self.motion) - set(ids))
        if unknown:
            raise ParameterError(where, "motion", f"ids of the scene's shapes ({ids})", unknown)
        self.motion = {key: value for key, value in self.motion.items()
                       if any(v != 0.0 for v in value)}
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
        self.time = 0.0

    @property
    def moving(self) -> bool:
        """Whether any shape moves."""
        return bool(self.motion)

    def max_speed(self) -> float:
        """Largest shape speed [m/s] (0 without moving shapes)."""
        return max((float(np.linalg.norm(v)) for v in self.motion.values()), default=0.0)

    def set_time(self, time: float) -> None:
        """Move every moving shape to ``x + v time`` (x: its state at load) and update the
        scene's acceleration structure."""
        if not self.moving or time == self.time:
            return
        mi = self._mi
        for shape_id, (key, initial) in self._initial.items():
            shift = np.asarray(self.motion[shape_id], dtype=np.float64) * time
            if key.endswith("vertex_positions"):
                moved = (initial.reshape(-1, 3) + shift).ravel()
                self.params[key] = mi.Float(moved.astype(np.float32))
            else:
                self.params[key] = mi.Transform4f().translate(
                    [float(v) for v in shift]) @ initial
        self.params.update()
        self.time = float(time)

    def reset(self) -> None:
        """Back to the state at load (time 0)."""
        self.set_time(0.0)
