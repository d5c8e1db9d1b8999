"""Parsers of the tables of an experiment file, one per table.

Each ``parse_*`` function takes a :class:`~mitsar.experiment.table.Table`, reads and checks its
keys and returns the object the table describes (a :class:`~mitsar.model.radar.Radar`, a
:class:`~mitsar.model.geometry.trajectory.Trajectory`, options ...). Physics checks done by the
core classes are re-raised with the key path prefixed (:func:`~mitsar.experiment.table.prefixed`).
Keys, types, units and defaults are documented in ``docs/experiments.md``.
"""

from __future__ import annotations

import copy
import dataclasses
import os
from pathlib import Path
from typing import Any

import numpy as np

from mitsar.errors import ParameterError
from mitsar.experiment.options import (
    ALGORITHMS,
    AUTOFOCUS_METHODS,
    GRID_KINDS,
    ISLR_EXTENTS,
    WINDOWS,
    FocusOptions,
    InterferometryOptions,
    MappingOptions,
    MetricsOptions,
    Pass,
    pass_seed,
)
from mitsar.experiment.phase_centres import parse_array, parse_phase_centres
from mitsar.experiment.table import Table, prefixed
from mitsar.focus.aperture import MAX_AZIMUTH_RESOLUTION
from mitsar.focus.grid import axis_count, require_pixels
from mitsar.model.geometry.attitude import Look
from mitsar.model.geometry.navigation import NavigationErrors
from mitsar.model.geometry.trajectory import Trajectory, is_vertical
from mitsar.model.radar import Radar
from mitsar.model.targets import Background, PointTarget
from mitsar.model.trace_options import MAX_DEPTH, TraceOptions
from mitsar.scene.motion import Motion
from mitsar.scene.motion import parse_motion as parse_motion_mapping

__all__ = [
    "check_grid",
    "merge_trajectory",
    "parse_axis",
    "parse_background",
    "parse_focus",
    "parse_grid",
    "parse_interferometry",
    "parse_look",
    "parse_metrics",
    "parse_navigation",
    "parse_pass",
    "parse_radar",
    "parse_scene",
    "parse_simulation",
    "parse_target",
    "parse_flight",
    "parse_navigation_errors",
    "parse_trajectory",
    "read_navigation_csv",
]


def parse_radar(t: Table) -> Radar:
    """``[radar]``: every :class:`~mitsar.model.radar.Radar` field, defaults from Table 1;
    ``receivers`` / ``transmitters`` as arrays of body-frame 3-vectors [m] or as arrays of
    tables (``[[radar.receivers]]`` with ``position = [x, y, z]``), and ``ping_pong`` for a
    multi-channel (interferometric) radar."""
    kwargs: dict[str, Any] = {}
    array = parse_array(t)
    for f in dataclasses.fields(Radar):
        if not f.init:  # derived (the elements of receivers/transmitters)
            continue
        if f.name in ("receivers", "transmitters"):  # phase centres (docs/interferometry.md)
            if array is not None and t.has(f.name):
                raise t.error(f.name, "no receivers/transmitters key with a [radar.array] "
                              "table (give the phase centres as a uniform array or as a "
                              "list, not both)", t.data[f.name])
            value = None if array is not None else parse_phase_centres(t, f.name)
        elif f.name == "ping_pong":
            value = t.boolean(f.name, False) or None
        elif f.name.endswith("_db"):
            value = t.number(f.name, f.default, unit="dB")
        elif f.name.endswith("_deg"):
            value = t.number(f.name, f.default, unit="deg", gt=0, lt=180)
        else:
            value = t.number(f.name, f.default, unit=_RADAR_UNITS.get(f.name, ""), gt=0)
        if value is not None:
            kwargs[f.name] = value
    t.finish()
    with prefixed(t):
        return Radar(**kwargs) if array is None else Radar.array(array, **kwargs)


