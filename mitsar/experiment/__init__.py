"""Experiments: a whole acquisition and its processing, described in one TOML file and run.

Configuration (:mod:`~mitsar.experiment.options`, read and validated by
:mod:`~mitsar.experiment.loading` with :mod:`~mitsar.experiment.table` and
:mod:`~mitsar.experiment.parsers`) stands apart from the workflow (:mod:`~mitsar.experiment.runs`,
:mod:`~mitsar.experiment.montecarlo`); an experiment with ``[[passes]]`` is simulated pass by
pass (:func:`simulate_passes`). Bundled examples: :mod:`~mitsar.experiment.examples`.
"""

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
