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

from mitsar.focus.windows import WINDOWS as _WINDOWS
from mitsar.lazy import LazyModule
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
    "PASS_SEED_RULE",
    "RESUME_CHUNK_SWEEPS",
    "Pass",
    "pass_seed",
]

grid_module = LazyModule("mitsar.focus.grid")
"""The focusing grids, imported when an experiment makes its grid (xarray and SciPy behind
them: reading an experiment, or a campaign's no-op rerun, needs neither)."""

ALGORITHMS = ("bpa", "rda", "wda", "fsa", "ffbp")
"""Focusing algorithms accepted by ``[focus] algorithm``: :data:`mitsar.focus.dispatch.
ALGORITHMS`, written out so that reading an experiment does not import every focuser (1 CPU-s
of SciPy and xarray; ``tests/test_startup_montecarlo.py`` holds the two equal)."""

AUTOFOCUS_METHODS = ("pga", "entropy")
"""Autofocus methods of :func:`mitsar.focus` (``autofocus=``)."""

ISLR_EXTENTS = tuple(_QUALITY_EXTENTS)
"""Named ISLR side-lobe extents accepted by ``[metrics] islr_extent`` (or a number of cells)."""

WINDOWS = tuple(_WINDOWS)
"""Spectral windows accepted by ``[focus] window``."""

GRID_KINDS = ("slant", "plane", "points")
"""Output grid kinds accepted by ``[focus.grid] kind``."""

RESUME_CHUNK_SWEEPS = 1024
"""Sweeps per chunk of :func:`mitsar.experiment.runs.simulate_to` (the unit of resumption): a
multiple of the ray tracer's 128-sweep chunks, so that a traced product made chunk by chunk
equals one :func:`mitsar.simulate_scene` call bit for bit wherever the tracer keeps those
chunks (docs/reliability.md §5). Here, not in :mod:`~mitsar.experiment.runs`, so that the
command line's parser reads it without importing the stages."""


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
    band_limit : bool
        Band-limit BPA's and FFBP's 2-D images off a straight track to the processed azimuth
        resolution (:mod:`mitsar.focus.band_limit`, ``docs/focusing.md``); False keeps each
        pixel's own aperture band.
    """

    algorithm: str = "bpa"
    window: str = "rect"
    azimuth_resolution: float | None = None
    grid: dict[str, Any] | None = None
    autofocus: str | None = None
    band_limit: bool = True

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


@dataclass(frozen=True)
class MappingOptions:
    """Mapping options (``[mapping]``; :func:`mitsar.map_scene`, docs/features.md): what
    ``mitsar run`` does with the passes of an experiment over a scene.

    Attributes
    ----------
    pfa : float
        CFAR false-alarm probability per voxel (0 < pfa < 1).
    method : {"ca", "os"}
        CFAR method (cell-averaging or ordered-statistic).
    tau : float
        Distance threshold of the map scores [m].
    combine : {"coherent", "incoherent"}
        How the passes are summed in the volume.
    elevation_window : str or None
        Window across the passes ("hamming", ...), or none.
    """

    pfa: float = 1e-6
    method: str = "ca"
    tau: float = 0.05
    combine: str = "coherent"
    elevation_window: str | None = None


PASS_SEED_RULE = "numpy.random.SeedSequence(seed, spawn_key=(pass index,)), first 64-bit word >> 1"
"""How a pass's seeds follow from the experiment's (:func:`pass_seed`; recorded in products)."""


def pass_seed(seed: int, index: int) -> int:
    """The seed of pass ``index`` derived from an experiment seed (:data:`PASS_SEED_RULE`).

    The rule of :func:`mitsar.experiment.campaign.task_seed` with the pass index as the spawn
    key: independent streams for different passes, the same number for the same (seed, index).

    Parameters
    ----------
    seed : int
        The experiment's seed (``[simulation] seed``, or the inherited ``[trajectory.errors]
        seed`` for navigation errors), >= 0.
    index : int
        The pass index (0, 1, ...).

    Returns
    -------
    int
        A seed in [0, 2**63).
    """
    state = np.random.SeedSequence(int(seed), spawn_key=(int(index),))
    return int(state.generate_state(1, np.uint64)[0] >> np.uint64(1))


@dataclass(frozen=True)
class Pass:
    """One acquisition of a multi-pass experiment (``[[passes]]``, docs/experiments.md).

    Attributes
    ----------
    index : int
        Position in ``[[passes]]`` (0, 1, ...): the raw product's ``pass`` attribute.
    name : str
        Free label (default ``"pass<index>"``).
    trajectory : Trajectory
        The pass's true track (its ``trajectory`` keys over the experiment's ``[trajectory]``,
        then shifted by ``offset``).
    look : Look
        The pass's antenna look (its ``look`` keys over the experiment's ``[look]``).
    navigation : NavigationErrors or None
        The pass's navigation errors (``trajectory.errors`` keys over the experiment's
        ``[trajectory.errors]``; the seed, unless the pass gives one, is
        :func:`pass_seed` of the inherited seed and the index).
    seed : int or None
        The pass's receiver-noise seed when the file gives one; ``None``: :func:`pass_seed`
        of the experiment's ``[simulation] seed`` (:meth:`Experiment.pass_seed`).
    offset : tuple of 3 floats
        Translation [m] applied to the inherited track.
    """

    index: int
    name: str
    trajectory: Trajectory
    look: Look
    navigation: NavigationErrors | None = None
    seed: int | None = None
    offset: tuple[float, float, float] = (0.0, 0.0, 0.0)


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
    mapping : MappingOptions or None
        ``[mapping]``: map the scene from the passes and score the map against it
        (``mitsar run``; None: no map).
    passes : tuple of Pass
        ``[[passes]]``: several acquisitions of one scene (empty: one acquisition). With
        passes, ``trajectory``, ``look`` and ``navigation`` above are pass 0's, so that a tool
        that flies one track (preview, rays, Monte Carlo, sweeps) flies pass 0.
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
    passes: tuple[Pass, ...] = ()
    mapping: MappingOptions | None = None

    def pass_seed(self, index: int) -> int:
        """Receiver-noise seed of pass ``index``: the pass's ``seed`` when the file gives one,
        else :func:`pass_seed` of ``[simulation] seed`` and the index (docs/experiments.md
        §Passes)."""
        given = self.passes[index].seed
        return given if given is not None else pass_seed(self.simulation.seed or 0, index)

    def metrics_target(self) -> tuple[float, float, float] | None:
        """The target to measure: ``[metrics] target``, else the first point target."""
        if self.metrics.target is not None:
            return self.metrics.target
        if self.targets:
            return tuple(float(v) for v in np.asarray(self.targets[0].position))
        return None

