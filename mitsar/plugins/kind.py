"""What a mitsar plugin is: the typed marker the plugins carry and the stages above read.

Every mitsar plugin class sets the class attribute ``PLUGIN_KIND`` to a :class:`PluginKind`
member; :func:`plugin_kind` reads it from any Mitsuba object (a shape's BSDF, a scene's
integrator), ``None`` for objects that are not mitsar plugins (Mitsuba's own ``diffuse``, a
missing BSDF). Nothing here imports Mitsuba.
"""

from __future__ import annotations

import enum
from typing import Any

__all__ = ["PluginKind", "plugin_kind"]


class PluginKind(enum.Enum):
    """The kinds of mitsar plugin that the scene and the tracer tell apart."""

    DOUBLELOBE = "doublelobe"
    """A radar material (``doublelobe``, ``itu-radio-material``, ``radio-material``): reads
    ``material`` (:class:`~mitsar.model.doublelobe.DoubleLobe`)."""
    POINTTARGET = "pointtarget"
    """A shape that stands for one ideal point scatterer (``pointtarget``)."""
    RADAR = "radar"
    """The ``radar`` integrator."""


def plugin_kind(obj: Any) -> PluginKind | None:
    """The :class:`PluginKind` of a Mitsuba object, ``None`` if it is not a mitsar plugin.

    Parameters
    ----------
    obj : Any
        A Mitsuba object (BSDF, integrator) or ``None``.
    """
    kind = getattr(obj, "PLUGIN_KIND", None) if obj is not None else None
    return kind if isinstance(kind, PluginKind) else None
