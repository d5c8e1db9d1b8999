"""The Mitsuba variant mitsar runs in, and its plugins registered for it.

:func:`ensure_variant` picks the variant (``llvm_ad_mono``; ``cuda_ad_mono`` with a GPU) and
checks, once per process in a subprocess, that Dr.Jit's LLVM backend works (libLLVM >= 16).
:func:`register_plugins` registers mitsar's plugins for the active variant, and again on every
later variant change (Python plugin classes are tied to the variant they were created in).
The plugin modules are imported here by name (:data:`PLUGIN_MODULES`), inside this package, once
a variant is set; the stages above (``scene``, ``raw``) call :func:`register_plugins` and never
name a plugin module.
"""

from __future__ import annotations

import importlib
from typing import Any

from mitsar import backend
from mitsar.errors import ParameterError

__all__ = ["DEFAULT_VARIANT", "GPU_VARIANT", "PLUGIN_MODULES", "SUPPORTED_VARIANTS",
           "ensure_variant", "import_mitsuba", "register_plugins"]

DEFAULT_VARIANT = "llvm_ad_mono"
"""Variant used when none is set and no GPU is present."""

GPU_VARIANT = "cuda_ad_mono"
"""Variant used when none is set and a CUDA GPU is present."""

SUPPORTED_VARIANTS = ("llvm_ad_mono", "cuda_ad_mono", "llvm_mono", "cuda_mono")
"""Variants the plugins and the integrator support (JIT, monochromatic, unpolarised)."""


def _gpu_present() -> bool:
    """mitsar's one backend choice (:func:`mitsar.backend.backend_name`: ``MITSAR_BACKEND``,
    else a CUDA device) is CUDA, and a CUDA device is there."""
    return backend.backend_name() == "cuda" and backend.cuda_available()


def ensure_variant(variant: str | None = None) -> str:
    """Set (if needed) and return a Mitsuba variant that mitsar supports.

    Parameters
    ----------
    variant : str, optional
        Variant to use. Default: keep the active variant if it is one of
        :data:`SUPPORTED_VARIANTS`, else ``cuda_ad_mono`` when a CUDA GPU is present and
        ``MITSAR_BACKEND`` is not ``llvm`` (:func:`mitsar.backend.backend_name`), else
        ``llvm_ad_mono``.

    Returns
    -------
    str
        The active variant.

    Raises
    ------
    ParameterError
        If ``variant`` is not a supported variant of this Mitsuba build.
    BackendError
        If the LLVM backend fails a ``dr.maximum`` smoke test (libLLVM < 16); the message names
        the fix (``apt-get install libllvm19`` or ``DRJIT_LIBLLVM_PATH``). The test runs once
        per process in a subprocess (:func:`mitsar.backend.require_llvm`); set
        ``MITSAR_SKIP_BACKEND_PROBE=1`` to skip it.
    """
    import mitsuba as mi  # lazy: importing Mitsuba loads its native libraries

    available = [v for v in SUPPORTED_VARIANTS if v in mi.variants()]
    if variant is None:
        current = mi.variant()
        if current in SUPPORTED_VARIANTS:
            variant = current
        elif GPU_VARIANT in available and _gpu_present():
            variant = GPU_VARIANT
        else:
            variant = DEFAULT_VARIANT
    if variant not in available:
        raise ParameterError("ensure_variant", "variant",
                             f"one of the Mitsuba variants {available}", variant)
    if variant.startswith("llvm_"):
        backend.require_llvm()
    if mi.variant() != variant:
        mi.set_variant(variant)
    return variant


PLUGIN_MODULES: tuple[str, ...] = ("mitsar.plugins.bsdfs.doublelobe",
                                   "mitsar.plugins.bsdfs.pointtarget",
                                   "mitsar.plugins.bsdfs.radio_material",
                                   "mitsar.plugins.integrators.radar.integrator")
"""The plugin modules, in registration order. They are imported by name once a variant is set
(Mitsuba's classes exist per variant), so importing this module loads no Mitsuba."""

_registered_variant: str | None = None
_callback_installed = False


def _plugin_modules() -> list[Any]:
    """Import the plugin modules (they need the variant set: Mitsuba imports at their top)."""
    return [importlib.import_module(name) for name in PLUGIN_MODULES]


def _register_current() -> None:
    global _registered_variant
    import mitsuba as mi  # lazy: see ensure_variant

    for module in _plugin_modules():
        module.register()
    _registered_variant = mi.variant()


def _on_variant_change(old: str | None, new: str | None) -> None:
    """Mitsuba variant callback: register the plugins for the new variant."""
    if new in SUPPORTED_VARIANTS and new != _registered_variant:
        _register_current()


def register_plugins(variant: str | None = None) -> str:
    """Register mitsar's Mitsuba plugins for the active variant (idempotent).

    Registers every plugin of :mod:`mitsar.plugins` (``doublelobe``, ``pointtarget``,
    ``itu-radio-material``, ``radio-material``, ``radar``) and installs a variant callback so
    that a later ``mi.set_variant`` to a
    supported variant registers them again.

    Parameters
    ----------
    variant : str, optional
        Passed to :func:`ensure_variant`.

    Returns
    -------
    str
        The active variant.
    """
    global _callback_installed
    import mitsuba as mi  # lazy: see ensure_variant

    variant = ensure_variant(variant)
    if _registered_variant != variant:
        _register_current()
    if not _callback_installed:
        mi.detail.add_variant_callback(_on_variant_change)
        _callback_installed = True
    return variant


def import_mitsuba(variant: str | None = None) -> Any:
    """The ``mitsuba`` module with a supported variant set (:func:`ensure_variant`).

    For code that builds Mitsuba objects itself (rectangles for shadow rays, ray tests) without
    mitsar's plugins; :func:`register_plugins` also registers those.
    """
    import mitsuba as mi  # lazy: see ensure_variant

    ensure_variant(variant)
    return mi
