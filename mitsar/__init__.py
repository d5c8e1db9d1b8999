"""mitsar: FMCW millimetre-wave SAR simulation and processing for indoor drones.

The public API, re-exported from the modules that define it (see ``docs/``).
"""

__version__ = "0.1.0"

from mitsar.errors import MitsarError, ParameterError  # noqa: E402
from mitsar.focus import focus, range_compress  # noqa: E402
from mitsar.geometry.attitude import Look, boresight  # noqa: E402
from mitsar.geometry.trajectory import Trajectory  # noqa: E402
from mitsar.radar import Radar  # noqa: E402
from mitsar.simulate import simulate_point_targets  # noqa: E402
from mitsar.targets import Background, PointTarget  # noqa: E402

__all__ = [
    "Background", "Look", "MitsarError", "ParameterError", "PointTarget", "Radar", "Trajectory",
    "boresight", "focus", "range_compress", "simulate_point_targets",
]
