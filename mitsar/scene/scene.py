"""Scenes: Mitsuba variant and plugins, XML loading, point targets and surface scatterers.

- :func:`ensure_variant` picks the Mitsuba variant (``llvm_ad_mono``; ``cuda_ad_mono`` with a
  GPU) and checks, in a subprocess, that Dr.Jit's LLVM backend works (libLLVM >= 16).
- :func:`register_plugins` registers mitsar's plugins (``doublelobe``, ``pointtarget`` and, when
  ``mitsar/plugins/radar.py`` exists, ``radar``) for the active variant, again on every variant
  change.
- :func:`load_scene` loads an XML scene (a path or a canned scene name) with errors that name the
  file, the element and the parameter.
- :func:`scene_surfaces`, :func:`scene_point_targets` and :func:`sample_surface_scatterers` turn
  a loaded scene into what the radar integrator needs (DESIGN §5.4, mechanism 1): materials per
  shape, ideal point scatterers, and a fixed, seeded set of surface scatterers with a frozen
  speckle phase each, so that the returns stay coherent from sweep to sweep.
- :func:`write_ply` and :func:`box_mesh` generate the PLY meshes under ``mitsar/scene/canned/meshes``.

Shapes are listed in a canonical order (by id, then kind and bounding box), because the order of
``scene.shapes()`` is not stable between loads; ``shape_index`` refers to that order.
"""

from __future__ import annotations

import importlib
import importlib.util
import math
import os
import re
import xml.parsers.expat
from dataclasses import dataclass
from pathlib import Path
from typing import Any, NamedTuple

import numpy as np

from mitsar.backend import LLVM_FIX, BackendError
from mitsar.backend import llvm_probe as _llvm_probe
from mitsar.model.doublelobe import DoubleLobe
from mitsar.errors import MissingFileError, ParameterError, SceneError

__all__ = [
    "DEFAULT_VARIANT",
    "GPU_VARIANT",
    "SUPPORTED_VARIANTS",
    "ScenePointTarget",
    "SceneSurface",
    "SurfaceScatterers",
    "box_mesh",
    "ensure_variant",
    "load_scene",
    "register_plugins",
    "sample_surface_scatterers",
    "scene_point_targets",
    "scene_surfaces",
    "write_ply",
]

DEFAULT_VARIANT = "llvm_ad_mono"
"""Variant used when none is set and no GPU is present."""

GPU_VARIANT = "cuda_ad_mono"
"""Variant used when none is set and a CUDA GPU is present."""

SUPPORTED_VARIANTS = ("llvm_ad_mono", "cuda_ad_mono", "llvm_mono", "cuda_mono")
"""Variants the plugins and the integrator support (JIT, monochromatic, unpolarised)."""

def _gpu_present() -> bool:
    try:
        import drjit as dr

        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # noqa: BLE001 - no CUDA driver, or an old Dr.Jit
        return False


def ensure_variant(variant: str | None = None) -> str:
    """Set (if needed) and return a Mitsuba variant that mitsar supports.

    Parameters
    ----------
    variant : str, optional
        Variant to use. Default: keep the active variant if it is one of
        :data:`SUPPORTED_VARIANTS`, else ``cuda_ad_mono`` when a CUDA GPU is present, else
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
        per process in a subprocess; set ``MITSAR_SKIP_BACKEND_PROBE=1`` to skip it.
    """
    import mitsuba as mi

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
        ok, detail = _llvm_probe()
        if not ok:
            raise BackendError(
                "Dr.Jit's LLVM backend failed a smoke test (dr.maximum on a 3-element array); it "
                f"needs libLLVM >= 16. Fix: {LLVM_FIX}. Probe output: {detail}")
    if mi.variant() != variant:
        mi.set_variant(variant)
    return variant


_registered_variant: str | None = None
_callback_installed = False


