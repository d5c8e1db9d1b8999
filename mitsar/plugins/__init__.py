"""Mitsuba plugins of mitsar, written in Python on Dr.Jit, in Mitsuba's own vocabulary.

===================================== ========== ==============================================
module                                kind       XML type name
===================================== ========== ==============================================
``bsdfs.doublelobe``                  BSDF       ``doublelobe``: radar material (paper eqs. 8-11)
``bsdfs.pointtarget``                 BSDF       ``pointtarget``: a small shape as one ideal
                                                 point scatterer
``bsdfs.radio_material``              BSDF       ``itu-radio-material``, ``radio-material``:
                                                 Sionna RT's materials (Fresnel + double lobe)
``integrators.radar`` (by stage)      integrator ``radar``: range histograms of an acquisition
===================================== ========== ==============================================

Each plugin module (listed in :data:`mitsar.plugins.variant.PLUGIN_MODULES`) exposes
``register()``, which registers its plugin for the *active* Mitsuba variant (Python plugin
classes are tied to the variant they were created in; :class:`PerVariant` makes one class per
variant). Call :func:`mitsar.plugins.variant.register_plugins` rather than these directly: it
picks and checks the variant and registers again when the variant changes. Each plugin class
carries a typed marker, :class:`mitsar.plugins.kind.PluginKind`, that the stages above read with
:func:`~mitsar.plugins.kind.plugin_kind`. :mod:`mitsar.plugins.ops` holds Dr.Jit's side of the
``ops`` namespace (:mod:`mitsar.model.ops`). The plugins import only :mod:`mitsar.model` and
the ground floor (``errors``, ``checks``, ``backend``); the scene and raw stages sit above them.

This module holds the small helpers the plugins share to read and check their XML properties;
it does not import Mitsuba.
"""

from __future__ import annotations

from collections.abc import Callable, Iterable
from typing import Any

from mitsar.errors import ParameterError


def plugin_where(plugin: str, props: Any) -> str:
    """Name of a plugin instance for error messages: ``"doublelobe 'wall'"`` or ``"doublelobe"``.

    Parameters
    ----------
    plugin : str
        XML type name of the plugin.
    props : mitsuba.Properties
        Its properties (the XML ``id``, if any, is read from them).
    """
    try:
        ident = props.id()
    except Exception:  # noqa: BLE001 - any Properties-like object without an id
        ident = ""
    return f"{plugin} {ident!r}" if ident else plugin


def _plain(value: Any) -> Any:
    """Mitsuba property value -> plain Python (float, int, bool, str or tuple of floats)."""
    if isinstance(value, bool | int | float | str):
        return value
    try:
        return tuple(float(value[i]) for i in range(len(value)))
    except TypeError:
        return value


def read_properties(props: Any, where: str, allowed: Iterable[str]) -> dict[str, Any]:
    """Read the properties of a plugin, rejecting unknown ones.

    Mitsuba does not check the properties of Python plugins, so every plugin calls this.

    Parameters
    ----------
    props : mitsuba.Properties
        The plugin's properties.
    where : str
        Plugin name for messages (:func:`plugin_where`).
    allowed : iterable of str
        Accepted property names.

    Returns
    -------
    dict
        Property name -> plain Python value (vectors and colours become tuples of floats).

    Raises
    ------
    ParameterError
        For an unknown property, naming the plugin and the property.
    """
    allowed = tuple(allowed)
    out: dict[str, Any] = {}
    for key in props.keys():
        value = _plain(props[key])
        if key not in allowed:
            raise ParameterError(where, key, f"one of the parameters {sorted(allowed)}", value)
        out[key] = value
    return out


def parse_vector3(value: Any, where: str, name: str) -> tuple[float, float, float]:
    """A 3-vector from ``"vx, vy, vz"`` (commas and/or spaces), a tuple, or a Mitsuba vector.

    Raises
    ------
    ParameterError
        If the value is not three finite numbers.
    """
    expected = "three finite numbers, e.g. \"0.5, 0, 0\" or <vector x=.. y=.. z=../>"
    items: Any = value
    if isinstance(value, str):
        items = value.replace(",", " ").split()
    try:
        vec = tuple(float(v) for v in items)
    except (TypeError, ValueError):
        raise ParameterError(where, name, expected, value) from None
    if len(vec) != 3 or not all(abs(v) < float("inf") for v in vec):
        raise ParameterError(where, name, expected, value)
    return vec  # type: ignore[return-value]


class PerVariant:
    """A plugin class made once per Mitsuba variant.

    Python plugin classes derive from the variant's ``mi.BSDF`` or ``mi.SamplingIntegrator``,
    so each variant needs its own; calling the instance returns the active variant's class.

    Parameters
    ----------
    factory : callable
        Creates the class for the active variant.
    """

    def __init__(self, factory: Callable[[], type]) -> None:
        self._factory = factory
        self._classes: dict[str, type] = {}

    def __call__(self) -> type:
        import mitsuba as mi

        variant = mi.variant()
        if variant not in self._classes:
            self._classes[variant] = self._factory()
        return self._classes[variant]
