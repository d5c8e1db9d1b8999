"""The ambiguity TOML file: read and validate it (format in ``docs/ambiguity.md``).

The ``[radar]``, ``[look]`` and ``[trajectory]`` tables are those of experiment files
(:mod:`mitsar.experiment.parsers`); ``[ambiguity]`` holds the options of
:func:`~mitsar.ambiguity.maps.ambiguity`, ``[[surfaces]]`` rectangles instead of a scene.
"""

from __future__ import annotations

import copy
import json
import os
import tomllib
from pathlib import Path
from typing import Any

import numpy as np

from mitsar.ambiguity.maps import CRITERIA, INTEGRATION_MODES, required_resolutions
from mitsar.checks import MAX_DURATION, bounded
from mitsar.errors import ParameterError
from mitsar.experiment.parsers import parse_look, parse_radar, parse_trajectory
from mitsar.experiment.table import Table
from mitsar.model.geometry.attitude import Look

__all__ = ["ambiguity_from_dict", "load_ambiguity_experiment"]


MAX_STATES = 10**7
"""Largest ``max_states``: ten million states is a 14-hour flight at 250 Hz, every sweep."""


def _parse_ambiguity_options(t: Table) -> dict[str, Any]:
    options: dict[str, Any] = {}
    options["spacing"] = t.number("spacing", 0.25, unit="m", gt=0)
    surfaces = t.data.get("surfaces")
    t.seen.add("surfaces")
    if surfaces is not None:
        if not (isinstance(surfaces, list) and all(isinstance(s, str) for s in surfaces)):
            raise t.error("surfaces", "an array of shape ids (strings)", surfaces)
        options["shapes"] = surfaces
    exclude = t.data.get("exclude", [])
    t.seen.add("exclude")
    if not (isinstance(exclude, list) and all(isinstance(s, str) for s in exclude)):
        raise t.error("exclude", "an array of shape ids (strings)", exclude)
    options["exclude"] = exclude
    options["sweep_step"] = t.integer("sweep_step", None, ge=1)
    options["max_states"] = t.integer("max_states", 600, ge=2)
    if options["max_states"] > MAX_STATES:
        raise t.error("max_states", f"an integer in [2, {MAX_STATES}] (states)",
                      options["max_states"])
    t.seen.add("integration_time")
    value = t.data.get("integration_time", "beam")
    if isinstance(value, str):
        if value not in INTEGRATION_MODES:
            raise t.error("integration_time", "'beam', 'required' or a time > 0 [s]", value)
    elif isinstance(value, bool) or not isinstance(value, int | float) \
            or not 0 < value <= MAX_DURATION:
        raise t.error("integration_time", "'beam', 'required' or a time > 0 and <= "
                      f"{MAX_DURATION:g} [s]", value)
    options["integration_time"] = float(value) if not isinstance(value, str) else value
    options["beam_threshold_db"] = t.number("beam_threshold_db", -6.0, unit="dB", lt=0)
    options["min_angle_deg"] = t.number("min_angle_deg", 30.0, unit="deg", ge=0, lt=90)
    options["criterion"] = t.string("criterion", "gradient", choices=CRITERIA)
    options["shadowing"] = t.boolean("shadowing", True)
    options["per_state"] = t.boolean("per_state", True)
    t.finish()
    return options


def _parse_planes(tables: list[Table]) -> list[dict[str, Any]]:
    planes = []
    for i, t in enumerate(tables):
        name = t.string("name", f"surface{i}")
        if any(plane["name"] == name for plane in planes):  # maps and tables are by name
            raise t.error("name", "a name no other [[surfaces]] entry has", name)
        origin = t.vector("origin", 3, unit="m")
        axis_u = t.vector("axis_u", 3, unit="direction")
        axis_v = t.vector("axis_v", 3, unit="direction")
        size = t.vector("size", 2, unit="m")
        t.finish()
        u, v = np.asarray(axis_u), np.asarray(axis_v)
        if np.linalg.norm(u) == 0 or np.linalg.norm(v) == 0 or abs(
                u @ v) > 1e-6 * np.linalg.norm(u) * np.linalg.norm(v):
            raise t.error("axis_v", "a non-zero vector orthogonal to axis_u", list(axis_v))
        if min(size) <= 0:
            raise t.error("size", "2 sizes > 0 [m]", list(size))
        planes.append({"name": name, "origin": origin, "axis_u": axis_u, "axis_v": axis_v,
                       "size": size})
    return planes


