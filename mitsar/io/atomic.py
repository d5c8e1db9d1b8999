"""Atomic output: files and folders written beside their final name and moved into place.

A file is written to a temporary ``.NAME.PID.RANDOM.tmpSUFFIX`` in the destination folder and
moved into place with :func:`os.replace` (atomic on one file system), so that a failed or
interrupted write never leaves a partial product, and an existing file is only replaced when
asked to (:func:`atomic_output`, :func:`atomic_writer`); a folder (a ``.zarr`` store) likewise
(:func:`atomic_directory`). Temporaries a killed writer left behind are removed by the next
writer (:func:`remove_stale_temporaries`; docs/reliability.md §5).
"""

from __future__ import annotations

import glob
import os
import re
import shutil
import tempfile
import time
from collections.abc import Callable, Iterator
from contextlib import contextmanager
from pathlib import Path

from mitsar.errors import MitsarError


class OutputExistsError(MitsarError, FileExistsError):
    """The output file exists and overwriting was not requested."""


class ProductFileError(MitsarError, ValueError):
    """A file is missing, unreadable, or not a mitsar product of the expected type."""


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
        check_store_writable(path, overwrite)
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

    :func:`atomic_output` names its temporary file ``.NAME.PID.RANDOM.tmpSUFFIX`` and
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
                if process_alive(int(match.group(1))):
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


def process_alive(pid: int) -> bool:
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


def atomic_writer(path: str | os.PathLike, overwrite: bool,
                  write: Callable[[Path], None]) -> Path:
    """Call ``write(tmp)`` and move ``tmp`` to ``path`` atomically (see :func:`atomic_output`)."""
    with atomic_output(path, overwrite) as tmp:
        write(tmp)
    return Path(path)


ZARR_SUFFIX = ".zarr"
"""Suffix that selects the Zarr format in :func:`save` and :class:`ZarrStream`."""


ZARR_MARKERS = (".zgroup", ".zmetadata", "zarr.json")
"""Files that make a folder a Zarr store (format 2 or 3)."""


def is_zarr(path: str | os.PathLike) -> bool:
    """True when ``path`` names a Zarr store (suffix ``.zarr``)."""
    return Path(path).suffix.lower() == ZARR_SUFFIX


def check_store_writable(path: Path, overwrite: bool) -> None:
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
    check_store_writable(path, overwrite)
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
