"""The scatterers of a scene as one flat set: surface scatterers first, then point targets.

What the radar integrator traces for direct backscatter (docs/design.md §5.4 mechanism 1): the
area-sampled surface scatterers of a scene (one area share and one frozen speckle phase each, σ⁰
from their material's monostatic table) and its point targets (their RCS, their velocity). A
plain NumPy type, so that the scene stage that fills it
(:func:`mitsar.scene.scatterers.collect_scatterers`) and the plugins that trace it both import
it from below; the kernels upload the arrays once per set (``device``).
"""

from __future__ import annotations

import dataclasses
from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mitsar.model.doublelobe import TABLE_SIZE
from mitsar.model.radar import Radar

__all__ = ["POINT_TARGET_MARGIN", "ScattererSet", "empty_scatterers", "range_limits"]

POINT_TARGET_MARGIN = 1.01
"""Shadow rays to a point target stop this factor times its bounding radius before the centre."""


@dataclass
class ScattererSet:
    """All scatterers of a scene as flat arrays: surface scatterers first, then point targets.

    ``weight`` is the area share [m²] of a surface scatterer (RCS = σ⁰ x weight) or the RCS
    [m²] of a point target (its table row is all ones); ``phase`` is in cycles; ``stop`` is the
    distance before the centre where a point target's shadow ray stops [m] (0 for surfaces);
    ``tables`` are the σ⁰ tables (one row per material, then the point-target row) on the nodes
    of :func:`mitsar.model.doublelobe.theta_table_cosines`.
    """

    position: NDArray[np.float64]
    normal: NDArray[np.float64]
    velocity: NDArray[np.float64]
    weight: NDArray[np.float64]
    phase: NDArray[np.float64]
    table_row: NDArray[np.int64]
    stop: NDArray[np.float64]
    tables: NDArray[np.float64]
    surface_count: int
    point_target_count: int
    density: float
    seed: int
    device: dict = dataclasses.field(default_factory=dict, repr=False)

    def __len__(self) -> int:
        return len(self.weight)

    def extent(self, duration: float) -> tuple[NDArray, NDArray]:
        """Bounding box of every scatterer over ``[0, duration]`` seconds [m]."""
        if len(self) == 0:
            return np.zeros(3), np.zeros(3)
        if "static_box" not in self.device:
            self.device["static_box"] = (self.position.min(axis=0), self.position.max(axis=0))
        lo, hi = self.device["static_box"]
        if "moving" not in self.device:  # cached: a set's arrays are not changed in place
            self.device["moving"] = np.flatnonzero(np.any(self.velocity != 0.0, axis=1))
        moving = self.device["moving"]
        if len(moving):
            ends = self.position[moving] + self.velocity[moving] * duration
            lo, hi = np.minimum(lo, ends.min(axis=0)), np.maximum(hi, ends.max(axis=0))
        return lo, hi

    def max_speed(self) -> float:
        """Largest scatterer speed [m/s] (0 for an empty set)."""
        if "max_speed" not in self.device:  # cached: ~40 ms per call at 1 M scatterers
            self.device["max_speed"] = (float(np.linalg.norm(self.velocity, axis=1).max())
                                        if len(self) else 0.0)
        return self.device["max_speed"]


def empty_scatterers(density: float, seed: int) -> ScattererSet:
    """A scatterer set without scatterers (multipath-only tracing)."""
    return ScattererSet(position=np.zeros((0, 3)), normal=np.zeros((0, 3)),
                        velocity=np.zeros((0, 3)), weight=np.zeros(0), phase=np.zeros(0),
                        table_row=np.zeros(0, dtype=np.int64), stop=np.zeros(0),
                        tables=np.zeros((1, TABLE_SIZE)), surface_count=0,
                        point_target_count=0, density=float(density), seed=int(seed))


def range_limits(scatterers: ScattererSet, positions: NDArray, max_speed: float,
                 radar: Radar, duration: float) -> tuple[float, float]:
    """Apparent ranges that can occur [m]: antenna-to-scatterer-box distances plus a Doppler
    margin ``(f_c / K) (v_platform + v_target)`` and two range cells."""
    lo, hi = scatterers.extent(duration)
    nearest = np.clip(positions, lo, hi) - positions
    corners = np.array([[x, y, z] for x in (lo[0], hi[0]) for y in (lo[1], hi[1])
                        for z in (lo[2], hi[2])])
    farthest = np.linalg.norm(positions[:, None, :] - corners[None], axis=-1).max()
    margin = (radar.carrier_frequency / radar.chirp_rate) * (max_speed
                                                             + scatterers.max_speed()) \
        + 2 * radar.range_resolution
    return (max(0.0, float(np.linalg.norm(nearest, axis=1).min())) - margin,
            float(farthest) + margin)
