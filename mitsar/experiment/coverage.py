"""Is the measured target inside the focusing grid? Asked before a campaign spends any run.

A Monte Carlo (or any campaign of whole runs) whose target lies outside the image would have
every realisation simulated and focused, then refused by the measurement
(:func:`mitsar.quality.impulse.measure_impulse_response`). The grid depends only on the track,
the radar and the ``[focus]`` options, not on the echoes, so it is resolved here from the
experiment's (recorded) track alone, sampled at mid-sweep as a simulation samples it
(:func:`mitsar.raw.product.sweep_geometry`), and the target mapped onto it as the measurement
maps it (:func:`mitsar.focus.grid.equivalent_position`). The criterion is the measurement's: a
target more than half a pixel beyond the first or last pixel along either image axis is
outside (docs/reliability.md §3).
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from mitsar.errors import ParameterError
from mitsar.experiment.options import Experiment
from mitsar.focus.aperture import aperture_half_width, is_uniform_straight_track
from mitsar.focus.grid import SlantGrid, equivalent_position
from mitsar.model.geometry.navigation import resolve_navigation
from mitsar.model.signal import sweep_count
from mitsar.products.raw import track_variables
from mitsar.raw.product import require_raw_memory, sweep_geometry

__all__ = ["SAME_GRID_ANY_TRACK", "check_target_in_grid", "grid_layout", "target_axes"]

SAME_GRID_ANY_TRACK = ("bpa", "ffbp")
"""Algorithms that resolve the grid on the recorded track whatever its shape; the others do
so only on a straight constant-velocity track (else on the motion-compensation line)."""


def grid_layout(experiment: Experiment) -> tuple[dict, bool]:
    """The focusing grid of an experiment, resolved without simulating (module docstring).

    Returns
    -------
    layout : dict
        As :meth:`mitsar.focus.grid.SlantGrid.resolve` (``dims``, ``coords`` [m],
        ``position``, ``attrs``).
    straight : bool
        Whether the recorded track is straight at constant velocity (then every algorithm
        images on this grid).
    """
    radar, trajectory = experiment.radar, experiment.trajectory
    sweeps = sweep_count(radar, trajectory.duration)
    if sweeps < 1:
        raise ParameterError(experiment.source or "experiment", "trajectory.duration",
                             f">= one sweep ({radar.sweep_duration:g} s)", trajectory.duration)
    # the same budget as the simulation it stands in for, before any per-sweep array
    require_raw_memory(experiment.source or "experiment", radar, sweeps)
    recorded = resolve_navigation("grid_layout", trajectory, experiment.navigation)
    geometry = sweep_geometry(radar, recorded or trajectory, experiment.look, sweeps)
    track = xr.Dataset(track_variables(geometry),
                       coords={"sweep": np.arange(sweeps), "xyz": ["x", "y", "z"],
                               "angle": ["heading", "pitch", "roll"]})
    grid = experiment.focus.make_grid() or SlantGrid()
    nominal_azimuth = radar.wavelength / (
        4.0 * aperture_half_width(radar, experiment.focus.azimuth_resolution))
    return grid.resolve(track, radar, nominal_azimuth), is_uniform_straight_track(track)


def target_axes(layout: dict, target: Sequence[float]) -> dict[str, float] | None:
    """The target's metre coordinate along each image axis of a slant or plane grid.

    ``None`` for a grid of points (no axes to compare against).
    """
    attrs = layout["attrs"]
    point = equivalent_position(xr.Dataset(attrs=attrs), target)
    origin = np.asarray(attrs["grid_origin"], dtype=float)
    offset = point - origin
    if attrs["grid_kind"] == "slant":
        along = np.asarray(attrs["grid_along_track"], dtype=float)
        a = float(offset @ along)
        return {"azimuth": a, "range": float(np.linalg.norm(offset - a * along))}
    if attrs["grid_kind"] == "plane":
        return {"v": float(offset @ np.asarray(attrs["grid_axis_v"], dtype=float)),
                "u": float(offset @ np.asarray(attrs["grid_axis_u"], dtype=float))}
    return None


def check_target_in_grid(experiment: Experiment, target: Sequence[float],
                         algorithms: Sequence[str], where: str = "montecarlo") -> None:
    """Refuse, before any simulation, a target outside the focusing grid.

    Parameters
    ----------
    experiment : Experiment
        Its track, radar and ``[focus]`` options give the grid.
    target : sequence of 3 floats
        World position of the measured target [m].
    algorithms : sequence of str
        The algorithms that will focus; the check applies to those that image on the grid
        resolved here (:data:`SAME_GRID_ANY_TRACK`, all of them on a straight track).
    where : str
        The caller, for the error.

    Raises
    ------
    ParameterError
        Naming ``metrics.target``, the image axis, the target's coordinate on it and the
        grid's extent, and what to change (``[focus.grid]`` or the target).
    """
    layout, straight = grid_layout(experiment)
    if not (straight or any(a in SAME_GRID_ANY_TRACK for a in algorithms)):
        return
    axes = target_axes(layout, target)
    if axes is None:
        return
    for dim, value in axes.items():
        coords = np.asarray(layout["coords"][dim], dtype=float)
        half = 0.5 * abs(float(coords[1] - coords[0])) if coords.size > 1 else 0.0
        low, high = float(coords.min()) - half, float(coords.max()) + half
        if not low <= value <= high:
            key = {"azimuth": "along_track", "range": "slant_range"}.get(dim, dim)
            raise ParameterError(
                where, "metrics.target",
                f"a target inside the focusing grid; it is outside the image: it images at "
                f"{dim} = {value:.3f} m, the grid's {dim} axis spans {low:.3f} to "
                f"{high:.3f} m (checked before any realisation); extend [focus.grid] "
                f"{key} to cover it (plus the measurement window) or move the target",
                [round(float(v), 6) for v in target])
