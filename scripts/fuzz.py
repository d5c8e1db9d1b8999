"""Fuzz campaign of mitsar's input checking (docs/reliability.md §4; issue #15).

A seeded generator of bad (and some good) inputs over seven families:

``simulate``, ``rays``, ``ambiguity``, ``montecarlo``
    Mutated TOML experiments, starting from small copies of the bundled examples, run through
    the command line (in-process, ``--debug`` so that a foreign exception surfaces as such).
``xml``
    Mutated Mitsuba scenes from ``scenes/`` (material parameters, malformed XML,
    unknown plugins and parameters, missing meshes, scenes that see nothing).
``api``
    Bad Python arguments to the public API (``mitsar.Radar``, ``Trajectory``, ``Look``,
    ``PointTarget``, ``Background``, ``simulate_point_targets``, ``focus``,
    ``measure_impulse_response``, ``range_compress``, ``load``, ``save``).
``cli``
    Command-line misuse (unknown commands, missing or bad options, files that are not what
    they should be, outputs that exist or cannot be written).

Every case is marked *invalid by construction* or *valid*, with the names (tokens) a clean
refusal must mention, and classified as:

CLEAN      invalid, refused by a mitsar error (or a loud mitsar warning) naming a token
VAGUE      invalid, refused by a mitsar error that names none of the tokens
TRACEBACK  a foreign exception (NumPy, Python, Mitsuba ...) escaped
SILENT     invalid, but accepted without an error or a mitsar warning
HANG       still running after the per-case timeout
CRASH      the worker process died
DEBRIS     refused, but the command left its output (or a temporary file) behind
OK         valid and accepted
REFUSED    valid, but refused (a false alarm)

Cases run in a worker process (``--worker``), one after the other, in-process for speed; the
parent restarts a worker that died or hung, classifying that case CRASH or HANG. The worker's
memory budget is ``MITSAR_MEMORY_LIMIT`` (2 GiB by default here) so that nothing large is
allocated on a shared machine.

Usage::

    python scripts/fuzz.py                  # the full campaign: 1,100 cases, the table
    python scripts/fuzz.py --cases 250 --fast --seed 7
"""

from __future__ import annotations

import argparse
import contextlib
import copy
import io
import json
import math
import os
import random
import select
import shutil
import signal
import subprocess
import sys
import tempfile
import time
import tomllib
import warnings
from collections import Counter
from collections.abc import Callable
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

REPO = Path(__file__).resolve().parent.parent
EXAMPLES = REPO / "examples"
CANNED = REPO / "scenes"
VERDICTS = ("CLEAN", "VAGUE", "TRACEBACK", "SILENT", "HANG", "CRASH", "DEBRIS", "OK", "REFUSED")
FAILURES = ("TRACEBACK", "SILENT", "HANG", "CRASH", "DEBRIS", "REFUSED")
"""Verdicts a campaign must not have (VAGUE is reported, below 1% of the cases)."""
FAMILIES = ("simulate", "rays", "ambiguity", "montecarlo", "xml", "api", "cli")
TIMEOUT = 120.0
"""Per-case timeout [s] (the slowest valid case, a one-realisation Monte Carlo, takes ~10 s)."""
WORKER_MEMORY = "2G"
"""The workers' memory budget (``MITSAR_MEMORY_LIMIT``)."""


@dataclass
class Case:
    """One fuzz input: what to run and how to judge the outcome."""

    family: str
    name: str
    invalid: bool
    tokens: tuple[str, ...]
    action: Callable[[Path], Any]
    outputs: tuple[str, ...] = ()
    """Paths (relative to the case folder) a refused command must not leave behind."""
    compute: bool = False
    """True when the case is expected to get past the checks (simulation, focusing ...)."""
    timeout: float = TIMEOUT


@dataclass
class Outcome:
    kind: str  # "ok", "mitsar", "warning", "foreign", "timeout"
    message: str = ""
    seconds: float = 0.0
    debris: list[str] = field(default_factory=list)


# --- TOML writing (no third-party writer needed) ----------------------------------------------

def _toml_value(value: Any) -> str:
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, int):
        return str(value)
    if isinstance(value, float):
        if math.isnan(value):
            return "nan"
        if math.isinf(value):
            return "inf" if value > 0 else "-inf"
        return repr(value)
    if isinstance(value, str):
        return json.dumps(value)
    if isinstance(value, list):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    if isinstance(value, dict):
        items = ", ".join(f"{json.dumps(k)} = {_toml_value(v)}" for k, v in value.items())
        return "{" + items + "}"
    raise TypeError(type(value))


def dumps_toml(document: dict, prefix: str = "") -> str:
    """A TOML text of ``document`` (tables, arrays of tables, scalars, arrays)."""
    lines, tables = [], []
    for key, value in document.items():
        name = json.dumps(key) if not key.replace("_", "").isalnum() else key
        if isinstance(value, dict):
            tables.append((name, value, False))
        elif isinstance(value, list) and value and all(isinstance(v, dict) for v in value):
            tables.append((name, value, True))
        else:
            lines.append(f"{name} = {_toml_value(value)}")
    out = "\n".join(lines) + ("\n" if lines else "")
    for name, value, array in tables:
        path = f"{prefix}{name}"
        for entry in (value if array else [value]):
            out += f"\n[[{path}]]\n" if array else f"\n[{path}]\n"
            out += dumps_toml(entry, path + ".")
    return out


# --- base experiments (small copies of the examples, so that valid cases run in seconds) ------

def _read(name: str) -> dict:
    return tomllib.loads((EXAMPLES / name).read_text())


def base_documents() -> dict[str, dict]:
    """The documents each TOML family mutates."""
    point = _read("paper_point_target.toml")
    point["trajectory"].update(start=[14.8, 1.4, 4.5], duration=1.2)
    point["background"]["size"] = [0.6, 0.6]
    point["focus"]["grid"].update(along_track=[-0.4, 0.8, 0.02], slant_range=[7.3, 8.7, 0.02])
    rays = _read("case1_2d.toml")
    rays["trajectory"]["duration"] = 0.02
    rays["simulation"]["rays"] = 50
    ambiguity = _read("ambiguity_control_volume.toml")
    ambiguity["trajectories"] = {"paper_pass": dict(ambiguity["trajectories"]["paper_pass"],
                                                    duration=4.0)}
    ambiguity["ambiguity"].update(spacing=1.0, max_states=10)
    ambiguity["surfaces"] = ambiguity["surfaces"][:2]
    return {"simulate": point, "montecarlo": copy.deepcopy(point), "rays": rays,
            "ambiguity": ambiguity}


REQUIRED = {"trajectory", "look", "trajectory.start", "trajectory.velocity",
            "trajectory.duration", "look.off_nadir_deg", "targets.position", "background.center",
            "background.size", "trajectories", "surfaces", "surfaces.origin", "surfaces.axis_u",
            "surfaces.axis_v", "surfaces.size", "trajectories.paper_pass.start",
            "trajectories.paper_pass.velocity", "trajectories.paper_pass.duration",
            "focus.grid.along_track", "focus.grid.slant_range",
            "trajectories.paper_pass", "scene"}
"""Keys whose removal is invalid (the others have defaults)."""

STRICTLY_POSITIVE = {"carrier_frequency", "bandwidth", "sampling_frequency", "prf", "max_range",
                     "antenna_width", "antenna_length", "transmit_power", "duration", "speed",
                     "rcs", "size", "scatterers_per_cell", "spacing", "max_states", "rays",
                     "max_depth", "ray_cover", "slab_width", "scatterer_density",
                     "azimuth_resolution", "required_resolution", "along_track", "slant_range"}
"""Keys (last component) whose value must be > 0 (every entry, for arrays)."""

NEGATIVE_OK = {"start", "velocity", "position", "center", "origin", "axis_u", "axis_v",
               "target", "squint_deg", "cell_rcs_db", "beam_threshold_db", "plane_normal"}
"""Keys where -1 (or a negative entry) is a valid value."""

