"""Platform states of an ambiguity map and the illuminated runs of each point.

The trajectory is subsampled at mid-sweep times (every ``step``-th sweep); each state stands for
the interval of sweeps up to the next one. A point's integration time by default is the duration
of the contiguous run of illuminated states holding the state (:func:`run_durations`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mitsar.budget import MAX_SWEEPS, require_count, require_memory
from mitsar.checks import integer
from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import Look, antenna_frame
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.model.signal import sweep_count

__all__ = ["States", "platform_states", "run_durations"]


@dataclass(frozen=True)
class States:
    """Platform states: sweep index, mid-sweep time [s] and the time span each stands for,
    antenna position [m], velocity [m/s], boresight and antenna frame, sweep step."""

    sweep: NDArray
    time: NDArray
    interval: NDArray  # (S, 2) time span each state stands for
    position: NDArray
    velocity: NDArray
    boresight: NDArray
    frame: NDArray
    step: int


STATE_BYTES = 512
"""Peak bytes per platform state: time, interval, position, velocity, attitude, antenna frame
and the per-state sums of the maps (float64)."""


def platform_states(radar: Radar, trajectory: Trajectory, look: Look, sweep_step: int | None,
                    max_states: int) -> States:
    """Every ``sweep_step``-th sweep (default: at most ``max_states`` states) of a trajectory."""
    sweeps = sweep_count(radar, trajectory.duration)
    if sweeps < 1:
        raise ParameterError("ambiguity", "trajectory.duration",
                             f">= one sweep ({radar.sweep_duration:g} s)", trajectory.duration)
    require_count("ambiguity", "trajectory.duration", sweeps, MAX_SWEEPS,
                  "sweeps (duration x prf)")
    if sweep_step is None:
        max_states = integer("ambiguity", "max_states", max_states, 2, "an integer >= 2 (states)")
        step = max(1, math.ceil(sweeps / max_states))
    else:
        if isinstance(sweep_step, bool) or int(sweep_step) != sweep_step or sweep_step < 1:
            raise ParameterError("ambiguity", "sweep_step", "an integer >= 1 (sweeps)",
                                 sweep_step)
        step = int(sweep_step)
    count = math.ceil(sweeps / step)
    require_memory("ambiguity", "max_states" if sweep_step is None else "sweep_step",
                   count * STATE_BYTES, f"{count} platform states of {sweeps} sweeps: "
                   "fewer max_states or a larger sweep_step")
    sweep = np.arange(0, sweeps, step)
    time = (sweep + 0.5) / radar.prf
    interval = np.stack([sweep / radar.prf, np.minimum(sweep + step, sweeps) / radar.prf], -1)
    attitude = trajectory.attitude_at(time)
    frame = antenna_frame(look, attitude[:, 0], attitude[:, 1], attitude[:, 2])
    return States(sweep, time, interval, trajectory.position(time), trajectory.velocity(time),
                   frame[..., 2], frame, step)


def run_durations(lit: NDArray, margin: NDArray, states: States) -> NDArray:
    """Duration [s] of the contiguous illuminated run holding each illuminated state.

    A run ends between two states; where one of them is inside and the other outside the beam
    (``margin`` = two-way pattern minus threshold, finite, changing sign) the end is
    interpolated linearly in ``margin``, else it is the edge of the state's interval.
    """
    count, size = lit.shape
    time = states.time
    index = np.broadcast_to(np.arange(size), lit.shape)
    previous = np.zeros_like(lit)
    previous[:, 1:] = lit[:, :-1]
    following = np.zeros_like(lit)
    following[:, :-1] = lit[:, 1:]
    starts = lit & ~previous
    ends = lit & ~following

    start_time = np.broadcast_to(states.interval[:, 0], lit.shape).copy()
    end_time = np.broadcast_to(states.interval[:, 1], lit.shape).copy()
    with np.errstate(divide="ignore", invalid="ignore"):
        # Interpolated start between state s-1 (outside) and s (inside).
        m_out, m_in = margin[:, :-1], margin[:, 1:]
        fraction = -m_out / (m_in - m_out)
        ok = np.isfinite(m_out) & (m_out < 0) & (m_in >= 0)
        crossing = time[:-1] + fraction * (time[1:] - time[:-1])
        start_time[:, 1:] = np.where(ok, crossing, start_time[:, 1:])
        # Interpolated end between state s (inside) and s+1 (outside).
        m_in, m_out = margin[:, :-1], margin[:, 1:]
        fraction = m_in / (m_in - m_out)
        ok = np.isfinite(m_out) & (m_out < 0) & (m_in >= 0)
        crossing = time[:-1] + fraction * (time[1:] - time[:-1])
        end_time[:, :-1] = np.where(ok, crossing, end_time[:, :-1])

    first = np.maximum.accumulate(np.where(starts, index, -1), axis=1)
    last = np.minimum.accumulate(np.where(ends, index, size)[:, ::-1], axis=1)[:, ::-1]
    first = np.clip(first, 0, size - 1)
    last = np.clip(last, 0, size - 1)
    duration = (np.take_along_axis(end_time, last, axis=1)
                - np.take_along_axis(start_time, first, axis=1))
    return np.where(lit, np.maximum(duration, 0.0), 0.0)
