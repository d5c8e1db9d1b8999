"""Ambiguity maps: the gradient method over surface points x platform states.

Every point of a set of surface points (:mod:`mitsar.ambiguity.points`) is evaluated at every
platform state of a subsampling of the sweeps (:mod:`mitsar.ambiguity.states`) with the
gradients and resolutions of :mod:`mitsar.ambiguity.gradient`.


A point is *illuminated* at a state when it is inside the beam (two-way pattern at least
``beam_threshold_db``, default -6 dB, i.e. inside the one-way half-power beam), within the
radar's ``max_range``, and not shadowed (``scene.ray_test`` from the point toward the antenna).
Surfaces are treated as two-sided; the normal is flipped toward the antenna.

Integration time ``T_int`` (the choices are discussed in ``docs/ambiguity.md``):

* ``None`` or ``"beam"`` (default): the time the point stays illuminated, i.e. the duration of
  the contiguous run of illuminated states holding the state (run ends interpolated linearly in
  two-way pattern power between states where the run ends at the beam edge);
* a number [s]: a fixed processed aperture time, capped by the illuminated run;
* ``"required"``: the aperture a processor would choose to reach ``required_resolution`` in the
  slant plane, ``T = 1 / (rho_req |grad f_D|)`` (unprojected gradient), capped by the run.

A point is *ambiguous* at an illuminated state when ``Theta < min_angle_deg`` or a resolution is
worse than ``required_resolution`` (``criterion="gradient"``: ``rho_r`` and ``rho_a``;
``criterion="cell"``: the cell sides ``rho / sin Theta``). It is *resolved* at that state
otherwise. Over the trajectory every point gets its best range and azimuth resolutions (with
when and from where), the single best state, and a status: never in the beam, in the beam but
always shadowed, observed only ambiguously, or resolved at least once.

Everything is vectorised over points x states with NumPy (chunked over points); shadow rays of
the in-beam pairs go to Mitsuba's ``ray_test`` in one wavefront per chunk.
"""

from __future__ import annotations

import json
import math
import os
from collections.abc import Mapping, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.ambiguity.gradient import doppler_gradient, gradient_resolution
from mitsar.ambiguity.points import SurfacePoints, sample_surfaces, unit_rows
from mitsar.ambiguity.shadows import visible
from mitsar.ambiguity.states import States, platform_states, run_durations
from mitsar.budget import require_memory
from mitsar.errors import ParameterError
from mitsar.model.geometry.antenna import one_way_pattern
from mitsar.model.geometry.attitude import Look
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.scene.loading import load_scene
from mitsar.version import __version__

__all__ = ["CRITERIA", "INTEGRATION_MODES", "OBSERVATION_MEANINGS", "STATUS_MEANINGS",
           "ambiguity", "overall_fractions", "points_and_scene", "required_resolutions",
           "surface_summary"]

OBSERVATION_MEANINGS = ("outside_beam", "shadowed", "ambiguous", "resolved")
"""Meanings of the per-state ``observation`` codes 0..3."""

STATUS_MEANINGS = ("never_in_beam", "shadowed", "only_ambiguous", "resolved")
"""Meanings of the per-point ``status`` codes 0..3 (best observation over the trajectory)."""

INTEGRATION_MODES = ("beam", "required")
"""Named integration-time models (besides a fixed time in seconds)."""

CRITERIA = ("gradient", "cell")
"""Resolutions compared with the requirement: along the gradients, or the cell sides."""


def required_resolutions(value: Any) -> tuple[float, float]:
    """Required (range, azimuth) resolution [m] from a number or a pair."""
    pair = (value, value) if isinstance(value, int | float) else value
    try:
        pair = tuple(pair)
    except TypeError:
        pair = ()
    if (len(pair) != 2 or any(isinstance(r, bool) or not isinstance(r, int | float)
                              or not (r > 0 and math.isfinite(r)) for r in pair)):
        raise ParameterError("ambiguity", "required_resolution",
                             "a resolution > 0 m, or a (range, azimuth) pair of them", value)
    return float(pair[0]), float(pair[1])