_RADAR_UNITS = {"carrier_frequency": "Hz", "bandwidth": "Hz", "sampling_frequency": "Hz",
                "prf": "Hz", "max_range": "m", "antenna_width": "m", "antenna_length": "m",
                "transmit_power": "W"}


def parse_trajectory(t: Table) -> Trajectory:
    """``[trajectory]``: kind = "linear" | "waypoints" | "flight" | "navigation"."""
    kind = t.string("kind", "linear", choices=("linear", "waypoints", "flight", "navigation"))
    with prefixed(t):
        if kind == "linear":
            start = t.vector("start", 3, unit="m")
            velocity = t.vector("velocity", 3, unit="m/s")
            duration = t.number("duration", unit="s", gt=0)
            t.finish()
            if is_vertical(np.asarray(velocity)[None]):
                raise t.error("velocity", "a velocity with a horizontal component (the heading "
                              "follows it; for a vertical climb use kind = 'navigation' with "
                              "attitude_deg)", list(velocity))
            return Trajectory.linear(start, velocity, duration)
        if kind == "waypoints":
            points = t.vectors("points", 3, min_count=2, unit="m")
            speed = t.number("speed", unit="m/s", gt=0)
            t.finish()
            if is_vertical(np.diff(np.asarray(points, dtype=float), axis=0)):
                raise t.error("points", "legs with a horizontal component (the heading follows "
                              "them; for a vertical climb use kind = 'flight' or 'navigation')",
                              [list(p) for p in points])
            return Trajectory.waypoints(points, speed)
        if kind == "flight":
            points = t.vectors("points", 3, min_count=2, unit="m")
            speed = (t.numbers("speed", min_count=1, unit="m/s")
                     if isinstance(t.data.get("speed"), list)
                     else t.number("speed", unit="m/s", gt=0))
            options = {"turn_radius": t.number("turn_radius", 0.0, unit="m", ge=0),
                       "acceleration": t.number("acceleration", None, unit="m/s^2", gt=0),
                       "hover": t.number("hover", 0.0, unit="s", ge=0)}
            t.finish()
            return Trajectory.flight(points, speed, **options)
        return parse_navigation(t)


def parse_flight(t: Table) -> tuple[Trajectory, NavigationErrors | None]:
    """``[trajectory]`` with its optional ``[trajectory.errors]``: the true track and what the
    navigation system records of it (docs/navigation.md)."""
    errors_table = t.table("errors")
    trajectory = parse_trajectory(t)
    if errors_table is None:
        return trajectory, None
    errors = parse_navigation_errors(errors_table)
    t.out["errors"] = errors_table.out
    return trajectory, errors


_ERROR_VECTORS = (("position_offset", "m"), ("position_random_walk", "m/sqrt(s)"),
                  ("position_noise", "m"), ("attitude_offset_deg", "deg"),
                  ("attitude_random_walk_deg", "deg/sqrt(s)"), ("attitude_noise_deg", "deg"),
                  ("lever_arm", "m"))


def parse_navigation_errors(t: Table) -> NavigationErrors:
    """``[trajectory.errors]``: the fields of :class:`NavigationErrors`, vibrations as
    ``[[trajectory.errors.vibration]]`` tables (amplitude [m], frequency [Hz], phase [rad])."""
    values: dict[str, Any] = {"seed": _seed(t)}
    for name, unit in _ERROR_VECTORS:
        vec = t.vector(name, 3, default=None, unit=unit)
        if vec is not None:
            values[name] = vec
    for name, unit in (("position_correlation_time", "s"), ("attitude_correlation_time", "s"),
                       ("sample_rate", "Hz")):
        number = t.number(name, None, unit=unit, gt=0)
        if number is not None:
            values[name] = number
    vibrations = []
    for table in t.tables("vibration"):
        vibrations.append({"amplitude": table.vector("amplitude", 3, unit="m"),
                           "frequency": table.number("frequency", unit="Hz", gt=0),
                           "phase": table.number("phase", 0.0, unit="rad")})
        table.finish()
    t.out["vibration"] = vibrations
    t.finish()
    with prefixed(t):
        return NavigationErrors(vibration=tuple(vibrations), **values)