def _plugin_modules() -> list[Any]:
    """Import the plugin modules that exist (``radar`` is optional)."""
    from mitsar.plugins import PLUGIN_MODULES

    modules = []
    for name in PLUGIN_MODULES:
        full = f"mitsar.plugins.{name}"
        if importlib.util.find_spec(full) is None:
            continue
        modules.append(importlib.import_module(full))
    return modules


def _register_current() -> None:
    global _registered_variant
    import mitsuba as mi

    for module in _plugin_modules():
        register = getattr(module, "register", None)
        if register is not None:
            register()
    _registered_variant = mi.variant()


def _on_variant_change(old: str | None, new: str | None) -> None:
    """Mitsuba variant callback: register the plugins for the new variant."""
    if new in SUPPORTED_VARIANTS and new != _registered_variant:
        _register_current()


def register_plugins(variant: str | None = None) -> str:
    """Register mitsar's Mitsuba plugins for the active variant (idempotent).

    Registers ``doublelobe``, ``pointtarget`` and, if the module ``mitsar.plugins.integrators.radar`` exists,
    whatever its ``register()`` registers. Installs a variant callback so that a later
    ``mi.set_variant`` to a supported variant registers them again.

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
    import mitsuba as mi

    variant = ensure_variant(variant)
    if _registered_variant != variant:
        _register_current()
    if not _callback_installed:
        mi.detail.add_variant_callback(_on_variant_change)
        _callback_installed = True
    return variant


# --------------------------------------------------------------------------------------------
# Loading XML scenes with useful errors
# --------------------------------------------------------------------------------------------


@dataclass(frozen=True)
class _Element:
    tag: str
    attrs: dict[str, str]
    line: int
    column: int  # 1-based column of '<'
    parent: int | None


class _Verbatim(str):
    """A string shown without quotes in ParameterError's ``found``."""

    def __repr__(self) -> str:
        return str(self)


def _scan_xml(path: Path) -> list[_Element]:
    """Elements of an XML file with their line and column, in document order."""
    elements: list[_Element] = []
    stack: list[int] = []
    parser = xml.parsers.expat.ParserCreate()

    def start(tag: str, attrs: dict[str, str]) -> None:
        parent = stack[-1] if stack else None
        elements.append(_Element(tag, dict(attrs), parser.CurrentLineNumber,
                                 parser.CurrentColumnNumber + 1, parent))
        stack.append(len(elements) - 1)

    def end(tag: str) -> None:
        stack.pop()

    parser.StartElementHandler = start
    parser.EndElementHandler = end
    try:
        parser.Parse(path.read_bytes(), True)
    except xml.parsers.expat.ExpatError as error:
        raise SceneError(f"{path}: not well-formed XML: {error}") from None
    return elements


def _describe(elements: list[_Element], index: int | None) -> str:
    """``"shape 'floor' (type rectangle, line 12)"``, with the parent for unnamed elements."""
    if index is None:
        return "the scene"
    el = elements[index]
    kind = el.attrs.get("type")
    ident = el.attrs.get("id") or el.attrs.get("name")
    text = el.tag + (f" {ident!r}" if ident else "")
    details = ([f"type {kind}"] if kind else []) + [f"line {el.line}"]
    text += f" ({', '.join(details)})"
    if not el.attrs.get("id") and el.parent is not None and elements[el.parent].tag != "scene":
        text += f" in {_describe(elements, el.parent)}"
    return text


def _element_at(elements: list[_Element], line: int, column: int) -> int | None:
    """Index of the last element starting at or before (line, column)."""
    best = None
    for i, el in enumerate(elements):
        if (el.line, el.column) <= (line, column):
            best = i
    return best


def _substitute(value: str, values: dict[str, str]) -> str:
    return re.sub(r"\$(\w+)", lambda m: values.get(m.group(1), m.group(0)), value)