SCALAR_OK = {"required_resolution"}
"""Array keys that also take one number (the same in range and azimuth)."""
HUGE_OK: set[str] = set()
"""Keys where 1e300 is valid: none since issue 27 (a 2-D slab or a point spacing of 1e300 m
used to pass; every length [m] is now bounded at 10 km, mitsar.checks.MAX_LENGTH)."""
FREE_TEXT = {"name", "description"}
NUMBER_OK = {"islr_extent", "integration_time"}
"""String keys that also take a number > 0 (a number of cells, a time in seconds)."""
MEASURED = {"montecarlo": {"islr_extent"}}
"""Keys that, in a family that uses them, make ``42`` too large for the base image (refused,
naming the key: an ISLR extent of 42 cells needs a grid 42 cells beyond the target)."""
INTEGER_KEYS = {"seed", "scatterers_per_cell", "max_states", "rays", "max_depth"}

MEMORY_CASES = {
    "simulate": [("background.size", [1e4, 1e4]), ("radar.sampling_frequency", 1e15),
                 ("trajectory.duration", 1e4), ("focus.grid.along_track", [-1e3, 1e3, 1e-6]),
                 ("background.scatterers_per_cell", 10**12), ("focus.grid.slant_range",
                                                              [0.0, 30.0, 1e-9])],
    "montecarlo": [("background.size", [1e4, 1e4]), ("trajectory.duration", 1e4),
                   ("focus.grid.slant_range", [0.0, 30.0, 1e-9])],
    "rays": [("simulation.scatterer_density", 1e12), ("trajectory.duration", 1e4)],
    "ambiguity": [("ambiguity.spacing", 1e-6), ("ambiguity.max_states", 10**18),
                  ("trajectories.paper_pass.duration", 1e12)],
}
"""Requests too large for any machine (issue #15): refused before any work, key named."""


LOAD_CASES = {
    "simulate": [("metrics.target", [1e300, 8.0, 0.0]), ("simulation.slab_width", 1e300),
                 ("simulation.max_depth", 100), ("simulation.orders", [1e300]),
                 ("simulation.rays", 10**15), ("metrics.islr_extent", 1e300),
                 ("trajectory.errors.position_noise", [1e300, 0.0, 0.0]),
                 ("radar.noise_figure_db", 1e300), ("background.cell_rcs_db", -1e300),
                 ("trajectory.velocity", [1e300, 0.0, 0.0])],
    "montecarlo": [("simulation.slab_width", 1e300), ("metrics.islr_extent", 1e300)],
    "rays": [("simulation.slab_width", 1e300), ("simulation.ray_cover", 1e300),
             ("simulation.plane_normal", [1e300, 0.0, 0.0]), ("metrics.target", [1e300, 8, 0]),
             ("simulation.scatterer_density", 1e300), ("trajectory.duration", 1e300)],
    "ambiguity": [("ambiguity.integration_time", 1e300), ("required_resolution", [1e300, 0.1]),
                  ("surfaces[1].name", "__same__"), ("surfaces[0].axis_u", [1e300, 0.0, 0.0]),
                  ("trajectories.paper_pass.velocity", [1e300, 0.0, 0.0])],
}
"""Issue 27 item 2: every section validated at load whatever the command, keys the command
does not use included (``[metrics] target`` for ``simulate`` and ``rays``, a 1e300 slab for
``simulate``); ``__same__`` gives the surface the name of ``surfaces[0]`` (two surfaces of one
name)."""


def _leaves(document: Any, prefix: str = "") -> list[tuple[str, Any]]:
    """(dotted path, value) of every scalar or array leaf; arrays of tables by index."""
    out = []
    if isinstance(document, dict):
        for key, value in document.items():
            path = f"{prefix}{key}"
            if isinstance(value, dict) or (isinstance(value, list) and value
                                           and all(isinstance(v, dict) for v in value)):
                out.extend(_leaves(value, path + "."))
            else:
                out.append((path, value))
    elif isinstance(document, list):
        for index, value in enumerate(document):
            out.extend(_leaves(value, f"{prefix[:-1]}[{index}]."))
    return out


def _parts(path: str) -> list[Any]:
    parts: list[Any] = []
    for piece in path.split("."):
        if "[" in piece:
            name, index = piece[:-1].split("[")
            parts += [name, int(index)]
        else:
            parts.append(piece)
    return parts


def _set(document: dict, path: str, value: Any, delete: bool = False) -> None:
    parts = _parts(path)
    node: Any = document
    for part in parts[:-1]:
        if isinstance(part, str) and part not in node:
            node[part] = {}
        node = node[part]
    if delete:
        del node[parts[-1]]
    else:
        node[parts[-1]] = value


def _generic(path: str) -> str:
    """The path without array indices, e.g. ``targets.position``."""
    return ".".join(p for p in _parts(path) if isinstance(p, str))


def _last(path: str) -> str:
    return [p for p in _parts(path) if isinstance(p, str)][-1]


def _mutations(path: str, value: Any, family: str = "simulate") -> list[tuple[str, Any, bool]]:
    """(label, new value or a marker, invalid?) for one leaf of a ``family`` document."""
    last = _last(path)
    number_ok = NUMBER_OK - MEASURED.get(family, set())
    out: list[tuple[str, Any, bool]] = []
    numeric = isinstance(value, int | float) and not isinstance(value, bool)
    vector = isinstance(value, list) and value and all(
        isinstance(v, int | float) and not isinstance(v, bool) for v in value)
    if isinstance(value, str):
        out.append(("number", 42.0, last not in number_ok))
        if last in FREE_TEXT:
            out.append(("text", "fuzz \u00e9 text", False))
        else:
            out += [("bogus", "bogus-choice", True), ("empty", "", True)]
        return out
    if isinstance(value, bool):
        return [("string", "yes", True), ("number", 1, True)]
    out += [("string", "abc", True), ("bool", True, True), ("table", {"x": 1}, True)]
    if numeric:
        out += [("nan", math.nan, True), ("inf", math.inf, True), ("-inf", -math.inf, True),
                ("huge", 1e300, last not in HUGE_OK), ("list", [1.0, 2.0], True)]
        if last in STRICTLY_POSITIVE:
            out += [("zero", 0, True), ("negative", -1.0, True)]
        if last in INTEGER_KEYS:
            out.append(("fraction", 1.5, True))
    if vector:
        out += [("short", value[:-1], True), ("long", value + [1.0], True),
                ("nan-entry", value[:-1] + [math.nan], True),
                ("inf-entry", [math.inf] + value[1:], True),
                ("scalar", 1.0, last not in SCALAR_OK),
                ("empty", [], True), ("strings", ["a"] * len(value), True)]
        if last in STRICTLY_POSITIVE and len(value) == 2:
            out.append(("negative-entry", [-1.0, value[1]], True))
    if isinstance(value, list) and value and all(isinstance(v, list) for v in value):
        out += [("ragged", value[:-1] + [value[-1][:2]], True), ("flat", value[0], True)]
    return out


def _toml_cases(family: str, document: dict, rng: random.Random, count: int,
                fast: bool) -> list[Case]:
    leaves = _leaves(document)
    cases = []
    for key, value in MEMORY_CASES[family]:
        cases.append(_toml_case(family, document, f"memory {key}", key, value, True,
                                (_last(key),)))
    for key, value in LOAD_CASES[family]:
        if value == "__same__":
            value = document["surfaces"][0].get("name", "surface0")
        cases.append(_toml_case(family, document, f"load {key}={value!r}"[:120], key, value,
                                True, (_last(key),)))
    for _ in range(count - len(cases)):
        op = rng.random()
        if op < 0.08:  # an unknown key
            tables = sorted({p.rsplit(".", 1)[0] for p, _ in leaves if "." in p} | {""})
            table = rng.choice(tables)
            key = (table + "." if table else "") + "bogus_key"
            cases.append(_toml_case(family, document, f"unknown {key}", key, 1, True,
                                    ("bogus_key",)))
            continue
        path, value = rng.choice(leaves)
        if op < 0.14:  # a removed key
            invalid = _generic(path) in REQUIRED
            if fast and not invalid:
                continue
            cases.append(_toml_case(family, document, f"remove {path}", path, None, invalid,
                                    (_last(path),), delete=True))
            continue
        label, new, invalid = rng.choice(_mutations(path, value, family))
        if fast and not invalid:
            continue
        cases.append(_toml_case(family, document, f"{label} {path}={new!r}"[:120], path, new,
                                invalid, (_last(path),)))
    return cases