MAX_SEED = 2**63 - 1
"""Largest seed: products record it as a 64-bit integer."""


def _seed(t: Table) -> int:
    seed = t.integer("seed", 0, ge=0)
    if seed > MAX_SEED:
        raise t.error("seed", f"an integer in [0, {MAX_SEED}] (recorded as 64 bits)", seed)
    return seed


def parse_navigation(t: Table) -> Trajectory:
    """Navigation data inline (times, positions, ...) or from a CSV ``file``."""
    if t.has("file"):
        path = t.path_value("file")
        t.finish()
        times, positions, velocities, attitude = read_navigation_csv(t, path)
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


def read_navigation_csv(t: Table, path: Path) -> tuple[Any, Any, Any, Any]:
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


def parse_look(t: Table) -> Look:
    """``[look]``: off-nadir and squint angles [deg]."""
    off_nadir = t.number("off_nadir_deg", unit="deg", ge=0, lt=180)
    squint = t.number("squint_deg", 0.0, unit="deg", gt=-90, lt=90)
    t.finish()
    with prefixed(t):
        return Look(off_nadir, squint)


def parse_target(t: Table) -> PointTarget:
    """One ``[[targets]]`` entry."""
    position = t.vector("position", 3, unit="m")
    rcs = t.number("rcs", 1.0, unit="m^2", gt=0)
    velocity = t.vector("velocity", 3, (0.0, 0.0, 0.0), unit="m/s")
    t.finish()
    with prefixed(t):
        return PointTarget(position, rcs=rcs, velocity=velocity)


def parse_background(t: Table) -> Background:
    """``[background]``: a fluctuating patch (paper eq. 4)."""
    center = t.vector("center", 3, unit="m")
    size = t.vector("size", 2, unit="m")
    if size is not None and min(size) <= 0:
        raise t.error("size", "2 sizes > 0 [m]", list(size))
    cell_rcs_db = t.number("cell_rcs_db", -20.0, unit="dB")
    per_cell = t.integer("scatterers_per_cell", 9, ge=1)
    mode = t.string("mode", "pulse", choices=("pulse", "frozen"))
    axis_u = t.vector("axis_u", 3, (1.0, 0.0, 0.0), unit="direction")
    axis_v = t.vector("axis_v", 3, (0.0, 1.0, 0.0), unit="direction")
    for name, axis in (("axis_u", axis_u), ("axis_v", axis_v)):
        if not np.linalg.norm(axis) > 0:
            raise t.error(name, "a non-zero direction", list(axis))
    t.finish()
    with prefixed(t):
        return Background(center, size, cell_rcs_db=cell_rcs_db, scatterers_per_cell=per_cell,
                          mode=mode, axis_u=axis_u, axis_v=axis_v)


