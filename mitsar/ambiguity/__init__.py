"""Resolution and ambiguity maps by the gradient method (see ``docs/ambiguity.md``).

Gradients and resolutions (:mod:`~mitsar.ambiguity.gradient`), surface points
(:mod:`~mitsar.ambiguity.points`), platform states (:mod:`~mitsar.ambiguity.states`), shadows
(:mod:`~mitsar.ambiguity.shadows`), the maps (:mod:`~mitsar.ambiguity.maps`), trajectories
compared (:mod:`~mitsar.ambiguity.comparison`), figures (:mod:`~mitsar.ambiguity.plots`), the
TOML file (:mod:`~mitsar.ambiguity.config`) and its run (:mod:`~mitsar.ambiguity.run`).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mitsar.lazy import lazy_exports

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.ambiguity.comparison import (
        compare_trajectories,
        comparison_from_products,
        comparison_table,
    )
    from mitsar.ambiguity.config import load_ambiguity_experiment
    from mitsar.ambiguity.gradient import delay_gradient, doppler_gradient, gradient_resolution
    from mitsar.ambiguity.maps import (
        OBSERVATION_MEANINGS,
        STATUS_MEANINGS,
        ambiguity,
        surface_summary,
    )
    from mitsar.ambiguity.plots import (
        plot_ambiguity,
        plot_ambiguity_3d,
        plot_ambiguity_maps,
        plot_ambiguity_timeline,
        plot_comparison,
    )
    from mitsar.ambiguity.points import SurfacePoints, plane_points, sample_surfaces
    from mitsar.ambiguity.run import run_ambiguity_experiment
    from mitsar.ambiguity.shadows import planes_scene

__all__ = [
    "OBSERVATION_MEANINGS", "STATUS_MEANINGS", "SurfacePoints", "ambiguity",
    "compare_trajectories", "comparison_from_products", "comparison_table", "delay_gradient",
    "doppler_gradient", "gradient_resolution", "load_ambiguity_experiment", "plane_points",
    "planes_scene", "plot_ambiguity", "plot_ambiguity_3d", "plot_ambiguity_maps",
    "plot_ambiguity_timeline", "plot_comparison", "run_ambiguity_experiment", "sample_surfaces",
    "surface_summary",
]

_EXPORTS = {
    "OBSERVATION_MEANINGS": "mitsar.ambiguity.maps",
    "STATUS_MEANINGS": "mitsar.ambiguity.maps",
    "SurfacePoints": "mitsar.ambiguity.points",
    "ambiguity": "mitsar.ambiguity.maps",
    "compare_trajectories": "mitsar.ambiguity.comparison",
    "comparison_from_products": "mitsar.ambiguity.comparison",
    "comparison_table": "mitsar.ambiguity.comparison",
    "delay_gradient": "mitsar.ambiguity.gradient",
    "doppler_gradient": "mitsar.ambiguity.gradient",
    "gradient_resolution": "mitsar.ambiguity.gradient",
    "load_ambiguity_experiment": "mitsar.ambiguity.config",
    "plane_points": "mitsar.ambiguity.points",
    "planes_scene": "mitsar.ambiguity.shadows",
    "plot_ambiguity": "mitsar.ambiguity.plots",
    "plot_ambiguity_3d": "mitsar.ambiguity.plots",
    "plot_ambiguity_maps": "mitsar.ambiguity.plots",
    "plot_ambiguity_timeline": "mitsar.ambiguity.plots",
    "plot_comparison": "mitsar.ambiguity.plots",
    "run_ambiguity_experiment": "mitsar.ambiguity.run",
    "sample_surfaces": "mitsar.ambiguity.points",
    "surface_summary": "mitsar.ambiguity.maps",
}
"""Public names -> the module that defines each, imported on first use (PEP 562)."""


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), __all__)