def _check_options(radar: Radar, trajectory: Trajectory, look: Look,
                   required_resolution: float, integration_time: Any, beam_threshold_db: float,
                   min_angle_deg: float, criterion: str) -> tuple[str, float | None]:
    if not isinstance(radar, Radar):
        raise ParameterError("ambiguity", "radar", "a mitsar.Radar", type(radar).__name__)
    if not isinstance(trajectory, Trajectory):
        raise ParameterError("ambiguity", "trajectory", "a mitsar.Trajectory",
                             type(trajectory).__name__)
    if not isinstance(look, Look):
        raise ParameterError("ambiguity", "look", "a mitsar.Look", type(look).__name__)
    required_resolutions(required_resolution)
    if not (isinstance(beam_threshold_db, int | float) and beam_threshold_db < 0):
        raise ParameterError("ambiguity", "beam_threshold_db",
                             "a two-way pattern level < 0 dB", beam_threshold_db)
    if not (isinstance(min_angle_deg, int | float) and 0 <= min_angle_deg < 90):
        raise ParameterError("ambiguity", "min_angle_deg", "an angle in [0, 90) deg",
                             min_angle_deg)
    if criterion not in CRITERIA:
        raise ParameterError("ambiguity", "criterion", f"one of {CRITERIA}", criterion)
    if integration_time is None or integration_time == "beam":
        return "beam", None
    if integration_time == "required":
        return "required", None
    if (isinstance(integration_time, int | float) and not isinstance(integration_time, bool)
            and integration_time > 0 and math.isfinite(integration_time)):
        return "fixed", float(integration_time)
    raise ParameterError("ambiguity", "integration_time",
                         "None/'beam', 'required' or a time > 0 s", integration_time)


def points_and_scene(scene_or_grid: Any, spacing: float, shapes: Sequence[str] | None,
                     exclude: Sequence[str], scene: Any) -> tuple[SurfacePoints, Any]:
    """The surface points to analyse and the Mitsuba scene for shadowing (or None)."""
    if isinstance(scene_or_grid, SurfacePoints):
        points = scene_or_grid
    elif isinstance(scene_or_grid, Mapping):
        points = SurfacePoints.from_arrays(
            scene_or_grid["position"], scene_or_grid.get("normal"), scene_or_grid.get("area"),
            scene_or_grid.get("surface"), scene_or_grid.get("names"))
    elif isinstance(scene_or_grid, tuple) and len(scene_or_grid) == 2:
        points = SurfacePoints.from_arrays(*scene_or_grid)
    elif isinstance(scene_or_grid, np.ndarray):
        points = SurfacePoints.from_arrays(scene_or_grid)
    else:
        loaded = load_scene(scene_or_grid)
        points = sample_surfaces(loaded, spacing, shapes=shapes, exclude=exclude)
        scene = loaded if scene is None else scene
    if scene is not None:
        scene = load_scene(scene)
    return points, scene


def _beam_pattern(ux: NDArray, uy: NDArray, uz: NDArray, frame: NDArray,
                  radar: Radar) -> NDArray:
    """Two-way pattern of unit directions (components (P, S)) in per-state antenna frames."""
    def local(axis: int) -> NDArray:
        f = frame[:, :, axis]
        return f[None, :, 0] * ux + f[None, :, 1] * uy + f[None, :, 2] * uz

    return one_way_pattern(local(0), local(1), radar.azimuth_beamwidth,
                           radar.elevation_beamwidth, local(2)) ** 2


def _pair_resolutions(x: NDArray, n: NDArray | None, p: NDArray, v: NDArray,
                      radar: Radar) -> dict[str, NDArray]:
    """Gradient quantities of matched (point, state) pairs, arrays of shape (L, 3).

    The projected quantities of :func:`~mitsar.ambiguity.gradient.gradient_resolution` (at
    ``T_int`` = 1 s; the caller scales the azimuth resolution), the norm of the unprojected
    Doppler gradient (``"required"`` integration time) and the incidence angle [deg].
    """
    resolution = gradient_resolution(x, n, p, v, radar, 1.0)
    g_fd_3d = doppler_gradient(x, p, v, radar.wavelength)
    incidence = (np.full(len(x), np.nan) if n is None else np.degrees(
        np.arccos(np.clip(np.abs(np.sum(unit_rows(x - p) * n, axis=-1)), 0, 1))))
    return {"rho_r": resolution["range_resolution"],
            "n_fd": np.linalg.norm(resolution["doppler_gradient"], axis=-1),
            "n_fd_3d": np.linalg.norm(g_fd_3d, axis=-1),
            "angle": np.degrees(resolution["angle"]), "incidence": incidence}


