"""The platform state at every sweep of an acquisition: one type for every stage that reads it.

:func:`mitsar.raw.product.sweep_geometry` makes it from a trajectory, the raw and histogram
products store it (:func:`mitsar.products.raw.track_variables`) and give it back
(:func:`mitsar.products.raw.track_geometry`), and the ray tracer, the analytic simulator and
physical optics read it (docs/conventions.md: sweep ``k`` starts at ``eta_k = k / PRF``; the
state is taken at mid-sweep ``eta_k + T/2``). Pure NumPy.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

__all__ = ["SweepGeometry"]


@dataclass(frozen=True)
class SweepGeometry:
    """Per-sweep platform state at mid-sweep, world frame.

    Attributes
    ----------
    slow_time : ndarray, shape (sweeps,)
        Sweep start times ``eta_k`` [s] (the state is at ``eta_k + T/2``).
    position : ndarray, shape (sweeps, 3)
        Antenna phase centre [m].
    velocity : ndarray, shape (sweeps, 3)
        Platform velocity [m/s].
    attitude : ndarray, shape (sweeps, 3)
        Heading, pitch, roll [rad].
    boresight : ndarray, shape (sweeps, 3)
        Antenna boresight, unit vector [-].
    """

    slow_time: NDArray[np.float64]
    position: NDArray[np.float64]
    velocity: NDArray[np.float64]
    attitude: NDArray[np.float64]
    boresight: NDArray[np.float64]

    def select(self, sweeps: ArrayLike | slice) -> SweepGeometry:
        """The state at some sweeps (an index array, a boolean mask or a slice)."""
        return SweepGeometry(slow_time=self.slow_time[sweeps], position=self.position[sweeps],
                             velocity=self.velocity[sweeps], attitude=self.attitude[sweeps],
                             boresight=self.boresight[sweeps])