def _check_referenced_files(path: Path, elements: list[_Element],
                            params: dict[str, str]) -> None:
    """Raise MissingFileError for a ``filename`` of a shape (mesh) that does not exist."""
    values = {el.attrs["name"]: el.attrs.get("value", "") for el in elements
              if el.tag == "default" and "name" in el.attrs}
    values.update(params)
    for el in elements:
        if el.tag != "string" or el.attrs.get("name") != "filename" or el.parent is None:
            continue
        owner = elements[el.parent]
        if owner.tag != "shape":
            continue
        filename = _substitute(el.attrs.get("value", ""), values)
        candidates = [Path(filename)] if Path(filename).is_absolute() else [
            path.parent / filename, Path.cwd() / filename]
        if not any(c.is_file() for c in candidates):
            raise MissingFileError(
                f"{path.name}: {_describe(elements, el.parent)}: parameter 'filename': "
                f"mesh file {filename!r} not found (looked in {path.parent})")


_RE_POSITION = re.compile(r"\(line (\d+), col (\d+)\)")
_RE_PLUGIN_PARAM = re.compile(
    r"(\w*Error): (?P<where>.+?): parameter '(?P<name>[^']+)': expected (?P<expected>.+), "
    r"found (?P<found>.+)$", re.MULTILINE)
_RE_UNREFERENCED = re.compile(
    r'unreferenced propert(?:y|ies) in (?P<kind>\w+) plugin of type "(?P<type>[^"]+)":\s*'
    r'-\s*(?P<ptype>\w+) "(?P<name>[^"]+)": (?P<value>[^\n]*)', re.IGNORECASE)
_RE_UNUSED = re.compile(r"unused parameters:\s*-\s*\$(?P<name>\w+)=(?P<value>[^\n]*)",
                        re.IGNORECASE)


def _translate_error(error: Exception, path: Path, elements: list[_Element],
                     params: dict[str, str]) -> Exception:
    """Turn Mitsuba's loader exception into a mitsar error naming element and parameter."""
    message = str(error)
    position = _RE_POSITION.search(message)
    index = None
    if position is not None:
        index = _element_at(elements, int(position.group(1)), int(position.group(2)))
    element = _describe(elements, index)
    if (match := _RE_UNUSED.search(message)) is not None:
        declared = sorted(el.attrs["name"] for el in elements
                          if el.tag == "default" and "name" in el.attrs)
        return ParameterError(f"load_scene({path.name})", match.group("name"),
                              f"a scene parameter declared with <default> (one of {declared})",
                              _Verbatim(match.group("value").strip()))
    matches = list(_RE_PLUGIN_PARAM.finditer(message))
    if matches:
        m = matches[-1]
        return ParameterError(f"{path.name}: {element}", m.group("name"), m.group("expected"),
                              _Verbatim(m.group("found").strip()))
    if (match := _RE_UNREFERENCED.search(message)) is not None:
        return ParameterError(
            f"{path.name}: {element}", match.group("name"),
            f"a parameter of Mitsuba's {match.group('kind')} plugin '{match.group('type')}'",
            _Verbatim(f"{match.group('ptype')} {match.group('value').strip()}"))
    if "file not found" in message.lower() or "does not exist" in message.lower():
        return MissingFileError(f"{path.name}: {element}: {message}")
    return SceneError(f"{path.name}: {element}: {message}")


