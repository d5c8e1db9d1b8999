"""What a product schema is, and the one validator every product uses.

A :class:`Schema` names a product's ``product`` attribute, its dimensions (required and
optional), its variables with their dimensions and CF attributes (``units``, ``long_name``,
``standard_name`` where CF has one) and its required attributes. :func:`validate` checks a
dataset against it and raises :class:`~mitsar.errors.ParameterError` naming the first thing
missing.

Optional dimensions
-------------------
``channel`` and ``pass`` are declared here for every product (:data:`OPTIONAL_DIMS`): the
receive channels of a multi-channel radar and the passes of a repeat-pass acquisition, which
the next issues add. A product without them is a single-channel, single-pass product; a
variable that gains one of them keeps its other dimensions in the order of the schema, the
optional dimension first. Nothing in mitsar makes them yet.
"""

from __future__ import annotations

import json
from collections.abc import Mapping
from dataclasses import dataclass, field
from typing import Any

import xarray as xr

from mitsar.errors import ParameterError

__all__ = ["OPTIONAL_DIMS", "Schema", "Variable", "encode_attrs", "validate"]

OPTIONAL_DIMS: dict[str, str] = {
    "channel": "receive channel of a multi-channel radar (absent: one channel)",
    "pass": "pass of a repeat-pass acquisition (absent: one pass)",
}
"""Dimensions any product may gain in front of its own (module docstring), with meanings."""


@dataclass(frozen=True)
class Variable:
    """One variable (or coordinate) of a product schema.

    Attributes
    ----------
    dims : tuple of str
        Its dimensions, in order (an optional dimension of :data:`OPTIONAL_DIMS` may precede
        them).
    units : str
        CF ``units`` (``"1"``: dimensionless; ``""``: none, e.g. labels).
    long_name : str
        CF ``long_name``.
    standard_name : str
        CF ``standard_name`` where the CF table has one, else ``""``.
    required : bool
        Whether every product of the kind holds it.
    """

    dims: tuple[str, ...]
    units: str = ""
    long_name: str = ""
    standard_name: str = ""
    required: bool = True

    def attrs(self) -> dict[str, str]:
        """The CF attributes this variable carries (empty ones left out)."""
        return {key: value for key, value in (("units", self.units),
                                              ("long_name", self.long_name),
                                              ("standard_name", self.standard_name)) if value}


@dataclass(frozen=True)
class Schema:
    """A product's layout: ``product`` attribute, dimensions, variables, attributes.

    Attributes
    ----------
    product : str
        The ``product`` attribute's value (``"raw"``, ``"histogram"``, ``"image"``).
    variables : mapping of str to Variable
        Data variables and coordinates by name.
    attrs : mapping of str to str
        Required attributes and what each holds (with units).
    optional_attrs : mapping of str to str
        Attributes some products carry, and what each holds.
    optional_dims : mapping of str to str
        Dimensions the product may gain (:data:`OPTIONAL_DIMS`).
    """

    product: str
    variables: Mapping[str, Variable]
    attrs: Mapping[str, str]
    optional_attrs: Mapping[str, str] = field(default_factory=dict)
    optional_dims: Mapping[str, str] = field(default_factory=lambda: dict(OPTIONAL_DIMS))


def validate(product: xr.Dataset, schema: Schema, where: str) -> xr.Dataset:
    """Check ``product`` against ``schema``; return it unchanged.

    Parameters
    ----------
    product : xarray.Dataset
    schema : Schema
    where : str
        The caller, for the error message.

    Returns
    -------
    xarray.Dataset
        ``product``.

    Raises
    ------
    ParameterError
        Naming the ``product`` attribute, the first missing variable or attribute, or a
        variable whose dimensions differ from the schema's (optional dimensions allowed in
        front).
    """
    if not isinstance(product, xr.Dataset):
        raise ParameterError(where, "product", f"a {schema.product} product (xarray Dataset)",
                             type(product).__name__)
    if product.attrs.get("product") != schema.product:
        raise ParameterError(where, schema.product,
                             f"a {schema.product} product (attribute product="
                             f"'{schema.product}')", product.attrs.get("product"))
    for name, variable in schema.variables.items():
        if name not in product.variables:
            if variable.required:
                raise ParameterError(where, name, f"variable {name!r} of a {schema.product} "
                                     f"product, dims {variable.dims}",
                                     f"variables {sorted(map(str, product.variables))}")
            continue
        dims = tuple(map(str, product[name].dims))
        extra = len(dims) - len(variable.dims)
        if extra < 0 or dims[extra:] != variable.dims or any(
                d not in schema.optional_dims for d in dims[:extra]):
            raise ParameterError(where, name, f"dims {variable.dims} (optionally preceded by "
                                 f"{tuple(schema.optional_dims)})", dims)
    missing = [key for key in schema.attrs if key not in product.attrs]
    if missing:
        raise ParameterError(where, missing[0], f"attribute {missing[0]!r} of a "
                             f"{schema.product} product ({schema.attrs[missing[0]]})",
                             "no such attribute")
    return product


def encode_attrs(attrs: Mapping[str, Any], types: tuple[type, ...] = (dict, list)
                 ) -> dict[str, Any]:
    """Attributes ready for netCDF: values of ``types`` as JSON strings, others as given."""
    return {key: json.dumps(value) if isinstance(value, types) else value
            for key, value in attrs.items()}
