"""The XML parameters of mitsar's Mitsuba plugins as Markdown tables, generated from the code.

Each table lists a plugin's accepted parameters (the ``PARAMETERS`` the plugin reads, in its
order), with the type, default and meaning taken from the code that owns them:

- ``radar`` integrator: :data:`mitsar.plugins.integrators.radar.config.PARAMETERS`, described by
  the ``Attributes`` of :class:`mitsar.TraceOptions`, defaults from
  :data:`mitsar.model.trace_options.DEFAULTS`;
- ``doublelobe`` BSDF: the ``Parameters`` of :class:`mitsar.model.doublelobe.DoubleLobe` and its
  field defaults; ``preset`` from :data:`~mitsar.model.doublelobe.material.PRESETS`;
- ``pointtarget`` BSDF: the XML example of the plugin's module docstring (its comments);
- ``itu-radio-material`` / ``radio-material``: the ``Parameters`` and defaults of
  :func:`mitsar.model.doublelobe.radio_material_from_sionna`.

A parameter without a description raises :class:`LookupError`, so a new parameter that nobody
documented fails the documentation build (``make docs``) instead of leaving a hole.

Usage: ``python scripts/plugin_tables.py [radar|doublelobe|pointtarget|radio-material]`` prints
the tables (all by default). The documentation site includes them through
``scripts/docs_hooks.py`` (placeholders ``<!-- mitsar:plugin-table NAME -->`` in
``docs/plugins.md``).
"""

from __future__ import annotations

import dataclasses
import inspect
import math
import re
import sys
from collections.abc import Callable

TABLE_HEADER = "| parameter | type | default | description |\n|---|---|---|---|"


def numpydoc_entries(doc: str, section: str) -> dict[str, tuple[str, str]]:
    """``{name: (type, description)}`` of a numpydoc section (``Parameters``, ``Attributes``).

    An entry ``a, b : float`` gives both names the same type and description.
    """
    lines = inspect.cleandoc(doc).splitlines()
    try:
        start = next(i for i, line in enumerate(lines[:-1])
                     if line.strip() == section and set(lines[i + 1].strip()) == {"-"})
    except StopIteration:
        return {}
    entries: dict[str, tuple[str, str]] = {}
    current: list[str] | None = None
    description: list[str] = []
    kind = ""

    def flush() -> None:
        if current:
            for name in current:
                entries[name] = (kind, " ".join(description).strip())

    for line in lines[start + 2:]:
        if not line.strip():
            continue
        if not line.startswith(" "):
            if set(line.strip()) == {"-"}:  # the next section's underline: stop
                current = None
                break
            flush()
            if line.strip() in ("Raises", "Returns", "Yields", "Notes", "Examples",
                                "See Also", "Methods", "References", "Warns"):
                current = None
                break
            names, _, kind = line.partition(" : ")
            current = [n.strip().lstrip("*") for n in names.split(",")]
            description = []
        else:
            description.append(line.strip())
    flush()
    return entries


def _code(value: object) -> str:
    """A default as it reads in the table."""
    if value is None:
        return "—"
    if isinstance(value, bool):
        return f"`{str(value).lower()}`"
    if isinstance(value, float) and math.isinf(value):
        return "`inf`"
    if isinstance(value, float) and value >= 1e6:
        return f"`{value:g}`".replace("e+", "e")
    if isinstance(value, int) and value >= 2**16 and value & (value - 1) == 0:
        return f"`{value}` (2^{value.bit_length() - 1})"
    return f"`{value}`"


def _escape(text: str) -> str:
    """Table-safe text: no pipes, Sphinx roles reduced to code."""
    text = re.sub(r":(?:class|func|data|attr|meth|mod):`~?([^`]+)`", r"`\1`", text)
    return text.replace("|", "\\|")


def _row(name: str, kind: str, default: object, description: str) -> str:
    if not description:
        raise LookupError(f"plugin parameter {name!r} has no description in the code")
    return (f"| `{name}` | {_escape(kind)} | {default if isinstance(default, str) else ''}"
            f" | {_escape(description)} |")


