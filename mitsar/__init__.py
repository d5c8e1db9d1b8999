"""mitsar: FMCW millimetre-wave SAR simulation and processing for indoor drones.

The public API, re-exported from the modules that define it (see ``docs/``).
"""

__version__ = "0.1.0"

from mitsar import grid  # noqa: E402
from mitsar.errors import MitsarError, ParameterError  # noqa: E402
from mitsar.focus import focus, range_compress  # noqa: E402
from mitsar.geometry.attitude import Look, boresight  # noqa: E402
from mitsar.geometry.trajectory import Trajectory  # noqa: E402
from mitsar.io import load, save  # noqa: E402
from mitsar.quality import measure_impulse_response  # noqa: E402
from mitsar.radar import Radar  # noqa: E402
from mitsar.realdata import raw_from_arrays, read_gotcha, read_raw  # noqa: E402
from mitsar.simulate import simulate_point_targets  # noqa: E402
from mitsar.targets import Background, PointTarget  # noqa: E402
from mitsar.trace import histogram_to_raw_product, simulate_scene, trace  # noqa: E402

__all__ = [
    "Background", "Look", "MitsarError", "ParameterError", "PointTarget", "Radar", "Trajectory",
    "boresight", "focus", "grid", "histogram_to_raw_product", "load", "measure_impulse_response",
    "range_compress", "raw_from_arrays", "read_gotcha", "read_raw", "save",
    "simulate_point_targets", "simulate_scene", "trace",
]
