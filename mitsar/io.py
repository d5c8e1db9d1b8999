"""Products on disk: netCDF4/HDF5 files written atomically, complex data stored natively.

Every mitsar product (raw, range-compressed profile, image, ...) is an :class:`xarray.Dataset`
with a ``product`` attribute. :func:`save` writes it with the ``h5netcdf`` engine, which stores
complex variables as native HDF5 compound types that ``xarray.open_dataset`` reads back as
complex. Attributes are sanitised first (netCDF attributes hold only numbers, strings and flat
numeric arrays). Files are written to a temporary file in the destination folder and moved into
place with :func:`os.replace`, so a failed or interrupted write never leaves a partial product,
and an existing file is only replaced when asked to.
"""

from __future__ import annotations

import json
import math
import os
import tempfile
from collections.abc import Callable, Iterator, Mapping
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from mitsar.errors import MitsarError

__all__ = [
    "OutputExistsError",
    "ProductFileError",
    "atomic_output",
    "atomic_writer",
    "check_writable",
    "load",
    "sanitize_attrs",
    "save",
    "to_jsonable",
    "write_json",
]

ENGINE = "h5netcdf"
"""xarray engine used for every product file."""


class OutputExistsError(MitsarError, FileExistsError):
    """The output file exists and overwriting was not requested."""


class ProductFileError(MitsarError, ValueError):
    """A file is missing, unreadable, or not a mitsar product of the expected type."""


# --- attributes ---------------------------------------------------------------------------
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


def _sanitized(ds: xr.Dataset) -> xr.Dataset:
    """A shallow copy of ``ds`` with all dataset and variable attributes sanitised."""
    out = ds.copy(deep=False)
    out.attrs = sanitize_attrs(ds.attrs)
    for name in out.variables:
        out[name].attrs = sanitize_attrs(ds[name].attrs)
    return out


# --- atomic output ------------------------------------------------------------------------
def check_writable(path: str | os.PathLike, overwrite: bool = False) -> Path:
    """Refuse to replace an existing file unless ``overwrite``.

    Parameters
    ----------
    path : path-like
        Output file.
    overwrite : bool
        Allow replacing an existing file.

    Returns
    -------
    Path
        ``path`` as a :class:`~pathlib.Path`.

    Raises
    ------
    OutputExistsError
        If the file exists and ``overwrite`` is false.
    ProductFileError
        If the destination folder does not exist or ``path`` is a folder.
    """
    path = Path(path)
    if path.is_dir():
        raise ProductFileError(f"{path}: is a folder, expected a file name")
    if path.exists() and not overwrite:
        raise OutputExistsError(
            f"{path}: file exists; pass overwrite=True (--overwrite on the command line) "
            "to replace it")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ProductFileError(f"{path}: folder {parent} does not exist")
    return path


@contextmanager
def atomic_output(path: str | os.PathLike, overwrite: bool = False) -> Iterator[Path]:
    """Context manager giving a temporary path that replaces ``path`` on success.

    The temporary file lives in the destination folder (same file system, so the final
    :func:`os.replace` is atomic) and keeps the suffix of ``path``. If the body raises, the
    temporary file is removed and ``path`` is left untouched.

    Parameters
    ----------
    path : path-like
        Final output file.
    overwrite : bool
        Allow replacing an existing file.

    Yields
    ------
    Path
        The temporary file to write.
    """
    path = check_writable(path, overwrite)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.", suffix=f".tmp{path.suffix}",
                                    dir=path.parent)
    os.close(fd)
    tmp = Path(tmp_name)
    try:
        yield tmp
        if path.exists() and not overwrite:  # appeared while we were writing
            raise OutputExistsError(f"{path}: file appeared during the write; pass "
                                    "overwrite=True (--overwrite) to replace it")
        os.chmod(tmp, 0o666 & ~_umask())
        os.replace(tmp, path)
    finally:
        if tmp.exists():
            tmp.unlink()