def _evaluate(points: SurfacePoints, rows: slice, states: States, radar: Radar,
              options: dict, scene: Any) -> dict[str, NDArray]:
    """Per-state quantities of the points ``rows`` (chunk) x all states.

    Beam and range are tested on every pair (component arrays of shape (P, S)); shadow rays and
    gradients only on the pairs inside the beam.
    """
    x = points.position[rows]
    p = states.position
    ox = x[:, 0, None] - p[None, :, 0]
    oy = x[:, 1, None] - p[None, :, 1]
    oz = x[:, 2, None] - p[None, :, 2]
    distance = np.sqrt(ox * ox + oy * oy + oz * oz)
    safe = np.where(distance > 0, distance, 1.0)
    pattern = _beam_pattern(ox / safe, oy / safe, oz / safe, states.frame, radar)
    threshold = 10 ** (options["beam_threshold_db"] / 10)
    in_range = (distance > 0) & (distance <= radar.max_range)
    in_beam = (pattern >= threshold) & in_range
    lit = in_beam.copy()
    if scene is not None and options["shadowing"] and np.any(in_beam):
        i, k = np.nonzero(in_beam)
        normals = None if points.normal is None else points.normal[rows][i]
        lit[i, k] = visible(scene, x[i], normals, p[k])
    margin = np.where(in_range, pattern - threshold, np.nan)
    run = run_durations(lit, margin, states)

    # Gradients and resolutions of the illuminated pairs.
    i, k = np.nonzero(lit)
    pair = _pair_resolutions(x[i], None if points.normal is None else points.normal[rows][i],
                             p[k], states.velocity[k], radar)
    t_int = run[i, k]
    if options["mode"] == "fixed":
        t_int = np.minimum(t_int, options["integration_time"])
    elif options["mode"] == "required":
        with np.errstate(divide="ignore"):
            t_int = np.minimum(t_int, 1.0 / (options["required_azimuth"] * pair["n_fd_3d"]))
    with np.errstate(divide="ignore", invalid="ignore"):
        rho_a = 1.0 / (t_int * pair["n_fd"])
        sine = np.sin(np.radians(pair["angle"]))
        if options["criterion"] == "cell":
            check_r, check_a = pair["rho_r"] / sine, rho_a / sine
        else:
            check_r, check_a = pair["rho_r"], rho_a
    angle_ok = pair["angle"] >= options["min_angle_deg"]
    good = angle_ok & (check_r <= options["required_range"]) & (
        check_a <= options["required_azimuth"])

    def full(values: NDArray, fill: Any = np.nan) -> NDArray:
        out = np.full(lit.shape, fill, dtype=np.asarray(values).dtype if fill is not np.nan
                      else float)
        out[i, k] = values
        return out

    observation = np.where(in_beam, 1, 0).astype(np.int8)
    observation[i, k] = np.where(good, 3, 2)
    return {"range_resolution": full(pair["rho_r"]), "azimuth_resolution": full(rho_a),
            "angle": full(pair["angle"]), "incidence": full(pair["incidence"]),
            "integration_time": full(t_int), "observation": observation,
            "check_r": full(check_r), "check_a": full(check_a),
            "angle_ok": full(angle_ok, False)}


def _argmin_rows(values: NDArray) -> tuple[NDArray, NDArray]:
    """Row-wise argmin ignoring NaN and the minimum; (-1, NaN) for all-NaN rows."""
    filled = np.where(np.isnan(values), np.inf, values)
    index = np.argmin(filled, axis=1)
    best = filled[np.arange(len(filled)), index]
    valid = np.any(~np.isnan(values), axis=1)
    return np.where(valid, index, -1), np.where(valid, best, np.nan)


