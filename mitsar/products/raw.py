"""The raw-data product: dechirped FMCW samples with their geometry, as an xarray Dataset.

Every producer of raw data (analytic simulator, ray tracer, real recordings) makes this one
product, and every processing step consumes it (docs/design.md §2, docs/products.md).

Layout (:data:`RAW_SCHEMA`)
---------------------------
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
    ``seed``, ``config``), and what the run asks of later stages
    (:mod:`mitsar.products.requests`).
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike

from mitsar.model.geometry.attitude import Look
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.radar import Radar
from mitsar.model.signal import fast_time
from mitsar.products.requests import REQUEST_ATTRS
from mitsar.products.schema import Schema, Variable, encode_attrs, validate
from mitsar.version import __version__

__all__ = ["RAW_SCHEMA", "TRACK_VARIABLES", "look_of", "make_raw_product", "radar_of",
           "sweep_rate", "track_geometry", "track_variables", "validate_raw"]

TRACK_VARIABLES = (
    ("platform_position", "position", "xyz", "m"),
    ("platform_velocity", "velocity", "xyz", "m/s"),
    ("boresight", "boresight", "xyz", "1"),
    ("attitude", "attitude", "angle", "rad"),
)
"""Per-sweep track variables: (name, :class:`~mitsar.model.geometry.sweeps.SweepGeometry`
field, second dim, units); the true track's carry the prefix ``true_``."""

_TRACK_LONG_NAMES = {
    "platform_position": "antenna phase centre at mid-sweep",
    "platform_velocity": "platform velocity at mid-sweep",
    "boresight": "antenna boresight at mid-sweep (unit vector)",
    "attitude": "heading, pitch, roll at mid-sweep",
}


def _track_schema() -> dict[str, Variable]:
    out = {name: Variable(("sweep", dims), units, _TRACK_LONG_NAMES[name])
           for name, _, dims, units in TRACK_VARIABLES}
    out.update({f"true_{name}": Variable(("sweep", dims), units, "ground truth (true track)",
                                         required=False)
                for name, _, dims, units in TRACK_VARIABLES})
    return out


TRACK_SCHEMA: dict[str, Variable] = {
    **_track_schema(),
    "slow_time": Variable(("sweep",), "s", "sweep start time"),
    "xyz": Variable(("xyz",)),
    "angle": Variable(("angle",)),
}
"""Track variables and coordinates shared by the raw and histogram products."""

PRODUCT_ATTRS: dict[str, str] = {
    "product": "product type",
    "radar_carrier_frequency": "radar parameters radar_* (mitsar.Radar.to_attrs), SI units",
    "look_off_nadir_deg": "off-nadir look angle [deg]",
    "look_squint_deg": "squint angle [deg]",
    "rvp": "1 when the samples hold the residual video phase",
    "mitsar_version": "version of mitsar that made the product",
}
"""Attributes every raw and histogram product holds."""

RAW_SCHEMA = Schema(
    product="raw",
    variables={
        "raw": Variable(("sweep", "sample"), "sqrt(W)", "dechirped I/Q samples"),
        "sweep": Variable(("sweep",)),
        "sample": Variable(("sample",)),
        "fast_time": Variable(("sample",), "s", "fast time, sweep-centred"),
        **TRACK_SCHEMA,
    },
    attrs=PRODUCT_ATTRS,
    optional_attrs={"seed": "random seed", "config": "simulator configuration, JSON",
                    **REQUEST_ATTRS},
)
"""The raw product's layout (module docstring)."""


def validate_raw(product: xr.Dataset, where: str = "raw product") -> xr.Dataset:
    """Check a raw product against :data:`RAW_SCHEMA` (:func:`mitsar.products.schema.validate`)."""
    return validate(product, RAW_SCHEMA, where)


def make_raw_product(samples: ArrayLike, radar: Radar, look: Look, geometry: Any,
                     *, rvp: bool = True, attrs: dict[str, Any] | None = None,
                     true_geometry: Any = None, sweeps: ArrayLike | None = None) -> xr.Dataset:
    """Assemble the raw product from samples and per-sweep geometry.

    Parameters
    ----------
    samples : array_like, shape (sweeps, samples_per_sweep) or (channels, sweeps, samples)
        Dechirped complex samples [sqrt(W)]; a leading ``channel`` axis for a radar with
        phase centres (:attr:`mitsar.model.radar.Radar.has_channels`).
    radar, look : Radar, Look
    geometry : SweepGeometry
        Output of :func:`mitsar.raw.product.sweep_geometry` (or the track of a product,
        :func:`track_geometry`): slow time [s], positions [m], velocities [m/s], attitude
        [rad], boresights.
    rvp : bool
        Whether the samples still hold the residual video phase.
    attrs : dict, optional
        Extra attributes (provenance: seed, config, ...; dicts and lists as JSON).
    true_geometry : SweepGeometry, optional
        The true track's geometry when ``geometry`` is a navigation track.
    sweeps : array_like of int, optional
        Acquisition index of each sweep (the ``sweep`` coordinate; default 0, 1, ...); under
        TDM-MIMO they say which transmitter fired (:meth:`Radar.firing`).

    Returns
    -------
    xarray.Dataset
        The raw product (:data:`RAW_SCHEMA`).
    """
    samples = np.asarray(samples)
    channels = samples.ndim == 3  # (channel, sweep, sample): a radar with phase centres
    sweep_index = (np.arange(samples.shape[-2]) if sweeps is None
                   else np.asarray(sweeps, dtype=np.int64))
    slow = TRACK_SCHEMA["slow_time"]
    data = xr.Dataset(
        {"raw": ((("channel",) if channels else ()) + ("sweep", "sample"), samples),
         **track_variables(geometry, true_geometry)},
        coords={
            "sweep": sweep_index,
            "sample": np.arange(samples.shape[-1]),
            "slow_time": ("sweep", geometry.slow_time, slow.attrs()),
            "fast_time": ("sample", fast_time(radar), RAW_SCHEMA.variables["fast_time"].attrs()),
            "xyz": ["x", "y", "z"],
            "angle": ["heading", "pitch", "roll"],
        },
    )
    data["raw"].attrs.update(RAW_SCHEMA.variables["raw"].attrs())
    if channels:
        data = data.assign_coords(channel=np.arange(samples.shape[0]))
        data.update(channel_variables(radar, sweep_index))
    data.attrs.update(product_attrs("raw", radar, look, rvp))
    data.attrs.update(encode_attrs(attrs or {}))
    return data