def parse_simulation(t: Table | None) -> TraceOptions:
    """``[simulation]``: the experiment's layer of the trace request (seed, rvp, normalized,
    noise and physical_optics always set, with their defaults; the tracer's options only where
    the file gives them, so the rest falls to the scene's integrator)."""
    if t is None:
        return TraceOptions(seed=0, rvp=True, normalized=False, noise=False,
                            physical_optics=False)
    orders = t.numbers("orders", 1, None)
    if orders is not None and any(not 0 <= o <= MAX_DEPTH or o != int(o) for o in orders):
        raise t.error("orders", f"integers in [0, {MAX_DEPTH}] (0: direct backscatter; a ray "
                      f"makes at most {MAX_DEPTH} hits)", orders)
    options = TraceOptions(seed=_seed(t), rvp=t.boolean("rvp", True),
                           normalized=t.boolean("normalized", False),
                           noise=t.boolean("noise", False),
                           scatterer_density=t.number("scatterer_density", None,
                                                      unit="1/m^2", gt=0),
                           orders=None if orders is None else tuple(int(o) for o in orders),
                           max_depth=t.integer("max_depth", None, ge=1),
                           rays=t.integer("rays", None, ge=1),
                           ray_cover=t.number("ray_cover", None, unit="beamwidths", gt=0),
                           ghosts=t.boolean("ghosts", None),
                           plane_normal=t.vector("plane_normal", 3, None, unit="direction"),
                           slab_width=t.number("slab_width", None, unit="m", gt=0),
                           physical_optics=_physical_optics(t),
                           visibility_feature=t.number("visibility_feature", None,
                                                       unit="m", ge=0),
                           block_kernel=t.boolean("block_kernel", None),
                           receiver_visibility=t.boolean("receiver_visibility", None))
    t.finish()
    with prefixed(t):  # every field over the defaults, at load, whatever the command (issue 27)
        options.resolve("TraceOptions")
    return options


def _physical_optics(t: Table) -> bool | tuple[str, ...]:
    """``physical_optics``: true/false or an array of shape ids (docs/physical_optics.md §5)."""
    value = t.data.get("physical_optics", False)
    if isinstance(value, bool):
        return bool(t.boolean("physical_optics", False))
    if isinstance(value, list) and value and all(isinstance(v, str) for v in value):
        t.seen.add("physical_optics")
        t.out["physical_optics"] = list(value)
        return tuple(value)
    raise t.error("physical_optics", "true, false or an array of shape ids", value)


def parse_focus(t: Table | None) -> FocusOptions:
    """``[focus]``: algorithm, window, azimuth_resolution, autofocus, band_limit and
    ``[focus.grid]``."""
    if t is None:
        return FocusOptions()
    algorithm = t.string("algorithm", "bpa", choices=ALGORITHMS)
    window = t.string("window", "rect", choices=WINDOWS)
    resolution = t.number("azimuth_resolution", None, unit="m", gt=0, le=MAX_AZIMUTH_RESOLUTION)
    autofocus = t.string("autofocus", None, choices=AUTOFOCUS_METHODS)
    band_limit = bool(t.boolean("band_limit", True))
    grid_table = t.table("grid")
    grid = parse_grid(grid_table) if grid_table is not None else None
    if grid is not None:
        t.out["grid"] = grid
    t.finish()
    options = FocusOptions(algorithm, window, resolution, grid, autofocus, band_limit)
    check_grid(t, options)
    return options


def check_grid(t: Table, options: FocusOptions) -> None:
    """Build the grid once, so grid errors surface when the file is loaded."""
    if options.grid is None:
        return
    with prefixed(t, t.key("grid")):
        options.make_grid()




def parse_grid(t: Table) -> dict[str, Any]:
    """``[focus.grid]``: kind = "slant" | "plane" | "points" and its axes."""
    kind = t.string("kind", "slant", choices=GRID_KINDS)
    if kind == "slant":
        counts = [parse_axis(t, name) for name in ("along_track", "slant_range")]
        require_pixels(t.where, t.key("along_track") + " x slant_range", counts[0] * counts[1])
    elif kind == "plane":
        for name in ("origin", "axis_u", "axis_v"):
            t.vector(name, 3, unit="m" if name == "origin" else "direction")
        u, v = np.asarray(t.out["axis_u"]), np.asarray(t.out["axis_v"])
        for name, axis in (("axis_u", u), ("axis_v", v)):
            if not np.linalg.norm(axis) > 0:
                raise t.error(name, "a non-zero direction", t.out[name])
        if abs(u @ v) > 1e-6 * np.linalg.norm(u) * np.linalg.norm(v):
            raise t.error("axis_v", f"a direction orthogonal to axis_u {t.out['axis_u']}",
                          t.out["axis_v"])
        counts = [parse_axis(t, name) for name in ("u", "v")]
        require_pixels(t.where, t.key("u") + " x v", counts[0] * counts[1])
    else:
        t.vectors("points", 3, min_count=1, unit="m")
    return t.finish()


