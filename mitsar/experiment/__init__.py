"""Experiments: a whole acquisition and its processing, described in one TOML file and run.

Configuration (:mod:`~mitsar.experiment.options`, read and validated by
:mod:`~mitsar.experiment.loading` with :mod:`~mitsar.experiment.table` and
:mod:`~mitsar.experiment.parsers`) stands apart from the workflow (:mod:`~mitsar.experiment.runs`,
:mod:`~mitsar.experiment.montecarlo`); an experiment with ``[[passes]]`` is simulated pass by
pass (:func:`simulate_passes`). Bundled examples: :mod:`~mitsar.experiment.examples`.
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mitsar.lazy import lazy_exports

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.experiment.examples import example_path, examples_dir
    from mitsar.experiment.loading import experiment_from_dict, load_experiment, load_grid
    from mitsar.experiment.options import Experiment, FocusOptions, MetricsOptions, Pass
    from mitsar.experiment.runs import (
        pass_experiment,
        run_focus,
        run_focus_passes,
        run_metrics,
        run_simulation,
        simulate_pass,
        simulate_passes,
    )

__all__ = [
    "Experiment", "FocusOptions", "MetricsOptions", "Pass", "example_path",
    "examples_dir", "experiment_from_dict", "load_experiment", "load_grid", "pass_experiment",
    "run_focus", "run_focus_passes", "run_metrics", "run_simulation", "simulate_pass",
    "simulate_passes",
]

_EXPORTS = {
    "Experiment": "mitsar.experiment.options",
    "FocusOptions": "mitsar.experiment.options",
    "MetricsOptions": "mitsar.experiment.options",
    "Pass": "mitsar.experiment.options",
    "example_path": "mitsar.experiment.examples",
    "examples_dir": "mitsar.experiment.examples",
    "experiment_from_dict": "mitsar.experiment.loading",
    "load_experiment": "mitsar.experiment.loading",
    "load_grid": "mitsar.experiment.loading",
    "pass_experiment": "mitsar.experiment.runs",
    "run_focus": "mitsar.experiment.runs",
    "run_focus_passes": "mitsar.experiment.runs",
    "run_metrics": "mitsar.experiment.runs",
    "run_simulation": "mitsar.experiment.runs",
    "simulate_pass": "mitsar.experiment.runs",
    "simulate_passes": "mitsar.experiment.runs",
}
"""Public names -> the module that defines each, imported on first use (PEP 562)."""


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), __all__)
