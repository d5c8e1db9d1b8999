"""Reading experiment files: TOML in, a validated :class:`~.options.Experiment` out.

An experiment file has the tables ``[radar]``, ``[trajectory]``, ``[look]``, ``[[passes]]``
(optional: several acquisitions, each inheriting ``[trajectory]`` and ``[look]``),
``[[targets]]``, ``[background]`` (optional), ``[simulation]``, ``[focus]`` (with ``[focus.grid]``),
``[metrics]``, ``[interferometry]`` (optional, for a radar with several receivers),
``[mapping]`` (optional: map the scene from the passes and score it), and
the optional top-level keys ``name``, ``description`` and ``scene``. Every key,
its type, unit and default is documented in ``docs/experiments.md``.

Validation is strict: an unknown table or key, a wrong type, a vector of the wrong length or a
value out of range raises :class:`~mitsar.errors.ParameterError` naming the file, the key path
(e.g. ``radar.prf`` or ``targets[1].position``), what was expected and what was found. Physics
checks done by the core classes (e.g. the beat frequency at ``max_range`` above Nyquist, raised
by :class:`~mitsar.model.radar.Radar`) are re-raised with the key path prefixed.
"""

from __future__ import annotations

import copy
import dataclasses
import json
import os
import tomllib
from collections.abc import Callable, Mapping, Sequence
from pathlib import Path
from typing import Any

from mitsar.errors import MitsarError, ParameterError
from mitsar.experiment.options import Experiment, FocusOptions, MetricsOptions
from mitsar.experiment.parsers import (
    check_grid,
    parse_background,
    parse_flight,
    parse_focus,
    parse_grid,
    parse_interferometry,
    parse_look,
    parse_mapping,
    parse_metrics,
    parse_motion,
    parse_pass,
    parse_radar,
    parse_scene,
    parse_simulation,
    parse_target,
)
from mitsar.experiment.table import Table
from mitsar.model.radar import Radar

__all__ = [
    "apply_overrides",
    "experiment_from_dict",
    "focus_options_from_config",
    "load_experiment",
    "load_grid",
    "metrics_options_from_config",
    "read_toml",
]