def _aggregate(chunk: dict[str, NDArray], states: States) -> dict[str, NDArray]:
    """Per-point summaries over the trajectory."""
    count = len(chunk["observation"])
    out: dict[str, NDArray] = {}
    lit = chunk["observation"] >= 2

    def take(index: NDArray, values: NDArray) -> NDArray:
        return np.where(index >= 0, values[np.clip(index, 0, None)], np.nan)

    def take_position(index: NDArray) -> NDArray:
        return np.where((index >= 0)[:, None], states.position[np.clip(index, 0, None)], np.nan)

    for name in ("range", "azimuth"):
        index, best = _argmin_rows(chunk[f"{name}_resolution"])
        out[f"best_{name}_resolution"] = best
        out[f"best_{name}_time"] = take(index, states.time)
        out[f"best_{name}_platform_position"] = take_position(index)

    # The single best state: smallest max(range, azimuth) measure with an acceptable angle.
    score = np.maximum(chunk["check_r"], chunk["check_a"])
    score = np.where(lit, score, np.nan)
    preferred = np.where(chunk["angle_ok"], score, np.nan)
    index, _ = _argmin_rows(preferred)
    fallback, _ = _argmin_rows(score)
    index = np.where(index >= 0, index, fallback)
    rows = np.arange(count)
    safe = np.clip(index, 0, None)
    out["best_time"] = take(index, states.time)
    out["best_platform_position"] = take_position(index)
    for name in ("range_resolution", "azimuth_resolution", "angle", "integration_time"):
        out[f"best_state_{name}"] = np.where(index >= 0, chunk[name][rows, safe], np.nan)

    status = chunk["observation"].max(axis=1)
    out["status"] = status.astype(np.int8)
    dt = states.interval[:, 1] - states.interval[:, 0]
    out["observed_time"] = (lit * dt).sum(axis=1)
    resolved = chunk["observation"] == 3
    out["resolved_time"] = (resolved * dt).sum(axis=1)
    first = np.argmax(resolved, axis=1)
    out["first_resolved_time"] = np.where(resolved.any(axis=1), states.time[first], np.nan)
    return out


PAIR_BYTES = 48
"""Peak bytes per (point, state) pair kept with ``per_state``: 21 bytes of maps, their
concatenation and the product's copy."""