def load_scene(path_or_scene: Any, **params: Any) -> Any:
    """Load a Mitsuba XML scene with mitsar's plugins registered.

    Parameters
    ----------
    path_or_scene : str, os.PathLike or mitsuba.Scene
        An XML file, a canned scene name (``mitsar.scene.canned.names()``, e.g. ``"dihedral"``), or an
        already loaded scene (returned unchanged).
    **params
        Values of the scene's ``<default name=...>`` parameters (converted with ``str``), e.g.
        ``material="concrete_94ghz"``.

    Returns
    -------
    mitsuba.Scene
        Loaded with ``optimize=False``: Mitsuba's optimiser would merge the shapes that share a
        BSDF into one mesh, and mitsar needs every shape (wall, target) on its own.

    Raises
    ------
    MissingFileError
        The scene file or a mesh it references does not exist (names the element).
    ParameterError
        A plugin parameter is unknown or out of range, or a scene parameter is not declared
        (names the file, the element and the parameter).
    SceneError
        Any other loader error, with the file and element.
    """
    import mitsuba as mi

    register_plugins()
    if isinstance(path_or_scene, mi.Scene):
        if params:
            raise ParameterError("load_scene", next(iter(params)),
                                 "no scene parameters for an already loaded scene",
                                 params[next(iter(params))])
        return path_or_scene
    if not isinstance(path_or_scene, str | os.PathLike):
        raise ParameterError("load_scene", "path_or_scene",
                             "a path, a canned scene name or a mitsuba.Scene", path_or_scene)
    path = Path(path_or_scene)
    if not path.is_file():
        from mitsar.scene import canned as scenes

        if path.suffix == "" and str(path_or_scene) in scenes.names():
            path = scenes.path(str(path_or_scene))
        else:
            raise MissingFileError(
                f"load_scene: scene file {str(path_or_scene)!r} not found (give an XML file or "
                f"one of the canned scenes {scenes.names()})")
    path = path.resolve()
    str_params = {key: str(value) for key, value in params.items()}
    elements = _scan_xml(path)
    _check_referenced_files(path, elements, str_params)
    try:
        return mi.load_file(str(path), optimize=False, **str_params)
    except Exception as error:  # noqa: BLE001 - Mitsuba raises RuntimeError for everything
        raise _translate_error(error, path, elements, str_params) from error


# --------------------------------------------------------------------------------------------
# What the integrator needs from a loaded scene
# --------------------------------------------------------------------------------------------


class SceneSurface(NamedTuple):
    """One shape of a scene, in canonical order."""

    index: int
    """Position in :func:`scene_surfaces` (the ``shape_index`` of scatterers)."""
    id: str
    """XML id of the shape ("" if none)."""
    kind: str
    """Mitsuba shape class, e.g. ``"Rectangle"``, ``"PLYMesh"``, ``"Sphere"``."""
    shape: Any
    """The ``mitsuba.Shape``."""
    material: DoubleLobe | None
    """Its radar material; None for point targets, absorbers and non-radar BSDFs."""
    area: float
    """Surface area [m²]."""


class ScenePointTarget(NamedTuple):
    """An ideal point scatterer marked by the ``pointtarget`` material."""

    position: np.ndarray
    """Centre of the shape's bounding box, shape (3,) [m]."""
    rcs: float
    """Radar cross section [m²]."""
    velocity: np.ndarray
    """Velocity, shape (3,) [m/s]."""
    shape_id: str
    """XML id of the shape ("" if none)."""


def _kind(obj: Any) -> str | None:
    return getattr(obj, "MITSAR_KIND", None) if obj is not None else None


def _canonical_shapes(scene: Any) -> list[Any]:
    def key(shape: Any) -> tuple:
        box = shape.bbox()
        return (shape.id(), shape.class_name(), tuple(float(v) for v in box.min),
                tuple(float(v) for v in box.max))

    return sorted(scene.shapes(), key=key)


def scene_surfaces(scene: Any) -> list[SceneSurface]:
    """Every shape of the scene with its radar material and area, in canonical order.

    Parameters
    ----------
    scene : mitsuba.Scene

    Returns
    -------
    list of SceneSurface
        ``material`` is the :class:`~mitsar.model.doublelobe.DoubleLobe` of a ``doublelobe`` BSDF,
        or None for point targets, absorbers (nothing comes back) and any other BSDF.
    """
    out = []
    for index, shape in enumerate(_canonical_shapes(scene)):
        bsdf = shape.bsdf()
        material = bsdf.material if _kind(bsdf) == "doublelobe" else None
        if material is not None and material.is_absorber:
            material = None
        out.append(SceneSurface(index=index, id=shape.id(), kind=shape.class_name(),
                                shape=shape, material=material,
                                area=float(shape.surface_area()[0])))
    return out


