"""The raw-data product: dechirped FMCW samples with their geometry, as an xarray Dataset.

Every producer of raw data (analytic simulator, ray tracer, real recordings) makes this one
product, and every processing step consumes it (docs/design.md §2).

Layout
------
``raw`` (sweep, sample) complex
    Dechirped I/Q samples, amplitude in sqrt(W) (or per unit RCS when normalised).
``slow_time`` (sweep) [s]
    Start of each sweep eta_k. ``fast_time`` (sample) [s]: centred fast time.
``platform_position``, ``platform_velocity``, ``boresight`` (sweep, xyz)
    Antenna phase centre [m], velocity [m/s] and boresight at mid-sweep.
``attitude`` (sweep, angle)
    Heading, pitch, roll [rad] at mid-sweep.
``true_platform_position``, ``true_platform_velocity``, ``true_boresight``, ``true_attitude``
    Only when the echoes were simulated on a true track that differs from the navigation track
    (:class:`mitsar.NavigationErrors`): the ground truth. The variables above are then what the
    navigation system recorded, as in a real recording; every focuser uses those.
attributes
    ``radar_*`` parameters, ``look_off_nadir_deg``, ``look_squint_deg``, ``rvp`` (1 when the
    residual video phase is present), ``product = "raw"``, provenance (``mitsar_version``,
    ``seed``, ``config``).
"""

from __future__ import annotations

import json
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from mitsar.budget import require_memory
from mitsar.model.geometry.attitude import Look, boresight
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.model.signal import fast_time, sweep_start_times
from mitsar.version import __version__

TRACK_VARIABLES = (
    ("platform_position", "position", "xyz", "m"),
    ("platform_velocity", "velocity", "xyz", "m/s"),
    ("boresight", "boresight", "xyz", "1"),
    ("attitude", "attitude", "angle", "rad"),
)
"""Per-sweep track variables: (name, :func:`sweep_geometry` key, second dim, units); the true
track's carry the prefix ``true_``."""


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
                   sweeps: int) -> dict[str, np.ndarray]:
    """Platform state at mid-sweep ``eta_k + T/2`` for ``sweeps`` sweeps.

    Returns
    -------
    dict
        ``slow_time`` (sweeps,), ``position``, ``velocity``, ``attitude``, ``boresight``
        (sweeps, 3).
    """
    slow_time = sweep_start_times(radar, sweeps)
    centre = slow_time + radar.sweep_duration / 2
    attitude = trajectory.attitude_at(centre)
    return {
        "slow_time": slow_time,
        "position": trajectory.position(centre),
        "velocity": trajectory.velocity(centre),
        "attitude": attitude,
        "boresight": boresight(look, attitude[:, 0], attitude[:, 1], attitude[:, 2]),
    }


def make_raw_product(samples: ArrayLike, radar: Radar, look: Look, geometry: dict,
                     *, rvp: bool = True, attrs: dict[str, Any] | None = None,
                     true_geometry: dict | None = None) -> xr.Dataset:
    """Assemble the raw product from samples and per-sweep geometry.

    Parameters
    ----------
    samples : array_like, shape (sweeps, samples_per_sweep)
        Dechirped complex samples.
    radar, look : Radar, Look
    geometry : dict
        Output of :func:`sweep_geometry` (or equivalent arrays).
    rvp : bool
        Whether the samples still hold the residual video phase.
    attrs : dict, optional
        Extra attributes (provenance: seed, config, ...).
    true_geometry : dict, optional
        The true track's :func:`sweep_geometry` when ``geometry`` is a navigation track.
    """
    samples = np.asarray(samples)
    sweeps = samples.shape[0]
    data = xr.Dataset(
        {"raw": (("sweep", "sample"), samples), **track_variables(geometry, true_geometry)},
        coords={
            "sweep": np.arange(sweeps),
            "sample": np.arange(samples.shape[1]),
            "slow_time": ("sweep", geometry["slow_time"], {"units": "s",
                                                          "long_name": "sweep start time"}),
            "fast_time": ("sample", fast_time(radar), {"units": "s",
                                                       "long_name": "fast time, sweep-centred"}),
            "xyz": ["x", "y", "z"],
            "angle": ["heading", "pitch", "roll"],
        },
    )
    data["raw"].attrs.update(units="sqrt(W)", long_name="dechirped I/Q samples")
    data.attrs.update(radar.to_attrs())
    data.attrs.update(product="raw", look_off_nadir_deg=look.off_nadir_deg,
                      look_squint_deg=look.squint_deg, rvp=int(rvp),
                      mitsar_version=__version__)
    for key, value in (attrs or {}).items():
        data.attrs[key] = json.dumps(value) if isinstance(value, dict | list) else value
    return data


def track_variables(geometry: dict, true_geometry: dict | None = None) -> dict[str, tuple]:
    """The per-sweep track variables of a product (raw or histogram) from
    :func:`sweep_geometry` outputs: the recorded track, and the true one when they differ."""
    out = {name: (("sweep", dims), geometry[key], {"units": units})
           for name, key, dims, units in TRACK_VARIABLES}
    if true_geometry is not None:
        out.update({f"true_{name}": (("sweep", dims), true_geometry[key],
                                     {"units": units, "long_name": "ground truth (true track)"})
                    for name, key, dims, units in TRACK_VARIABLES})
    return out


def track_geometry(product: xr.Dataset, prefix: str = "") -> dict[str, np.ndarray] | None:
    """The :func:`sweep_geometry` dict stored in a product (``prefix="true_"``: the true
    track, None when the product has none)."""
    if f"{prefix}platform_position" not in product.variables:
        return None
    out = {key: product[f"{prefix}{name}"].values for name, key, _, _ in TRACK_VARIABLES}
    out["slow_time"] = product["slow_time"].values
    return out


def radar_of(product: xr.Dataset) -> Radar:
    """The :class:`Radar` recorded in a product's attributes."""
    return Radar.from_attrs(product.attrs)


def look_of(product: xr.Dataset) -> Look:
    """The :class:`Look` recorded in a product's attributes."""
    return Look(float(product.attrs["look_off_nadir_deg"]),
                float(product.attrs.get("look_squint_deg", 0.0)))
