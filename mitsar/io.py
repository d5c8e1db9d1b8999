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
"""

from __future__ import annotations

import glob
import hashlib
import json
import math
import os
import re
import shutil
import signal
import tempfile
import time
from collections.abc import Callable, Iterator, Mapping, Sequence
from contextlib import contextmanager
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from mitsar.errors import MitsarError
from mitsar.version import __version__

__all__ = [
    "INTERRUPT_ENV",
    "OutputExistsError",
    "ProductFileError",
    "WorkFolder",
    "ZarrStream",
    "atomic_output",
    "atomic_writer",
    "check_writable",
    "is_zarr",
    "load",
    "sanitize_attrs",
    "save",
    "to_jsonable",
    "work_folder_path",
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
    """Refuse to replace an existing file (or ``.zarr`` store) unless ``overwrite``.

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
    if is_zarr(path):
        _check_store_writable(path, overwrite)
        return path
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
    remove_stale_temporaries(path)
    fd, tmp_name = tempfile.mkstemp(prefix=f".{path.name}.{os.getpid()}.",
                                    suffix=f".tmp{path.suffix}", dir=path.parent)
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


STALE_AGE = 3600.0
"""Age [s] after which a temporary file without a writer's process id is taken as stale."""


def remove_stale_temporaries(path: str | os.PathLike) -> list[Path]:
    """Remove the temporaries a killed writer left beside ``path`` (docs/reliability.md §5).

    :func:`atomic_output` names its temporary file ``.NAME.PID.XXXX.tmpSUFFIX`` and
    :func:`atomic_directory` its temporary folder (a ``.zarr`` store) the same way, plus
    ``....tmpSUFFIX.old`` for the store it sets aside while replacing it; one whose process no
    longer runs is stale (SIGKILL leaves it behind). Older names without a process id are
    stale after :data:`STALE_AGE` seconds (a folder by its own modification time). Those of
    running writers are left alone.

    Returns
    -------
    list of Path
        The files and folders removed.
    """
    path = Path(path)
    removed = []
    if not path.parent.is_dir():
        return removed
    pattern = re.compile(re.escape(f".{path.name}.") + r"(?:(\d+)\.)?[^/]*"
                         + re.escape(f".tmp{path.suffix}") + r"(\.old)?$")
    stem = f".{glob.escape(path.name)}.*.tmp{glob.escape(path.suffix)}"
    for candidate in sorted({*path.parent.glob(stem), *path.parent.glob(stem + ".old")}):
        match = pattern.match(candidate.name)
        if match is None:
            continue
        try:
            if match.group(1) is not None:
                if _process_alive(int(match.group(1))):
                    continue
            elif time.time() - candidate.lstat().st_mtime < STALE_AGE:
                continue
            if candidate.is_dir() and not candidate.is_symlink():
                shutil.rmtree(candidate)
            elif match.group(2) is None:  # ".old" only ever names a set-aside folder
                candidate.unlink()
            else:
                continue
            removed.append(candidate)
        except OSError:  # gone meanwhile, or not ours to remove
            continue
    return removed


def _process_alive(pid: int) -> bool:
    """True if a process ``pid`` exists (signal 0 tests without sending anything)."""
    if pid == os.getpid():
        return True
    try:
        os.kill(pid, 0)
    except ProcessLookupError:
        return False
    except (PermissionError, OverflowError, OSError):
        return True
    return True


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
    if is_zarr(path):
        with atomic_directory(path, overwrite) as tmp:
            _write_zarr(clean, tmp)
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


# --- Zarr ---------------------------------------------------------------------------------
ZARR_SUFFIX = ".zarr"
"""Suffix that selects the Zarr format in :func:`save` and :class:`ZarrStream`."""

ZARR_FORMAT = 2
"""Zarr format written: 2, whose complex and fixed-length text data types are specified (Zarr 3
has no text type yet)."""