def scene_point_targets(scene: Any) -> list[ScenePointTarget]:
    """The point targets of a scene: shapes whose BSDF is ``pointtarget``.

    Parameters
    ----------
    scene : mitsuba.Scene

    Returns
    -------
    list of ScenePointTarget
        In canonical shape order; position = centre of the shape's bounding box.
    """
    out = []
    for shape in _canonical_shapes(scene):
        bsdf = shape.bsdf()
        if _kind(bsdf) != "pointtarget":
            continue
        box = shape.bbox()
        centre = 0.5 * (np.array([float(v) for v in box.min])
                        + np.array([float(v) for v in box.max]))
        out.append(ScenePointTarget(position=centre, rcs=float(bsdf.rcs),
                                    velocity=np.array(bsdf.velocity, dtype=np.float64),
                                    shape_id=shape.id()))
    return out


@dataclass(frozen=True)
class SurfaceScatterers:
    """A fixed set of surface scatterers (DESIGN §5.4, mechanism 1).

    Attributes
    ----------
    positions : numpy.ndarray
        Shape (N, 3) [m].
    normals : numpy.ndarray
        Unit surface normals at the scatterers as the shapes define them, shape (N, 3).
    area : numpy.ndarray
        Area each scatterer stands for, shape (N,) [m²]; its RCS is ``σ⁰ · area``.
    shape_index : numpy.ndarray
        Index into :func:`scene_surfaces` (and ``surface_ids``), shape (N,), int32.
    phase : numpy.ndarray
        Fixed speckle phase in [0, 2π), shape (N,) [rad].
    surface_ids : tuple of str
        XML id of every shape in canonical order.
    materials : tuple
        The DoubleLobe (or None) of every shape in canonical order.
    density_per_m2 : float
        Requested density [1/m²].
    seed : int
        Seed of the draw.
    """

    positions: np.ndarray
    normals: np.ndarray
    area: np.ndarray
    shape_index: np.ndarray
    phase: np.ndarray
    surface_ids: tuple[str, ...]
    materials: tuple[DoubleLobe | None, ...]
    density_per_m2: float
    seed: int

    def __len__(self) -> int:
        return int(self.positions.shape[0])


def _parametric_aspect(shape: Any) -> float:
    """``|dp/du| / |dp/dv|`` of ``shape.sample_position`` at the centre (1 for meshes)."""
    import mitsuba as mi

    if shape.shape_type() == int(mi.ShapeType.Mesh):
        return 1.0
    eps = 1e-3
    u = mi.Point2f([0.5 - eps, 0.5 + eps, 0.5, 0.5], [0.5, 0.5, 0.5 - eps, 0.5 + eps])
    p = np.array(shape.sample_position(0.0, u).p, dtype=np.float64)  # (3, 4)
    du = np.linalg.norm(p[:, 1] - p[:, 0])
    dv = np.linalg.norm(p[:, 3] - p[:, 2])
    if not (du > 0.0 and dv > 0.0) or not math.isfinite(du / dv):
        return 1.0
    return float(du / dv)


def _stratified_unit_square(n: int, aspect: float, rng: np.random.Generator) -> np.ndarray:
    """``n`` jittered-grid samples in [0,1)², the grid shaped to ``aspect`` (shape (2, n))."""
    nx = int(min(n, max(1, round(math.sqrt(n * aspect)))))
    ny = math.ceil(n / nx)
    cells = rng.choice(nx * ny, size=n, replace=False) if nx * ny > n else np.arange(n)
    cells = np.sort(cells)
    ix, iy = cells % nx, cells // nx
    jitter = rng.random((2, n))
    return np.stack([(ix + jitter[0]) / nx, (iy + jitter[1]) / ny])


