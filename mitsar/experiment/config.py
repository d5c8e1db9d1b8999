"""TOML experiment files: a whole acquisition and its processing in one validated file.

An experiment file has the tables ``[radar]``, ``[trajectory]``, ``[look]``, ``[[targets]]``,
``[background]`` (optional), ``[simulation]``, ``[focus]`` (with ``[focus.grid]``) and
``[metrics]``, and the optional top-level keys ``name``, ``description`` and ``scene``. Every key,
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
import difflib
import json
import math
import os
import sys
import tomllib
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from mitsar.errors import MitsarError, ParameterError
from mitsar.focus import ALGORITHMS as _FOCUS_ALGORITHMS
from mitsar.focus.windows import WINDOWS as _WINDOWS
from mitsar.model.geometry.attitude import Look
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.quality.impulse import ISLR_EXTENTS as _QUALITY_EXTENTS
from mitsar.model.radar import Radar
from mitsar.model.targets import Background, PointTarget

__all__ = [
    "ALGORITHMS",
    "ISLR_EXTENTS",
    "WINDOWS",
    "Experiment",
    "FocusOptions",
    "MetricsOptions",
    "SimulationOptions",
    "example_path",
    "examples_dir",
    "experiment_from_dict",
    "focus_options_from_config",
    "load_experiment",
    "load_grid",
    "metrics_options_from_config",
    "run_focus",
    "run_metrics",
    "run_simulation",
]

ALGORITHMS = tuple(_FOCUS_ALGORITHMS)
"""Focusing algorithms accepted by ``[focus] algorithm``."""

ISLR_EXTENTS = tuple(_QUALITY_EXTENTS)
"""Named ISLR side-lobe extents accepted by ``[metrics] islr_extent`` (or a number of cells)."""

WINDOWS = tuple(_WINDOWS)
"""Spectral windows accepted by ``[focus] window``."""

GRID_KINDS = ("slant", "plane", "points")
"""Output grid kinds accepted by ``[focus.grid] kind``."""

_MISSING = object()


# --- options --------------------------------------------------------------------------------
@dataclass(frozen=True)
class SimulationOptions:
    """Options of the analytic simulator (``[simulation]``).

    Attributes
    ----------
    seed : int
        Seed of the background and noise draws.
    rvp : bool
        Keep the residual video phase in the raw data.
    normalized : bool
        Unit amplitude per unit RCS (paper eq. 1) instead of the radar equation.
    noise : bool
        Add receiver noise (needs ``radar.noise_figure_db``).
    scatterer_density : float or None
        Surface scatterers per m^2 for a scene (default: the integrator's, >= 9 per cell).
    orders : list of int or None
        Path orders kept from a scene (0: direct backscatter); default all.
    max_depth, rays, ray_cover, ghosts, plane_normal, slab_width
        Multipath options of a scene (:func:`mitsar.raw.traced.trace`); ``None``: the scene
        integrator's (default: direct backscatter only, 3D).
    """

    seed: int = 0
    rvp: bool = True
    normalized: bool = False
    noise: bool = False
    scatterer_density: float | None = None
    orders: tuple[int, ...] | None = None
    max_depth: int | None = None
    rays: int | None = None
    ray_cover: float | None = None
    ghosts: bool | None = None
    plane_normal: tuple[float, float, float] | None = None
    slab_width: float | None = None

    def multipath(self) -> dict[str, Any]:
        """The multipath keyword arguments of :func:`mitsar.raw.traced.simulate_scene`."""
        return {"max_depth": self.max_depth, "rays": self.rays, "ray_cover": self.ray_cover,
                "ghosts": self.ghosts, "plane_normal": self.plane_normal,
                "slab_width": self.slab_width}


@dataclass(frozen=True)
class FocusOptions:
    """Focusing options (``[focus]``).

    Attributes
    ----------
    algorithm : {"bpa", "rda", "wda", "fsa"}
        Focusing algorithm.
    window : str
        Spectral window of range and azimuth compression (``"rect"`` = none).
    azimuth_resolution : float or None
        Processed azimuth resolution [m]; ``None`` uses the full beam.
    grid : dict or None
        The ``[focus.grid]`` table (see :func:`mitsar.focus.grid.from_dict`); ``None`` lets the
        algorithm choose its default slant-range grid.
    """

    algorithm: str = "bpa"
    window: str = "rect"
    azimuth_resolution: float | None = None
    grid: dict[str, Any] | None = None

    def make_grid(self) -> Any:
        """The output grid object, or ``None`` for the algorithm's default grid."""
        if self.grid is None:
            return None
        from mitsar.focus import grid as grid_module

        return grid_module.from_dict(copy.deepcopy(self.grid))


@dataclass(frozen=True)
class MetricsOptions:
    """Image-quality options (``[metrics]``).

    Attributes
    ----------
    target : tuple of float or None
        World position [m] of the target to measure; ``None`` means the first point target.
    islr_extent : str or float
        Side-lobe extent of the ISLR: ``"paper"`` (+-5 cells), ``"isce3"`` (+-11 cells),
        ``"chip"``, ``"inf"`` or a number of resolution cells (see :mod:`mitsar.quality.impulse`).
    """

    target: tuple[float, float, float] | None = None
    islr_extent: str | float = "paper"


@dataclass
class Experiment:
    """A validated experiment (see :func:`load_experiment`).

    Attributes
    ----------
    radar : Radar
    trajectory : Trajectory
    look : Look
    targets : list of PointTarget
    background : Background or None
    simulation : SimulationOptions
    focus : FocusOptions
    metrics : MetricsOptions
    scene : str or None
        A scene file (absolute path) or a canned scene name, for scene-based simulation.
    name, description : str
        Free text from the file.
    source : Path or None
        The TOML file the experiment was read from.
    config : dict
        The effective configuration (defaults filled in, paths resolved); JSON-serialisable,
        and :func:`experiment_from_dict` of it gives the same experiment.
    """

    radar: Radar
    trajectory: Trajectory
    look: Look
    targets: list[PointTarget]
    background: Background | None
    simulation: SimulationOptions
    focus: FocusOptions
    metrics: MetricsOptions
    scene: str | None = None
    name: str = ""
    description: str = ""
    source: Path | None = None
    config: dict[str, Any] = field(default_factory=dict)

    def metrics_target(self) -> tuple[float, float, float] | None:
        """The target to measure: ``[metrics] target``, else the first point target."""
        if self.metrics.target is not None:
            return self.metrics.target
        if self.targets:
            return tuple(float(v) for v in np.asarray(self.targets[0].position))
        return None


# --- the validating reader ------------------------------------------------------------------
def _describe(value: Any) -> Any:
    """A short description of a found value for error messages."""
    if isinstance(value, dict):
        return f"a table with keys {sorted(value)}"
    return value


def _type_name(value: Any) -> str:
    return {bool: "boolean", int: "integer", float: "number", str: "string", list: "array",
            dict: "table"}.get(type(value), type(value).__name__)


class _Table:
    """A TOML table being validated; records the keys read and the effective values.

    Parameters
    ----------
    data : mapping
        The table's content.
    path : str
        Its key path (``"radar"``, ``"targets[0]"``, ``""`` for the top level).
    where : str
        The file name (or ``"experiment"``) used in error messages.
    base : Path
        Folder against which relative file paths are resolved.
    """

    def __init__(self, data: Any, path: str, where: str, base: Path) -> None:
        if not isinstance(data, dict):
            raise ParameterError(where, path, "a table", _describe(data))
        self.data = data
        self.path = path
        self.where = where
        self.base = base
        self.seen: set[str] = set()
        self.out: dict[str, Any] = {}

    # helpers
    def key(self, name: str) -> str:
        """Full key path of ``name``."""
        return f"{self.path}.{name}" if self.path else name

    def error(self, name: str, expected: str, found: Any) -> ParameterError:
        """A ParameterError for key ``name`` of this table."""
        return ParameterError(self.where, self.key(name), expected, _describe(found))

    def has(self, name: str) -> bool:
        """True if the key is present."""
        return name in self.data

    def _absent(self, name: str, default: Any, expected: str) -> bool:
        """Mark ``name`` as read; True if it is absent (and optional, else raise)."""
        self.seen.add(name)
        if name in self.data:
            return False
        if default is _MISSING:
            raise self.error(name, f"{expected} (required key)", "nothing")
        if default is not None:
            self.out[name] = list(default) if isinstance(default, tuple) else default
        return True

    # scalar readers
    def number(self, name: str, default: Any = _MISSING, unit: str = "",
               gt: float | None = None, ge: float | None = None, lt: float | None = None,
               le: float | None = None) -> float | None:
        """A finite number (TOML integer or float), with optional bounds."""
        expected = _number_expectation(unit, gt, ge, lt, le)
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if isinstance(value, bool) or not isinstance(value, int | float):
            raise self.error(name, expected, f"{value!r} ({_type_name(value)})")
        value = float(value)
        if not math.isfinite(value) or not _in_bounds(value, gt, ge, lt, le):
            raise self.error(name, expected, value)
        self.out[name] = value
        return value

    def integer(self, name: str, default: Any = _MISSING, ge: int | None = None) -> int | None:
        """An integer, with an optional lower bound."""
        expected = "an integer" + (f" >= {ge}" if ge is not None else "")
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if isinstance(value, bool) or not isinstance(value, int):
            raise self.error(name, expected, f"{value!r} ({_type_name(value)})")
        if ge is not None and value < ge:
            raise self.error(name, expected, value)
        self.out[name] = value
        return value

    def boolean(self, name: str, default: Any = _MISSING) -> bool | None:
        """A TOML boolean (true/false)."""
        if self._absent(name, default, "true or false"):
            return default
        value = self.data[name]
        if not isinstance(value, bool):
            raise self.error(name, "true or false", f"{value!r} ({_type_name(value)})")
        self.out[name] = value
        return value

    def string(self, name: str, default: Any = _MISSING,
               choices: tuple[str, ...] | None = None) -> str | None:
        """A string, optionally one of ``choices``."""
        expected = ("one of " + ", ".join(repr(c) for c in choices)) if choices else "a string"
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if not isinstance(value, str) or (choices and value not in choices):
            shown = value if isinstance(value, str) else f"{value!r} ({_type_name(value)})"
            raise self.error(name, expected, shown)
        self.out[name] = value
        return value

    # vectors
    def vector(self, name: str, length: int, default: Any = _MISSING,
               unit: str = "") -> tuple[float, ...] | None:
        """A list of ``length`` finite numbers."""
        expected = f"an array of {length} numbers" + (f" [{unit}]" if unit else "")
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        vec = _as_vector(value, length)
        if vec is None:
            raise self.error(name, expected, _found_array(value))
        self.out[name] = list(vec)
        return vec

    def vectors(self, name: str, length: int, min_count: int = 1, default: Any = _MISSING,
                unit: str = "") -> list[tuple[float, ...]] | None:
        """A list of at least ``min_count`` vectors of ``length`` numbers."""
        expected = (f"an array of at least {min_count} arrays of {length} numbers"
                    + (f" [{unit}]" if unit else ""))
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        if not isinstance(value, list) or len(value) < min_count:
            raise self.error(name, expected, _found_array(value))
        out = []
        for i, item in enumerate(value):
            vec = _as_vector(item, length)
            if vec is None:
                raise self.error(f"{name}[{i}]", f"an array of {length} numbers"
                                 + (f" [{unit}]" if unit else ""), _found_array(item))
            out.append(vec)
        self.out[name] = [list(v) for v in out]
        return out

    def numbers(self, name: str, min_count: int = 1, default: Any = _MISSING,
                unit: str = "") -> list[float] | None:
        """A list of at least ``min_count`` finite numbers."""
        expected = f"an array of at least {min_count} numbers" + (f" [{unit}]" if unit else "")
        if self._absent(name, default, expected):
            return default
        value = self.data[name]
        vec = _as_vector(value, len(value)) if isinstance(value, list) else None
        if vec is None or len(vec) < min_count:
            raise self.error(name, expected, _found_array(value))
        self.out[name] = list(vec)
        return list(vec)

    def path_value(self, name: str, default: Any = None) -> Path | None:
        """A file path, resolved against the experiment file's folder."""
        value = self.string(name, default)
        if value is None:
            return None
        path = Path(value).expanduser()
        if not path.is_absolute():
            path = (self.base / path).resolve()
        self.out[name] = str(path)
        return path

    # sub-tables
    def table(self, name: str, required: bool = False) -> _Table | None:
        """A sub-table, or ``None`` when absent and not required."""
        self.seen.add(name)
        if name not in self.data:
            if required:
                raise self.error(name, "a table (required)", "nothing")
            return None
        return _Table(self.data[name], self.key(name), self.where, self.base)

    def tables(self, name: str) -> list[_Table]:
        """An array of tables (``[[name]]``); empty when absent."""
        self.seen.add(name)
        value = self.data.get(name, [])
        if not isinstance(value, list):
            raise self.error(name, "an array of tables ([[" + self.key(name) + "]])",
                             _describe(value))
        return [_Table(item, f"{self.key(name)}[{i}]", self.where, self.base)
                for i, item in enumerate(value)]

    def finish(self) -> dict[str, Any]:
        """Refuse unknown keys; return the effective values."""
        for name in self.data:
            if name not in self.seen:
                known = sorted(self.seen)
                close = difflib.get_close_matches(name, known, n=1)
                hint = f" (did you mean '{close[0]}'?)" if close else ""
                where = f"[{self.path}]" if self.path else "the top level"
                raise self.error(name, f"one of the keys of {where}: {', '.join(known)}{hint}",
                                 self.data[name])
        return self.out


def _number_expectation(unit: str, gt: float | None, ge: float | None, lt: float | None,
                        le: float | None) -> str:
    parts = ["a number" + (f" [{unit}]" if unit else "")]
    for op, bound in ((">", gt), (">=", ge), ("<", lt), ("<=", le)):
        if bound is not None:
            parts.append(f"{op} {bound:g}")
    return " ".join(parts[:1]) + ((" " + " and ".join(parts[1:])) if parts[1:] else "")


def _in_bounds(value: float, gt: float | None, ge: float | None, lt: float | None,
               le: float | None) -> bool:
    return ((gt is None or value > gt) and (ge is None or value >= ge)
            and (lt is None or value < lt) and (le is None or value <= le))


def _as_vector(value: Any, length: int) -> tuple[float, ...] | None:
    """``value`` as ``length`` finite floats, or ``None`` if it is not such a list."""
    if not isinstance(value, list) or len(value) != length:
        return None
    if any(isinstance(v, bool) or not isinstance(v, int | float) for v in value):
        return None
    vec = tuple(float(v) for v in value)
    return vec if all(math.isfinite(v) for v in vec) else None


def _found_array(value: Any) -> Any:
    if isinstance(value, list):
        return f"{value!r} ({len(value)} items)"
    return f"{_describe(value)!r} ({_type_name(value)})"


@contextmanager
def _prefixed(table: _Table, prefix: str | None = None) -> Iterator[None]:
    """Re-raise a core class's ParameterError with the file name and key path."""
    try:
        yield
    except ParameterError as error:
        if error.where == table.where:
            raise
        key = f"{prefix if prefix is not None else table.path}.{error.name}".lstrip(".")
        raise ParameterError(table.where, key, error.expected, error.found) from error


# --- tables ---------------------------------------------------------------------------------
def _parse_radar(t: _Table) -> Radar:
    """``[radar]``: every :class:`~mitsar.model.radar.Radar` field, defaults from Table 1."""
    kwargs: dict[str, Any] = {}
    for f in dataclasses.fields(Radar):
        if f.name.endswith("_db"):
            value = t.number(f.name, f.default, unit="dB")
        elif f.name.endswith("_deg"):
            value = t.number(f.name, f.default, unit="deg", gt=0, lt=180)
        else:
            value = t.number(f.name, f.default, unit=_RADAR_UNITS.get(f.name, ""), gt=0)
        if value is not None:
            kwargs[f.name] = value
    t.finish()
    with _prefixed(t):
        return Radar(**kwargs)


_RADAR_UNITS = {"carrier_frequency": "Hz", "bandwidth": "Hz", "sampling_frequency": "Hz",
                "prf": "Hz", "max_range": "m", "antenna_width": "m", "antenna_length": "m",
                "transmit_power": "W"}


def _parse_trajectory(t: _Table) -> Trajectory:
    """``[trajectory]``: kind = "linear" | "waypoints" | "navigation"."""
    kind = t.string("kind", "linear", choices=("linear", "waypoints", "navigation"))
    with _prefixed(t):
        if kind == "linear":
            start = t.vector("start", 3, unit="m")
            velocity = t.vector("velocity", 3, unit="m/s")
            duration = t.number("duration", unit="s", gt=0)
            t.finish()
            return Trajectory.linear(start, velocity, duration)
        if kind == "waypoints":
            points = t.vectors("points", 3, min_count=2, unit="m")
            speed = t.number("speed", unit="m/s", gt=0)
            t.finish()
            return Trajectory.waypoints(points, speed)
        return _parse_navigation(t)


def _parse_navigation(t: _Table) -> Trajectory:
    """Navigation data inline (times, positions, ...) or from a CSV ``file``."""
    if t.has("file"):
        path = t.path_value("file")
        t.finish()
        times, positions, velocities, attitude = _read_navigation_csv(t, path)
        t.out["kind"] = "navigation"
    else:
        times = t.numbers("times", min_count=2, unit="s")
        positions = t.vectors("positions", 3, min_count=2, unit="m")
        velocities = t.vectors("velocities", 3, default=None, unit="m/s")
        attitude = t.vectors("attitude_deg", 3, default=None, unit="deg")
        t.finish()
        for name, rows in (("positions", positions), ("velocities", velocities),
                           ("attitude_deg", attitude)):
            if rows is not None and len(rows) != len(times):
                raise t.error(name, f"{len(times)} rows (one per entry of 'times')",
                              f"{len(rows)} rows")
    return Trajectory.navigation(times, positions, velocities, attitude)


_NAV_COLUMNS = {"position": ("x", "y", "z"), "velocity": ("vx", "vy", "vz"),
                "attitude": ("heading_deg", "pitch_deg", "roll_deg")}


def _read_navigation_csv(t: _Table, path: Path) -> tuple[Any, Any, Any, Any]:
    """Read ``time,x,y,z[,vx,vy,vz][,heading_deg,pitch_deg,roll_deg]`` columns from a CSV."""
    if not path.is_file():
        raise t.error("file", "an existing CSV file of navigation data", str(path))
    try:
        table = np.genfromtxt(path, delimiter=",", names=True, dtype=float, ndmin=1)
    except ValueError as error:
        raise t.error("file", "a CSV file with a header row and numeric columns",
                      f"{path} ({error})") from error
    names = table.dtype.names or ()
    required = ("time",) + _NAV_COLUMNS["position"]
    if any(c not in names for c in required):
        raise t.error("file", "CSV columns time,x,y,z (optional vx,vy,vz and "
                      "heading_deg,pitch_deg,roll_deg)", f"{path} with columns {list(names)}")

    def columns(group: str) -> Any:
        cols = _NAV_COLUMNS[group]
        if all(c in names for c in cols):
            return np.stack([table[c] for c in cols], axis=-1)
        return None

    return table["time"], columns("position"), columns("velocity"), columns("attitude")


def _parse_look(t: _Table) -> Look:
    """``[look]``: off-nadir and squint angles [deg]."""
    off_nadir = t.number("off_nadir_deg", unit="deg", ge=0, lt=180)
    squint = t.number("squint_deg", 0.0, unit="deg", gt=-90, lt=90)
    t.finish()
    with _prefixed(t):
        return Look(off_nadir, squint)


def _parse_target(t: _Table) -> PointTarget:
    """One ``[[targets]]`` entry."""
    position = t.vector("position", 3, unit="m")
    rcs = t.number("rcs", 1.0, unit="m^2", gt=0)
    velocity = t.vector("velocity", 3, (0.0, 0.0, 0.0), unit="m/s")
    t.finish()
    with _prefixed(t):
        return PointTarget(position, rcs=rcs, velocity=velocity)


def _parse_background(t: _Table) -> Background:
    """``[background]``: a fluctuating patch (paper eq. 4)."""
    center = t.vector("center", 3, unit="m")
    size = t.vector("size", 2, unit="m")
    if size is not None and min(size) <= 0:
        raise t.error("size", "2 sizes > 0 [m]", list(size))
    cell_rcs_db = t.number("cell_rcs_db", -20.0, unit="dB")
    per_cell = t.integer("scatterers_per_cell", 9, ge=1)
    mode = t.string("mode", "pulse", choices=("pulse", "frozen"))
    axis_u = t.vector("axis_u", 3, (1.0, 0.0, 0.0))
    axis_v = t.vector("axis_v", 3, (0.0, 1.0, 0.0))
    for name, axis in (("axis_u", axis_u), ("axis_v", axis_v)):
        if not np.linalg.norm(axis) > 0:
            raise t.error(name, "a non-zero direction", list(axis))
    t.finish()
    with _prefixed(t):
        return Background(center, size, cell_rcs_db=cell_rcs_db, scatterers_per_cell=per_cell,
                          mode=mode, axis_u=axis_u, axis_v=axis_v)


def _parse_simulation(t: _Table | None) -> SimulationOptions:
    """``[simulation]``: seed, rvp, normalized, noise."""
    if t is None:
        return SimulationOptions()
    orders = t.numbers("orders", 1, None)
    if orders is not None and any(o != int(o) or o < 0 for o in orders):
        raise t.error("orders", "integers >= 0 (0: direct backscatter)", orders)
    options = SimulationOptions(seed=t.integer("seed", 0, ge=0), rvp=t.boolean("rvp", True),
                                normalized=t.boolean("normalized", False),
                                noise=t.boolean("noise", False),
                                scatterer_density=t.number("scatterer_density", None,
                                                           unit="1/m^2", gt=0),
                                orders=None if orders is None else tuple(int(o) for o in orders),
                                max_depth=t.integer("max_depth", None, ge=1),
                                rays=t.integer("rays", None, ge=1),
                                ray_cover=t.number("ray_cover", None, unit="beamwidths", gt=0),
                                ghosts=t.boolean("ghosts", None),
                                plane_normal=t.vector("plane_normal", 3, None),
                                slab_width=t.number("slab_width", None, unit="m", gt=0))
    t.finish()
    return options


def _parse_focus(t: _Table | None) -> FocusOptions:
    """``[focus]``: algorithm, window, azimuth_resolution and ``[focus.grid]``."""
    if t is None:
        return FocusOptions()
    algorithm = t.string("algorithm", "bpa", choices=ALGORITHMS)
    window = t.string("window", "rect", choices=WINDOWS)
    resolution = t.number("azimuth_resolution", None, unit="m", gt=0)
    grid_table = t.table("grid")
    grid = _parse_grid(grid_table) if grid_table is not None else None
    if grid is not None:
        t.out["grid"] = grid
    t.finish()
    options = FocusOptions(algorithm, window, resolution, grid)
    _check_grid(t, options)
    return options


def _check_grid(t: _Table, options: FocusOptions) -> None:
    """Build the grid once, so grid errors surface when the file is loaded."""
    if options.grid is None:
        return
    try:
        from mitsar import grid as _grid  # noqa: F401
    except ImportError:  # grids not available in this build
        return
    with _prefixed(t, t.key("grid")):
        options.make_grid()


_GRID_KEYS = {"slant": ("along_track", "slant_range"), "plane": ("origin", "axis_u", "axis_v",
                                                                  "u", "v"),
              "points": ("points",)}


def _parse_grid(t: _Table) -> dict[str, Any]:
    """``[focus.grid]``: kind = "slant" | "plane" | "points" and its axes."""
    kind = t.string("kind", "slant", choices=GRID_KINDS)
    if kind == "slant":
        for name in ("along_track", "slant_range"):
            _axis(t, name)
    elif kind == "plane":
        for name in ("origin", "axis_u", "axis_v"):
            t.vector(name, 3, unit="m" if name == "origin" else "")
        u, v = np.asarray(t.out["axis_u"]), np.asarray(t.out["axis_v"])
        for name, axis in (("axis_u", u), ("axis_v", v)):
            if not np.linalg.norm(axis) > 0:
                raise t.error(name, "a non-zero direction", t.out[name])
        if abs(u @ v) > 1e-6 * np.linalg.norm(u) * np.linalg.norm(v):
            raise t.error("axis_v", f"a direction orthogonal to axis_u {t.out['axis_u']}",
                          t.out["axis_v"])
        for name in ("u", "v"):
            _axis(t, name)
    else:
        t.vectors("points", 3, min_count=1, unit="m")
    return t.finish()


def _axis(t: _Table, name: str) -> None:
    """A grid axis ``[start, stop, step]`` [m] with ``stop > start`` and ``step > 0``."""
    vec = t.vector(name, 3, unit="m")
    start, stop, step = vec
    if not (stop > start and step > 0):
        raise t.error(name, "[start, stop, step] with stop > start and step > 0 [m]", list(vec))


def _parse_metrics(t: _Table | None) -> MetricsOptions:
    """``[metrics]``: target position and ISLR side-lobe extent."""
    if t is None:
        return MetricsOptions()
    target = t.vector("target", 3, None, unit="m")
    t.seen.add("islr_extent")
    extent: str | float = t.data.get("islr_extent", "paper")
    expected = f"one of {', '.join(repr(e) for e in ISLR_EXTENTS)} or a number of cells > 0"
    if isinstance(extent, bool) or not (
            (isinstance(extent, str) and extent in ISLR_EXTENTS)
            or (isinstance(extent, int | float) and math.isfinite(extent) and extent > 0)):
        raise t.error("islr_extent", expected, extent)
    t.out["islr_extent"] = extent
    t.finish()
    return MetricsOptions(target, extent if isinstance(extent, str) else float(extent))


def _parse_scene(t: _Table) -> str | None:
    """``scene``: a file path (resolved against the experiment's folder) or a canned name."""
    value = t.string("scene", None)
    if value is None:
        return None
    candidate = Path(value).expanduser()
    if not candidate.is_absolute():
        candidate = t.base / candidate
    looks_like_path = ("/" in value or os.sep in value or candidate.exists()
                       or value.startswith("~"))
    if looks_like_path:
        t.out["scene"] = str(candidate.resolve())
    return t.out["scene"]


# --- entry points ---------------------------------------------------------------------------
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
    top = _Table(copy.deepcopy(dict(data)), "", where, Path(base))
    name = top.string("name", "")
    description = top.string("description", "")
    scene = _parse_scene(top)
    radar = _parse_radar(top.table("radar") or _Table({}, "radar", where, top.base))
    top.out["radar"] = _radar_config(radar)
    trajectory_table = top.table("trajectory", required=True)
    trajectory = _parse_trajectory(trajectory_table)
    top.out["trajectory"] = trajectory_table.out
    look_table = top.table("look", required=True)
    look = _parse_look(look_table)
    top.out["look"] = look_table.out
    targets = []
    target_tables = top.tables("targets")
    for table in target_tables:
        targets.append(_parse_target(table))
    top.out["targets"] = [table.out for table in target_tables]
    background_table = top.table("background")
    background = None
    if background_table is not None:
        background = _parse_background(background_table)
        top.out["background"] = background_table.out
    if not targets and background is None and scene is None:
        raise top.error("targets", "at least one [[targets]] entry, a [background] or a scene",
                        "none of them")
    sections = {}
    for key, parser in (("simulation", _parse_simulation), ("focus", _parse_focus),
                        ("metrics", _parse_metrics)):
        table = top.table(key)
        sections[key] = parser(table)
        top.out[key] = table.out if table is not None else {}
    top.finish()
    config = json.loads(json.dumps(top.out))
    return Experiment(radar=radar, trajectory=trajectory, look=look, targets=targets,
                      background=background, simulation=sections["simulation"],
                      focus=sections["focus"], metrics=sections["metrics"], scene=scene,
                      name=name, description=description,
                      source=Path(source).resolve() if source is not None else None,
                      config=config)


def _radar_config(radar: Radar) -> dict[str, Any]:
    """The radar's effective parameters (None dropped) for the config record."""
    return {f.name: getattr(radar, f.name) for f in dataclasses.fields(radar)
            if getattr(radar, f.name) is not None}


def load_experiment(path: str | os.PathLike) -> Experiment:
    """Read and validate a TOML experiment file.

    Parameters
    ----------
    path : path-like
        The ``.toml`` file. Relative paths inside it (``scene``, navigation ``file``) are
        resolved against its folder.

    Returns
    -------
    Experiment

    Raises
    ------
    ParameterError
        For an invalid key or value (names the key path, the expectation and what was found).
    MitsarError
        If the file is missing or not valid TOML.

    Examples
    --------
    >>> exp = load_experiment(example_path("paper_point_target"))  # doctest: +SKIP
    >>> exp.radar.prf  # doctest: +SKIP
    250.0
    """
    path = Path(path)
    return experiment_from_dict(_read_toml(path), source=path)


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
    data = _read_toml(Path(path))
    prefix = ""
    if isinstance(data.get("grid"), dict):
        data, prefix = data["grid"], "grid"
    elif isinstance(data.get("focus"), dict) and isinstance(data["focus"].get("grid"), dict):
        data, prefix = data["focus"]["grid"], "focus.grid"
    table = _Table(data, prefix, str(path), Path(path).resolve().parent)
    grid = _parse_grid(table)
    options = FocusOptions(grid=grid)
    _check_grid(_Table({}, prefix.rpartition(".")[0], str(path), table.base), options)
    return grid


def _read_toml(path: Path) -> dict[str, Any]:
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
    config = json.loads(config) if isinstance(config, str) else config
    table = config.get("focus") or {}
    return _parse_focus(_Table(copy.deepcopy(table), "focus", where, Path.cwd()))


def metrics_options_from_config(config: Mapping[str, Any] | str,
                                where: str = "experiment") -> MetricsOptions:
    """Metrics options from an experiment config (dict or its JSON string)."""
    config = json.loads(config) if isinstance(config, str) else config
    table = config.get("metrics") or {}
    return _parse_metrics(_Table(copy.deepcopy(table), "metrics", where, Path.cwd()))


def _supports(function: Callable[..., Any], name: str) -> bool:
    """True if ``function`` accepts a keyword argument ``name``."""
    import inspect

    try:
        parameters = inspect.signature(function).parameters
    except (TypeError, ValueError):
        return False
    return name in parameters or any(p.kind is p.VAR_KEYWORD for p in parameters.values())


def run_simulation(experiment: Experiment, progress: bool = False) -> xr.Dataset:
    """Simulate the raw product of an experiment.

    Parameters
    ----------
    experiment : Experiment
        From :func:`load_experiment`.
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        The raw product; its attributes also record the experiment (``experiment``, a JSON
        string of :attr:`Experiment.config`) and its source file (``experiment_source``).
    """
    options = experiment.simulation
    if experiment.scene is not None:
        from mitsar.raw.traced import simulate_scene

        if options.noise:
            raise MitsarError(f"{experiment.source or 'experiment'}: key 'simulation.noise': "
                              "thermal noise is not available with a scene yet")
        raw = simulate_scene(
            experiment.radar, experiment.trajectory, experiment.look, experiment.scene,
            targets=experiment.targets, background=experiment.background, seed=options.seed,
            density=options.scatterer_density, orders=options.orders, rvp=options.rvp,
            normalized=options.normalized, progress=progress, **options.multipath())
    else:
        from mitsar.raw.analytic import simulate_point_targets

        raw = simulate_point_targets(
            experiment.radar, experiment.trajectory, experiment.look, experiment.targets,
            background=experiment.background, seed=options.seed, rvp=options.rvp,
            normalized=options.normalized, noise=options.noise, progress=progress)
    raw.attrs["experiment"] = json.dumps(experiment.config)
    if experiment.source is not None:
        raw.attrs["experiment_source"] = str(experiment.source)
    if experiment.name:
        raw.attrs["experiment_name"] = experiment.name
    return raw


def run_focus(raw: xr.Dataset, options: FocusOptions, progress: bool = False) -> xr.Dataset:
    """Focus a raw product with the given options.

    The image keeps the raw product's experiment record (``experiment`` and
    ``experiment_source`` attributes), so that metrics can find their target.

    Parameters
    ----------
    raw : xarray.Dataset
        A raw product.
    options : FocusOptions
        Algorithm, window, azimuth resolution and grid.
    progress : bool
        Show a progress bar when the algorithm supports one.

    Returns
    -------
    xarray.Dataset
        The image product.
    """
    from mitsar.focus import focus

    kwargs: dict[str, Any] = {"window": options.window,
                              "azimuth_resolution": options.azimuth_resolution}
    if progress and _supports(focus, "progress"):
        kwargs["progress"] = True
    image = focus(raw, algorithm=options.algorithm, grid=options.make_grid(), **kwargs)
    for key in ("experiment", "experiment_source", "experiment_name"):
        if key in raw.attrs and key not in image.attrs:
            image.attrs[key] = raw.attrs[key]
    return image


def run_metrics(image: xr.Dataset, target: Any | None = None,
                islr_extent: str | float | None = None) -> dict[str, Any]:
    """Measure the impulse response of a target in an image product.

    Parameters
    ----------
    image : xarray.Dataset
        An image product.
    target : array_like of 3 floats, optional
        World position [m]; by default the ``[metrics] target`` of the image's experiment, or
        its first point target.
    islr_extent : str or float, optional
        ISLR side-lobe extent; by default from the experiment, else ``"paper"``.

    Returns
    -------
    dict
        The result of :func:`mitsar.quality.impulse.measure_impulse_response`, plus ``target`` and
        ``islr_extent``.
    """
    from mitsar.quality.impulse import measure_impulse_response

    config = image.attrs.get("experiment")
    options = metrics_options_from_config(config) if config else MetricsOptions()
    if target is None:
        target = options.target
    if target is None and config:
        targets = json.loads(config).get("targets") or []
        target = targets[0]["position"] if targets else None
    if target is None:
        raise MitsarError("metrics: no target position: give one (--target X Y Z) or set "
                          "[metrics] target in the experiment")
    target = [float(v) for v in target]
    extent = islr_extent if islr_extent is not None else options.islr_extent
    result = dict(measure_impulse_response(image, target=target, islr_extent=extent))
    result.setdefault("target", target)
    result.setdefault("islr_extent", extent)
    return result


# --- bundled examples -----------------------------------------------------------------------
def examples_dir() -> Path:
    """The folder of the bundled example experiments.

    Searched in order: ``$MITSAR_EXAMPLES``, ``examples/`` next to the ``mitsar`` package
    (a source checkout or editable install), ``<prefix>/share/mitsar/examples`` (a copy
    installed as data files).

    Raises
    ------
    MitsarError
        If none of them exists.
    """
    candidates = []
    if os.environ.get("MITSAR_EXAMPLES"):
        candidates.append(Path(os.environ["MITSAR_EXAMPLES"]))
    candidates.append(Path(__file__).resolve().parents[2] / "examples")
    candidates.append(Path(sys.prefix) / "share" / "mitsar" / "examples")
    for candidate in candidates:
        if candidate.is_dir():
            return candidate
    raise MitsarError("bundled examples not found; looked in "
                      + ", ".join(str(c) for c in candidates)
                      + " (set MITSAR_EXAMPLES to the examples folder of a mitsar checkout)")


def example_path(name: str = "paper_point_target") -> Path:
    """Path of a bundled example experiment, by name (with or without ``.toml``).

    Raises
    ------
    MitsarError
        If there is no such example (the message lists the available ones).
    """
    folder = examples_dir()
    path = folder / (name if name.endswith(".toml") else f"{name}.toml")
    if not path.is_file():
        available = sorted(p.stem for p in folder.glob("*.toml"))
        raise MitsarError(f"no bundled example {name!r} in {folder}; available: "
                          f"{', '.join(available) or 'none'}")
    return path