def load_ambiguity_experiment(path: str | os.PathLike) -> dict[str, Any]:
    """Read and validate an ambiguity TOML file (format in ``docs/ambiguity.md``).

    Returns
    -------
    dict
        ``name``, ``description``, ``radar``, ``look`` (Look or dict name -> Look),
        ``trajectories`` (dict name -> Trajectory), ``required_resolution``, ``scene`` (path
        or name, or None), ``planes`` (list), ``options`` (keywords of :func:`ambiguity`),
        ``outputs`` (``figures``, ``format``), ``config`` (the effective values).
    """
    path = Path(path)
    where = str(path)
    if not path.is_file():
        raise ParameterError(where, "file", "an existing TOML file", str(path))
    try:
        data = tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as error:
        raise ParameterError(where, "file", "valid TOML", str(error)) from error
    except UnicodeDecodeError as error:
        raise ParameterError(where, "file", "a text (UTF-8) TOML file", str(error)) from error
    return ambiguity_from_dict(data, where, path.resolve().parent, path.stem)


def ambiguity_from_dict(data: dict[str, Any], where: str, base: str | os.PathLike,
                        default_name: str = "ambiguity") -> dict[str, Any]:
    """Validate an ambiguity document already read (e.g. a sweep's point, ``--set`` applied).

    Parameters
    ----------
    data : dict
        The TOML document (format in ``docs/ambiguity.md``); not modified.
    where : str
        Name used in error messages (the file, or the file and its variation).
    base : path-like
        Folder against which relative scene paths resolve (the file's folder).
    default_name : str
        ``name`` when the document has none (the file's stem).

    Returns
    -------
    dict
        As :func:`load_ambiguity_experiment`.
    """
    data = copy.deepcopy(data)
    top = Table(data, "", where, Path(base))
    out: dict[str, Any] = {}
    out["name"] = top.string("name", default_name)
    out["description"] = top.string("description", "")
    top.seen.add("required_resolution")
    required = top.data.get("required_resolution", 0.10)
    try:
        required_resolutions(required)
        bounded(where, "required_resolution", required, "m", "a resolution > 0 m, or a "
                "(range, azimuth) pair of them")
    except ParameterError as error:
        raise top.error("required_resolution", error.expected, required) from error
    out["required_resolution"] = (tuple(float(r) for r in required)
                                  if isinstance(required, list) else float(required))
    scene = top.string("scene", None)
    if scene is not None:
        candidate = Path(scene).expanduser()
        if not candidate.is_absolute() and (top.base / candidate).exists():
            scene = str((top.base / candidate).resolve())
    out["scene"] = scene
    radar_table = top.table("radar") or Table({}, "radar", where, top.base)
    out["radar"] = parse_radar(radar_table)
    look_table = top.table("look", required=True)
    out["look"] = parse_look(look_table)
    trajectories: dict[str, Any] = {}
    looks: dict[str, Look] = {}
    single = top.table("trajectory")
    multiple = top.table("trajectories")
    if (single is None) == (multiple is None):
        raise top.error("trajectory", "exactly one of [trajectory] or [trajectories.NAME]",
                        "both" if single is not None else "neither")
    if single is not None:
        trajectories[out["name"] or "trajectory"] = parse_trajectory(single)
    else:
        for name in multiple.data:
            t = multiple.table(name)
            if "look" in t.data:
                look_override = Table(t.data.pop("look"), t.key("look"), where, top.base)
                looks[name] = parse_look(look_override)
            trajectories[name] = parse_trajectory(t)
        multiple.finish()
        if not trajectories:
            raise top.error("trajectories", "at least one [trajectories.NAME] table", "none")
    out["trajectories"] = trajectories
    if looks:
        out["look"] = {name: looks.get(name, out["look"]) for name in trajectories}
    ambiguity_table = top.table("ambiguity") or Table({}, "ambiguity", where, top.base)
    out["options"] = _parse_ambiguity_options(ambiguity_table)
    out["planes"] = _parse_planes(top.tables("surfaces"))
    if scene is None and not out["planes"]:
        raise top.error("scene", "a scene (name or XML path) or at least one [[surfaces]] "
                        "rectangle", "neither")
    if scene is not None and out["planes"]:
        raise top.error("surfaces", "either a scene or [[surfaces]], not both", "both")
    output_table = top.table("output") or Table({}, "output", where, top.base)
    out["outputs"] = {"figures": output_table.boolean("figures", True),
                      "format": output_table.string("format", "png",
                                                    choices=("png", "pdf", "svg"))}
    output_table.finish()
    top.finish()
    out["config"] = json.loads(json.dumps(data, default=str))
    return out