def sample_surface_scatterers(scene: Any, density_per_m2: float,
                              seed: int = 0) -> SurfaceScatterers:
    """Sample a fixed set of scatterers on every radar surface of a scene (DESIGN §5.4).

    Each shape with a radar material (:func:`scene_surfaces`) gets ``round(density · area)``
    scatterers from ``shape.sample_position`` fed with a jittered grid over its parameter domain
    (area-uniform for rectangles, disks, spheres and meshes; the grid's aspect ratio follows the
    parametrisation, so a 30 m × 6 m wall gets a 5:1 grid). Each scatterer stands for
    ``area / count`` of its shape and has a uniform random speckle phase, fixed by ``seed``.

    Parameters
    ----------
    scene : mitsuba.Scene
    density_per_m2 : float
        Scatterers per m² (> 0). The paper uses at least 9 per resolution cell, e.g. 9/(0.1 m)² =
        900 per m².
    seed : int
        Seed (>= 0); the same seed gives the same scatterers.

    Returns
    -------
    SurfaceScatterers
    """
    import mitsuba as mi

    density = float(density_per_m2)
    if not (math.isfinite(density) and density > 0.0):
        raise ParameterError("sample_surface_scatterers", "density_per_m2",
                             "a finite density > 0 per m²", density_per_m2)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError("sample_surface_scatterers", "seed", "an integer >= 0", seed)
    surfaces = scene_surfaces(scene)
    pos, nrm, area, index, phase = [], [], [], [], []
    for surface in surfaces:
        if surface.material is None or surface.area <= 0.0:
            continue
        count = int(round(density * surface.area))
        if count == 0:
            continue
        rng = np.random.default_rng([int(seed), surface.index])
        uv = _stratified_unit_square(count, _parametric_aspect(surface.shape), rng)
        ps = surface.shape.sample_position(0.0, mi.Point2f(uv[0], uv[1]))
        p = np.array(ps.p, dtype=np.float64).T
        n = np.array(ps.n, dtype=np.float64).T  # width 1 for planar shapes
        n = np.broadcast_to(n / np.linalg.norm(n, axis=1, keepdims=True), p.shape).copy()
        if _has_vertex_normals(surface.shape):
            n = _geometric_normals(scene, p, n)
        pos.append(p)
        nrm.append(n)
        area.append(np.full(count, surface.area / count))
        index.append(np.full(count, surface.index, dtype=np.int32))
        phase.append(rng.uniform(0.0, 2.0 * math.pi, count))

    def cat(parts: list[np.ndarray], shape: tuple[int, ...], dtype: Any = np.float64
            ) -> np.ndarray:
        return np.concatenate(parts) if parts else np.zeros(shape, dtype=dtype)

    return SurfaceScatterers(
        positions=cat(pos, (0, 3)), normals=cat(nrm, (0, 3)), area=cat(area, (0,)),
        shape_index=cat(index, (0,), np.int32), phase=cat(phase, (0,)),
        surface_ids=tuple(s.id for s in surfaces),
        materials=tuple(s.material for s in surfaces),
        density_per_m2=density, seed=int(seed))


def _has_vertex_normals(shape: Any) -> bool:
    """Whether a shape is a mesh whose sampled normals are interpolated vertex normals."""
    try:
        return bool(shape.is_mesh() and shape.has_vertex_normals())
    except AttributeError:  # pragma: no cover - older Mitsuba
        return False


def _geometric_normals(scene: Any, positions: np.ndarray, shading: np.ndarray) -> np.ndarray:
    """Face normals at sampled mesh points, oriented like the interpolated ``shading`` normals.

    A mesh loaded without ``face_normals`` samples smoothed vertex normals (tens of degrees off
    on a box), which would read sigma0 at the wrong incidence; a short ray cast back onto each
    point returns the geometric normal of the triangle it lies on.
    """
    import mitsuba as mi

    offset = 1e-4
    origins = positions + offset * shading
    rays = mi.Ray3f(mi.Point3f(*origins.T.astype(np.float32)),
                    mi.Vector3f(*(-shading).T.astype(np.float32)))
    hit = scene.ray_intersect(rays)
    valid = np.array(hit.is_valid(), dtype=bool)
    normals = np.array(hit.n, dtype=np.float64).T
    normals = np.where(valid[:, None], normals, shading)
    normals /= np.linalg.norm(normals, axis=1, keepdims=True)
    flip = np.einsum("ij,ij->i", normals, shading) < 0
    normals[flip] *= -1.0
    return normals


