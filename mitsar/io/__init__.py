"""Products on disk: netCDF4/HDF5 files written atomically, complex data stored natively.

Every mitsar product (raw, range-compressed profile, image, ...) is an :class:`xarray.Dataset`
with a ``product`` attribute. :func:`save` writes it with the ``h5netcdf`` engine, which stores
complex variables as native HDF5 compound types that ``xarray.open_dataset`` reads back as
complex. Attributes are sanitised first (netCDF attributes hold only numbers, strings and flat
numeric arrays). Files are written to a temporary file in the destination folder and moved into
place with :func:`os.replace`, so a failed or interrupted write never leaves a partial product,
and an existing file is only replaced when asked to.

A path ending in ``.zarr`` is a chunked Zarr store instead (a folder; Zarr format 2, whose
complex and text data types are specified): variables along ``sweep`` are chunked by sweeps,
the folder is written beside its final name and renamed into place, and :class:`ZarrStream`
appends a long acquisition chunk by chunk (``append_dim="sweep"``), so that a product larger
than memory can be written; :func:`load` reads both formats.

A resumable command (``mitsar simulate``, ``run``, ``ambiguity``) keeps its progress in a
:class:`WorkFolder`, ``.NAME.partial`` beside its destination: the finished chunks or stages,
each written atomically, under the hash of the command's inputs; a rerun after an interruption
continues from there, and the result moves into place only when whole (docs/reliability.md §5).

One concept per module: :mod:`mitsar.io.attributes` (what attributes and JSON can hold),
:mod:`mitsar.io.atomic` (atomic output, its errors), :mod:`mitsar.io.stores` (Zarr),
:mod:`mitsar.io.products` (:func:`save`, :func:`load`, :func:`write_json`) and
:mod:`mitsar.io.work_folder` (resumable commands); their names are imported here.
"""

from __future__ import annotations

from mitsar.io.atomic import (
    STALE_AGE,
    ZARR_MARKERS,
    ZARR_SUFFIX,
    OutputExistsError,
    ProductFileError,
    atomic_directory,
    atomic_output,
    atomic_writer,
    check_writable,
    is_zarr,
    remove_stale_temporaries,
)
from mitsar.io.attributes import sanitize_attrs, to_jsonable
from mitsar.io.products import ENGINE, load, save, write_json
from mitsar.io.stores import CHUNK_BYTES, ZARR_FORMAT, ZarrStream
from mitsar.io.work_folder import (
    INTERRUPT_ENV,
    INTERRUPT_SIGNAL_ENV,
    LOCK,
    MANIFEST,
    PARTIAL_SUFFIX,
    WorkFolder,
    file_digest,
    inputs_hash,
    scene_digest,
    work_folder_path,
)

__all__ = [
    "CHUNK_BYTES",
    "ENGINE",
    "INTERRUPT_ENV",
    "INTERRUPT_SIGNAL_ENV",
    "LOCK",
    "MANIFEST",
    "PARTIAL_SUFFIX",
    "STALE_AGE",
    "ZARR_FORMAT",
    "ZARR_MARKERS",
    "ZARR_SUFFIX",
    "OutputExistsError",
    "ProductFileError",
    "WorkFolder",
    "ZarrStream",
    "atomic_directory",
    "atomic_output",
    "atomic_writer",
    "check_writable",
    "file_digest",
    "inputs_hash",
    "is_zarr",
    "load",
    "remove_stale_temporaries",
    "sanitize_attrs",
    "save",
    "scene_digest",
    "to_jsonable",
    "work_folder_path",
    "write_json",
]
