"""Mitsuba BSDF ``pointtarget``: marks a small shape as one ideal point scatterer (docs/design.md
§5.4).

XML::

    <shape type="sphere" id="target">
        <point name="center" x="15" y="8" z="0.03"/>
        <float name="radius" value="0.02"/>
        <bsdf type="pointtarget">
            <float  name="rcs" value="1.0"/>                 <!-- σ [m²], > 0 -->
            <string name="velocity" value="0.0, 0.0, 0.0"/>  <!-- [m/s], optional -->
        </bsdf>
    </shape>

``velocity`` may also be given as ``<vector name="velocity" x=".." y=".." z=".."/>``.

The target is one scatterer at the centre of the shape's bounding box with the given RCS
(:func:`mitsar.scene.scene_point_targets`), shadowed by the rest of the scene. For rays the shape
is a black absorber (``eval``, ``pdf`` and ``sample`` return zero), so it does not also scatter as
a surface. The integrator reads the Python attributes ``rcs`` [m²] and ``velocity`` [m/s] of the
instance returned by ``shape.bsdf()``.
"""

from __future__ import annotations

import math
from typing import Any

import drjit as dr
import mitsuba as mi

from mitsar.checks import MAX_RCS
from mitsar.errors import ParameterError
from mitsar.plugins import PerVariant, parse_vector3, plugin_where, read_properties
from mitsar.plugins.kind import PluginKind

PLUGIN_NAME = "pointtarget"
"""XML type name."""

PARAMETERS: tuple[str, ...] = ("rcs", "velocity")
"""Accepted XML parameters."""


def parse_rcs(value: Any, where: str) -> float:
    """Check an RCS value: a finite number > 0 [m²]."""
    expected = f"a radar cross section > 0 and <= {MAX_RCS:.0e} m² (finite)"
    if isinstance(value, bool):
        raise ParameterError(where, "rcs", expected, value)
    try:
        rcs = float(value)
    except (TypeError, ValueError):
        raise ParameterError(where, "rcs", expected, value) from None
    if not (math.isfinite(rcs) and 0.0 < rcs <= MAX_RCS):
        raise ParameterError(where, "rcs", expected, value)
    return rcs


def _make_class() -> type:
    """Create the BSDF class for the active variant."""

    class PointTargetBSDF(mi.BSDF):
        """Ideal point scatterer marker; a black absorber for rays."""

        PLUGIN_KIND = PluginKind.POINTTARGET

        def __init__(self, props: Any) -> None:
            mi.BSDF.__init__(self, props)
            self._where = plugin_where(PLUGIN_NAME, props)
            values = read_properties(props, self._where, PARAMETERS)
            if "rcs" not in values:
                raise ParameterError(self._where, "rcs", "a radar cross section > 0 m²",
                                     "nothing (the parameter is required)")
            self.rcs: float = parse_rcs(values["rcs"], self._where)
            self.velocity: tuple[float, float, float] = parse_vector3(
                values.get("velocity", (0.0, 0.0, 0.0)), self._where, "velocity")
            flags = mi.BSDFFlags.DiffuseReflection | mi.BSDFFlags.FrontSide \
                | mi.BSDFFlags.BackSide
            self.m_components = [flags]
            self.m_flags = flags

        def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            return mi.Spectrum(0.0)

        def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            return dr.zeros(mi.Float, dr.width(wo))

        def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            return mi.Spectrum(0.0), dr.zeros(mi.Float, dr.width(wo))

        def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any,
                   active: Any = True) -> Any:
            bs = dr.zeros(mi.BSDFSample3f, dr.width(sample1))
            return bs, mi.Spectrum(0.0)

        def traverse(self, callback: Any) -> None:
            """Nothing to expose: the RCS and velocity are not differentiable parameters."""

        def to_string(self) -> str:
            vx, vy, vz = self.velocity
            return f"PointTargetBSDF[rcs={self.rcs:g} m², velocity=({vx:g}, {vy:g}, {vz:g}) m/s]"

    return PointTargetBSDF


bsdf_class = PerVariant(_make_class)
"""The BSDF class for the active variant (created once per variant)."""


def register() -> None:
    """Register ``pointtarget`` for the active Mitsuba variant."""
    cls = bsdf_class()
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))