def _umask() -> int:
    """The process umask (read without changing it for long)."""
    mask = os.umask(0)
    os.umask(mask)
    return mask


def _write_netcdf(ds: xr.Dataset, path: Path) -> None:
    """Write ``ds`` to ``path`` with the h5netcdf engine (the step tests can replace)."""
    ds.to_netcdf(path, engine=ENGINE)


def save(ds: xr.Dataset, path: str | os.PathLike, overwrite: bool = False) -> Path:
    """Write a product to a netCDF4/HDF5 file, atomically.

    Complex variables are stored natively (HDF5 compound type), so
    ``xarray.open_dataset(path)`` reads them back as complex. Attributes are sanitised with
    :func:`sanitize_attrs`.

    Parameters
    ----------
    ds : xarray.Dataset
        The product; should carry a ``product`` attribute (``"raw"``, ``"image"``, ...).
    path : path-like
        Output file, conventionally ``*.nc``.
    overwrite : bool
        Replace an existing file.

    Returns
    -------
    Path
        The written file.

    Raises
    ------
    OutputExistsError
        If ``path`` exists and ``overwrite`` is false.
    """
    if not isinstance(ds, xr.Dataset):
        raise ProductFileError(f"{path}: expected an xarray.Dataset to save, found "
                               f"{type(ds).__name__}")
    clean = _sanitized(ds)
    return atomic_writer(path, overwrite, lambda tmp: _write_netcdf(clean, tmp))


def load(path: str | os.PathLike, product: str | tuple[str, ...] | None = None) -> xr.Dataset:
    """Read a product file into memory (the file is closed on return).

    Parameters
    ----------
    path : path-like
        A file written by :func:`save`.
    product : str or tuple of str, optional
        Expected product type(s); a file of another type is refused.

    Returns
    -------
    xarray.Dataset
        The product, fully loaded.

    Raises
    ------
    ProductFileError
        If the file does not exist, cannot be read as netCDF/HDF5, has no ``product``
        attribute, or is not of the expected product type.
    """
    path = Path(path)
    if not path.exists():
        raise ProductFileError(f"{path}: no such file")
    if path.is_dir():
        raise ProductFileError(f"{path}: is a folder, expected a mitsar product file (.nc)")
    try:
        with xr.open_dataset(path, engine=ENGINE) as handle:
            ds = handle.load()
    except (OSError, ValueError, TypeError) as error:
        raise ProductFileError(f"{path}: not a readable netCDF4/HDF5 product file "
                               f"({type(error).__name__}: {error})") from error
    kind = ds.attrs.get("product")
    if kind is None:
        raise ProductFileError(f"{path}: not a mitsar product: expected a 'product' attribute "
                               f"(raw, image, ...), found attributes {sorted(ds.attrs)}")
    wanted = (product,) if isinstance(product, str) else product
    if wanted is not None and kind not in wanted:
        raise ProductFileError(f"{path}: expected a product of type "
                               f"{' or '.join(repr(w) for w in wanted)}, found {kind!r}")
    return ds


def write_json(data: Any, path: str | os.PathLike, overwrite: bool = False) -> Path:
    """Write JSON atomically (NaN/inf become ``null``; NumPy values become plain numbers).

    Parameters
    ----------
    data : object
        JSON-serialisable data (NumPy scalars and arrays allowed).
    path, overwrite
        Output file and whether to replace it, as for :func:`save`.

    Returns
    -------
    path : Path
        The written file.
    """
    text = json.dumps(to_jsonable(data), indent=2, allow_nan=False) + "\n"
    return atomic_writer(path, overwrite, lambda tmp: tmp.write_text(text, encoding="utf-8"))


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


def atomic_writer(path: str | os.PathLike, overwrite: bool,
                  write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` and move ``tmp`` to ``path`` atomically (see :func:`atomic_output`)."""
    with atomic_output(path, overwrite) as tmp:
        write(tmp)
    return Path(path)