def radar_table() -> str:
    """The ``radar`` integrator's XML parameters."""
    from mitsar.model.trace_options import DEFAULTS, TraceOptions
    from mitsar.plugins.integrators.radar.config import PARAMETERS

    entries = numpydoc_entries(TraceOptions.__doc__ or "", "Attributes")
    rows = []
    for name in PARAMETERS:
        kind, description = entries.get(name, ("", ""))
        rows.append(_row(name, kind, _code(getattr(DEFAULTS, name)), description))
    return "\n".join([TABLE_HEADER, *rows])


def doublelobe_table() -> str:
    """The ``doublelobe`` BSDF's XML parameters."""
    from mitsar.model.doublelobe import DoubleLobe
    from mitsar.model.doublelobe.material import PRESETS
    from mitsar.plugins.bsdfs.doublelobe import PARAMETERS

    entries = numpydoc_entries(DoubleLobe.__doc__ or "", "Parameters")
    entries["preset"] = ("string", "Base values from a named preset, one of "
                         + ", ".join(f"`{p}`" for p in PRESETS)
                         + "; parameters given beside it override the preset's.")
    defaults = {f.name: f.default for f in dataclasses.fields(DoubleLobe)}
    rows = []
    for name in PARAMETERS:
        kind, description = entries.get(name, ("", ""))
        default = _code(defaults[name]) if name in defaults else "—"
        if name == "sigma0_db":
            default = "`none` (the lobe model)"
        rows.append(_row(name, kind, default, description))
    return "\n".join([TABLE_HEADER, *rows])


def pointtarget_table() -> str:
    """The ``pointtarget`` BSDF's XML parameters (from the XML example of its docstring)."""
    from mitsar.plugins.bsdfs import pointtarget

    doc = pointtarget.__doc__ or ""
    rows = []
    for name in pointtarget.PARAMETERS:
        match = re.search(rf'<(\w+)\s+name="{name}"\s+value="([^"]*)"\s*/>\s*<!--(.*?)-->', doc)
        if match is None:
            raise LookupError(f"pointtarget parameter {name!r} is not in the XML example of "
                              "mitsar/plugins/bsdfs/pointtarget.py's docstring")
        kind, example, comment = match.groups()
        required = "(required)" in comment or name == "rcs"
        description = comment.strip().replace(", optional", "")
        if name == "velocity":
            description += '; also `<vector name="velocity" x=".." y=".." z=".."/>`'
        rows.append(_row(name, kind, "required" if required else f"`{example}`",
                         description))
    return "\n".join([TABLE_HEADER, *rows])


def radio_material_table(plugin: str) -> str:
    """The XML parameters of ``itu-radio-material`` or ``radio-material``."""
    from mitsar.model.doublelobe import radio_material_from_sionna
    from mitsar.plugins.bsdfs import radio_material

    entries = numpydoc_entries(radio_material_from_sionna.__doc__ or "", "Parameters")
    entries["type"] = entries["itu_type"]
    for name in radio_material._DISPLAY:
        entries[name] = ("colour", "Display only (Sionna RT's viewer); accepted and ignored.")
    signature = inspect.signature(radio_material_from_sionna).parameters
    rows = []
    for name in radio_material.PARAMETERS[plugin]:
        kind, description = entries.get(name, ("", ""))
        key = "itu_type" if name == "type" else name
        default = signature[key].default if key in signature else None
        if plugin == radio_material.ITU_PLUGIN_NAME and name == "type":
            shown = "required"
        elif name in ("relative_permittivity", "conductivity"):
            shown = "`1`" if name == "relative_permittivity" else "`0`"
        else:
            shown = _code(default)
        rows.append(_row(name, kind, shown, description))
    return "\n".join([TABLE_HEADER, *rows])


TABLES: dict[str, Callable[[], str]] = {
    "radar": radar_table,
    "doublelobe": doublelobe_table,
    "pointtarget": pointtarget_table,
    "itu-radio-material": lambda: radio_material_table("itu-radio-material"),
    "radio-material": lambda: radio_material_table("radio-material"),
}
"""Every table, by plugin name."""


def main(argv: list[str]) -> int:
    names = argv or list(TABLES)
    for name in names:
        if name not in TABLES:
            print(f"unknown plugin {name!r}; one of {list(TABLES)}", file=sys.stderr)
            return 2
        print(f"## `{name}`\n\n{TABLES[name]()}\n")
    return 0


if __name__ == "__main__":
    raise SystemExit(main(sys.argv[1:]))
