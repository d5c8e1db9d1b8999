"""mitsar: FMCW millimetre-wave SAR simulation and processing for indoor drones.

The public API, re-exported from the stage that defines each name (``docs/design.md`` draws
the stages: model → scene → raw → focus → quality, with ambiguity maps beside them).

Every name is imported on first use (PEP 562 module ``__getattr__``), so ``import mitsar`` and
a command that needs little (a no-op campaign rerun) do not load Mitsuba, Dr.Jit, SciPy's
signal tools or Matplotlib (docs/design.md §3, issue 27 item 3); ``from mitsar import Radar``
and ``mitsar.focus(...)`` work as before.
"""

from __future__ import annotations

import importlib
import sys
import types
from typing import TYPE_CHECKING, Any

from mitsar.errors import MitsarError, ParameterError, public
from mitsar.version import __version__

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar import ambiguity
    from mitsar.export import read_cphd
    from mitsar.features import detect
    from mitsar.features.mapping import map_scene
    from mitsar.features.scores import map_scores
    from mitsar.focus import grid
    from mitsar.focus.compression import range_compress
    from mitsar.focus.dispatch import focus
    from mitsar.interferometry import interferogram
    from mitsar.io import load, save
    from mitsar.model.geometry.attitude import Look, boresight
    from mitsar.model.geometry.navigation import NavigationErrors, Vibration
    from mitsar.model.geometry.trajectory import Trajectory
    from mitsar.model.radar import Radar
    from mitsar.model.targets import Background, PointTarget
    from mitsar.model.trace_options import TraceOptions
    from mitsar.quality.impulse import measure_impulse_response
    from mitsar.raw.analytic import simulate_point_targets
    from mitsar.raw.recorded import raw_from_arrays, read_gotcha, read_raw
    from mitsar.raw.traced import histogram_to_raw_product, simulate_scene, trace

__all__ = [
    "Background", "Look", "MitsarError", "NavigationErrors", "ParameterError", "PointTarget",
    "Radar", "TraceOptions", "Trajectory", "Vibration", "__version__", "ambiguity", "boresight",
    "detect", "focus", "grid", "histogram_to_raw_product", "interferogram", "load", "map_scene",
    "map_scores",
    "measure_impulse_response", "range_compress", "raw_from_arrays", "read_cphd", "read_gotcha",
    "read_raw", "save", "simulate_point_targets", "simulate_scene", "trace",
]

_MODULES = {"ambiguity": "mitsar.ambiguity", "grid": "mitsar.focus.grid"}
"""Public names that are modules: the name -> the module."""

_EXPORTS = {
    "Background": "mitsar.model.targets", "Look": "mitsar.model.geometry.attitude",
    "NavigationErrors": "mitsar.model.geometry.navigation", "PointTarget": "mitsar.model.targets",
    "Radar": "mitsar.model.radar", "TraceOptions": "mitsar.model.trace_options",
    "Trajectory": "mitsar.model.geometry.trajectory",
    "Vibration": "mitsar.model.geometry.navigation",
    "boresight": "mitsar.model.geometry.attitude", "detect": "mitsar.features.detection",
    "focus": "mitsar.focus.dispatch", "histogram_to_raw_product": "mitsar.raw.traced",
    "interferogram": "mitsar.interferometry.interferogram", "load": "mitsar.io",
    "map_scene": "mitsar.features.mapping", "map_scores": "mitsar.features.scores",
    "measure_impulse_response": "mitsar.quality.impulse",
    "range_compress": "mitsar.focus.compression", "raw_from_arrays": "mitsar.raw.recorded",
    "read_cphd": "mitsar.export.cphd", "read_gotcha": "mitsar.raw.recorded",
    "read_raw": "mitsar.raw.recorded", "save": "mitsar.io",
    "simulate_point_targets": "mitsar.raw.analytic", "simulate_scene": "mitsar.raw.traced",
    "trace": "mitsar.raw.traced",
}
"""Public names defined in a module: the name -> the module that defines it."""


_CHECKED: dict[str, Any] = {}
"""Public functions wrapped by :func:`mitsar.errors.public` (argument classes checked)."""


def _public(name: str) -> Any:
    """The public ``name``, imported from its module (:data:`_EXPORTS`, :data:`_MODULES`);
    a function comes wrapped so that wrong arguments get a ParameterError
    (:func:`mitsar.errors.public`, issue 27)."""
    if name in _MODULES:
        return importlib.import_module(_MODULES[name])
    value = getattr(importlib.import_module(_EXPORTS[name]), name)
    if isinstance(value, types.FunctionType):
        if getattr(_CHECKED.get(name), "__wrapped__", None) is not value:  # new, or patched
            _CHECKED[name] = public(value, module=__name__)
        value = _CHECKED[name]
    return value


def __getattr__(name: str) -> Any:
    """Import a public name on first use (PEP 562) and keep it in the module's namespace."""
    if name not in _EXPORTS and name not in _MODULES:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = globals()[name] = _public(name)
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))


class _Package(types.ModuleType):
    """The module type of ``mitsar``: ``mitsar.focus`` is the function :func:`focus`, which has
    the name of the sub-package ``mitsar.focus``; importing that sub-package binds it on its
    parent, which would hide the function, so the name is a property that the import system's
    binding does not replace (the sub-package stays in ``sys.modules``)."""

    @property
    def focus(self) -> Any:
        """:func:`mitsar.focus.dispatch.focus`."""
        return _public("focus")

    @focus.setter
    def focus(self, value: Any) -> None:
        """The import system binding the sub-package ``mitsar.focus``: kept out of the way."""


sys.modules[__name__].__class__ = _Package
