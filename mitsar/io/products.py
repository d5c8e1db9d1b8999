"""Products on disk: :func:`save` and :func:`load` of netCDF4/HDF5 files and Zarr stores.

Every mitsar product (raw, range-compressed profile, image, ...) is an :class:`xarray.Dataset`
with a ``product`` attribute. :func:`save` writes it with the ``h5netcdf`` engine, which stores
complex variables as native HDF5 compound types that ``xarray.open_dataset`` reads back as
complex, after sanitising its attributes (:mod:`mitsar.io.attributes`), atomically
(:mod:`mitsar.io.atomic`); a ``.zarr`` path is a Zarr store (:mod:`mitsar.io.stores`).
:func:`load` reads both formats and refuses a file that is not the product expected;
:func:`write_json` writes JSON the same atomic way.
"""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import xarray as xr

from mitsar.io.atomic import (
    ZARR_MARKERS,
    ProductFileError,
    atomic_directory,
    atomic_writer,
    is_zarr,
)
from mitsar.io.attributes import sanitized, to_jsonable
from mitsar.io.stores import write_zarr

ENGINE = "h5netcdf"
"""xarray engine used for every product file."""


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
    clean = sanitized(ds)
    if is_zarr(path):
        with atomic_directory(path, overwrite) as tmp:
            write_zarr(clean, tmp)
        return Path(path)
    return atomic_writer(path, overwrite, lambda tmp: _write_netcdf(clean, tmp))


def load(path: str | os.PathLike, product: str | tuple[str, ...] | None = None) -> xr.Dataset:
    """Read a product file into memory (the file is closed on return).

    Parameters
    ----------
    path : path-like
        A file (``.nc``) or Zarr store (``.zarr``) written by :func:`save` or
        :class:`ZarrStream`.
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
    if not isinstance(path, str | os.PathLike):
        raise ProductFileError(f"load: parameter 'path': expected a file path (str or "
                               f"os.PathLike), found {type(path).__name__} {path!r:.80}")
    path = Path(path)
    if not path.exists():
        raise ProductFileError(f"load: parameter 'path': expected an existing product file "
                               f"(netCDF or a .zarr store), found {str(path)!r}: no such file")
    zarr_store = path.is_dir() and any((path / name).exists() for name in ZARR_MARKERS)
    if path.is_dir() and not zarr_store:
        raise ProductFileError(f"{path}: is a folder, expected a mitsar product file (.nc) "
                               "or Zarr store (.zarr)")
    try:
        if zarr_store:
            with xr.open_zarr(path, chunks=None) as handle:
                ds = handle.load()
        else:
            with xr.open_dataset(path, engine=ENGINE) as handle:
                ds = handle.load()
    except (OSError, ValueError, TypeError, KeyError) as error:
        kind = "Zarr" if zarr_store else "netCDF4/HDF5"
        raise ProductFileError(f"{path}: not a readable {kind} product "
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
