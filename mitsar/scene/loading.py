"""Loading Mitsuba XML scenes with errors that name the file, the element and the parameter.

:func:`load_scene` registers mitsar's plugins, resolves the names of the bundled scenes
(``scenes/``, :mod:`mitsar.scene.canned`), checks that referenced mesh files exist, and translates
Mitsuba's loader exceptions (one ``RuntimeError`` for everything) into
:class:`~mitsar.errors.MissingFileError`, :class:`~mitsar.errors.ParameterError` or
:class:`~mitsar.errors.SceneError`, located by the XML line and column Mitsuba reports.
"""

from __future__ import annotations

import os
import re
import xml.parsers.expat
from dataclasses import dataclass
from pathlib import Path
from typing import Any

from mitsar.errors import MissingFileError, ParameterError, SceneError
from mitsar.plugins.variant import register_plugins
from mitsar.scene import canned
from mitsar.scene.motion import MOTION_PROPERTIES, ShapeMotion, register_scene_motion

__all__ = ["load_scene"]


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
        An XML file, the name of a bundled scene (``scenes/*.xml``;
        ``mitsar.scene.canned.names()``, e.g. ``"dihedral"``, ``"sionna_room"``), or an
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
    import mitsuba as mi  # lazy: importing Mitsuba loads its native libraries

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
        if path.suffix == "" and str(path_or_scene) in canned.names():
            path = canned.path(str(path_or_scene))
        else:
            raise MissingFileError(
                f"load_scene: scene file {str(path_or_scene)!r} not found (give an XML file or "
                f"one of the bundled scenes {canned.names()})")
    path = path.resolve()
    str_params = {key: str(value) for key, value in params.items()}
    elements = _scan_xml(path)
    _check_referenced_files(path, elements, str_params)
    motion, text = _shape_motion(path, elements, str_params)
    try:
        if not motion:
            return mi.load_file(str(path), optimize=False, **str_params)
        # The shapes' velocity properties are mitsar's (mitsar.scene.motion): blanked out (same
        # lines and columns, so errors still point into the file) and loaded from the text,
        # with the scene's folder first on the file resolver for its meshes.
        resolver = mi.file_resolver()
        saved = [str(resolver[i]) for i in range(len(resolver))]
        resolver.prepend(str(path.parent))
        try:  # parameters used only by the blanked velocities are not passed on
            scene = mi.load_string(text, optimize=False, **{
                key: value for key, value in str_params.items() if f"${key}" in text})
        finally:
            resolver.clear()
            for folder in saved:
                resolver.append(folder)
        register_scene_motion(scene, motion)
        return scene
    except Exception as error:  # noqa: BLE001 - Mitsuba raises RuntimeError for everything
        raise _translate_error(error, path, elements, str_params) from error


def _shape_motion(path: Path, elements: list[_Element], params: dict[str, str]
                  ) -> tuple[dict[str, Any], str]:
    """Motions given as properties of ``<shape>`` elements, and the XML text without them.

    ``<vector name="velocity" x=".." y=".." z=".."/>`` or ``<string name="velocity"
    value="vx, vy, vz"/>`` [m/s] directly inside a shape with an ``id``; likewise
    ``angular_velocity_deg`` [deg/s] and ``rotation_centre`` [m] (:mod:`mitsar.scene.motion`).
    """
    motion: dict[str, Any] = {}
    properties: dict[str, dict[str, tuple[float, ...]]] = {}
    found = [(i, el) for i, el in enumerate(elements)
             if el.parent is not None and elements[el.parent].tag == "shape"
             and el.attrs.get("name") in MOTION_PROPERTIES]
    if not found:
        return motion, ""
    lines = path.read_text(encoding="utf-8").splitlines(keepends=True)
    params = {**{el.attrs["name"]: el.attrs.get("value", "") for el in elements
                 if el.tag == "default" and "name" in el.attrs}, **params}
    for index, el in found:
        where = f"{path.name}: {_describe(elements, index)}"
        shape = elements[el.parent]  # type: ignore[index]
        if not shape.attrs.get("id"):
            raise ParameterError(where, el.attrs["name"], "a shape with an id (moving shapes are "
                                 "named)", "a shape without id")
        if el.tag == "vector":
            value: object = [_substitute(el.attrs.get(a, "0"), params) for a in "xyz"]
        elif el.tag == "string":
            value = _substitute(el.attrs.get("value", ""), params).replace(",", " ").split()
        else:
            raise ParameterError(where, el.attrs["name"], "<vector x= y= z=/> or <string "
                                 "value=\"vx, vy, vz\"/>", f"<{el.tag}>")
        try:
            velocity = tuple(float(v) for v in value)  # type: ignore[union-attr]
        except ValueError:
            velocity = ()
        if len(velocity) != 3 or not all(abs(v) < float("inf") for v in velocity):
            raise ParameterError(where, el.attrs["name"], "three finite numbers", value)
        properties.setdefault(shape.attrs["id"], {})[el.attrs["name"]] = velocity
        line = lines[el.line - 1]
        start = el.column - 1
        end = line.find("/>", start)
        if end < 0:
            raise ParameterError(where, el.attrs["name"], "a self-closing element on one line "
                                 "(<vector .../>)", line.strip())
        lines[el.line - 1] = line[:start] + " " * (end + 2 - start) + line[end + 2:]
    for shape_id, found_here in properties.items():
        velocity = found_here.get("velocity", (0.0, 0.0, 0.0))
        if set(found_here) == {"velocity"}:
            motion[shape_id] = velocity
        else:
            motion[shape_id] = ShapeMotion(velocity, found_here.get("angular_velocity_deg",
                                                                    (0.0, 0.0, 0.0)),
                                           found_here.get("rotation_centre"))
    return motion, "".join(lines)