def experiment_from_dict(data: Mapping[str, Any], source: str | os.PathLike | None = None,
                         base: str | os.PathLike | None = None) -> Experiment:
    """Validate an experiment given as a (TOML-like) dict.

    Parameters
    ----------
    data : mapping
        The parsed TOML document.
    source : path-like, optional
        The file it came from (used in error messages and recorded).
    base : path-like, optional
        Folder against which relative paths are resolved; the folder of ``source`` by default,
        else the current folder.

    Returns
    -------
    Experiment

    Raises
    ------
    ParameterError
        For any invalid key or value, naming the key path.
    """
    where = str(source) if source is not None else "experiment"
    if base is None:
        base = Path(source).resolve().parent if source is not None else Path.cwd()
    top = Table(copy.deepcopy(dict(data)), "", where, Path(base))
    name = top.string("name", "")
    description = top.string("description", "")
    scene = parse_scene(top)
    motion_table = top.table("motion")
    motion = parse_motion(motion_table)
    if motion_table is not None:
        if scene is None:
            raise top.error("motion", "no [motion] without a scene (it moves the scene's "
                            "shapes; point targets have their own velocity)", "a [motion] table")
        top.out["motion"] = motion_table.out
    radar = parse_radar(top.table("radar") or Table({}, "radar", where, top.base))
    top.out["radar"] = _radar_config(radar)
    # [[passes]] (docs/experiments.md §Passes): with passes, [trajectory] and [look] are what
    # every pass inherits, and may be left out when each pass gives its own.
    pass_tables = top.tables("passes")
    trajectory_table = top.table("trajectory", required=not pass_tables)
    trajectory = navigation = look = None
    if trajectory_table is not None:
        trajectory, navigation = parse_flight(trajectory_table)
        top.out["trajectory"] = trajectory_table.out
    look_table = top.table("look", required=not pass_tables)
    if look_table is not None:
        look = parse_look(look_table)
        top.out["look"] = look_table.out
    passes = tuple(parse_pass(table, index, None if trajectory_table is None
                              else trajectory_table.data,
                              None if look_table is None else look_table.data)
                   for index, table in enumerate(pass_tables))
    if passes:  # tools that fly one track fly pass 0
        top.out["passes"] = [table.out for table in pass_tables]
        trajectory, look, navigation = (passes[0].trajectory, passes[0].look,
                                        passes[0].navigation)
    targets = []
    target_tables = top.tables("targets")
    for table in target_tables:
        targets.append(parse_target(table))
    top.out["targets"] = [table.out for table in target_tables]
    background_table = top.table("background")
    background = None
    if background_table is not None:
        background = parse_background(background_table)
        top.out["background"] = background_table.out
    if not targets and background is None and scene is None:
        raise top.error("targets", "at least one [[targets]] entry, a [background] or a scene",
                        "none of them")
    sections = {}
    for key, parser in (("simulation", parse_simulation), ("focus", parse_focus),
                        ("metrics", parse_metrics)):
        table = top.table(key)
        sections[key] = parser(table)
        top.out[key] = table.out if table is not None else {}
    interferometry_table = top.table("interferometry")
    interferometry = parse_interferometry(interferometry_table, radar.channel_count)
    if interferometry_table is not None:
        top.out["interferometry"] = interferometry_table.out
    mapping_table = top.table("mapping")
    mapping = parse_mapping(mapping_table, scene is not None)
    if mapping_table is not None:
        top.out["mapping"] = mapping_table.out
    top.finish()
    config = json.loads(json.dumps(top.out))
    return Experiment(radar=radar, trajectory=trajectory, navigation=navigation, look=look,
                      targets=targets,
                      background=background, simulation=sections["simulation"],
                      focus=sections["focus"], metrics=sections["metrics"], scene=scene,
                      motion=motion, interferometry=interferometry, name=name,
                      description=description,
                      source=Path(source).resolve() if source is not None else None,
                      config=config, passes=passes, mapping=mapping)


def _radar_config(radar: Radar) -> dict[str, Any]:
    """The radar's effective parameters (None and a false ``ping_pong`` dropped; elements
    with their own beam as tables) for the config record."""
    config = {f.name: getattr(radar, f.name) for f in dataclasses.fields(radar)
              if f.init and getattr(radar, f.name) is not None
              and getattr(radar, f.name) is not False}
    for name in ("receivers", "transmitters"):
        elements = getattr(radar, f"{name[:-1]}_elements") or ()
        if any(e.has_own_beam for e in elements):
            config[name] = [e.to_dict() for e in elements]
    return config


def load_experiment(path: str | os.PathLike, overrides: Sequence[str] = ()) -> Experiment:
    """Read and validate a TOML experiment file.

    Parameters
    ----------
    path : path-like
        The ``.toml`` file. Relative paths inside it (``scene``, navigation ``file``) are
        resolved against its folder.
    overrides : sequence of str
        ``"key.path=value"`` changes applied before validation (:func:`apply_overrides`; the
        CLI's ``--set``).

    Returns
    -------
    experiment : Experiment
        Validated as by :func:`experiment_from_dict`, with ``source`` set to ``path``.

    Raises
    ------
    MitsarError
        If the file is missing or not valid TOML.
    ParameterError
        For an invalid key or value (names the key path, the expectation and what was found).

    Examples
    --------
    >>> exp = load_experiment(example_path("paper_point_target"))  # doctest: +SKIP
    >>> exp.radar.prf  # doctest: +SKIP
    250.0
    """
    path = Path(path)
    return experiment_from_dict(apply_overrides(read_toml(path), overrides, str(path)),
                                source=path)


