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

from mitsar.model.geometry.attitude import Look, boresight
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar
from mitsar.model.signal import fast_time, sweep_start_times
from mitsar.version import __version__


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
                     *, rvp: bool = True, attrs: dict[str, Any] | None = None) -> xr.Dataset:
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
    """
    samples = np.asarray(samples)
    sweeps = samples.shape[0]
    data = xr.Dataset(
        {
            "raw": (("sweep", "sample"), samples),
            "platform_position": (("sweep", "xyz"), geometry["position"], {"units": "m"}),
            "platform_velocity": (("sweep", "xyz"), geometry["velocity"], {"units": "m/s"}),
            "boresight": (("sweep", "xyz"), geometry["boresight"], {"units": "1"}),
            "attitude": (("sweep", "angle"), geometry["attitude"], {"units": "rad"}),
        },
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


def radar_of(product: xr.Dataset) -> Radar:
    """The :class:`Radar` recorded in a product's attributes."""
    return Radar.from_attrs(product.attrs)


def look_of(product: xr.Dataset) -> Look:
    """The :class:`Look` recorded in a product's attributes."""
    return Look(float(product.attrs["look_off_nadir_deg"]),
                float(product.attrs.get("look_squint_deg", 0.0)))