def parse_axis(t: Table, name: str) -> float:
    """A grid axis ``[start, stop, step]`` [m] with ``stop > start`` and ``step > 0``; returns
    its number of coordinates."""
    vec = t.vector(name, 3, unit="m")
    start, stop, step = vec
    if not (stop > start and step > 0):
        raise t.error(name, "[start, stop, step] with stop > start and step > 0 [m]", list(vec))
    return axis_count(start, stop, step)


MAX_ISLR_CELLS = 1.0e5
"""Largest numeric ``islr_extent`` [resolution cells]: a chip of 2e5 cells a side is beyond any
image grid (``mitsar.focus.grid.require_pixels``); 1e300 used to pass the load (issue 27)."""


def parse_metrics(t: Table | None) -> MetricsOptions:
    """``[metrics]``: target position and ISLR side-lobe extent."""
    if t is None:
        return MetricsOptions()
    target = t.vector("target", 3, None, unit="m")
    t.seen.add("islr_extent")
    extent: str | float = t.data.get("islr_extent", "paper")
    expected = (f"one of {', '.join(repr(e) for e in ISLR_EXTENTS)} or a number of cells > 0 "
                f"and <= {MAX_ISLR_CELLS:g}")
    if isinstance(extent, bool) or not (
            (isinstance(extent, str) and extent in ISLR_EXTENTS)
            or (isinstance(extent, int | float) and 0 < extent <= MAX_ISLR_CELLS)):
        raise t.error("islr_extent", expected, extent)
    t.out["islr_extent"] = extent
    t.finish()
    return MetricsOptions(target, extent if isinstance(extent, str) else float(extent))


def _integer_pair(t: Table, name: str, default: tuple[int, int], expected: str,
                  ok: Any) -> tuple[int, int]:
    """An array of two TOML integers for which ``ok(first, second)`` holds."""
    t.seen.add(name)
    value = t.data.get(name, list(default))
    if not (isinstance(value, list) and len(value) == 2
            and all(isinstance(v, int) and not isinstance(v, bool) for v in value)
            and ok(*value)):
        raise t.error(name, expected, value)
    t.out[name] = list(value)
    return int(value[0]), int(value[1])


def parse_interferometry(t: Table | None, channels: int = 2) -> InterferometryOptions:
    """``[interferometry]``: pair, looks, unwrap and min_coherence of the interferogram of a
    radar with ``channels`` receive channels (docs/interferometry.md)."""
    if t is None:
        return InterferometryOptions()
    if channels < 2:
        raise ParameterError(t.where, t.path or "interferometry", "a radar with two or more "
                             "receive channels for an [interferometry] table: [radar] receivers "
                             "= [[0, 0, 0], [0, 0, 0.05]] (or drop the table)",
                             f"{channels} receive channel")
    pair = _integer_pair(t, "pair", (0, 1), f"two different channel indices in 0..{channels - 1}"
                         ", e.g. [0, 1]", lambda a, b: a != b and 0 <= a < channels
                         and 0 <= b < channels)
    looks = _integer_pair(t, "looks", (1, 1), "an array of two integers >= 1 [pixels] "
                          "(rows, cols), e.g. [5, 5]", lambda a, b: a >= 1 and b >= 1)
    unwrap = t.boolean("unwrap", True)
    min_coherence = t.number("min_coherence", 0.3, ge=0.0, le=1.0)
    t.finish()
    return InterferometryOptions(pair, looks, bool(unwrap), float(min_coherence))


