"""The benchmarks' common workload: the paper's point target (§4.1 geometry, unit echo) seen by
a pass of ``sweeps`` sweeps centred on it. Not a benchmark itself."""

from __future__ import annotations

import math

import xarray as xr

import mitsar

TARGET = (15.0, 8.0, 0.0)


def paper_target_raw(sweeps: int, radar: mitsar.Radar | None = None) -> xr.Dataset:
    """Normalised raw data of the paper's target over a pass of ``sweeps`` sweeps at 0.5 m/s."""
    radar = radar or mitsar.Radar()
    duration = sweeps / radar.prf
    trajectory = mitsar.Trajectory.linear([15.0 - 0.25 * duration, 1.4, 4.5], [0.5, 0, 0],
                                          duration)
    look = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
    return mitsar.simulate_point_targets(radar, trajectory, look, [mitsar.PointTarget(TARGET)],
                                         normalized=True)