ZARR_MARKERS = (".zgroup", ".zmetadata", "zarr.json")
"""Files that make a folder a Zarr store (format 2 or 3)."""

CHUNK_BYTES = 8 * 2**20
"""Target size of one chunk of a variable along ``sweep`` [bytes]."""


def is_zarr(path: str | os.PathLike) -> bool:
    """True when ``path`` names a Zarr store (suffix ``.zarr``)."""
    return Path(path).suffix.lower() == ZARR_SUFFIX


def _zarr_encoding(ds: xr.Dataset, chunk_sweeps: int | None = None) -> dict[str, dict]:
    """Chunks of every variable along ``sweep``: ``chunk_sweeps`` sweeps, or as many as make
    :data:`CHUNK_BYTES` for the largest variable; other dimensions whole."""
    along = [name for name in ds.variables if "sweep" in ds[name].dims]
    if not along:
        return {}
    if chunk_sweeps is None:
        per_sweep = max(ds[name].dtype.itemsize * ds[name].size // max(ds.sizes["sweep"], 1)
                        for name in along)
        chunk_sweeps = max(1, CHUNK_BYTES // max(per_sweep, 1))
    encoding = {}
    for name in along:
        chunks = tuple(min(chunk_sweeps, n) if d == "sweep" else n
                       for d, n in zip(ds[name].dims, ds[name].shape, strict=True))
        encoding[name] = {"chunks": tuple(max(c, 1) for c in chunks)}
    return encoding


def _write_zarr(ds: xr.Dataset, path: Path, chunk_sweeps: int | None = None) -> None:
    """Write a sanitised product as a new Zarr store (the step tests can replace)."""
    ds.to_zarr(path, mode="w", zarr_format=ZARR_FORMAT, consolidated=True,
               encoding=_zarr_encoding(ds, chunk_sweeps))


def _check_store_writable(path: Path, overwrite: bool) -> None:
    """Refuse to replace an existing store unless ``overwrite`` (or a folder that is none)."""
    if path.exists() and not overwrite:
        raise OutputExistsError(f"{path}: exists; pass overwrite=True (--overwrite on the "
                                "command line) to replace it")
    if path.exists() and path.is_dir() and not any((path / m).exists() for m in ZARR_MARKERS):
        raise ProductFileError(f"{path}: is a folder that is not a Zarr store; not replaced "
                               "(choose another name)")
    parent = path.parent if str(path.parent) else Path(".")
    if not parent.is_dir():
        raise ProductFileError(f"{path}: folder {parent} does not exist")


@contextmanager
def atomic_directory(path: str | os.PathLike, overwrite: bool = False) -> Iterator[Path]:
    """Like :func:`atomic_output` for a folder (a Zarr store): a temporary folder beside
    ``path`` that replaces it on success and is removed if the body raises.

    Replacing an existing store renames it aside first, then removes it, so that ``path``
    always holds a whole store (the old one or the new one).
    """
    path = Path(path)
    _check_store_writable(path, overwrite)
    remove_stale_temporaries(path)
    tmp = Path(tempfile.mkdtemp(prefix=f".{path.name}.{os.getpid()}.",
                                suffix=f".tmp{path.suffix}", dir=path.parent))
    try:
        yield tmp
        if path.exists():
            if not overwrite:  # appeared while we were writing
                raise OutputExistsError(f"{path}: appeared during the write; pass "
                                        "overwrite=True (--overwrite) to replace it")
            old = tmp.with_name(tmp.name + ".old")
            os.replace(path, old)
            os.replace(tmp, path)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(tmp, path)
    finally:
        if tmp.exists():
            shutil.rmtree(tmp, ignore_errors=True)


class ZarrStream:
    """Write a product to a Zarr store chunk by chunk along ``sweep`` (context manager).

    The first :meth:`append` creates the store with every variable (chunked by
    ``chunk_sweeps`` sweeps) and the first chunk's attributes; later ones append the variables
    that have a ``sweep`` dimension (``append_dim="sweep"``). Memory holds one chunk. The store
    is written beside ``path`` and moved into place when the ``with`` block ends without an
    error (then ``attrs`` given to :meth:`finish` are set); on an error nothing is left.

    Examples
    --------
    >>> with ZarrStream("raw.zarr") as out:  # doctest: +SKIP
    ...     for chunk in mitsar.raw.analytic.stream_point_targets(...):
    ...         out.append(chunk)
    """

    def __init__(self, path: str | os.PathLike, overwrite: bool = False,
                 chunk_sweeps: int | None = None) -> None:
        self.path = Path(path)
        if not is_zarr(self.path):
            raise ProductFileError(f"{self.path}: a streamed product is a Zarr store: name it "
                                   f"with the suffix {ZARR_SUFFIX}")
        self.overwrite, self.chunk_sweeps = overwrite, chunk_sweeps
        self.sweeps = 0
        self._attrs: dict[str, Any] = {}
        self._context: Any = None
        self._tmp: Path | None = None

    def __enter__(self) -> ZarrStream:
        self._context = atomic_directory(self.path, self.overwrite)
        self._tmp = self._context.__enter__()
        return self

    def append(self, chunk: xr.Dataset) -> None:
        """Write the next sweeps (a product whose ``sweep`` coordinate continues the last)."""
        if self._tmp is None:
            raise ProductFileError(f"{self.path}: ZarrStream.append outside its 'with' block")
        clean = _sanitized(chunk)
        if self.sweeps == 0:
            _write_zarr(clean, self._tmp, self.chunk_sweeps or clean.sizes.get("sweep"))
        else:
            along = [n for n in clean.data_vars if "sweep" in clean[n].dims]
            extra = [n for n in clean.coords if "sweep" not in clean[n].dims]
            clean[along].drop_vars(extra).to_zarr(self._tmp, append_dim="sweep",
                                                  consolidated=True)
        self.sweeps += int(clean.sizes.get("sweep", 0))

    def finish(self, attrs: Mapping[str, Any]) -> None:
        """Set (or change) attributes of the product, e.g. totals known at the end."""
        self._attrs.update(attrs)

    def __exit__(self, kind: Any, error: Any, trace: Any) -> bool:
        if kind is None:
            try:
                self._close()
            except BaseException as failure:  # the temporary store is removed, then raised
                self._context.__exit__(type(failure), failure, failure.__traceback__)
                raise
        return bool(self._context.__exit__(kind, error, trace))

    def _close(self) -> None:
        """Check that something was written and set the final attributes."""
        if self.sweeps == 0:
            raise ProductFileError(f"{self.path}: nothing was appended")
        if self._attrs:
            # lazy: zarr is a heavy optional reader only needed once a store is written
            import zarr

            group = zarr.open_group(self._tmp, mode="r+")
            group.attrs.update(sanitize_attrs(self._attrs))
            zarr.consolidate_metadata(self._tmp)


# --- resumable commands -------------------------------------------------------------------
PARTIAL_SUFFIX = ".partial"
"""Suffix of a resumable command's work folder, ``.NAME.partial`` beside its destination."""

MANIFEST = "manifest.json"
"""The work folder's record: the inputs' hash and the finished chunks or stages."""

LOCK = "lock"
"""File in a work folder holding the process id of the command working in it."""

INTERRUPT_ENV = "MITSAR_TEST_INTERRUPT_AFTER_CHUNK"
"""Test hook (docs/reliability.md §5): a resumable command sends itself a signal right after
it records its k-th finished chunk or stage (``k`` the variable's value), so that tests
interrupt it at a known point."""

INTERRUPT_SIGNAL_ENV = "MITSAR_TEST_INTERRUPT_SIGNAL"
"""The signal of :data:`INTERRUPT_ENV`: ``INT`` (default; SIGINT, as Ctrl-C) or ``KILL``."""


def work_folder_path(destination: str | os.PathLike) -> Path:
    """The work folder of a resumable command writing ``destination``: ``.NAME.partial``
    in the same folder (same file system, so its results move into place atomically)."""
    destination = _named(destination)
    return destination.parent / f".{destination.name}{PARTIAL_SUFFIX}"


def _named(path: str | os.PathLike) -> Path:
    """``path``, made absolute when it has no name of its own (``.``, ``..``, ``/x/..``)."""
    path = Path(path)
    return path.resolve() if path.name in ("", ".", "..") else path


def inputs_hash(inputs: Any) -> str:
    """The SHA-256 (hex) of JSON-able ``inputs`` with sorted keys, and mitsar's version."""
    text = json.dumps({"inputs": to_jsonable(inputs), "mitsar": __version__}, sort_keys=True,
                      default=str)
    return hashlib.sha256(text.encode()).hexdigest()


def file_digest(path: str | os.PathLike) -> str | None:
    """SHA-256 (hex) of a file's content, or None when it is not a readable file."""
    try:
        return hashlib.sha256(Path(path).read_bytes()).hexdigest()
    except OSError:
        return None


def scene_digest(source: str | os.PathLike, scene: Any) -> str | None:
    """The content hash of the scene file a configuration file names (a path absolute or
    relative to the configuration's folder; a canned scene: its name; no scene: None), for
    the inputs of a resumable command (:class:`WorkFolder`)."""
    if not isinstance(scene, str):
        return None
    for candidate in (Path(scene), Path(source).parent / scene):
        digest = file_digest(candidate)
        if digest:
            return digest
    return scene


class WorkFolder:
    """The progress of a resumable command, kept beside its destination (context manager).

    The folder :func:`work_folder_path` holds :data:`MANIFEST` (the hash of the command's
    inputs, the finished chunks or stages with what the command noted about each) and the
    files the command writes as it goes, each written atomically before it is marked finished
    (:meth:`mark`). Opened again with the same inputs after an interruption (SIGINT, SIGKILL, a
    crash) the command skips what is marked finished; with other inputs the folder is removed
    and the command starts over, and says so. Nothing is written at the destination until the
    command moves its result there (:meth:`move_file`, :meth:`move_folder`) and removes the
    folder (:meth:`remove`); a failure leaves the folder for the next run to resume, unless
    nothing was finished yet (a refused input leaves nothing behind).

    Parameters
    ----------
    destination : path-like
        The command's output (a file, a ``.zarr`` store or a folder).
    inputs : object
        Everything the result depends on, JSON-able (:func:`inputs_hash` adds mitsar's version).
    command : str
        The command's name, for messages.
    log : callable, optional
        Receives the messages "resuming ..." and "starting over ...".

    Examples
    --------
    >>> work = WorkFolder("raw.nc", {"experiment": config}, command="simulate")  # doctest: +SKIP
    >>> with work:  # doctest: +SKIP
    ...     for k in range(chunks):
    ...         if not work.done(f"chunk{k}"):
    ...             save(make(k), work.file(f"chunk{k}.nc"), overwrite=True)
    ...             work.mark(f"chunk{k}")
    ...     work.move_file(work.file("result.nc"), overwrite=False)
    ...     work.remove()
    """

    def __init__(self, destination: str | os.PathLike, inputs: Any, *, command: str,
                 log: Callable[[str], None] | None = None) -> None:
        self.destination = _named(destination)
        self.path = work_folder_path(self.destination)
        self.inputs = inputs_hash(inputs)
        self.command = command
        self.log = log or (lambda message: None)
        self.finished: dict[str, Any] = {}
        self.resumed: list[str] = []
        self._locked = False

    # -- opening -----------------------------------------------------------------------
    def __enter__(self) -> WorkFolder:
        self.open()
        return self

    def __exit__(self, kind: Any, error: Any, trace: Any) -> bool:
        if kind is not None and self.path.is_dir() and not self._progress():
            self.remove()  # refused or stopped before anything was finished: nothing to resume
        self.unlock()
        return False

    def _progress(self) -> bool:
        """True when something is finished here or in a work folder nested in this one (the
        raw product's chunks inside ``mitsar run``'s)."""
        if self.finished:
            return True
        for manifest in self.path.rglob(MANIFEST):
            try:
                if json.loads(manifest.read_text(encoding="utf-8")).get("finished"):
                    return True
            except (OSError, ValueError, AttributeError):
                continue
        return False

    def open(self) -> None:
        """Create the folder, or take up the one an interrupted run left (same inputs), or
        start over (other inputs); then lock it for this process."""
        if self.path.exists() and (self.path.is_symlink() or not self.path.is_dir()):
            raise ProductFileError(f"{self.path}: expected the work folder of mitsar "
                                   f"{self.command}, found a file; remove it or choose "
                                   "another output name")
        manifest = self._read_manifest()
        if self.path.is_dir():
            self._lock()
            if manifest is not None and manifest.get("inputs") == self.inputs:
                self.finished = dict(manifest.get("finished", {}))
                self.resumed = list(self.finished)
                if self.resumed:
                    self.log(f"{self.command}: resuming from {self.path} ({len(self.resumed)} "
                             f"finished: {', '.join(self.resumed[:6])}"
                             f"{', ...' if len(self.resumed) > 6 else ''})")
                return
            if manifest is not None:
                self.log(f"{self.command}: the inputs changed since the interrupted run in "
                         f"{self.path} (experiment, options or mitsar version): starting over")
            for entry in self.path.iterdir():
                if entry.name == LOCK:
                    continue
                if entry.is_dir() and not entry.is_symlink():
                    shutil.rmtree(entry)
                else:
                    entry.unlink()
        else:
            self.path.mkdir()
            self._lock()
        self._write_manifest()

    def _read_manifest(self) -> dict | None:
        try:
            data = json.loads((self.path / MANIFEST).read_text(encoding="utf-8"))
        except (OSError, ValueError):
            return None
        return data if isinstance(data, dict) else None

    def _write_manifest(self) -> None:
        write_json({"command": self.command, "destination": str(self.destination),
                    "inputs": self.inputs, "finished": self.finished},
                   self.path / MANIFEST, overwrite=True)

    def _lock(self) -> None:
        """Take the folder for this process; refuse while another live process holds it."""
        lock = self.path / LOCK
        for _ in range(2):
            try:
                fd = os.open(lock, os.O_CREAT | os.O_EXCL | os.O_WRONLY, 0o644)
            except FileExistsError:
                try:
                    owner = int(lock.read_text().strip() or 0)
                except (OSError, ValueError):
                    owner = 0
                if owner and owner != os.getpid() and _process_alive(owner):
                    raise MitsarError(
                        f"{self.destination}: another mitsar process (pid {owner}) is writing "
                        f"it (work folder {self.path}); wait for it to end, or remove that "
                        "folder if no such process runs") from None
                lock.unlink(missing_ok=True)  # left by a process that no longer runs
                continue
            with os.fdopen(fd, "w") as handle:
                handle.write(str(os.getpid()))
            self._locked = True
            return
        raise MitsarError(f"{self.path}: cannot take the work folder's lock {lock}")

    def unlock(self) -> None:
        """Release the folder (the next run may resume it)."""
        if self._locked:
            (self.path / LOCK).unlink(missing_ok=True)
            self._locked = False

    # -- progress ----------------------------------------------------------------------
    def file(self, name: str) -> Path:
        """A path inside the work folder."""
        return self.path / name

    def done(self, key: str) -> bool:
        """True when chunk or stage ``key`` was marked finished (by this run or an earlier)."""
        return key in self.finished

    def info(self, key: str) -> Any:
        """What :meth:`mark` noted about a finished ``key`` (``None`` if not finished)."""
        return self.finished.get(key)

    def mark(self, key: str, info: Any = None) -> None:
        """Record ``key`` as finished (its files must already be written), atomically.

        With :data:`INTERRUPT_ENV` set to ``k``, the ``k``-th mark of this process (of all its
        work folders: ``mitsar run`` nests the one of its raw product) is followed by the
        signal of :data:`INTERRUPT_SIGNAL_ENV` (a test hook)."""
        self.finished[key] = to_jsonable(info if info is not None else {})
        self._write_manifest()
        _MARKS[0] += 1
        _test_interrupt(_MARKS[0])

    # -- finishing ---------------------------------------------------------------------
    def move_file(self, source: Path, destination: str | os.PathLike | None = None,
                  overwrite: bool = False) -> Path:
        """Move a finished file or ``.zarr`` store from the work folder to ``destination``
        (default the command's) with one rename; an existing one is replaced only with
        ``overwrite`` (a store is set aside first, so the destination is always whole)."""
        target = Path(destination) if destination is not None else self.destination
        if target.exists() and not overwrite:
            raise OutputExistsError(f"{target}: exists; pass overwrite=True (--overwrite on "
                                    "the command line) to replace it (the finished result "
                                    f"waits in {self.path}: the rerun only moves it)")
        if source.is_dir() and target.exists():
            old = target.with_name(f".{target.name}.{os.getpid()}.old{PARTIAL_SUFFIX}")
            os.replace(target, old)
            os.replace(source, target)
            shutil.rmtree(old, ignore_errors=True)
        else:
            os.replace(source, target)
        return target

    def move_folder(self, source: Path, destination: str | os.PathLike | None = None,
                    overwrite: bool = False, last: Sequence[str] = ()) -> Path:
        """Move a finished folder to ``destination`` (default the command's): one rename when
        the destination does not exist, else file by file (each a rename; the names in
        ``last`` after the others, so that a record written last, e.g. ``run.json``, only
        appears with everything it lists). Existing files are replaced only with
        ``overwrite``; every clash is checked before anything moves."""
        target = _named(destination) if destination is not None else self.destination
        if target.exists() and not target.is_dir():
            raise ProductFileError(f"{target}: is a file, expected a folder")
        if not target.exists():
            os.replace(source, target)
            return target
        moves = [(entry, target / entry.relative_to(source))
                 for entry in sorted(source.rglob("*")) if not entry.is_dir()]
        clashes = [str(dest) for _, dest in moves if dest.exists()]
        if clashes and not overwrite:
            raise OutputExistsError(
                f"{target}: {len(clashes)} files exist ({', '.join(clashes[:3])}"
                f"{', ...' if len(clashes) > 3 else ''}); pass overwrite=True (--overwrite on "
                f"the command line) to replace them (the finished result waits in "
                f"{self.path}: the rerun only moves it)")
        order = {name: rank for rank, name in enumerate(last, start=1)}
        moves.sort(key=lambda pair: order.get(pair[0].name, 0))  # stable: the rest in order
        for entry, dest in moves:
            dest.parent.mkdir(parents=True, exist_ok=True)
            if dest.is_dir() and not dest.is_symlink():
                shutil.rmtree(dest)
            os.replace(entry, dest)
        return target

    def remove(self) -> None:
        """Remove the work folder (after the result has moved into place)."""
        self._locked = False
        shutil.rmtree(self.path, ignore_errors=True)


_MARKS = [0]
"""Marks made by this process, for :data:`INTERRUPT_ENV`."""


def _test_interrupt(marks: int) -> None:
    """The test hook of :data:`INTERRUPT_ENV`: signal this process after mark ``marks``."""
    wanted = os.environ.get(INTERRUPT_ENV, "").strip()
    if not wanted or not wanted.isdigit() or int(wanted) != marks:
        return
    name = os.environ.get(INTERRUPT_SIGNAL_ENV, "INT").strip().upper().removeprefix("SIG")
    sig = signal.SIGKILL if name == "KILL" else signal.SIGINT
    os.kill(os.getpid(), sig)