def _toml_case(family: str, document: dict, name: str, path: str, value: Any, invalid: bool,
               tokens: tuple[str, ...], delete: bool = False) -> Case:
    mutated = copy.deepcopy(document)
    _set(mutated, path, value, delete=delete)
    text = dumps_toml(mutated)

    def action(folder: Path) -> Any:
        experiment = folder / "experiment.toml"
        experiment.write_text(text, encoding="utf-8")
        return _command(family, experiment, folder)

    outputs = {"simulate": ("raw.nc",), "rays": ("out",), "ambiguity": ("out",),
               "montecarlo": ()}[family]
    return Case(family, name, invalid, tokens, action, outputs, compute=not invalid)


def _command(family: str, experiment: Path, folder: Path) -> Any:
    if family == "simulate":
        return cli(["simulate", str(experiment), "-o", str(folder / "raw.nc")])
    if family == "rays":
        return cli(["rays", str(experiment), "-o", str(folder / "out"), "--rays", "20"])
    if family == "ambiguity":
        return cli(["ambiguity", str(experiment), "-o", str(folder / "out"), "--no-figures"])
    return cli(["montecarlo", str(experiment), "-n", "1", "-a", "bpa", "--cuts", "0", "-o",
                str(folder / "mc")])


class UsageError(Exception):
    """argparse refused the command line (exit status 2); the message is argparse's."""


def cli(argv: list[str]) -> int:
    """Run ``mitsar --debug -q ARGV`` in-process: mitsar errors and foreign exceptions
    propagate; argparse's refusals become :class:`UsageError`; a non-zero status without an
    exception becomes a :class:`~mitsar.errors.MitsarError`."""
    from mitsar.cli import main  # noqa: PLC0415 - the worker imports mitsar, the parent not
    from mitsar.errors import MitsarError  # noqa: PLC0415

    stderr = io.StringIO()
    with contextlib.redirect_stderr(stderr), contextlib.redirect_stdout(io.StringIO()):
        try:
            status = main(["--debug", "-q", *argv])
        except SystemExit as exit_:
            if exit_.code in (0, None):
                return 0
            lines = stderr.getvalue().strip().splitlines() or [f"exit status {exit_.code}"]
            raise UsageError(lines[-1]) from None  # argparse's "error:" line
    if status:
        raise MitsarError(f"exit status {status}: {stderr.getvalue().strip()}")
    return status


# --- XML scenes ---------------------------------------------------------------------------------

DOUBLELOBE_VALID = {
    "transmission_loss_db": lambda v: v <= 0,
    "reflection_reduction_db": lambda v: v <= 0,
    "sigma0_db": lambda v: v <= 100,
    "backscatter_fraction": lambda v: 0 <= v <= 1,
    "alpha_b": lambda v: 0 < v <= 20,
    "alpha_f": lambda v: 0 < v <= 20,
}
"""Validity of a doublelobe parameter value (docs/materials.md); NaN is never valid."""
XML_VALUES = (math.nan, math.inf, -math.inf, -1.0, 2.0, 1e300, -1e300, 0.5)

SCENE_SHELL = '<?xml version="1.0"?>\n<scene version="3.0.0">\n{body}\n</scene>\n'
FLOOR = ('<shape type="rectangle" id="floor"><transform name="to_world"><scale x="15" y="5"/>'
         '<translate x="15" y="5" z="0"/></transform>{bsdf}</shape>')


