"""Product attributes and JSON values: what netCDF attributes and JSON files can hold.

netCDF attributes hold only numbers, strings and flat numeric arrays: :func:`sanitize_attrs`
turns booleans into 0/1, mappings and nested lists into JSON strings, paths into strings and
drops ``None`` (docs/conventions.md); :func:`to_jsonable` makes NumPy values plain and
non-finite floats ``null`` for the JSON files :func:`mitsar.io.write_json` writes.
"""

from __future__ import annotations

import json
import math
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr


def _sanitize_value(value: Any) -> Any:
    """One attribute value as something netCDF can store, or ``None`` to drop it."""
    if value is None:
        return None
    if isinstance(value, bool | np.bool_):
        return int(value)
    if isinstance(value, str | bytes):
        return value
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, int | float | np.integer | np.floating):
        return value
    if isinstance(value, complex | np.complexfloating):
        return json.dumps([float(np.real(value)), float(np.imag(value))])
    if isinstance(value, Mapping):
        return json.dumps(value, default=_json_default)
    if isinstance(value, list | tuple | np.ndarray):
        array = np.asarray(value) if _is_flat(value) else None
        if array is not None and array.ndim == 1 and array.dtype.kind in "biuf":
            return array.astype(np.int64) if array.dtype.kind == "b" else array
        if array is not None and array.ndim == 1 and array.dtype.kind == "U" and len(array):
            return json.dumps(array.tolist())
        return json.dumps(value, default=_json_default)
    return str(value)


def _is_flat(value: Any) -> bool:
    """True when ``value`` is a 1-D sequence of scalars (numbers or strings)."""
    if isinstance(value, np.ndarray):
        return value.ndim == 1
    return all(isinstance(v, int | float | str | np.number | np.bool_) for v in value)


def _json_default(value: Any) -> Any:
    """JSON encoder fallback for NumPy scalars and arrays, paths and complex numbers."""
    if isinstance(value, np.ndarray):
        return value.tolist()
    if isinstance(value, np.generic):
        return value.item()
    if isinstance(value, Path):
        return str(value)
    if isinstance(value, complex):
        return [value.real, value.imag]
    raise TypeError(f"cannot store {type(value).__name__} in a product attribute")


def sanitize_attrs(attrs: Mapping[str, Any]) -> dict[str, Any]:
    """Attributes that netCDF can store.

    Booleans become integers (0/1), dicts and nested lists become JSON strings, paths become
    strings, ``None`` values are dropped; numbers, strings and flat numeric sequences are kept.

    Parameters
    ----------
    attrs : mapping
        Attributes of a dataset or a variable.

    Returns
    -------
    dict
        The sanitised attributes (a new dict).

    Examples
    --------
    >>> sanitize_attrs({"rvp": True, "noise": None, "look": {"off_nadir_deg": 60.0}})
    {'rvp': 1, 'look': '{"off_nadir_deg": 60.0}'}
    """
    out = {}
    for key, value in attrs.items():
        clean = _sanitize_value(value)
        if clean is not None:
            out[str(key)] = clean
    return out


def sanitized(ds: xr.Dataset) -> xr.Dataset:
    """A shallow copy of ``ds`` with all dataset and variable attributes sanitised."""
    out = ds.copy(deep=False)
    out.attrs = sanitize_attrs(ds.attrs)
    for name in out.variables:
        out[name].attrs = sanitize_attrs(ds[name].attrs)
    return out


def to_jsonable(data: Any) -> Any:
    """``data`` with NumPy values made plain and non-finite floats made ``None``."""
    if isinstance(data, Mapping):
        return {str(k): to_jsonable(v) for k, v in data.items()}
    if isinstance(data, list | tuple | np.ndarray):
        return [to_jsonable(v) for v in (data.tolist() if isinstance(data, np.ndarray)
                                         else data)]
    if isinstance(data, np.generic):
        data = data.item()
    if isinstance(data, float) and not math.isfinite(data):
        return None
    if isinstance(data, complex):
        return [to_jsonable(data.real), to_jsonable(data.imag)]
    if isinstance(data, Path):
        return str(data)
    return data
