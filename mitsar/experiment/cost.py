"""The cost of one whole run of a campaign (simulate, focus, measure), from its parameters.

:func:`estimate_run_seconds` chooses where a campaign runs, in this process or on a local Dask
cluster (:func:`mitsar.experiment.campaign.choose_scheduler`, docs/reliability.md §7); its
constants were measured on a loaded 2-core machine (issue 27), so it is right within a factor
of 2 or so. The Monte Carlo (:mod:`mitsar.experiment.montecarlo`) and the sweeps
(:mod:`mitsar.experiment.sweep`) use it.
"""

from __future__ import annotations

import contextlib
from collections.abc import Sequence
from typing import Any

import numpy as np

from mitsar.experiment.options import Experiment
from mitsar.lazy import LazyModule
from mitsar.model.signal import sweep_count

__all__ = ["FOCUS_SECONDS_PER_PIXEL_SWEEP", "MEASURE_SECONDS", "SCENE_RUN_SECONDS",
           "SIMULATE_SECONDS_PER_ECHO", "estimate_run_seconds", "pixel_count"]

analytic = LazyModule("mitsar.raw.analytic")
"""The analytic simulator, for the background's cell area (imported when a cost is estimated,
i.e. when a campaign has runs left)."""


SIMULATE_SECONDS_PER_ECHO = 1e-8
"""Analytic simulation cost per sweep x sample x scatterer x channel [s]: the paper's point target
(600 sweeps x 660 samples x 1074 scatterers) simulates in 3.8-4.9 s on a loaded 2-core
machine (issue 27)."""


FOCUS_SECONDS_PER_PIXEL_SWEEP = 1e-8
"""Focusing cost per pixel x sweep x channel [s] (back-projection, the slowest: 0.16-0.25 s for
the paper's 121 x 201 grid and 600 sweeps)."""


MEASURE_SECONDS = 0.6
"""Cost of measuring one image's impulse response [s] (0.56-1.8 s for the paper's grid)."""


SCENE_RUN_SECONDS = 60.0
"""Assumed cost of simulating a ray-traced scene [s]: not estimated from its parameters."""


def estimate_run_seconds(experiment: Experiment, algorithms: Sequence[str]) -> float:
    """Rough cost of :func:`measure_realisation` on this experiment [s], from its parameters only.

    Simulation: sweeps x samples x (targets + background scatterers) x channels x
    :data:`SIMULATE_SECONDS_PER_ECHO` (a scene: :data:`SCENE_RUN_SECONDS`); per algorithm:
    pixels x sweeps x channels x :data:`FOCUS_SECONDS_PER_PIXEL_SWEEP` + :data:`MEASURE_SECONDS`.
    It chooses where a campaign runs (:func:`mitsar.experiment.campaign.choose_scheduler`); the
    constants are measured on a loaded 2-core machine, so within a factor of 2 or so.

    Parameters
    ----------
    experiment : Experiment
    algorithms : sequence of str

    Returns
    -------
    float
        Seconds (> 0).
    """
    radar = experiment.radar
    sweeps = max(sweep_count(radar, experiment.trajectory.duration), 1)
    channels = max(int(getattr(radar, "channel_count", 1) or 1), 1)
    if experiment.scene is not None:
        simulate = SCENE_RUN_SECONDS
    else:
        scatterers = len(experiment.targets)
        background = experiment.background
        if background is not None:
            with contextlib.suppress(ValueError, ZeroDivisionError, AttributeError):
                mid = experiment.trajectory.position(experiment.trajectory.duration / 2)
                area = analytic.background_cell_area(radar, background,
                                                     np.asarray(mid).reshape(3))
                scatterers += background.scatterer_count(area)
        simulate = (sweeps * radar.samples_per_sweep * max(scatterers, 1) * channels
                    * SIMULATE_SECONDS_PER_ECHO)
    per_algorithm = (pixel_count(experiment.focus.grid) * sweeps * channels
                     * FOCUS_SECONDS_PER_PIXEL_SWEEP + MEASURE_SECONDS)
    return float(simulate + len(algorithms) * per_algorithm)


def pixel_count(grid: dict | None) -> int:
    """Pixels of a ``[focus.grid]`` table (an axis it leaves to the algorithm: 256)."""
    if not grid:
        return 256 * 256

    def count(axis: Any) -> int:
        if (isinstance(axis, list | tuple) and len(axis) == 3
                and all(isinstance(v, int | float) for v in axis) and axis[2]):
            return max(int((axis[1] - axis[0]) / axis[2]) + 1, 1)
        if isinstance(axis, list | tuple) and axis:
            return len(axis)
        return 256

    if "points" in grid:
        return max(len(grid["points"]), 1)
    axes = [grid[k] for k in ("along_track", "slant_range", "u", "v", "x", "y", "z") if k in grid]
    return int(np.prod([count(a) for a in axes])) if axes else 256 * 256
