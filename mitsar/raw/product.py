"""What the raw producers share besides the product itself: the platform state at each
sweep (:func:`sweep_geometry`) and the memory budget of raw data (:func:`require_raw_memory`).

The raw product's schema, maker and accessors (``make_raw_product``, ``radar_of``, ``look_of``,
``track_geometry``, ``track_variables``) are in :mod:`mitsar.products.raw`.
"""

from __future__ import annotations

from mitsar.budget import require_memory
from mitsar.model.geometry.attitude import Look, boresight
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.model.signal import sweep_start_times

RAW_BYTES_PER_SAMPLE = 48
"""Peak bytes per raw sample: the complex128 samples, one chunk or noise copy and the product's
copy on writing (3 x 16 bytes); plus ``GEOMETRY_BYTES_PER_SWEEP`` per sweep."""

GEOMETRY_BYTES_PER_SWEEP = 512
"""Per-sweep geometry (times, positions, velocities, boresights, attitude, frames; float64)."""


def require_raw_memory(where: str, radar: Radar, sweeps: int) -> None:
    """Refuse, before any work, raw data of ``sweeps`` sweeps that would not fit in memory
    (:func:`mitsar.budget.require_memory`; docs/reliability.md §2)."""
    samples = radar.samples_per_sweep
    require_memory(where, "trajectory.duration",
                   float(sweeps) * (samples * RAW_BYTES_PER_SAMPLE + GEOMETRY_BYTES_PER_SWEEP),
                   f"{sweeps} sweeps (duration x prf) x {samples} samples "
                   "(sampling_frequency / prf): shorten the flight, or lower the PRF or the "
                   "sampling frequency")


def sweep_geometry(radar: Radar, trajectory: Trajectory, look: Look,
                   sweeps: int) -> SweepGeometry:
    """Platform state at mid-sweep ``eta_k + T/2`` for ``sweeps`` sweeps.

    Returns
    -------
    SweepGeometry
        ``slow_time`` (sweeps,) [s], ``position`` [m], ``velocity`` [m/s], ``attitude`` [rad],
        ``boresight`` (sweeps, 3).
    """
    slow_time = sweep_start_times(radar, sweeps)
    centre = slow_time + radar.sweep_duration / 2
    attitude = trajectory.attitude_at(centre)
    return SweepGeometry(
        slow_time=slow_time,
        position=trajectory.position(centre),
        velocity=trajectory.velocity(centre),
        attitude=attitude,
        boresight=boresight(look, attitude[:, 0], attitude[:, 1], attitude[:, 2]),
    )