def channel_variables(radar: Radar, sweeps: ArrayLike | None = None) -> dict[str, tuple]:
    """``transmitter_offset`` and ``receiver_offset`` (channel, xyz): each channel's body-frame
    phase centres [m] (:meth:`mitsar.model.radar.Radar.channel_offsets`).

    Under TDM-MIMO (:attr:`mitsar.model.radar.Radar.is_tdm`) also ``channel_transmitter`` and
    ``channel_receiver`` (channel): the pair's indices (channel ``c = i N_rx + j``), and
    ``fires`` (channel, sweep): whether the channel's transmitter fired in the sweep
    (``sweeps``: acquisition sweep indices; sweep k belongs to transmitter ``k mod N_tx``).
    Its samples in the other sweeps are exact zeros. docs/interferometry.md §8.
    """
    transmitters, receivers = radar.channel_offsets()
    out = {
        "transmitter_offset": (("channel", "xyz"), np.array(transmitters, dtype=float),
                               {"units": "m", "long_name": "body-frame transmit phase centre"}),
        "receiver_offset": (("channel", "xyz"), np.array(receivers, dtype=float),
                            {"units": "m", "long_name": "body-frame receive phase centre"}),
    }
    if radar.is_tdm and sweeps is not None:
        pairs = np.array(radar.channel_pairs(), dtype=np.int32)
        out.update(
            channel_transmitter=(("channel",), pairs[:, 0], {
                "long_name": "transmitter index i of the channel (its TDM time slot)"}),
            channel_receiver=(("channel",), pairs[:, 1], {
                "long_name": "receiver index j of the channel"}),
            fires=(("channel", "sweep"), radar.firing(sweeps), {
                "long_name": "the channel's transmitter fired in the sweep (TDM-MIMO: sweep k "
                             "is transmitter k mod N_tx's); zero samples elsewhere"}))
    return out


def product_attrs(product: str, radar: Radar, look: Look, rvp: bool) -> dict[str, Any]:
    """The attributes a raw or histogram product starts with (:data:`PRODUCT_ATTRS`)."""
    return {**radar.to_attrs(), "product": product, "look_off_nadir_deg": look.off_nadir_deg,
            "look_squint_deg": look.squint_deg, "rvp": int(rvp), "mitsar_version": __version__}


def track_variables(geometry: Any, true_geometry: Any = None) -> dict[str, tuple]:
    """The per-sweep track variables of a product (raw or histogram) from
    :func:`mitsar.raw.product.sweep_geometry` outputs: the recorded track, and the true one when
    they differ."""
    out = {name: (("sweep", dims), getattr(geometry, key), {"units": units})
           for name, key, dims, units in TRACK_VARIABLES}
    if true_geometry is not None:
        out.update({f"true_{name}": (("sweep", dims), getattr(true_geometry, key),
                                     {"units": units, "long_name": "ground truth (true track)"})
                    for name, key, dims, units in TRACK_VARIABLES})
    return out


def track_geometry(product: xr.Dataset, prefix: str = "") -> SweepGeometry | None:
    """The :func:`mitsar.raw.product.sweep_geometry` arrays stored in a product
    (``prefix="true_"``: the true track, None when the product has none)."""
    if f"{prefix}platform_position" not in product.variables:
        return None
    return SweepGeometry(slow_time=product["slow_time"].values,
                         **{key: product[f"{prefix}{name}"].values
                            for name, key, _, _ in TRACK_VARIABLES})


def radar_of(product: xr.Dataset) -> Radar:
    """The :class:`Radar` recorded in a product's attributes."""
    return Radar.from_attrs(product.attrs)


def sweep_rate(product: xr.Dataset, radar: Radar | None = None) -> float:
    """Rate [Hz] at which a product's consecutive sweeps sample the aperture.

    The PRF, divided by the attribute ``sweep_stride`` (default 1) of a product that holds
    every ``sweep_stride``-th sweep only: one channel of a TDM-MIMO product
    (:func:`mitsar.focus.channels.channel_view`), whose transmitter fires in one sweep of
    N_tx. The sweep *duration* stays ``1/prf``. ``radar``: the product's, if already read.
    """
    radar = radar or radar_of(product)
    return radar.prf / int(product.attrs.get("sweep_stride", 1))


def look_of(product: xr.Dataset) -> Look:
    """The :class:`Look` recorded in a product's attributes."""
    return Look(float(product.attrs["look_off_nadir_deg"]),
                float(product.attrs.get("look_squint_deg", 0.0)))
