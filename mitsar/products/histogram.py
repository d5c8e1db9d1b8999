"""The histogram product: complex range histograms of a traced acquisition, per path order.

:func:`mitsar.raw.traced.trace` returns it; :func:`mitsar.raw.traced.histogram_to_raw_product`
turns it into the raw product (one inverse FFT per sweep) with :func:`raw_from_histogram`.

Layout (:data:`HISTOGRAM_SCHEMA`)
---------------------------------
``histogram`` (sweep, order, bin) complex
    Sum of the deposits ``a exp{j 2 pi (f_c tau_0 - K tau_0^2/2 + phi)}`` at each apparent range
    bin [sqrt(W)]. ``order`` is the number of specular reflections on the path (0: direct
    backscatter; 1: e.g. a mirror; 2: dihedral; 3: trihedral), ``0 .. max_depth - 1``.
``apparent_range`` (bin) [m]
    ``(k_0 + j) dr``, ``dr`` = range cell / ``bins_per_cell`` (:mod:`mitsar.model.histogram`).
``slow_time``, ``platform_position``, ``platform_velocity``, ``boresight``, ``attitude``
    As in the raw product; ``sweep`` holds the absolute sweep indices of the acquisition.
attributes
    ``radar_*``, ``look_*``, ``product = "histogram"``, ``rvp``, ``normalized``,
    ``histogram_first_index``, and the tracer's (``seed``, ``scatterer_count``, ...; see
    :mod:`mitsar.raw.traced`), provenance.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.model.geometry.attitude import Look
from mitsar.model.radar import Radar
from mitsar.products.raw import (
    PRODUCT_ATTRS,
    TRACK_SCHEMA,
    look_of,
    make_raw_product,
    product_attrs,
    radar_of,
    track_geometry,
    track_variables,
)
from mitsar.products.schema import Schema, Variable, encode_attrs, validate

__all__ = ["HISTOGRAM_SCHEMA", "RAW_ATTRS_FROM_HISTOGRAM", "make_histogram_product",
           "raw_from_histogram", "validate_histogram"]

HISTOGRAM_SCHEMA = Schema(
    product="histogram",
    variables={
        "histogram": Variable(("sweep", "order", "bin"), "sqrt(W)", "complex range histogram"),
        "sweep": Variable(("sweep",)),
        "order": Variable(("order",)),
        "bin": Variable(("bin",)),
        "apparent_range": Variable(("bin",), "m", "apparent range c f / (2K)"),
        **TRACK_SCHEMA,
    },
    attrs={**PRODUCT_ATTRS, "normalized": "1 when amplitudes are per unit RCS",
           "histogram_first_index": "index k_0 of the first bin"},
)
"""The histogram product's layout (module docstring)."""

RAW_ATTRS_FROM_HISTOGRAM = (
    "seed", "normalized", "scatterer_count", "point_target_count", "scatterer_density",
    "bins_per_cell", "integrator", "scene", "trajectory_kind", "trajectory_straight", "config")
"""Histogram attributes its raw product keeps (besides ``traced_*``, ``physical_optics_*``
and ``motion*``)."""


def validate_histogram(product: xr.Dataset, where: str = "histogram product") -> xr.Dataset:
    """Check a histogram product against :data:`HISTOGRAM_SCHEMA`
    (:func:`mitsar.products.schema.validate`)."""
    return validate(product, HISTOGRAM_SCHEMA, where)


def make_histogram_product(histogram: NDArray, radar: Radar, look: Look, sweeps: NDArray,
                           apparent_range: NDArray, geometry: Any, true_geometry: Any = None,
                           *, rvp: bool, normalized: bool, first_index: int,
                           attrs: dict[str, Any] | None = None) -> xr.Dataset:
    """Assemble the histogram product.

    Parameters
    ----------
    histogram : ndarray, shape (sweeps, orders, bins), complex
        Deposits [sqrt(W)].
    radar, look : Radar, Look
    sweeps : ndarray of int
        Absolute sweep indices.
    apparent_range : ndarray, shape (bins,)
        Apparent range of each bin [m].
    geometry, true_geometry : SweepGeometry
        Recorded (and true) track of the sweeps (:func:`mitsar.raw.product.sweep_geometry`
        arrays: slow time [s], positions [m], ...).
    rvp, normalized : bool
        Residual video phase present; amplitudes per unit RCS.
    first_index : int
        Index k_0 of the first bin.
    attrs : dict, optional
        The tracer's attributes (dicts and lists as JSON).

    Returns
    -------
    xarray.Dataset
        The histogram product (:data:`HISTOGRAM_SCHEMA`).
    """
    variables = HISTOGRAM_SCHEMA.variables
    data = xr.Dataset(
        {
            "histogram": (("sweep", "order", "bin"), histogram,
                          variables["histogram"].attrs()),
            **track_variables(geometry, true_geometry),
        },
        coords={
            "sweep": sweeps,
            "order": np.arange(histogram.shape[1]),
            "bin": np.arange(histogram.shape[2]),
            "apparent_range": ("bin", apparent_range, variables["apparent_range"].attrs()),
            "slow_time": ("sweep", geometry.slow_time, variables["slow_time"].attrs()),
            "xyz": ["x", "y", "z"],
            "angle": ["heading", "pitch", "roll"],
        },
    )
    data.attrs.update(product_attrs("histogram", radar, look, rvp))
    version = data.attrs.pop("mitsar_version")
    data.attrs.update(normalized=int(normalized), histogram_first_index=int(first_index),
                      mitsar_version=version)
    data.attrs.update(encode_attrs(attrs or {}))
    return data


def raw_from_histogram(histogram: xr.Dataset, samples: ArrayLike,
                       orders: ArrayLike) -> xr.Dataset:
    """The raw product of a histogram product, given its synthesised samples.

    Parameters
    ----------
    histogram : xarray.Dataset
        The histogram product the samples come from.
    samples : array_like, shape (sweeps, samples_per_sweep)
        Dechirped samples [sqrt(W)] of the summed orders.
    orders : array_like of int
        The path orders summed.

    Returns
    -------
    xarray.Dataset
        The raw product, on the histogram's sweep indices, keeping its tracer attributes
        (:data:`RAW_ATTRS_FROM_HISTOGRAM`).
    """
    attrs = {key: histogram.attrs[key] for key in RAW_ATTRS_FROM_HISTOGRAM
             if key in histogram.attrs}
    attrs.update({key: value for key, value in histogram.attrs.items()
                  if key.startswith(("traced_", "physical_optics_", "motion"))})
    attrs.update(simulator="ray tracing (radar integrator)",
                 orders=[int(o) for o in np.ravel(orders)])
    product = make_raw_product(samples, radar_of(histogram), look_of(histogram),
                               track_geometry(histogram),
                               rvp=bool(histogram.attrs.get("rvp", 1)), attrs=attrs,
                               true_geometry=track_geometry(histogram, "true_"))
    for name in ("transmitter_offset", "receiver_offset"):  # one channel of several
        if name in histogram.variables:
            product[name] = histogram[name]
    for key in ("channel", "sweep_stride"):  # one channel of several (TDM-MIMO: its sweeps)
        if key in histogram.attrs:
            product.attrs[key] = histogram.attrs[key]
    return product.assign_coords(sweep=histogram["sweep"].values)
