"""Resumable commands: the work folder ``.NAME.partial`` that keeps a command's progress.

A resumable command (``mitsar simulate``, ``run``, ``ambiguity``) keeps its progress in a
:class:`WorkFolder`, ``.NAME.partial`` beside its destination: the finished chunks or stages,
each written atomically, under the hash of the command's inputs; a rerun after an interruption
continues from there, and the result moves into place only when whole (docs/reliability.md §5).
"""

from __future__ import annotations

import hashlib
import json
import os
import shutil
import signal
from collections.abc import Callable, Sequence
from pathlib import Path
from typing import Any

from mitsar.errors import MitsarError
from mitsar.io.atomic import OutputExistsError, ProductFileError, process_alive
from mitsar.io.attributes import to_jsonable
from mitsar.io.products import write_json
from mitsar.version import __version__

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
                if owner and owner != os.getpid() and process_alive(owner):
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
