"""Experiments: a whole acquisition and its processing, described in one TOML file and run.

Configuration (:mod:`~mitsar.experiment.options`, read and validated by
:mod:`~mitsar.experiment.loading` with :mod:`~mitsar.experiment.table` and
:mod:`~mitsar.experiment.parsers`) stands apart from the workflow (:mod:`~mitsar.experiment.runs`,
:mod:`~mitsar.experiment.montecarlo`). Bundled examples: :mod:`~mitsar.experiment.examples`.
"""

from mitsar.experiment.examples import example_path, examples_dir
from mitsar.experiment.loading import experiment_from_dict, load_experiment, load_grid
from mitsar.experiment.options import Experiment, FocusOptions, MetricsOptions
from mitsar.experiment.runs import run_focus, run_metrics, run_simulation

__all__ = [
    "Experiment", "FocusOptions", "MetricsOptions", "example_path",
    "examples_dir", "experiment_from_dict", "load_experiment", "load_grid", "run_focus",
    "run_metrics", "run_simulation",
]