def ambiguity(radar: Radar, trajectory: Trajectory, look: Look, scene_or_grid: Any,
              required_resolution: float = 0.10, *, sweep_step: int | None = None,
              integration_time: float | str | None = None, spacing: float = 0.25,
              shapes: Sequence[str] | None = None, exclude: Sequence[str] = (),
              scene: Any = None, beam_threshold_db: float = -6.0, min_angle_deg: float = 30.0,
              criterion: str = "gradient", shadowing: bool = True, max_states: int = 600,
              per_state: bool = True, chunk_pairs: int = 1 << 20,
              progress: bool = False) -> xr.Dataset:
    """Resolution and ambiguity of surface points along a trajectory (gradient method).

    Parameters
    ----------
    radar, trajectory, look : Radar, Trajectory, Look
    scene_or_grid : mitsuba.Scene, path, scene name, SurfacePoints, mapping, tuple or array
        A scene (its surfaces are sampled every ``spacing`` m, and it shadows), or points:
        :class:`SurfacePoints`, a mapping with ``position`` and optional ``normal``, ``area``,
        ``surface``, ``names``, a tuple ``(position, normal)``, or an (n, 3) array (3-D
        gradients).
    required_resolution : float or (float, float)
        Required resolution [m], or a (range, azimuth) pair. Paper Table 1 gives 0.10 m in
        slant range and azimuth; note that the range resolution projected on a surface is
        ``c / (2 B sin theta_inc)``, coarser than 0.10 m everywhere but at grazing incidence.
    sweep_step : int, optional
        Evaluate every ``sweep_step``-th sweep (mid-sweep states); default so that at most
        ``max_states`` states are evaluated.
    integration_time : None, "beam", "required" or float
        Integration time model (module docstring; default: time in the beam).
    spacing : float
        Point spacing on scene surfaces [m].
    shapes, exclude : sequence of str, optional
        Shape ids to sample / to skip.
    scene : mitsuba.Scene, path or name, optional
        Scene for shadowing when ``scene_or_grid`` is a point set.
    beam_threshold_db : float
        Two-way pattern level that bounds the beam [dB] (-6 dB: one-way half power).
    min_angle_deg : float
        Angle between the projected gradients below which a state is ambiguous [deg].
    criterion : {"gradient", "cell"}
        Resolutions compared with the requirement: along the gradients, or the resolution
        cell sides ``rho / sin Theta``.
    shadowing : bool
        Test visibility with ``ray_test`` (needs a scene).
    max_states : int
        Bound on the number of states when ``sweep_step`` is not given.
    per_state : bool
        Keep the (point, state) maps in the result (21 bytes per point-state pair).
    chunk_pairs : int
        Point-state pairs evaluated at once (memory bound).
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        ``product = "ambiguity"``; see ``docs/ambiguity.md`` for every variable.
    """
    mode, fixed = _check_options(radar, trajectory, look, required_resolution,
                                 integration_time, beam_threshold_db, min_angle_deg, criterion)
    points, scene = points_and_scene(scene_or_grid, spacing, shapes, exclude, scene)
    states = platform_states(radar, trajectory, look, sweep_step, max_states)
    required_range, required_azimuth = required_resolutions(required_resolution)
    options = {"mode": mode, "integration_time": fixed, "beam_threshold_db": beam_threshold_db,
               "min_angle_deg": float(min_angle_deg), "criterion": criterion,
               "shadowing": bool(shadowing), "required_range": required_range,
               "required_azimuth": required_azimuth}
    size = len(states.time)
    require_memory("ambiguity", "spacing", float(len(points)) * size * (
        PAIR_BYTES if per_state else 0) + float(len(points)) * 256,
        f"{len(points)} points x {size} states: a coarser spacing, a larger sweep_step or "
        "fewer max_states, or per_state = false")
    rows_per_chunk = max(1, int(chunk_pairs) // size)
    per_state_names = ("range_resolution", "azimuth_resolution", "angle", "incidence",
                       "integration_time", "observation")
    maps: dict[str, list] = {name: [] for name in per_state_names}
    summaries: list[dict[str, NDArray]] = []
    chunks = range(0, len(points), rows_per_chunk)
    if progress:
        chunks = tqdm(chunks, desc="ambiguity", unit="chunk")
    observed_area = np.zeros(size)
    resolved_area = np.zeros(size)
    for start in chunks:
        rows = slice(start, min(start + rows_per_chunk, len(points)))
        chunk = _evaluate(points, rows, states, radar, options, scene)
        summaries.append(_aggregate(chunk, states))
        weights = points.area[rows][:, None]
        observed_area += np.sum((chunk["observation"] >= 2) * weights, axis=0)
        resolved_area += np.sum((chunk["observation"] == 3) * weights, axis=0)
        if per_state:
            for name in per_state_names:
                values = chunk[name]
                maps[name].append(values if name == "observation"
                                  else values.astype(np.float32))
    summary = {key: np.concatenate([s[key] for s in summaries]) for key in summaries[0]}
    return _product(points, states, summary, maps if per_state else None, observed_area,
                    resolved_area, radar, trajectory, look, options, spacing, scene_or_grid)


def _product(points: SurfacePoints, states: States, summary: dict, maps: dict | None,
             observed_area: NDArray, resolved_area: NDArray, radar: Radar,
             trajectory: Trajectory, look: Look, options: dict, spacing: float,
             source: Any) -> xr.Dataset:
    """Assemble the ambiguity product."""
    m, s, deg, none = {"units": "m"}, {"units": "s"}, {"units": "deg"}, {"units": "1"}
    point_dims, state_dims = ("point", "state"), ("state", "xyz")
    total_area = float(points.area.sum())
    data: dict[str, Any] = {
        "position": (("point", "xyz"), points.position, {**m, "long_name": "surface point"}),
        "area": ("point", points.area, {"units": "m^2", "long_name": "area per point"}),
        "surface_index": ("point", points.surface.astype(np.int32),
                          {"long_name": "index into the surface dimension"}),
        "facet_index": ("point", points.facet.astype(np.int32),
                        {"long_name": "index into the facet dimension (planar part of a "
                                      "surface, for maps)"}),
        "map_u": ("point", points.map_uv[:, 0], {**m, "long_name": "unfolded map abscissa"}),
        "map_v": ("point", points.map_uv[:, 1], {**m, "long_name": "unfolded map ordinate"}),
        "platform_position": (state_dims, states.position, m),
        "platform_velocity": (state_dims, states.velocity, {"units": "m/s"}),
        "boresight": (state_dims, states.boresight, none),
        "observed_fraction": ("state", observed_area / total_area, {
            **none, "long_name": "area fraction illuminated at this state"}),
        "resolved_fraction": ("state", resolved_area / total_area, {
            **none, "long_name": "area fraction resolved (unambiguous) at this state"}),
    }
    if points.normal is not None:
        data["normal"] = (("point", "xyz"), points.normal, none)
    descriptions = {
        "best_range_resolution": (m, "best range resolution 1/(B|grad tau|) over the track"),
        "best_range_time": (s, "time of the best range resolution"),
        "best_range_platform_position": (m, "platform position at the best range resolution"),
        "best_azimuth_resolution": (m, "best azimuth resolution 1/(T_int|grad f_D|)"),
        "best_azimuth_time": (s, "time of the best azimuth resolution"),
        "best_azimuth_platform_position": (m, "platform position at the best azimuth "
                                              "resolution"),
        "best_time": (s, "time of the best state (smallest max(range, azimuth) measure with "
                         "an acceptable gradient angle)"),
        "best_platform_position": (m, "platform position of the best state"),
        "best_state_range_resolution": (m, "range resolution at the best state"),
        "best_state_azimuth_resolution": (m, "azimuth resolution at the best state"),
        "best_state_angle": (deg, "angle between projected gradients at the best state"),
        "best_state_integration_time": (s, "integration time at the best state"),
        "observed_time": (s, "total time illuminated"),
        "resolved_time": (s, "total time resolved"),
        "first_resolved_time": (s, "first time resolved"),
    }
    for name, (units, long_name) in descriptions.items():
        values = summary[name]
        dims = ("point", "xyz") if values.ndim == 2 else ("point",)
        data[name] = (dims, values, {**units, "long_name": long_name})
    status = summary["status"]
    data["status"] = ("point", status, {
        "flag_values": np.arange(4, dtype=np.int8), "flag_meanings": " ".join(STATUS_MEANINGS),
        "long_name": "best observation over the trajectory"})
    data["never_observed"] = ("point", status <= 1, {"long_name": "never illuminated"})
    data["only_ambiguous"] = ("point", status == 2, {
        "long_name": "illuminated, but never unambiguous at the required resolution"})
    data["resolved"] = ("point", status == 3, {
        "long_name": "unambiguous at the required resolution at least once"})
    if maps is not None:
        units = {"range_resolution": m, "azimuth_resolution": m, "angle": deg,
                 "incidence": deg, "integration_time": s}
        for name, unit in units.items():
            data[name] = (point_dims, np.concatenate(maps[name]), dict(unit))
        data["observation"] = (point_dims, np.concatenate(maps["observation"]), {
            "flag_values": np.arange(4, dtype=np.int8),
            "flag_meanings": " ".join(OBSERVATION_MEANINGS)})
        data["range_resolution"][2]["long_name"] = "range resolution 1/(B|grad_t tau|)"
        data["azimuth_resolution"][2]["long_name"] = "azimuth resolution 1/(T_int|grad_t f_D|)"
        data["angle"][2]["long_name"] = "angle between the projected gradients"
        data["incidence"][2]["long_name"] = "incidence angle on the surface"
        data["integration_time"][2]["long_name"] = "integration time T_int"

    # Cumulative coverage along the track.
    first = summary["first_resolved_time"]
    order = np.searchsorted(states.time, np.where(np.isnan(first), np.inf, first))
    cumulative = np.cumsum(np.bincount(order, weights=points.area,
                                       minlength=len(states.time) + 1))[:len(states.time)]
    data["cumulative_resolved_fraction"] = ("state", cumulative / total_area, {
        **none, "long_name": "area fraction resolved at least once so far"})

    product = xr.Dataset(data, coords={
        "point": np.arange(len(points)), "state": np.arange(len(states.time)),
        "time": ("state", states.time, {**s, "long_name": "mid-sweep time of the state"}),
        "sweep": ("state", states.sweep), "xyz": ["x", "y", "z"],
        "surface": list(points.names), "facet": list(points.facet_names)})
    table = surface_summary(product)
    for name in table.data_vars:
        product[name] = table[name]
    product.attrs.update(radar.to_attrs())
    product.attrs.update(
        product="ambiguity", mitsar_version=__version__,
        look_off_nadir_deg=look.off_nadir_deg, look_squint_deg=look.squint_deg,
        required_resolution=max(options["required_range"], options["required_azimuth"]),
        required_range_resolution=options["required_range"],
        required_azimuth_resolution=options["required_azimuth"],
        min_angle_deg=options["min_angle_deg"], beam_threshold_db=options["beam_threshold_db"],
        integration_time_mode=options["mode"],
        integration_time=-1.0 if options["integration_time"] is None
        else options["integration_time"],
        criterion=options["criterion"], shadowing=int(options["shadowing"]),
        sweep_step=states.step, state_interval=states.step / radar.prf,
        spacing=float(spacing), normals=int(points.normal is not None),
        trajectory=json.dumps(trajectory.describe()),
        source=str(source) if isinstance(source, str | os.PathLike) else type(source).__name__)
    return product


def surface_summary(product: xr.Dataset) -> xr.Dataset:
    """Area fractions per surface: resolved, observed, only ambiguous, shadowed, outside beam.

    Returns
    -------
    xarray.Dataset
        Variables on the ``surface`` dimension: ``surface_area`` [m^2], ``fraction_resolved``
        (observed at the required resolution without ambiguity at least once),
        ``fraction_observed``, ``fraction_only_ambiguous``, ``fraction_shadowed``,
        ``fraction_outside_beam``.
    """
    surfaces = product["surface"].values
    index = product["surface_index"].values
    area = product["area"].values
    status = product["status"].values
    count = len(surfaces)
    total = np.bincount(index, weights=area, minlength=count)
    safe = np.where(total > 0, total, 1.0)

    def fraction(mask: NDArray) -> NDArray:
        return np.bincount(index, weights=area * mask, minlength=count) / safe

    none = {"units": "1"}
    return xr.Dataset({
        "surface_area": ("surface", total, {"units": "m^2"}),
        "fraction_resolved": ("surface", fraction(status == 3), {
            **none, "long_name": "area fraction resolved at the required resolution"}),
        "fraction_observed": ("surface", fraction(status >= 2), {
            **none, "long_name": "area fraction illuminated at least once"}),
        "fraction_only_ambiguous": ("surface", fraction(status == 2), {
            **none, "long_name": "area fraction observed only ambiguously"}),
        "fraction_shadowed": ("surface", fraction(status == 1), {
            **none, "long_name": "area fraction in the beam but always shadowed"}),
        "fraction_outside_beam": ("surface", fraction(status == 0), {
            **none, "long_name": "area fraction never in the beam"}),
    }, coords={"surface": surfaces})


def overall_fractions(product: xr.Dataset) -> dict[str, float]:
    """The fractions of :func:`surface_summary` over all surfaces together."""
    area = product["area"].values
    status = product["status"].values
    total = float(area.sum())
    return {"surface_area": total,
            "fraction_resolved": float(area[status == 3].sum() / total),
            "fraction_observed": float(area[status >= 2].sum() / total),
            "fraction_only_ambiguous": float(area[status == 2].sum() / total),
            "fraction_shadowed": float(area[status == 1].sum() / total),
            "fraction_outside_beam": float(area[status == 0].sum() / total)}
