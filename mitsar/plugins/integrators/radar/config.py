"""Parameters of the ``radar`` integrator: limits, defaults and their validation (pure Python).

This module imports neither Mitsuba nor Dr.Jit, so the orchestration in :mod:`mitsar.raw.traced`
and the experiment configuration can build and check a configuration before a variant is set.
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass
from typing import Any

import numpy as np

from mitsar import checks
from mitsar.errors import ParameterError
from mitsar.model import histogram as hg
from mitsar.model.multipath import CAPTURE_KINDS
from mitsar.model.radar import Radar
from mitsar.plugins import parse_vector3

PLUGIN_NAME = "radar"
"""XML type name."""

PARAMETERS: tuple[str, ...] = ("scatterer_density", "scatterers_per_cell", "max_depth",
                               "chunk_lanes", "seed", "bins_per_cell", "beam_cull", "rays",
                               "ray_cover", "capture", "ghosts", "plane_normal", "slab_width",
                               "visibility_feature", "block_kernel")
"""Accepted XML parameters."""

MAX_LANES = 2**26
"""Upper bound on lanes per kernel launch (Dr.Jit wavefront size; docs/design.md §7)."""

DEFAULT_CHUNK_LANES = 2**24
"""Default lanes (scatterer x sweep pairs) per kernel launch."""

MAX_DEPTH = 8
"""Largest ``max_depth`` (hits per ray; up to 7 reflections)."""

MULTIPATH_CHUNK_LANES = 2**20
"""Ray x sweep lanes per multipath launch (each lane holds ~40 floats of state)."""

DEFAULT_RAYS = 4096
"""Default number of multipath rays per sweep."""

SWEEPS_PER_CHUNK = 128
"""Sweeps traced together (one histogram buffer, one chunk-level beam cull)."""

HISTOGRAM_CHUNK_ELEMENTS = 2**22
"""Bound on sweeps x orders x bins of the histogram buffer of one launch (2 x 32 MiB)."""

def histogram_buffer_length(size: int) -> int:
    """Length of a histogram buffer of ``size`` elements: the next power of two or 1.5 times a
    power of two, at least 2^16 (the length is a literal of the kernels: two lengths per
    octave, few compilations; at most a third of the buffer is unused)."""
    power = 1 << (max(int(size), 1) - 1).bit_length()
    return max(2**16, power * 3 // 4 if power * 3 // 4 >= size else power)


AZIMUTH_CELL = 0.10
"""Azimuth size of the resolution cell for ``scatterers_per_cell`` [m] (paper Table 1)."""

DEFAULT_VISIBILITY_FEATURE = 0.03
"""Default smallest occluder (or gap) width that shadow-ray reuse across sweeps resolves [m]:
~10 wavelengths at 94 GHz, below the first Fresnel zone radius sqrt(λ d) of an occluder more
than 0.3 m from the scatterer, where sharp geometric shadows are already an approximation
(docs/integrator.md §"Visibility reuse")."""

_FLOATS = ("scatterer_density", "scatterers_per_cell", "beam_cull", "ray_cover", "slab_width",
           "visibility_feature")


@dataclass(frozen=True)
class RadarIntegratorConfig:
    """Parameters of the ``radar`` integrator (XML reference: :mod:`.integrator`)."""

    scatterer_density: float | None = None
    scatterers_per_cell: float = 9.0
    max_depth: int = 1
    chunk_lanes: int = DEFAULT_CHUNK_LANES
    seed: int = 0
    bins_per_cell: int = hg.DEFAULT_BINS_PER_CELL
    beam_cull: float = 2.0
    rays: int = DEFAULT_RAYS
    ray_cover: float = 1.0
    capture: str = "tent"
    ghosts: bool = False
    plane_normal: tuple[float, float, float] | None = None
    slab_width: float = AZIMUTH_CELL
    visibility_feature: float = DEFAULT_VISIBILITY_FEATURE
    block_kernel: bool = True
    """Direct backscatter of static 3-D scatterer sets with visibility reuse by the block
    kernel (:mod:`.blocks`, docs/integrator.md §"Performance"); False: the lane kernels."""

    def __post_init__(self) -> None:
        self.validate("radar")

    def validate(self, where: str) -> None:
        """Raise ParameterError naming the first invalid parameter."""
        def integer(name: str, low: int, high: int | None = None) -> None:
            value = getattr(self, name)
            bound = f"an integer in [{low}, {high}]" if high else f"an integer >= {low}"
            checks.integer(where, name, value, low, bound)
            if high is not None and value > high:
                raise ParameterError(where, name, bound, value)

        if self.scatterer_density is not None:
            checks.positive(where, "scatterer_density", self.scatterer_density,
                            "None or a finite number > 0")
        for name in ("scatterers_per_cell", "ray_cover", "slab_width"):
            checks.positive(where, name, getattr(self, name))
        integer("max_depth", 1, MAX_DEPTH)
        integer("chunk_lanes", 1, MAX_LANES - 1)
        integer("rays", 1, MULTIPATH_CHUNK_LANES)
        if self.capture not in CAPTURE_KINDS:
            raise ParameterError(where, "capture", f"one of {list(CAPTURE_KINDS)}", self.capture)
        checks.boolean(where, "ghosts", self.ghosts)
        checks.boolean(where, "block_kernel", self.block_kernel)
        if self.plane_normal is not None:
            normal = np.asarray(self.plane_normal, dtype=float)
            if normal.shape != (3,) or not np.all(np.isfinite(normal)) \
                    or not np.linalg.norm(normal) > 0:
                raise ParameterError(where, "plane_normal", "None (3D) or a non-zero 3-vector "
                                     "(2D mode: normal of the plane of the rays)",
                                     self.plane_normal)
        integer("seed", 0)
        integer("bins_per_cell", 1, 256)
        checks.finite(where, "visibility_feature", self.visibility_feature,
                      "a width >= 0 m (0: a shadow ray per sweep)")
        if not self.visibility_feature >= 0:
            raise ParameterError(where, "visibility_feature", "a width >= 0 m (0: a shadow ray "
                                 "per sweep)", self.visibility_feature)
        value = self.beam_cull
        if not checks.is_real(value) or not value > 0:
            raise ParameterError(where, "beam_cull", "a number of beamwidths > 0 (inf: no "
                                 "culling)", value)

    @classmethod
    def from_values(cls, values: dict[str, Any], where: str = "radar") -> RadarIntegratorConfig:
        """Build from XML property values (already checked against :data:`PARAMETERS`)."""
        values = dict(values)
        if values.get("plane_normal") is not None:
            values["plane_normal"] = parse_vector3(values["plane_normal"], where,
                                                   "plane_normal")
        for name in _FLOATS:
            if isinstance(values.get(name), int) and not isinstance(values[name], bool):
                values[name] = float(values[name])
        return cls._build(values, where)

    def replace(self, where: str = "radar", **changes: Any) -> RadarIntegratorConfig:
        """A validated copy with some parameters changed (``None`` values are ignored)."""
        changes = {k: v for k, v in changes.items() if v is not None}
        if "plane_normal" in changes:
            changes["plane_normal"] = tuple(float(v) for v in np.ravel(changes["plane_normal"]))
        unknown = set(changes) - {f.name for f in dataclasses.fields(self)}
        if unknown:
            name = sorted(unknown)[0]
            raise ParameterError(where, name, f"one of {list(PARAMETERS)}", changes[name])
        return self._build({**self.to_dict(), **changes}, where)

    @classmethod
    def _build(cls, values: dict[str, Any], where: str) -> RadarIntegratorConfig:
        # Bypass __post_init__ so that errors name ``where`` (the XML id or the caller).
        obj = cls.__new__(cls)
        for f in dataclasses.fields(cls):
            object.__setattr__(obj, f.name, values.get(f.name, f.default))
        obj.validate(where)
        return obj

    def density(self, radar: Radar) -> float:
        """Surface scatterers per m²: given, or ``scatterers_per_cell`` per resolution cell."""
        if self.scatterer_density is not None:
            return float(self.scatterer_density)
        return self.scatterers_per_cell / (radar.range_resolution * AZIMUTH_CELL)

    def to_dict(self) -> dict[str, Any]:
        """Plain dict (provenance)."""
        return dataclasses.asdict(self)
