"""Run configuration: what an experiment file describes, as plain validated objects.

:class:`Experiment` bundles the radar, trajectory, look, targets and the options of the three
workflow steps (the trace request :class:`~mitsar.model.trace_options.TraceOptions` that
``[simulation]`` fills, :class:`FocusOptions`, :class:`MetricsOptions`).
Reading them from TOML is :mod:`mitsar.experiment.loading`; running them is
:mod:`mitsar.experiment.runs`.
"""

from __future__ import annotations

import copy
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from mitsar.focus import grid as grid_module
from mitsar.focus.dispatch import ALGORITHMS as _FOCUS_ALGORITHMS
from mitsar.focus.windows import WINDOWS as _WINDOWS
from mitsar.model.geometry.attitude import Look
from mitsar.model.geometry.navigation import NavigationErrors
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.model.targets import Background, PointTarget
from mitsar.model.trace_options import TraceOptions
from mitsar.quality.cuts import ISLR_EXTENTS as _QUALITY_EXTENTS

__all__ = [
    "ALGORITHMS",
    "AUTOFOCUS_METHODS",
    "GRID_KINDS",
    "ISLR_EXTENTS",
    "WINDOWS",
    "Experiment",
    "FocusOptions",
    "InterferometryOptions",
    "MetricsOptions",
]

ALGORITHMS = tuple(_FOCUS_ALGORITHMS)

AUTOFOCUS_METHODS = ("pga", "entropy")
"""Autofocus methods of :func:`mitsar.focus` (``autofocus=``)."""
"""Focusing algorithms accepted by ``[focus] algorithm``."""

ISLR_EXTENTS = tuple(_QUALITY_EXTENTS)
"""Named ISLR side-lobe extents accepted by ``[metrics] islr_extent`` (or a number of cells)."""

WINDOWS = tuple(_WINDOWS)
"""Spectral windows accepted by ``[focus] window``."""

GRID_KINDS = ("slant", "plane", "points")
"""Output grid kinds accepted by ``[focus.grid] kind``."""


@dataclass(frozen=True)
class FocusOptions:
    """Focusing options (``[focus]``).

    Attributes
    ----------
    algorithm : {"bpa", "rda", "wda", "fsa", "ffbp"}
        Focusing algorithm.
    window : str
        Spectral window of range and azimuth compression (``"rect"`` = none).
    azimuth_resolution : float or None
        Processed azimuth resolution [m]; ``None`` uses the full beam.
    grid : dict or None
        The ``[focus.grid]`` table (see :func:`mitsar.focus.grid.from_dict`); ``None`` lets the
        algorithm choose its default slant-range grid.
    autofocus : {"pga", "entropy"} or None
        Autofocus after back-projection (``docs/autofocus.md``); ``None``: none.
    """

    algorithm: str = "bpa"
    window: str = "rect"
    azimuth_resolution: float | None = None
    grid: dict[str, Any] | None = None
    autofocus: str | None = None

    def make_grid(self) -> Any:
        """The output grid object, or ``None`` for the algorithm's default grid."""
        if self.grid is None:
            return None
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
        ``"chip"``, ``"inf"`` or a number of resolution cells (see :mod:`mitsar.quality.cuts`).
    """

    target: tuple[float, float, float] | None = None
    islr_extent: str | float = "paper"


@dataclass(frozen=True)
class InterferometryOptions:
    """Interferometry options (``[interferometry]``; :func:`mitsar.interferometry.interferogram`,
    docs/interferometry.md). Used when the radar has two or more receive channels.

    Attributes
    ----------
    pair : (int, int)
        Channels (1, 2) of the interferogram ``s_1 s_2*``.
    looks : (int, int)
        Multilook window (rows, cols) [pixels] on the image grid.
    unwrap : bool
        Unwrap the phase with SNAPHU; false takes the wrapped phase (right when every scatterer
        lies within half an ambiguity height of the focusing grid).
    min_coherence : float
        Pixels of lower coherence [1] are left out of unwrapping and of the point cloud.
    """

    pair: tuple[int, int] = (0, 1)
    looks: tuple[int, int] = (1, 1)
    unwrap: bool = True
    min_coherence: float = 0.3


@dataclass
class Experiment:
    """A validated experiment (see :func:`load_experiment`).

    Attributes
    ----------
    radar : Radar
    trajectory : Trajectory
        The true track.
    look : Look
    targets : list of PointTarget
    background : Background or None
    simulation : TraceOptions
        ``[simulation]``: the trace request of a scene (its seed, ``rvp``, ``normalized`` and
        ``noise`` also drive the analytic simulator); fields the file leaves out are ``None``
        and fall to the scene's integrator, then to the defaults.
    focus : FocusOptions
    metrics : MetricsOptions
    interferometry : InterferometryOptions
        ``[interferometry]``: what ``mitsar run`` does with the image of a radar with two or
        more receive channels (the defaults when the file has no such table).
    scene : str or None
        A scene file (absolute path) or a canned scene name, for scene-based simulation.
    navigation : NavigationErrors or None
        ``[trajectory.errors]``: what the navigation system records differs from the track.
    motion : dict
        ``[motion.<shape id>]``: shapes of the scene that move: a velocity [m/s], or a
        :class:`mitsar.scene.motion.ShapeMotion` (angular velocity, centre, sampled path).
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
    simulation: TraceOptions
    focus: FocusOptions
    metrics: MetricsOptions
    scene: str | None = None
    navigation: NavigationErrors | None = None
    motion: dict[str, Any] = field(default_factory=dict)
    interferometry: InterferometryOptions = field(default_factory=InterferometryOptions)
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

