"""mitsar: FMCW millimetre-wave SAR simulation and processing for indoor drones.

The public API, re-exported from the stage that defines each name (``docs/design.md`` draws
the stages: model → scene → raw → focus → quality, with ambiguity maps beside them).
"""

from mitsar import ambiguity
from mitsar.errors import MitsarError, ParameterError
from mitsar.export import read_cphd
from mitsar.features import detect
from mitsar.features.mapping import map_scene
from mitsar.features.scores import map_scores
from mitsar.focus import grid
from mitsar.focus.compression import range_compress
from mitsar.focus.dispatch import focus
from mitsar.interferometry import interferogram
from mitsar.io import load, save
from mitsar.model.geometry.attitude import Look, boresight
from mitsar.model.geometry.navigation import NavigationErrors, Vibration
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.model.targets import Background, PointTarget
from mitsar.model.trace_options import TraceOptions
from mitsar.quality.impulse import measure_impulse_response
from mitsar.raw.analytic import simulate_point_targets
from mitsar.raw.recorded import raw_from_arrays, read_gotcha, read_raw
from mitsar.raw.traced import histogram_to_raw_product, simulate_scene, trace
from mitsar.version import __version__

__all__ = [
    "Background", "Look", "MitsarError", "NavigationErrors", "ParameterError", "PointTarget",
    "Radar", "TraceOptions", "Trajectory", "Vibration", "__version__", "ambiguity", "boresight",
    "detect", "focus", "grid", "histogram_to_raw_product", "interferogram", "load", "map_scene",
    "map_scores",
    "measure_impulse_response", "range_compress", "raw_from_arrays", "read_cphd", "read_gotcha",
    "read_raw", "save", "simulate_point_targets", "simulate_scene", "trace",
]