def parse_mapping(t: Table | None, has_scene: bool) -> MappingOptions | None:
    """``[mapping]``: CFAR ``pfa`` and ``method``, score threshold ``tau`` [m], ``combine`` and
    ``elevation_window`` of the map ``mitsar run`` makes from an experiment's passes over its
    scene (docs/features.md); None without the table."""
    if t is None:
        return None
    if not has_scene:
        raise ParameterError(t.where, t.path or "mapping", "a scene to map and score against "
                             "(scene = \"control_volume\" or an XML file) for a [mapping] table",
                             "no scene")
    options = MappingOptions(
        pfa=t.number("pfa", 1e-6, gt=0.0, lt=1.0),
        method=t.string("method", "ca", choices=("ca", "os")),
        tau=t.number("tau", 0.05, unit="m", gt=0.0),
        combine=t.string("combine", "coherent", choices=("coherent", "incoherent")),
        elevation_window=t.string("elevation_window", None, choices=tuple(WINDOWS)))
    t.finish()
    return options


def parse_motion(t: Table | None) -> dict[str, Motion]:
    """``[motion.<shape id>]``: ``velocity`` [m/s], ``angular_velocity_deg`` [deg/s] and
    ``centre`` [m], or ``path = {times, positions, attitude_deg | rotation_vector}``, of a
    moving shape of the scene (:mod:`mitsar.scene.motion`; the ids are checked against the
    scene when it is loaded)."""
    if t is None:
        return {}
    given = {}
    for shape_id in list(t.data):
        if not isinstance(t.data[shape_id], dict):
            raise t.error(shape_id, "a table [motion.<shape id>] with velocity = [vx, vy, vz]",
                          t.data[shape_id])
        shape = t.table(shape_id)
        entry = {key: value for key, value in (
            ("velocity", shape.vector("velocity", 3, None, unit="m/s")),
            ("angular_velocity_deg", shape.vector("angular_velocity_deg", 3, None,
                                                  unit="deg/s")),
            ("centre", shape.vector("centre", 3, None, unit="m"))) if value is not None}
        path = shape.table("path")
        if path is not None:
            entry["path"] = {key: value for key, value in (
                ("times", path.numbers("times", 2, unit="s")),
                ("positions", path.vectors("positions", 3, 2, unit="m")),
                ("attitude_deg", path.vectors("attitude_deg", 3, 2, None, unit="deg")),
                ("rotation_vector", path.vectors("rotation_vector", 3, 2, None, unit="rad")))
                if value is not None}
            shape.out["path"] = path.finish()
        if not entry:
            raise t.error(shape_id, "velocity, angular_velocity_deg or path", "none of them")
        given[shape_id] = entry
        t.out[shape_id] = shape.finish()
    t.finish()
    return parse_motion_mapping(t.where, {key: value if set(value) - {"velocity"}
                                          else value["velocity"]
                                          for key, value in given.items()})


def parse_scene(t: Table) -> str | None:
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


# --------------------------------------------------------------------------------------------
# [[passes]]
# --------------------------------------------------------------------------------------------

_TRACK_KEYS = {"linear": ("start",), "waypoints": ("points",), "flight": ("points",),
               "navigation": ("positions",)}
"""The keys of each trajectory kind that a pass's ``offset`` shifts."""


def merge_trajectory(base: dict[str, Any] | None,
                     own: dict[str, Any] | None) -> dict[str, Any] | None:
    """A pass's ``trajectory`` document: its keys over the experiment's ``[trajectory]``.

    Every key the pass leaves out is inherited, except when the pass changes ``kind``: then
    only ``errors`` is (the other keys belong to the experiment's kind). ``errors`` is merged
    key by key the same way (``vibration`` as a whole). ``None`` when neither exists.
    """
    if base is None and own is None:
        return None
    base, own = copy.deepcopy(base or {}), copy.deepcopy(own or {})
    base_kind, own_kind = base.get("kind", "linear"), own.get("kind", base.get("kind", "linear"))
    merged = base if own_kind == base_kind else (
        {"errors": base["errors"]} if isinstance(base.get("errors"), dict) else {})
    own_errors = own.pop("errors", None)
    merged.update(own)
    if isinstance(own_errors, dict) and isinstance(merged.get("errors"), dict):
        merged["errors"] = {**merged["errors"], **own_errors}
    elif own_errors is not None:
        merged["errors"] = own_errors
    return merged


