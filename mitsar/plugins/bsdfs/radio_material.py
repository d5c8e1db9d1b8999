"""Mitsuba BSDFs ``itu-radio-material`` and ``radio-material``: Sionna RT scenes in mitsar.

Scenes written for Sionna RT (its Blender add-on, or by hand) name their materials with these
two XML types (Sionna RT documentation, "Radio Materials"). mitsar registers its own plugins
under the same names, which build a :class:`~mitsar.model.doublelobe.RadioMaterial`
(:func:`~mitsar.model.doublelobe.radio_material_from_sionna`): a Fresnel slab reflection
(ITU-R P.2040-3) whose scattered part follows the double-lobe model. Sionna's own plugins are
not needed (and are replaced if Sionna registered them first in the same process)::

    <bsdf type="itu-radio-material" id="mat-itu_concrete">
        <string name="type" value="concrete"/>            <!-- ITU-R P.2040-3 Table 3 name -->
        <float  name="thickness" value="0.2"/>            <!-- slab [m], default 0.1 -->
        <float  name="scattering_coefficient" value="0.3"/>  <!-- S in [0, 1], default 0 -->
        <float  name="xpd_coefficient" value="0.1"/>      <!-- K_x, recorded only -->
        <rgb    name="color" value="0.5, 0.5, 0.5"/>      <!-- display only, ignored -->
        <!-- mitsar extensions -->
        <float  name="frequency" value="94e9"/>           <!-- [Hz], default 94 GHz -->
        <string name="polarization" value="average"/>     <!-- average | te | tm -->
        <string name="scattering_pattern" value="backscattering"/>  <!-- lambertian | directive
                                                                         | backscattering -->
        <float  name="alpha_r" value="4"/> <float name="alpha_i" value="4"/>
        <float  name="lambda_" value="0.75"/>             <!-- Sionna's λ (specular lobe) -->
        <float  name="sigma0_db" value="-20"/>            <!-- optional given σ⁰, as doublelobe -->
    </bsdf>

    <bsdf type="radio-material" id="glass">
        <float name="relative_permittivity" value="6.31"/>  <!-- ε_r' -->
        <float name="conductivity" value="1.58"/>           <!-- σ [S/m] -->
        <!-- thickness, scattering_coefficient, ... as above -->
    </bsdf>

The permittivity is evaluated at ``frequency`` (94 GHz unless given): a BSDF does not know the
radar, so a scene for another carrier sets it. Unknown parameters raise
:class:`~mitsar.errors.ParameterError` naming ``itu-radio-material '<id>'`` and the parameter.
The instance behaves as a ``doublelobe`` BSDF (``PLUGIN_KIND = PluginKind.DOUBLELOBE``,
attribute ``material``) whose Γ² depends on the incidence: the radar integrator reads its
specular field factor Γ(θ_i)R and its σ⁰ through θ-tables, and the Mitsuba methods interpolate
a Γ² table.
"""

from __future__ import annotations

from typing import Any

import mitsuba as mi

from mitsar.errors import ParameterError
from mitsar.model import doublelobe as dl
from mitsar.plugins import PerVariant, plugin_where, read_properties
from mitsar.plugins.bsdfs import doublelobe as doublelobe_plugin
from mitsar.plugins.ops import DRJIT_OPS

ITU_PLUGIN_NAME = "itu-radio-material"
"""XML type name of the ITU-R P.2040-3 material."""

PLUGIN_NAME = "radio-material"
"""XML type name of the material with explicit permittivity and conductivity."""

_COMMON = ("thickness", "scattering_coefficient", "xpd_coefficient", "color", "reflectance",
           "base_color", "frequency", "polarization", "scattering_pattern", "alpha_r",
           "alpha_i", "lambda_", "sigma0_db")
_DISPLAY = ("color", "reflectance", "base_color")

PARAMETERS: dict[str, tuple[str, ...]] = {
    ITU_PLUGIN_NAME: ("type", *_COMMON),
    PLUGIN_NAME: ("relative_permittivity", "conductivity", *_COMMON),
}
"""Accepted XML parameters of each plugin (Sionna's, then mitsar's extensions)."""


def _material(plugin: str, where: str, values: dict[str, Any]) -> dl.RadioMaterial:
    """The radar material of an XML element's properties."""
    for key in _DISPLAY:
        values.pop(key, None)
    if plugin == ITU_PLUGIN_NAME:
        if "type" not in values:
            raise ParameterError(where, "type", "the name of an ITU-R P.2040-3 material, "
                                 "e.g. <string name=\"type\" value=\"concrete\"/>", None)
        values["itu_type"] = values.pop("type")
    if isinstance(values.get("sigma0_db"), str) \
            and values["sigma0_db"].strip().lower() in ("none", ""):
        values["sigma0_db"] = None
    return dl.radio_material_from_sionna(**values, where=where)


def _make_class(plugin: str) -> type:
    """The BSDF class of ``plugin`` for the active variant (a ``doublelobe`` subclass)."""
    base = doublelobe_plugin.bsdf_class()

    class RadioMaterialBSDF(base):  # type: ignore[misc, valid-type]
        """Sionna RT radio material as a double-lobe BSDF with a Fresnel Γ² (module docstring)."""

        def __init__(self, props: Any) -> None:
            mi.BSDF.__init__(self, props)
            self._where = plugin_where(plugin, props)
            values = read_properties(props, self._where, PARAMETERS[plugin])
            self.material = _material(plugin, self._where, values)
            self._init_components()

        def _setup(self) -> None:
            super()._setup()
            self._gamma2_table = mi.Float(self.material.gamma2_at(dl.theta_table_cosines()))

        def _gamma2_at(self, cos_theta_i: Any) -> Any:
            """``Γ²(θ_i)`` interpolated in the material's table (ITU-R P.2040-3 slab)."""
            return dl.interp_theta_table(self._gamma2_table, dl.TABLE_SIZE, cos_theta_i,
                                         DRJIT_OPS)

        def traverse(self, callback: Any) -> None:
            """Nothing is exposed: the material is fixed by the XML."""

        def parameters_changed(self, keys: Any = None) -> None:
            """Nothing to update (nothing is traversed)."""

        def to_string(self) -> str:
            m = self.material
            return (f"RadioMaterialBSDF[{plugin}, itu_type={m.itu_type!r}, "
                    f"eta={m.eta:.4g}, frequency={m.frequency:g}, thickness={m.thickness:g}, "
                    f"polarization={m.polarization!r}, S={m.scattering:g}, "
                    f"backscatter_fraction={m.backscatter_fraction:g}, alpha_b={m.alpha_b:g}, "
                    f"alpha_f={m.alpha_f:g}]")

    RadioMaterialBSDF.__name__ = RadioMaterialBSDF.__qualname__ = (
        "ITURadioMaterialBSDF" if plugin == ITU_PLUGIN_NAME else "RadioMaterialBSDF")
    return RadioMaterialBSDF


itu_bsdf_class = PerVariant(lambda: _make_class(ITU_PLUGIN_NAME))
"""The ``itu-radio-material`` class for the active variant."""

bsdf_class = PerVariant(lambda: _make_class(PLUGIN_NAME))
"""The ``radio-material`` class for the active variant."""


def register() -> None:
    """Register ``itu-radio-material`` and ``radio-material`` for the active Mitsuba variant."""
    itu_cls, cls = itu_bsdf_class(), bsdf_class()
    mi.register_bsdf(ITU_PLUGIN_NAME, lambda props: itu_cls(props))
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))