def apply_overrides(document: dict[str, Any], overrides: Sequence[str],
                    where: str = "--set") -> dict[str, Any]:
    """Set keys of a TOML document from ``"key.path=value"`` strings (in place, returned).

    ``value`` is read as a TOML value (``-10``, ``0.5``, ``true``, ``[1, 2, 3]``,
    ``"text"``); anything that is not one is taken as a string (``algorithm=wda``). Tables along
    the path are created; an entry of an array of tables is addressed by its index
    (``targets.0.rcs=2``). The validation that follows names any key that does not exist.

    Raises
    ------
    ParameterError
        For an override without ``=`` or with an empty key, or a path through a value that is
        not a table.
    """
    for override in overrides:
        key, sep, text = override.partition("=")
        parts = [p.strip() for p in key.strip().split(".")]
        if not sep or not all(parts):
            raise ParameterError(where, "--set", "KEY=VALUE with a dotted key, e.g. "
                                 "background.cell_rcs_db=-10", override)
        try:
            value = tomllib.loads(f"value = {text.strip()}")["value"]
        except tomllib.TOMLDecodeError:
            value = text.strip()
        node: Any = document
        for depth, part in enumerate(parts[:-1]):
            if isinstance(node, list) and part.isdigit() and int(part) < len(node):
                node = node[int(part)]
                continue
            if not isinstance(node, dict):
                raise ParameterError(where, ".".join(parts[:depth + 1]), "a table to set a "
                                     "key in", override)
            node = node.setdefault(part, {})
        last = parts[-1]
        if isinstance(node, list) and last.isdigit() and int(last) < len(node):
            node[int(last)] = value
        elif isinstance(node, dict):
            node[last] = value
        else:
            raise ParameterError(where, key, "a key of a table", override)
    return document


def load_grid(path: str | os.PathLike) -> dict[str, Any]:
    """Read and validate an output grid from a TOML file.

    The grid is the file's ``[grid]`` table, or its ``[focus.grid]`` table (so an experiment
    file can be given), or else the file's top-level keys (``kind``, ``along_track``, ...).

    Parameters
    ----------
    path : path-like
        The ``.toml`` file.

    Returns
    -------
    dict
        The validated grid table (see :func:`mitsar.focus.grid.from_dict`).

    Raises
    ------
    ParameterError
        For an invalid key or value (names the key path).
    """
    data = read_toml(Path(path))
    prefix = ""
    if isinstance(data.get("grid"), dict):
        data, prefix = data["grid"], "grid"
    elif isinstance(data.get("focus"), dict) and isinstance(data["focus"].get("grid"), dict):
        data, prefix = data["focus"]["grid"], "focus.grid"
    table = Table(data, prefix, str(path), Path(path).resolve().parent)
    grid = parse_grid(table)
    options = FocusOptions(grid=grid)
    check_grid(Table({}, prefix.rpartition(".")[0], str(path), table.base), options)
    return grid


def read_toml(path: Path) -> dict[str, Any]:
    """Parse a TOML file, with clear errors for a missing or malformed file."""
    if not path.is_file():
        raise MitsarError(f"{path}: no such file")
    try:
        return tomllib.loads(path.read_text(encoding="utf-8"))
    except tomllib.TOMLDecodeError as error:
        raise MitsarError(f"{path}: not a valid TOML file: {error}") from error
    except UnicodeDecodeError as error:
        raise MitsarError(f"{path}: not a text (UTF-8) TOML file: {error}") from error


def focus_options_from_config(config: Mapping[str, Any] | str,
                              where: str = "experiment") -> FocusOptions:
    """Focus options from an experiment config (dict or its JSON string)."""
    return _options_from_config(config, "focus", parse_focus, where)


def metrics_options_from_config(config: Mapping[str, Any] | str,
                                where: str = "experiment") -> MetricsOptions:
    """Metrics options from an experiment config (dict or its JSON string)."""
    return _options_from_config(config, "metrics", parse_metrics, where)


def _options_from_config(config: Mapping[str, Any] | str, key: str,
                         parser: Callable[[Table], Any], where: str) -> Any:
    """Parse table ``key`` of an experiment config (dict or JSON string) with ``parser``."""
    config = json.loads(config) if isinstance(config, str) else config
    table = config.get(key) or {}
    return parser(Table(copy.deepcopy(table), key, where, Path.cwd()))