def _xml_cases(rng: random.Random, count: int, fast: bool) -> list[Case]:
    cases: list[Case] = []
    texts = {name: (CANNED / f"{name}.xml").read_text() for name in
             ("dihedral", "point_target", "cross_section_2d", "box_obstacle")}
    fixed = [
        ("empty scene", SCENE_SHELL.format(body=""), True, ("zeros", "beam", "nothing")),
        ("malformed", texts["dihedral"][: len(texts["dihedral"]) // 2], True, ("scene.xml",)),
        ("binary", "\x80\x81\x00garbage", True, ("scene.xml",)),
        ("unknown plugin", SCENE_SHELL.format(body=FLOOR.format(
            bsdf='<bsdf type="bogusbsdf"/>')), True, ("bogusbsdf",)),
        ("unknown parameter", SCENE_SHELL.format(body=FLOOR.format(
            bsdf='<bsdf type="doublelobe"><float name="bogus_param" value="1"/></bsdf>')),
         True, ("bogus_param",)),
        ("missing mesh", SCENE_SHELL.format(body='<shape type="ply"><string name="filename" '
                                            'value="missing_mesh.ply"/></shape>'),
         True, ("missing_mesh.ply",)),
        ("bad preset", SCENE_SHELL.format(body=FLOOR.format(
            bsdf='<bsdf type="doublelobe"><string name="preset" value="bogus_preset"/></bsdf>')),
         True, ("bogus_preset", "preset")),
        ("rendering integrator", SCENE_SHELL.format(body='<integrator type="path"/>' + FLOOR.format(
            bsdf='<bsdf type="doublelobe"/>')), True, ("integrator",)),
        ("absorbing floor only", SCENE_SHELL.format(body=FLOOR.format(
            bsdf='<bsdf type="doublelobe"><string name="preset" value="absorber"/></bsdf>')),
         True, ("zeros", "beam", "nothing")),
    ]
    for name, text, invalid, tokens in fixed:
        simulate = "zeros" in tokens or "integrator" in tokens  # said when traced
        cases.append(_xml_case(name, text, invalid, tokens, simulate))
    while len(cases) < count:
        op = rng.random()
        if op < 0.6:
            parameter = rng.choice(sorted(DOUBLELOBE_VALID))
            value = rng.choice(XML_VALUES)
            valid = not math.isnan(value) and DOUBLELOBE_VALID[parameter](value)
            if fast and valid:
                continue
            shown = {math.inf: "inf", -math.inf: "-inf"}.get(value, repr(value))
            bsdf = (f'<bsdf type="doublelobe"><float name="{parameter}" '
                    f'value="{shown}"/></bsdf>')
            cases.append(_xml_case(f"doublelobe {parameter}={shown}",
                                   SCENE_SHELL.format(body=FLOOR.format(bsdf=bsdf)),
                                   not valid, (parameter,)))
        elif op < 0.8:
            value = rng.choice((math.nan, math.inf, -1.0, 0.0, 1e300, "abc"))
            shown = {math.inf: "inf"}.get(value, str(value))
            text = texts["point_target"].replace('value="$rcs"', f'value="{shown}"')
            kind = "string" if isinstance(value, str) else "float"
            text = text.replace('<float name="rcs"', f'<{kind} name="rcs"')
            cases.append(_xml_case(f"pointtarget rcs={shown}", text, True, ("rcs",)))
        else:
            name = rng.choice(sorted(texts))
            text = texts[name]
            cut = rng.randrange(len(text) // 3, len(text) - 12)
            cases.append(_xml_case(f"truncated {name} at {cut}", text[:cut], True,
                                   ("scene.xml",)))
    return cases


def _xml_case(name: str, text: str, invalid: bool, tokens: tuple[str, ...],
              simulate: bool = False) -> Case:
    def action(folder: Path) -> Any:
        scene = folder / "scene.xml"
        scene.write_text(text, encoding="utf-8", errors="surrogateescape")
        if not simulate:
            from mitsar.scene import load_scene, sample_surface_scatterers  # noqa: PLC0415

            loaded = load_scene(str(scene))
            return sample_surface_scatterers(loaded, 4.0, 0)
        experiment = folder / "experiment.toml"
        experiment.write_text(dumps_toml({
            "scene": str(scene), "trajectory": {"start": [14.8, 1.4, 4.5],
                                                "velocity": [0.5, 0.0, 0.0],
                                                "duration": 0.02},
            "look": {"off_nadir_deg": 55.71}}))
        return cli(["simulate", str(experiment), "-o", str(folder / "raw.nc")])

    return Case("xml", name, invalid, tokens, action, ("raw.nc",), compute=not invalid)


# --- Python API -------------------------------------------------------------------------------

_PRODUCTS: dict[str, Any] = {}


def _products() -> tuple[Any, Any]:
    """A small raw product and its image (made once per worker)."""
    if not _PRODUCTS:
        import mitsar  # noqa: PLC0415

        raw = mitsar.simulate_point_targets(
            mitsar.Radar(), mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], 1.2),
            mitsar.Look(55.71), [mitsar.PointTarget([15.0, 8.0, 0.0])])
        grid = {"kind": "slant", "along_track": [-0.4, 0.8, 0.02],
                "slant_range": [7.3, 8.7, 0.02]}
        _PRODUCTS.update(raw=raw, image=mitsar.focus(raw, grid=grid, azimuth_resolution=0.1))
    return _PRODUCTS["raw"], _PRODUCTS["image"]


BAD = {"str": "abc", "none": None, "pair": [1.0, 2.0], "ragged": [[1.0, 2.0, 3.0], [1.0, 2.0]],
       "nan": math.nan, "inf": math.inf, "neg": -1.0, "zero": 0, "huge": 1e300, "bool": True,
       "dict": {"a": 1}, "fraction": 1.5}


KNOTS = [[0.0, 0.0, 1.0], [1.0, 0.0, 1.0], [2.0, 0.0, 1.0]]
"""Navigation knots of the API cases (one per second: 1 m/s)."""
LEGS = [[0.0, 0.0, 1.0], [4.0, 0.0, 1.0], [4.0, 4.0, 1.0]]
"""Flight waypoints of the API cases: two 4 m legs, a turn of up to 4 m radius between."""


def _api_specs() -> list[tuple[str, Callable[[Any], Any], str, set[str]]]:
    """(callable name, call with one bad value, parameter, labels of BAD that are valid)."""
    import mitsar  # noqa: PLC0415

    def radar(name: str) -> Callable[[Any], Any]:
        return lambda v: mitsar.Radar(**{name: v})

    good_track = ([14.9, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    specs: list[tuple[str, Callable[[Any], Any], str, set[str]]] = []
    for name in ("carrier_frequency", "sampling_frequency"):
        specs.append(("Radar", radar(name), name, set()))
    for name in ("bandwidth", "prf", "max_range", "antenna_width", "antenna_length",
                 "transmit_power"):  # 1.5 Hz, m or W: odd, but a radar
        specs.append(("Radar", radar(name), name, {"fraction"}))
    specs += [
        ("Trajectory.linear", lambda v: mitsar.Trajectory.linear(v, *good_track[1:]), "start",
         set()),
        ("Trajectory.linear", lambda v: mitsar.Trajectory.linear(good_track[0], v, 0.4),
         "velocity", set()),
        ("Trajectory.linear", lambda v: mitsar.Trajectory.linear(*good_track[:2], v),
         "duration", {"fraction"}),  # 1e300 s: beyond MAX_DURATION (issue 27)
        ("Trajectory.waypoints", lambda v: mitsar.Trajectory.waypoints(v, 0.5), "points",
         set()),
        ("Trajectory.waypoints", lambda v: mitsar.Trajectory.waypoints(
            [[0, 0, 1], [1, 0, 1]], v), "speed", {"fraction"}),  # 1e300 m/s: beyond MAX_SPEED
        # issue 27: a bad entry in navigation data, a bad flight parameter, a bad time
        ("Trajectory.navigation", lambda v: mitsar.Trajectory.navigation(
            [0.0, v, 2.0], KNOTS), "times", {"fraction", "bool"}),
        ("Trajectory.navigation", lambda v: mitsar.Trajectory.navigation(
            [0.0, 1.0, 2.0], [[0, 0, 1], [v, 0, 1], [2, 0, 1]]), "positions",
         {"fraction", "zero", "neg", "bool"}),
        ("Trajectory.navigation", lambda v: mitsar.Trajectory.navigation(
            [0.0, 1.0, 2.0], KNOTS, [[1, 0, 0], [v, 0, 0], [1, 0, 0]]), "velocities",
         {"fraction", "zero", "neg", "bool"}),
        ("Trajectory.navigation", lambda v: mitsar.Trajectory.navigation(
            [0.0, 1.0, 2.0], KNOTS, attitude_deg=[[0, 0, 0], [v, 0, 0], [0, 0, 0]]),
         "attitude_deg", {"fraction", "zero", "neg", "bool"}),
        ("Trajectory.navigation", lambda v: mitsar.Trajectory.navigation(
            [0.0, 1.0, 2.0], KNOTS, heading_smoothing=v), "heading_smoothing",
         {"fraction", "zero"}),
        ("Trajectory.flight", lambda v: mitsar.Trajectory.flight(LEGS, v), "speed",
         {"fraction", "pair"}),  # a pair: one speed per leg
        ("Trajectory.flight", lambda v: mitsar.Trajectory.flight(LEGS, 0.5, turn_radius=v),
         "turn_radius", {"fraction", "zero"}),
        ("Trajectory.flight", lambda v: mitsar.Trajectory.flight(
            LEGS, 0.5, acceleration=1.0, hover=v), "hover", {"fraction", "zero"}),
        ("Trajectory.flight", lambda v: mitsar.Trajectory.flight(LEGS, 0.5, acceleration=v),
         "acceleration", {"fraction", "none"}),
        ("Trajectory.flight", lambda v: mitsar.Trajectory.flight(LEGS, 0.5, sample_rate=v),
         "sample_rate", {"fraction"}),
        ("Trajectory.position", lambda v: mitsar.Trajectory.linear(*good_track).position(v),
         "time", {"zero"}),
        ("Trajectory.velocity", lambda v: mitsar.Trajectory.navigation(
            [0.0, 1.0, 2.0], KNOTS).velocity([0.5, v]), "time", {"zero", "fraction", "bool"}),
        # issue 27: a wrong argument class at the public API (mitsar.errors.public)
        ("measure_impulse_response", lambda v: mitsar.measure_impulse_response(
            v, (15.0, 8.0, 0.0)), "image", set()),
        ("save", lambda v: mitsar.save(v, "/nonexistent-fuzz-folder/x.nc"), "ds", set()),
        ("read_raw", lambda v: mitsar.read_raw(v), "path", set()),
        ("read_cphd", lambda v: mitsar.read_cphd(v), "path", set()),
        ("simulate_point_targets", lambda v: mitsar.simulate_point_targets(
            mitsar.Radar(), v, mitsar.Look(55.71), []), "trajectory", set()),
        ("simulate_point_targets", lambda v: mitsar.simulate_point_targets(
            mitsar.Radar(), mitsar.Trajectory.linear(*good_track), v, []), "look", set()),
        # issue 27: the records bound their fields by unit as their TOML tables do
        ("PointTarget", lambda v: mitsar.PointTarget([15.0, v, 0.0]), "position",
         {"fraction", "zero", "neg", "bool"}),
        ("Radar", lambda v: mitsar.Radar(noise_figure_db=v), "noise_figure_db",
         {"fraction", "zero", "neg", "none"}),
        ("NavigationErrors", lambda v: mitsar.NavigationErrors(position_noise=(v, 0.0, 0.0)),
         "position_noise", {"fraction", "zero", "bool"}),
        ("Vibration", lambda v: mitsar.Vibration((1e-3, 0.0, 0.0), v), "frequency",
         {"fraction"}),
        ("Look", lambda v: mitsar.Look(v), "off_nadir_deg", {"zero", "fraction"}),
        ("Look", lambda v: mitsar.Look(45.0, v), "squint_deg", {"zero", "fraction", "neg"}),
        ("PointTarget", lambda v: mitsar.PointTarget(v), "position", set()),
        ("PointTarget", lambda v: mitsar.PointTarget([1, 2, 0], rcs=v), "rcs", {"fraction"}),
        ("PointTarget", lambda v: mitsar.PointTarget([1, 2, 0], velocity=v), "velocity", set()),
        ("Background", lambda v: mitsar.Background(v, (1, 1)), "center", set()),
        ("Background", lambda v: mitsar.Background((0, 0, 0), v), "size", {"pair"}),
        ("Background", lambda v: mitsar.Background((0, 0, 0), (1, 1), cell_rcs_db=v),
         "cell_rcs_db", {"neg", "zero", "fraction"}),
        ("Background", lambda v: mitsar.Background((0, 0, 0), (1, 1), scatterers_per_cell=v),
         "scatterers_per_cell", set()),
        ("Background", lambda v: mitsar.Background((0, 0, 0), (1, 1), mode=v), "mode", set()),
        ("simulate_point_targets", lambda v: mitsar.simulate_point_targets(
            mitsar.Radar(), mitsar.Trajectory.linear(*good_track), mitsar.Look(55.71), v),
         "targets", set()),
        ("simulate_point_targets", lambda v: mitsar.simulate_point_targets(
            v, mitsar.Trajectory.linear(*good_track), mitsar.Look(55.71),
            [mitsar.PointTarget([15, 8, 0])]), "radar", set()),
        ("simulate_point_targets", lambda v: mitsar.simulate_point_targets(
            mitsar.Radar(), mitsar.Trajectory.linear(*good_track), mitsar.Look(55.71),
            [mitsar.PointTarget([15, 8, 0])], seed=v), "seed", {"zero"}),
        ("focus", lambda v: mitsar.focus(v), "raw", set()),
        ("focus", lambda v: mitsar.focus(_products()[0], v), "algorithm", set()),
        ("focus", lambda v: mitsar.focus(_products()[0], window=v), "window", set()),
        ("focus", lambda v: mitsar.focus(_products()[0], range_upsample=v), "range_upsample",
         set()),
        ("focus", lambda v: mitsar.focus(_products()[0], azimuth_resolution=v),
         "azimuth_resolution", {"none", "fraction"}),
        ("focus", lambda v: mitsar.focus(_products()[0], grid=v), "grid", {"none"}),
    ]
    for name, valid in (("factor", set()), ("first_subaperture", set()),
                        ("final_subapertures", set()), ("lookup_upsample", set()),
                        ("angle_oversample", {"fraction"}), ("range_oversample", {"fraction"}),
                        ("first_angle_oversample", {"fraction"})):
        specs.append(("focus(ffbp)", lambda v, name=name: mitsar.focus(
            _products()[0], algorithm="ffbp", azimuth_resolution=0.1,
            algorithm_options={name: v}), name, valid))
    specs += [
        ("measure_impulse_response", lambda v: mitsar.measure_impulse_response(
            _products()[1], v), "target", set()),
        ("measure_impulse_response", lambda v: mitsar.measure_impulse_response(
            _products()[1], (15.0, 8.0, 0.0), search_radius_m=v), "search_radius_m",
         {"none", "fraction"}),
        ("measure_impulse_response", lambda v: mitsar.measure_impulse_response(
            _products()[1], (15.0, 8.0, 0.0), islr_extent=v), "islr_extent",
         {"fraction", "inf"}),  # inf: the whole chip; a finite 1e300 needs a chip that big
        ("range_compress", lambda v: mitsar.range_compress(v), "raw", set()),
        ("range_compress", lambda v: mitsar.range_compress(_products()[0], window=v), "window",
         {"none"}),  # None: no window (rect)
        ("load", lambda v: mitsar.load(v), "path", set()),
    ]
    return specs


def _unreceived(distance: float | None) -> Any:
    """The paper's pass with one target ``distance`` metres from mid-track along the line of
    sight to [15, 8, 0.3] m (None: 1.5 m above the platform, behind the antenna): a target a
    real receiver cannot receive, which mitsar must name (issue 27)."""
    import numpy as np  # noqa: PLC0415

    import mitsar  # noqa: PLC0415

    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    middle = np.asarray(track.position(0.2))
    sight = np.array([15.0, 8.0, 0.3]) - middle
    target = (middle + [0.0, 0.0, 1.5] if distance is None
              else middle + distance * sight / np.linalg.norm(sight))
    return mitsar.simulate_point_targets(mitsar.Radar(), track, mitsar.Look(55.7),
                                         [mitsar.PointTarget(target)])


def _edge_channel(folder: Path) -> Any:
    """An interferometer whose second receiver sits 5 cm behind the antenna along the line of
    sight, with a target 5 mm inside ``max_range`` at the far end of the pass: the reference
    point receives it, channel 1's half path does not (issue 27: reception per channel)."""
    import numpy as np  # noqa: PLC0415

    import mitsar  # noqa: PLC0415

    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    middle = np.asarray(track.position(0.2))
    aim = np.array([15.0, 8.0, 0.3])
    sight = (aim - middle) / np.linalg.norm(aim - middle)
    radar = mitsar.Radar(max_range=8.0, receivers=[(0.0, 0.0, 0.0), tuple(-0.05 * sight)])
    far = max(np.linalg.norm(aim - track.position(t)) for t in (0.0, 0.4))
    target = middle + (8.0 - 0.005 - far + np.linalg.norm(aim - middle)) * sight
    return mitsar.simulate_point_targets(radar, track, mitsar.Look(55.7),
                                         [mitsar.PointTarget(target)])


def _edge_traced_channel(folder: Path) -> Any:
    """The canned point_target scene ([15, 8, 0.03] m) traced by an interferometer whose second
    receiver is 5 cm behind the antenna along the line of sight, ``max_range`` 5 mm beyond the
    reference point's farthest range: channel 1 must be named (issue 27, the tracer)."""
    import numpy as np  # noqa: PLC0415

    import mitsar  # noqa: PLC0415

    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.02)
    aim = np.array([15.0, 8.0, 0.03])
    sight = (aim - track.position(0.01)) / np.linalg.norm(aim - track.position(0.01))
    far = max(np.linalg.norm(aim - track.position(t)) for t in (0.0, 0.02))
    radar = mitsar.Radar(max_range=far + 0.005, receivers=[(0.0, 0.0, 0.0),
                                                           tuple(-0.05 * sight)])
    return mitsar.simulate_scene(radar, track, mitsar.Look(55.7), "point_target")


def _edge_pass(folder: Path) -> Any:
    """Two passes of the paper's point target, the second 3 m further away: its echo is beyond
    ``max_range`` = 9 m (issue 27: reception per pass)."""
    from mitsar.experiment import experiment_from_dict, simulate_passes  # noqa: PLC0415

    document = base_documents()["simulate"]
    document["radar"]["max_range"] = 9.0
    document["trajectory"]["duration"] = 0.2
    document["passes"] = [{"name": "near"}, {"name": "far", "offset": [0.0, -3.0, 0.0]}]
    document.pop("background", None)
    return simulate_passes(experiment_from_dict(document, folder / "passes.toml"))


def _text_file_case(kind: str) -> Callable[[Path], Any]:
    """Load a file that is not text through the Python API (issue 27): an experiment, an
    ambiguity configuration, a navigation CSV an experiment names."""
    def action(folder: Path) -> Any:
        binary = folder / ("binary.csv" if kind == "navigation" else "binary.toml")
        binary.write_bytes(b"\x80\x81\xff\x00 not text")
        if kind == "experiment":
            from mitsar.experiment import load_experiment  # noqa: PLC0415

            return load_experiment(binary)
        if kind == "ambiguity":
            from mitsar.ambiguity import load_ambiguity_experiment  # noqa: PLC0415

            return load_ambiguity_experiment(binary)
        from mitsar.experiment import experiment_from_dict  # noqa: PLC0415

        document = base_documents()["simulate"]
        document["trajectory"] = {"kind": "navigation", "file": str(binary)}
        return experiment_from_dict(document, folder / "nav.toml")
    return action


def _issue27_api_cases() -> list[tuple[str, Callable[[Path], Any], tuple[str, ...]]]:
    """Fixed API cases of issue 27's checks (each invalid by construction)."""
    def boresight(folder: Path) -> Any:
        import mitsar  # noqa: PLC0415

        return mitsar.boresight(mitsar.Look(55.7), "north")

    def missing_scene(folder: Path) -> Any:
        import mitsar  # noqa: PLC0415

        return mitsar.trace(mitsar.Radar(), mitsar.Trajectory.linear(
            [14.8, 1.4, 4.5], [0.5, 0, 0], 0.02), mitsar.Look(55.7))

    return [("interferometer: target out of band for channel 1 only", _edge_channel,
             ("channels [1]",)),
            ("traced interferometer: channel 1 out of band", _edge_traced_channel,
             ("channels [1]",)),
            ("passes: the far pass beyond max_range", _edge_pass, ("pass 1 (far)",)),
            ("load_experiment(binary file)", _text_file_case("experiment"), ("binary.toml",)),
            ("load_ambiguity_experiment(binary file)", _text_file_case("ambiguity"),
             ("binary.toml",)),
            ("navigation CSV not text", _text_file_case("navigation"), ("file",)),
            ("boresight(heading='north')", boresight, ("heading",)),
            ("trace without a scene", missing_scene, ("scene",))]


def _api_cases(rng: random.Random, count: int, fast: bool) -> list[Case]:
    specs = _api_specs()
    extra = [
        ("Radar(bogus=1)", lambda: __import__("mitsar").Radar(bogus=1), ("bogus",)),
        ("simulate_point_targets(targets=PointTarget)", lambda: __import__("mitsar")
         .simulate_point_targets(__import__("mitsar").Radar(), __import__("mitsar").Trajectory
                                 .linear([14.9, 1.4, 4.5], [0.5, 0, 0], 0.4),
                                 __import__("mitsar").Look(55.71),
                                 __import__("mitsar").PointTarget([15, 8, 0])), ("targets",)),
        ("Trajectory vertical", lambda: __import__("mitsar").Trajectory.linear(
            [0, 0, 1], [0, 0, 0.5], 1.0), ("vertical",)),
        ("check_prf(nan)", lambda: __import__("mitsar").Radar().check_prf(math.nan), ("speed",)),
        # issue 27: echoes that cannot be received are said, naming the target
        ("simulate_point_targets(target beyond max_range)", lambda: _unreceived(31.5),
         ("beyond max_range",)),
        ("simulate_point_targets(target behind the antenna)", lambda: _unreceived(None),
         ("targets",)),  # warned about by name, then refused: nothing at all is received
        ("simulate_point_targets(target at the antenna)", lambda: _unreceived(0.05),
         ("near field",)),
        ("TraceOptions(slab_width=1e300)", lambda: __import__("mitsar").TraceOptions(
            slab_width=1e300).resolve("fuzz"), ("slab_width",)),
    ]
    cases = [Case("api", name, True, tokens, (lambda f: lambda folder: f())(func))
             for name, func, tokens in extra]
    cases += [Case("api", name, True, tokens, action) for name, action, tokens in
              _issue27_api_cases()]
    while len(cases) < count:
        where, call, parameter, valid = rng.choice(specs)
        label = rng.choice(sorted(BAD))
        invalid = label not in valid
        if fast and (not invalid or where in ("focus", "focus(ffbp)",
                                              "measure_impulse_response", "range_compress")
                     and label in ("none",)):
            continue
        value = BAD[label]
        heavy = where in ("focus", "focus(ffbp)", "measure_impulse_response", "range_compress",
                          "simulate_point_targets")

        def action(folder: Path, call: Callable = call, value: Any = value) -> Any:
            return call(copy.deepcopy(value))

        tokens = (parameter, value) if label == "str" else (parameter,)  # a missing file: named
        cases.append(Case("api", f"{where}({parameter}={label})", invalid, tokens,
                          action, compute=heavy and not invalid))
    return cases


# --- CLI misuse ---------------------------------------------------------------------------------

def _cli_cases(rng: random.Random, count: int) -> list[Case]:
    point = EXAMPLES / "paper_point_target.toml"

    def prepare(folder: Path) -> dict[str, str]:
        (folder / "exists.nc").write_text("x")
        (folder / "text.nc").write_text("not a product")
        (folder / "binary.toml").write_bytes(b"\x80\x81\x82\x00\xff")
        (folder / "empty.toml").write_text("")
        (folder / "syntax.toml").write_text("[radar\nprf = ")
        (folder / "data.json").write_text("{}")
        (folder / "dir.toml").mkdir()
        return {k: str(folder / k) for k in ("exists.nc", "text.nc", "binary.toml",
                                             "empty.toml", "syntax.toml", "data.json",
                                             "dir.toml")}

    table: list[tuple[str, Callable[[dict, Path], list[str]], tuple[str, ...], tuple[str, ...]]]
    table = [
        ("unknown command", lambda f, d: ["bogus-cmd"], ("bogus-cmd",), ()),
        ("simulate without args", lambda f, d: ["simulate"], ("required",), ()),
        ("simulate missing file", lambda f, d: ["simulate", str(d / "missing.toml"), "-o",
                                                str(d / "o.nc")], ("missing.toml",), ("o.nc",)),
        ("simulate binary toml", lambda f, d: ["simulate", f["binary.toml"], "-o",
                                               str(d / "o.nc")], ("binary.toml",), ("o.nc",)),
        ("simulate empty toml", lambda f, d: ["simulate", f["empty.toml"], "-o",
                                              str(d / "o.nc")], ("trajectory",), ("o.nc",)),
        ("simulate syntax error", lambda f, d: ["simulate", f["syntax.toml"], "-o",
                                                str(d / "o.nc")], ("syntax.toml",), ("o.nc",)),
        ("simulate a folder", lambda f, d: ["simulate", f["dir.toml"], "-o", str(d / "o.nc")],
         ("dir.toml",), ("o.nc",)),
        ("simulate output exists", lambda f, d: ["simulate", str(point), "-o", f["exists.nc"]],
         ("exists.nc",), ()),
        ("simulate output folder missing", lambda f, d: ["simulate", str(point), "-o",
                                                         str(d / "nowhere" / "o.nc")],
         ("nowhere",), ()),
        ("seed negative", lambda f, d: ["simulate", str(point), "-o", str(d / "o.nc"),
                                        "--seed", "-1"], ("seed",), ("o.nc",)),
        ("seed 2^64", lambda f, d: ["simulate", str(point), "-o", str(d / "o.nc"), "--seed",
                                    str(2**64)], ("seed",), ("o.nc",)),
        ("seed text", lambda f, d: ["simulate", str(point), "-o", str(d / "o.nc"), "--seed",
                                    "abc"], ("seed",), ("o.nc",)),
        ("set without =", lambda f, d: ["simulate", str(point), "-o", str(d / "o.nc"), "--set",
                                        "radar.prf"], ("radar.prf",), ("o.nc",)),
        ("set unknown key", lambda f, d: ["simulate", str(point), "-o", str(d / "o.nc"),
                                          "--set", "radar.bogus_key=1"], ("bogus_key",),
         ("o.nc",)),
        ("set bad value", lambda f, d: ["simulate", str(point), "-o", str(d / "o.nc"), "--set",
                                        "radar.prf=abc"], ("prf",), ("o.nc",)),
        ("set nan speed", lambda f, d: ["simulate", str(point), "-o", str(d / "o.nc"), "--set",
                                        "trajectory.velocity=[nan, 0, 0]"], ("velocity",),
         ("o.nc",)),
        ("memory limit text", lambda f, d: ["--memory-limit", "lots", "simulate", str(point),
                                            "-o", str(d / "o.nc")], ("memory",), ("o.nc",)),
        ("memory limit tiny", lambda f, d: ["--memory-limit", "1K", "simulate", str(point),
                                            "-o", str(d / "o.nc")], ("memory",), ("o.nc",)),
        ("focus a text file", lambda f, d: ["focus", f["text.nc"], "-o", str(d / "i.nc")],
         ("text.nc",), ("i.nc",)),
        ("focus missing", lambda f, d: ["focus", str(d / "missing.nc"), "-o", str(d / "i.nc")],
         ("missing.nc",), ("i.nc",)),
        ("focus bad algorithm", lambda f, d: ["focus", f["text.nc"], "-o", str(d / "i.nc"),
                                              "-a", "bogus"], ("bogus",), ("i.nc",)),
        ("focus missing grid", lambda f, d: ["focus", f["text.nc"], "-o", str(d / "i.nc"),
                                             "--grid", str(d / "nogrid.toml")],
         ("text.nc", "nogrid.toml"), ("i.nc",)),
        ("focus negative resolution", lambda f, d: ["focus", f["text.nc"], "-o",
                                                    str(d / "i.nc"), "--azimuth-resolution",
                                                    "-1"], ("text.nc", "azimuth-resolution"),
         ("i.nc",)),
        ("metrics of a json", lambda f, d: ["metrics", f["data.json"]], ("data.json",), ()),
        ("metrics nan target", lambda f, d: ["metrics", f["text.nc"], "--target", "nan", "nan",
                                             "nan"], ("text.nc", "target"), ()),
        ("metrics two numbers", lambda f, d: ["metrics", f["text.nc"], "--target", "1", "2"],
         ("target",), ()),
        ("plot negative range", lambda f, d: ["plot", f["text.nc"], "-o", str(d / "p.png"),
                                              "--dynamic-range", "-5"], ("dynamic-range",),
         ("p.png",)),
        ("plot a json", lambda f, d: ["plot", f["data.json"], "-o", str(d / "p.png")],
         ("data.json",), ("p.png",)),
        ("rays zero", lambda f, d: ["rays", str(EXAMPLES / "case1_2d.toml"), "-o",
                                    str(d / "r"), "--rays", "0"], ("rays",), ("r",)),
        ("rays negative", lambda f, d: ["rays", str(EXAMPLES / "case1_2d.toml"), "-o",
                                        str(d / "r"), "--rays", "-4"], ("rays",), ("r",)),
        ("rays sweep beyond", lambda f, d: ["rays", str(EXAMPLES / "case1_2d.toml"), "-o",
                                            str(d / "r"), "--sweep", "1000000"], ("sweep",),
         ("r",)),
        ("montecarlo zero", lambda f, d: ["montecarlo", str(point), "-n", "0", "-o",
                                          str(d / "m")], ("realisations",), ()),
        ("montecarlo negative", lambda f, d: ["montecarlo", str(point), "-n", "-3", "-o",
                                              str(d / "m")], ("realisations",), ()),
        ("montecarlo into a file", lambda f, d: ["montecarlo", str(point), "-n", "1", "-o",
                                                 f["exists.nc"]], ("exists.nc",), ()),
        ("montecarlo bad algorithm", lambda f, d: ["montecarlo", str(point), "-a", "bogus",
                                                   "-o", str(d / "m")], ("bogus",), ()),
        ("ambiguity of a point-target file", lambda f, d: ["ambiguity", str(point), "-o",
                                                           str(d / "a")],
         ("trajectories", "surfaces", "ambiguity", "paper_point_target.toml"), ("a",)),
        ("report of a non-run", lambda f, d: ["report", str(d)], ("run.json",), ()),
        ("export without raw", lambda f, d: ["export", f["text.nc"], "-f", "sicd", "-o",
                                             str(d / "x.nitf")], ("raw", "text.nc"),
         ("x.nitf",)),
        ("demo into a file", lambda f, d: ["demo", "-o", f["exists.nc"]], ("exists.nc",), ()),
        ("metrics islr extent negative", lambda f, d: ["metrics", f["text.nc"],
                                                       "--islr-extent", "-3"],
         ("text.nc", "islr"), ()),
    ]
    cases = []
    for index in range(count):
        name, argv, tokens, outputs = table[index] if index < len(table) else rng.choice(table)

        def action(folder: Path, argv: Callable = argv) -> Any:
            return cli(argv(prepare(folder), folder))

        cases.append(Case("cli", name, True, tokens, action, outputs))
    return cases


# --- self test: one case of each verdict, so that the harness itself can fail ---------------------

def _selftest_cases() -> list[Case]:
    """Synthetic cases with known verdicts (``tests/test_fuzz.py``); not part of a campaign."""
    from mitsar.errors import MitsarError, MitsarWarning, ParameterError  # noqa: PLC0415

    def refuse(folder: Path) -> None:
        raise ParameterError("selftest", "knob", "a good value", 1)

    def vague(folder: Path) -> None:
        raise MitsarError("something is wrong")

    def foreign(folder: Path) -> None:
        raise TypeError("unsupported operand")

    def warn(folder: Path) -> None:
        warnings.warn("selftest: raw data of exact zeros", MitsarWarning, stacklevel=1)

    def debris(folder: Path) -> None:
        (folder / "out.nc").write_text("partial")
        raise ParameterError("selftest", "knob", "a good value", 1)

    def hang(folder: Path) -> None:
        time.sleep(30)

    def crash(folder: Path) -> None:
        os.kill(os.getpid(), signal.SIGKILL)

    nothing: Callable[[Path], None] = lambda folder: None  # noqa: E731
    return [Case("selftest", "clean", True, ("knob",), refuse),
            Case("selftest", "vague", True, ("knob",), vague),
            Case("selftest", "traceback", True, ("knob",), foreign),
            Case("selftest", "silent", True, ("knob",), nothing),
            Case("selftest", "warned", True, ("zeros",), warn),
            Case("selftest", "debris", True, ("knob",), debris, ("out.nc",)),
            Case("selftest", "hang", True, ("knob",), hang, timeout=1.0),
            Case("selftest", "crash", True, ("knob",), crash),
            Case("selftest", "ok", False, (), nothing),
            Case("selftest", "refused", False, (), refuse)]


SELFTEST_VERDICTS = ("CLEAN", "VAGUE", "TRACEBACK", "SILENT", "CLEAN", "DEBRIS", "HANG", "CRASH",
                     "OK", "REFUSED")
"""The verdict each self-test case must get."""


# --- generation, running, classification --------------------------------------------------------

def generate(count: int, seed: int = 0, fast: bool = False,
             families: tuple[str, ...] = FAMILIES) -> list[Case]:
    """``count`` cases over ``families`` (in equal shares), deterministic in ``seed``.

    ``fast`` keeps invalid cases only (most are refused before any compute) and a few valid
    ones per family.
    """
    if families == ("selftest",):
        return _selftest_cases()
    rng = random.Random(seed)
    share = max(1, count // len(families))
    documents = base_documents()
    cases: list[Case] = []
    for family in families:
        n = share + (count - share * len(families) if family == families[-1] else 0)
        if family in documents:
            cases += _toml_cases(family, documents[family], rng, n, fast)
        elif family == "xml":
            cases += _xml_cases(rng, n, fast)
        elif family == "api":
            cases += _api_cases(rng, n, fast)
        else:
            cases += _cli_cases(rng, n)
    return cases


class _Timeout(BaseException):
    """Raised by the alarm in a case that runs too long."""


def _alarm(signum: int, frame: Any) -> None:
    raise _Timeout()


def run_case(case: Case, folder: Path) -> Outcome:
    """Run one case in ``folder``; what happened (not yet judged)."""
    from mitsar.errors import MitsarError, MitsarWarning  # noqa: PLC0415

    start = time.perf_counter()
    signal.signal(signal.SIGALRM, _alarm)
    signal.setitimer(signal.ITIMER_REAL, case.timeout)
    try:
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            case.action(folder)
        loud = [str(w.message) for w in caught if issubclass(w.category, MitsarWarning)]
        outcome = Outcome("warning", loud[0]) if loud else Outcome("ok")
    except _Timeout:
        outcome = Outcome("timeout", f"> {case.timeout:g} s")
    except (MitsarError, UsageError) as error:
        outcome = Outcome("mitsar", f"{type(error).__name__}: {error}")
    except Exception as error:  # noqa: BLE001 - a foreign exception is what we look for
        outcome = Outcome("foreign", f"{type(error).__name__}: {error}")
    finally:
        signal.setitimer(signal.ITIMER_REAL, 0)
    outcome.seconds = time.perf_counter() - start
    if outcome.kind in ("mitsar", "foreign"):
        outcome.debris = [o for o in case.outputs if _left(folder / o)]
        outcome.debris += [p.name for p in folder.rglob(".*.tmp*")]
    return outcome


def _left(path: Path) -> bool:
    if path.is_dir():
        return any(path.iterdir())
    return path.exists()


def classify(case: Case, outcome: Outcome) -> str:
    """The verdict of a case (module docstring)."""
    if outcome.kind == "timeout":
        return "HANG"
    if outcome.kind == "crash":
        return "CRASH"
    if outcome.kind == "foreign":
        return "TRACEBACK"
    if outcome.debris:
        return "DEBRIS"
    if not case.invalid:
        return "REFUSED" if outcome.kind == "mitsar" else "OK"
    if outcome.kind == "ok":
        return "SILENT"
    named = any(token.lower() in outcome.message.lower() for token in case.tokens)
    return "CLEAN" if named else "VAGUE"


def worker(seed: int, count: int, fast: bool, families: tuple[str, ...], start: int,
           result_fd: int, root: Path) -> None:
    """Run cases ``start ..`` in folders under ``root`` (the parent's, which it removes even
    when a worker is killed) and write one JSON line per case to ``result_fd``."""
    cases = generate(count, seed, fast, families)
    os.chdir(root)  # a case that writes a relative path ("abc") writes into the campaign's folder
    out = os.fdopen(result_fd, "w", buffering=1)
    for index in range(start, len(cases)):
        case = cases[index]
        folder = root / f"case{index}"
        folder.mkdir()
        outcome = run_case(case, folder)
        shutil.rmtree(folder, ignore_errors=True)
        out.write(json.dumps({"index": index, "kind": outcome.kind,
                              "verdict": classify(case, outcome),
                              "message": outcome.message[:400],
                              "seconds": round(outcome.seconds, 3),
                              "debris": outcome.debris}) + "\n")


def campaign(count: int, seed: int = 0, fast: bool = False,
             families: tuple[str, ...] = FAMILIES, log: Callable[[str], None] | None = None,
             timeout: float = TIMEOUT) -> list[dict]:
    """Run a campaign in worker processes; one record per case with its ``verdict``."""
    cases = generate(count, seed, fast, families)
    records: list[dict] = []
    env = dict(os.environ, MITSAR_MEMORY_LIMIT=os.environ.get("MITSAR_MEMORY_LIMIT",
                                                              WORKER_MEMORY),
               MPLBACKEND="Agg", PYTHONWARNINGS="ignore")
    root = Path(tempfile.mkdtemp(prefix="mitsar-fuzz-"))
    try:
        _run_workers(cases, records, root, count, seed, fast, families, env, log, timeout)
    finally:
        shutil.rmtree(root, ignore_errors=True)
    return records


def _run_workers(cases: list[Case], records: list[dict], root: Path, count: int, seed: int,
                 fast: bool, families: tuple[str, ...], env: dict, log: Any,
                 timeout: float) -> None:
    """Start workers until every case has a record (a dead or stuck worker is replaced)."""
    start = 0
    while start < len(cases):
        read_fd, write_fd = os.pipe()
        process = subprocess.Popen(
            [sys.executable, str(Path(__file__).resolve()), "--worker", "--seed", str(seed),
             "--cases", str(count), "--start", str(start), "--result-fd", str(write_fd),
             "--root", str(root),
             "--families", *families] + (["--fast"] if fast else []),
            pass_fds=(write_fd,), env=env, stdout=subprocess.DEVNULL,
            stderr=subprocess.DEVNULL)
        os.close(write_fd)
        reader = os.fdopen(read_fd)
        try:
            expected = _collect(cases, records, reader, process, start, log, timeout)
        finally:
            if process.poll() is None:  # interrupted: no orphan worker
                process.kill()
            process.wait()
            reader.close()
        if expected < len(cases) and (not records or records[-1]["index"] < expected):
            records.append(_judged(cases[expected], {
                "index": expected, "kind": "crash", "seconds": 0.0,
                "message": f"worker died (status {process.returncode})"}))
            expected += 1
        start = expected


def _collect(cases: list[Case], records: list[dict], reader: Any, process: Any, start: int,
             log: Any, timeout: float) -> int:
    """Read one worker's records; the index of the first case it did not report."""
    expected = start
    # Generous for the first case: the worker imports mitsar (and Mitsuba) first.
    deadline = time.monotonic() + timeout + 120
    while expected < len(cases):
        ready, _, _ = select.select([reader], [], [], 1.0)
        if ready:
            line = reader.readline()
            if not line:
                break
            record = json.loads(line)
            records.append(_judged(cases[record["index"]], record))
            if log:
                log(_line(records[-1]))
            expected = record["index"] + 1
            deadline = time.monotonic() + timeout + 30
        elif time.monotonic() > deadline:
            process.kill()
            records.append(_judged(cases[expected], {"index": expected, "kind": "timeout",
                                                     "message": "worker stuck",
                                                     "seconds": timeout}))
            expected += 1
            break
    return expected


def _judged(case: Case, record: dict) -> dict:
    outcome = Outcome(record["kind"], record.get("message", ""), record.get("seconds", 0.0),
                      record.get("debris", []))
    verdict = record.get("verdict") or classify(case, outcome)
    return {**record, "family": case.family, "name": case.name, "invalid": case.invalid,
            "verdict": verdict}


def _line(record: dict) -> str:
    return (f"{record['index']:5d} {record['family']:10s} {record['verdict']:9s} "
            f"{record['seconds']:6.2f}s {record['name'][:60]:60s} {record['message'][:120]}")


def table(records: list[dict]) -> str:
    """Verdict counts by family, with totals."""
    order = FAMILIES + ("selftest",)
    families = sorted({r["family"] for r in records}, key=order.index)
    counts = {f: Counter(r["verdict"] for r in records if r["family"] == f) for f in families}
    total = Counter(r["verdict"] for r in records)
    lines = [f"{'family':11s}" + "".join(f"{v:>10s}" for v in VERDICTS) + f"{'cases':>8s}"]
    for family in families + ["total"]:
        c = total if family == "total" else counts[family]
        lines.append(f"{family:11s}" + "".join(f"{c[v]:10d}" for v in VERDICTS)
                     + f"{sum(c.values()):8d}")
    vague = total["VAGUE"] / max(1, len(records))
    lines.append(f"VAGUE {100 * vague:.2f}% of {len(records)} cases")
    return "\n".join(lines)


def main(argv: list[str] | None = None) -> int:
    parser = argparse.ArgumentParser(description=__doc__.split("\n")[0])
    parser.add_argument("--cases", type=int, default=1100)
    parser.add_argument("--seed", type=int, default=0)
    parser.add_argument("--fast", action="store_true", help="invalid cases only, mostly")
    parser.add_argument("--families", nargs="+", default=list(FAMILIES),
                        choices=FAMILIES + ("selftest",))
    parser.add_argument("--json", metavar="FILE", help="also write every record as JSON")
    parser.add_argument("-v", "--verbose", action="store_true", help="one line per case")
    parser.add_argument("--worker", action="store_true", help=argparse.SUPPRESS)
    parser.add_argument("--start", type=int, default=0, help=argparse.SUPPRESS)
    parser.add_argument("--result-fd", type=int, help=argparse.SUPPRESS)
    parser.add_argument("--root", type=Path, help=argparse.SUPPRESS)
    args = parser.parse_args(argv)
    families = tuple(args.families)
    if args.worker:
        worker(args.seed, args.cases, args.fast, families, args.start, args.result_fd,
               args.root)
        return 0
    clock, load = time.perf_counter(), os.getloadavg()
    records = campaign(args.cases, args.seed, args.fast, families,
                       log=print if args.verbose else None)
    print(f"seed {args.seed}: {len(records)} cases in {time.perf_counter() - clock:.0f} s wall; "
          f"load average (1, 5, 15 min) {' '.join(f'{v:.1f}' for v in load)} at the start, "
          f"{' '.join(f'{v:.1f}' for v in os.getloadavg())} at the end, "
          f"{os.cpu_count()} CPUs")
    print(table(records))
    bad = [r for r in records if r["verdict"] in FAILURES or r["verdict"] == "VAGUE"]
    for record in bad:
        print(_line(record))
    print(f"{len(records)} cases in {time.perf_counter() - clock:.0f} s")
    if args.json:
        Path(args.json).write_text(json.dumps(records, indent=1))
    failed = any(r["verdict"] in FAILURES for r in records)
    vague = sum(r["verdict"] == "VAGUE" for r in records) / max(1, len(records))
    return 1 if failed or vague >= 0.01 else 0


if __name__ == "__main__":
    sys.exit(main())
