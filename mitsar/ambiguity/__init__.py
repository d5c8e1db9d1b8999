"""Resolution and ambiguity maps by the gradient method (see ``docs/ambiguity.md``)."""

from mitsar.ambiguity.gradient import (
    ambiguity,
    compare_trajectories,
    comparison_table,
    plot_ambiguity,
    run_ambiguity_experiment,
)

__all__ = ["ambiguity", "compare_trajectories", "comparison_table", "plot_ambiguity",
           "run_ambiguity_experiment"]