def parse_pass(t: Table, index: int, trajectory: dict[str, Any] | None,
               look: dict[str, Any] | None) -> Pass:
    """One ``[[passes]]`` entry: its own track, look and navigation errors over the
    experiment's (docs/experiments.md §Passes).

    Parameters
    ----------
    t : Table
        The entry (key path ``passes[<index>]``).
    index : int
        Its index.
    trajectory, look : dict or None
        The experiment's ``[trajectory]`` and ``[look]`` documents (already validated), which
        the pass inherits key by key; ``None`` when the file has none.

    Returns
    -------
    Pass
        With ``t.out`` the pass's effective table: the merged ``trajectory`` (before
        ``offset``; its ``errors.seed`` filled in) and ``look``.

    Raises
    ------
    ParameterError
        Naming ``passes[<index>].<key>``.
    """
    name = t.string("name", f"pass{index}")
    seed = t.integer("seed", None, ge=0)
    if seed is not None and seed > MAX_SEED:
        raise t.error("seed", f"an integer in [0, {MAX_SEED}] (recorded as 64 bits)", seed)
    offset = t.vector("offset", 3, (0.0, 0.0, 0.0), unit="m")
    for key in ("errors", "navigation"):
        if t.has(key):
            raise t.error(key, "no such key: a pass's navigation errors are its "
                          "[passes.trajectory.errors] table (the keys of [trajectory.errors])",
                          t.data[key])
    own_trajectory, own_look = t.table("trajectory"), t.table("look")
    document = merge_trajectory(trajectory, None if own_trajectory is None
                                else own_trajectory.data)
    if document is None:
        raise t.error("trajectory", "a table (required: the experiment has no [trajectory] to "
                      "inherit)", "nothing")
    errors = document.get("errors")
    own_errors = None if own_trajectory is None else own_trajectory.data.get("errors")
    if isinstance(errors, dict) and not (isinstance(own_errors, dict) and "seed" in own_errors):
        inherited = errors.get("seed", 0)
        if isinstance(inherited, int) and not isinstance(inherited, bool) and inherited >= 0:
            errors["seed"] = pass_seed(inherited, index)
    key = t.key("trajectory")
    table = Table(copy.deepcopy(document), key, t.where, t.base)
    flown, navigation = parse_flight(table)
    t.out["trajectory"] = table.out
    if any(offset):
        flown = _shifted(t, table, offset)
    if look is None and own_look is None:
        raise t.error("look", "a table (required: the experiment has no [look] to inherit)",
                      "nothing")
    look_table = Table({**copy.deepcopy(look or {}),
                        **copy.deepcopy(own_look.data if own_look is not None else {})},
                       t.key("look"), t.where, t.base)
    pass_look = parse_look(look_table)
    t.out["look"] = look_table.out
    t.finish()
    return Pass(index=index, name=str(name), trajectory=flown, look=pass_look,
                navigation=navigation, seed=seed, offset=tuple(offset))


def _shifted(t: Table, parsed: Table, offset: tuple[float, ...]) -> Trajectory:
    """The pass's (validated) track moved by ``offset`` [m]."""
    document = copy.deepcopy(parsed.out)
    kind = document.get("kind", "linear")
    if "file" in document:
        raise t.error("offset", "[0, 0, 0] with a navigation file (give the moved track in "
                      "its own file)", list(offset))
    shift = np.asarray(offset)
    for name in _TRACK_KEYS[kind]:
        document[name] = (np.asarray(document[name], dtype=float) + shift).tolist()
    document.pop("errors", None)
    return parse_trajectory(Table(document, parsed.path, t.where, t.base))
