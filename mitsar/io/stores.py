"""Zarr stores: a product as a chunked folder, written whole or appended sweep by sweep.

A path ending in ``.zarr`` is a chunked Zarr store (Zarr format 2, whose complex and text data
types are specified): variables along ``sweep`` are chunked by sweeps (:data:`CHUNK_BYTES`),
the folder is written beside its final name and renamed into place
(:func:`mitsar.io.atomic.atomic_directory`), and :class:`ZarrStream` appends a long acquisition
chunk by chunk (``append_dim="sweep"``), so that a product larger than memory can be written.
"""

from __future__ import annotations

import os
from collections.abc import Mapping
from pathlib import Path
from typing import Any

import xarray as xr

from mitsar.io.atomic import ZARR_SUFFIX, ProductFileError, atomic_directory, is_zarr
from mitsar.io.attributes import sanitize_attrs, sanitized

ZARR_FORMAT = 2
"""Zarr format written: 2, whose complex and fixed-length text data types are specified (Zarr 3
has no text type yet)."""


CHUNK_BYTES = 8 * 2**20
"""Target size of one chunk of a variable along ``sweep`` [bytes]."""


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


def write_zarr(ds: xr.Dataset, path: Path, chunk_sweeps: int | None = None) -> None:
    """Write a sanitised product as a new Zarr store (the step tests can replace)."""
    ds.to_zarr(path, mode="w", zarr_format=ZARR_FORMAT, consolidated=True,
               encoding=_zarr_encoding(ds, chunk_sweeps))


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
        clean = sanitized(chunk)
        if self.sweeps == 0:
            write_zarr(clean, self._tmp, self.chunk_sweeps or clean.sizes.get("sweep"))
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