# --------------------------------------------------------------------------------------------
# PLY meshes
# --------------------------------------------------------------------------------------------


def box_mesh(lo: Any, hi: Any, inward: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box as 8 vertices and 12 triangles.

    Parameters
    ----------
    lo, hi : array_like, shape (3,)
        Opposite corners [m].
    inward : bool
        Wind the triangles so that the normals point into the box (a room) instead of out.

    Returns
    -------
    vertices : numpy.ndarray, shape (8, 3)
    faces : numpy.ndarray, shape (12, 3), int32
        Counter-clockwise seen from the side the normal points to.
    """
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(hi > lo):
        raise ParameterError("box_mesh", "lo/hi", "two corners with hi > lo on every axis",
                             (lo.tolist(), hi.tolist()))
    corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    vertices = lo + corners * (hi - lo)
    # Outward-facing quads (vertex index = x + 2y + 4z), counter-clockwise from outside.
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    faces = []
    for a, b, c, d in quads:
        tris = [(a, b, c), (a, c, d)]
        faces += [(t[0], t[2], t[1]) for t in tris] if inward else tris
    return vertices, np.array(faces, dtype=np.int32)


def write_ply(path: str | os.PathLike, vertices: Any, faces: Any, normals: Any = None,
              binary: bool = True) -> Path:
    """Write a triangle mesh as PLY (binary little-endian or ASCII) that Mitsuba reads.

    Parameters
    ----------
    path : path-like
        Output file (parent directories are created).
    vertices : array_like, shape (n, 3)
        Vertex positions [m] (stored as float32).
    faces : array_like, shape (m, 3)
        Vertex indices, counter-clockwise seen from the side the normal points to.
    normals : array_like, shape (n, 3), optional
        Vertex normals. Without them, set ``<boolean name="face_normals" value="true"/>`` in the
        XML for flat faces (otherwise Mitsuba smooths normals across edges).
    binary : bool
        Binary little-endian (default) or ASCII.

    Returns
    -------
    pathlib.Path
    """
    v = np.asarray(vertices, dtype=np.float32)
    f = np.asarray(faces, dtype=np.int32)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ParameterError("write_ply", "vertices/faces", "arrays of shape (n, 3) and (m, 3)",
                             (v.shape, f.shape))
    if f.size and (f.min() < 0 or f.max() >= v.shape[0]):
        raise ParameterError("write_ply", "faces", f"indices in [0, {v.shape[0]})",
                             (int(f.min()), int(f.max())))
    columns = [v]
    props = ["x", "y", "z"]
    if normals is not None:
        nrm = np.asarray(normals, dtype=np.float32)
        if nrm.shape != v.shape:
            raise ParameterError("write_ply", "normals", f"shape {v.shape}", nrm.shape)
        columns.append(nrm)
        props += ["nx", "ny", "nz"]
    data = np.concatenate(columns, axis=1)
    header = ["ply", "format " + ("binary_little_endian" if binary else "ascii") + " 1.0",
              "comment written by mitsar.scene.write_ply", f"element vertex {v.shape[0]}"]
    header += [f"property float {p}" for p in props]
    header += [f"element face {f.shape[0]}", "property list uchar int vertex_indices",
               "end_header"]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as out:
        out.write(("\n".join(header) + "\n").encode("ascii"))
        if binary:
            out.write(data.astype("<f4").tobytes())
            face_dtype = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
            rec = np.empty(f.shape[0], dtype=face_dtype)
            rec["n"] = 3
            rec["i"] = f
            out.write(rec.tobytes())
        else:
            for row in data:
                out.write((" ".join(f"{x:.9g}" for x in row) + "\n").encode("ascii"))
            for tri in f:
                out.write(f"3 {tri[0]} {tri[1]} {tri[2]}\n".encode("ascii"))
    return path
