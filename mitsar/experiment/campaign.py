"""Campaigns: many whole runs on Dask, recorded point by point so that a rerun resumes.

A campaign is a list of :class:`Task` (a key and the arguments of one whole run: simulate,
focus, measure). :func:`run_tasks` sends them to a Dask cluster, or runs them in this process
(``scheduler="inline"``), and hands every result, as it arrives (``as_completed``), to a
record store that writes it to disk atomically. The store says which keys are finished, so a
rerun after an interruption (SIGINT, a lost cluster) computes only the missing points; a task
that raises is recorded with its error text and does not stop the campaign (it is tried again by
the next rerun). Results do not depend on the number of workers: every task carries its own seed
(:func:`task_seed`), and records are gathered by key, not by arrival order (docs/experiments.md
§Campaigns).

Schedulers: ``None`` means the environment variable ``MITSAR_DASK_SCHEDULER`` when set, else
``"auto"``: the scheduler is chosen by the campaign's estimated cost (:func:`choose_scheduler`,
docs/experiments.md §Campaigns): this process for small campaigns, a local cluster only when
its start-up pays. ``"local"`` is a local cluster of one single-threaded worker process per CPU
core (``"local:N"`` for N workers); any other text is the address of a running Dask scheduler
(``tcp://host:8786``); ``"inline"`` runs the tasks one after another in this process.

A local cluster starts its workers with ``spawn``, which re-imports the calling script: a script
without an ``if __name__ == "__main__":`` guard would run its campaign again in every worker.
Such a script is recognised before the cluster starts; the campaign then runs in this process
with a :class:`~mitsar.errors.MitsarWarning` when the cluster was only the cost-based default,
and :class:`ClusterStartError` names the script and the fix when it was asked for. A cluster
that fails to start for another reason is a :class:`ClusterStartError` as well (or, for the
default, the same warning and this process).
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import math
import multiprocessing
import os
import re
import sys
import traceback
import warnings
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from tqdm.auto import tqdm

from mitsar.errors import MitsarError, MitsarWarning, ParameterError
from mitsar.io import to_jsonable, write_json

__all__ = ["AUTO", "INLINE", "LOCAL", "SCHEDULER_ENV", "ClusterStartError", "PointFolder",
           "RecordStore", "SchedulerChoice", "Task", "announce", "choose_scheduler", "dask_client",
           "fingerprint", "local_worker_count", "missing_main_guard", "outputs_match", "pending",
           "record_outputs", "resolve_scheduler", "run_tasks", "task_seed"]

SCHEDULER_ENV = "MITSAR_DASK_SCHEDULER"
"""Environment variable naming the default scheduler (an address, ``local[:N]`` or ``inline``)."""

INLINE = "inline"
"""Scheduler name: run the tasks in this process, one after another (no Dask)."""

LOCAL = "local"
"""Scheduler name: a Dask LocalCluster on this machine (``local:N`` for N workers)."""

AUTO = "auto"
"""Scheduler name: inline or a local cluster, whichever the estimated cost favours
(:func:`choose_scheduler`); the default."""

CLUSTER_START_SECONDS = 6.0
"""Fixed cost of a local cluster [s]: importing ``distributed``, starting its scheduler and
closing it (measured 4-6 s on a loaded 2-core machine, issue 27)."""

WORKER_START_SECONDS = 4.0
"""Cost of one worker process [s of a core]: Python, NumPy, SciPy, Dr.Jit and mitsar imported
afresh (3-4 CPU-s measured); workers start in parallel, one per core."""

WORKER_SLOWDOWN = 1.3
"""Cost of a task in a worker over its cost in this process: a worker has one thread (NumPy,
SciPy) and shares the cores with the other workers' Dr.Jit threads (7.0 against 5.5 CPU-s for
a realisation of the paper's point target with 5 algorithms, measured on 2 cores, issue 27)."""

PAYOFF = 1.5
"""A local cluster is chosen only when its estimated wall time is this many times shorter than
the inline run's: the estimates are rough, and an inline run already spreads Dr.Jit's kernels
over every core."""

UNKNOWN_TASK_SECONDS = 5.0
"""Assumed cost of a task whose campaign gives no estimate [s]."""

POINTS_FOLDER = "points"
"""Sub-folder of a campaign's output folder holding one JSON record per finished task."""


@dataclass(frozen=True)
class Task:
    """One whole run of a campaign.

    Attributes
    ----------
    key : str
        Name of the run, unique in the campaign (letters, digits, ``-``, ``_``, ``.``); also the
        name of its record file.
    args : tuple
        Positional arguments of the campaign's function (picklable: they travel to the workers).
    inputs : str
        Hash of everything the result depends on (:func:`fingerprint`); a stored record is only
        reused when it matches.
    """

    key: str
    args: tuple = ()
    inputs: str = ""


class RecordStore(Protocol):
    """Where a campaign keeps its records (:class:`PointFolder`, or Monte Carlo's own file)."""

    def finished(self) -> dict[str, dict]:
        """Records of the tasks that need not run again, by key."""

    def add(self, task: Task, record: dict) -> None:
        """Keep the record of a task that just finished (``status`` ``ok`` or ``failed``)."""


def fingerprint(data: Any) -> str:
    """A short stable hash (16 hex digits) of JSON-able data, keys sorted."""
    text = json.dumps(to_jsonable(data), sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


OUTPUTS_FILE = "outputs.json"
"""Hash of what a campaign's tables and figures were made from, written after them."""


def outputs_match(folder: Path, outputs: str, files: Sequence[str]) -> bool:
    """Whether ``folder``'s ``files`` exist and were made from ``outputs`` (the
    :func:`fingerprint` recorded in :data:`OUTPUTS_FILE` by :func:`record_outputs`): a rerun
    that ran nothing then rewrites nothing."""
    try:
        stored = json.loads((folder / OUTPUTS_FILE).read_text(encoding="utf-8"))
    except (OSError, ValueError):
        return False
    return (isinstance(stored, dict) and stored.get("fingerprint") == outputs
            and all((folder / name).is_file() for name in files))


def record_outputs(folder: Path, outputs: str, files: Sequence[str]) -> None:
    """Write :data:`OUTPUTS_FILE` (atomically), after the ``files`` made from ``outputs``."""
    write_json({"fingerprint": outputs, "files": list(files)}, folder / OUTPUTS_FILE,
               overwrite=True)


def task_seed(campaign_seed: int, *index: int) -> int:
    """The seed of one task, from the campaign's seed and the task's index.

    ``numpy.random.SeedSequence(campaign_seed, spawn_key=index)``: independent streams for
    different indices, the same seed for the same index whatever the worker or the order.

    Parameters
    ----------
    campaign_seed : int
        Seed of the whole campaign (>= 0).
    *index : int
        The task's index, e.g. (point, realisation).

    Returns
    -------
    int
        A seed in [0, 2**63).
    """
    if campaign_seed < 0 or any(i < 0 for i in index):
        raise ParameterError("task_seed", "campaign_seed", "integers >= 0",
                             (campaign_seed, *index))
    state = np.random.SeedSequence(int(campaign_seed), spawn_key=tuple(int(i) for i in index))
    return int(state.generate_state(1, np.uint64)[0] >> np.uint64(1))


def local_worker_count() -> int:
    """CPU cores this process may use (the size of the default local cluster)."""
    try:
        return max(1, len(os.sched_getaffinity(0)))
    except AttributeError:  # not on Linux
        return max(1, os.cpu_count() or 1)


def resolve_scheduler(scheduler: str | None) -> str:
    """The scheduler to use: ``scheduler``, else ``$MITSAR_DASK_SCHEDULER``, else ``"auto"``."""
    if scheduler is None or not str(scheduler).strip():
        scheduler = os.environ.get(SCHEDULER_ENV, "").strip() or AUTO
    return str(scheduler).strip()


@dataclass(frozen=True)
class SchedulerChoice:
    """Where a campaign runs and why (:func:`choose_scheduler`).

    Attributes
    ----------
    scheduler : str
        ``"inline"`` or ``"local:N"``.
    tasks : int
        Tasks to run.
    task_seconds : float
        Estimated cost of one task [s].
    inline_seconds, cluster_seconds : float
        Estimated wall time in this process and on the local cluster (start-up included) [s].
    reason : str
        One sentence for the user.
    """

    scheduler: str
    tasks: int
    task_seconds: float
    inline_seconds: float
    cluster_seconds: float
    reason: str


def choose_scheduler(tasks: int, task_seconds: float | None, workers: int | None = None,
                     cores: int | None = None) -> SchedulerChoice:
    """Inline or a local cluster, by the campaign's estimated cost (the ``"auto"`` scheduler).

    With W workers on C cores and tasks of t seconds, the inline run takes ``tasks * t`` and
    the cluster ``start + tasks * t * WORKER_SLOWDOWN / min(W, C)``, where ``start =
    CLUSTER_START_SECONDS + WORKER_START_SECONDS * ceil(W / C)`` (10 s when W <= C); the
    cluster is chosen when it is :data:`PAYOFF` times faster. One worker, or one task, always
    runs inline. For the paper's point target (t about 8 s with 5 algorithms) the cluster is
    chosen from 4 realisations on 4 cores and from 76 on 2 cores, where the best a cluster can
    do (2 / 1.3) barely beats the threshold; a 60 s task (a traced scene) goes to 2 cores from
    11 tasks on. The constants and their measurements: docs/experiments.md §Campaigns.

    Parameters
    ----------
    tasks : int
        Tasks still to run.
    task_seconds : float or None
        Estimated cost of one task [s] (None: :data:`UNKNOWN_TASK_SECONDS`).
    workers : int, optional
        Workers of the cluster (default: one per core).
    cores : int, optional
        CPU cores (default :func:`local_worker_count`).

    Returns
    -------
    SchedulerChoice
    """
    cores = local_worker_count() if cores is None else max(1, int(cores))
    count = cores if workers is None else max(1, int(workers))
    seconds = UNKNOWN_TASK_SECONDS if task_seconds is None else max(float(task_seconds), 0.0)
    inline = tasks * seconds
    start = CLUSTER_START_SECONDS + WORKER_START_SECONDS * math.ceil(count / cores)
    cluster = start + tasks * seconds * WORKER_SLOWDOWN / min(count, cores)
    if count < 2 or tasks < 2:
        why = "one worker" if count < 2 else "one run"
        return SchedulerChoice(INLINE, tasks, seconds, inline, cluster,
                               f"in this process ({why}: a cluster cannot help)")
    if cluster * PAYOFF < inline:
        return SchedulerChoice(f"{LOCAL}:{count}", tasks, seconds, inline, cluster,
                               f"on a local cluster of {count} workers (about "
                               f"{_duration(cluster)} with its {start:.0f} s start-up, against "
                               f"{_duration(inline)} in this process)")
    return SchedulerChoice(INLINE, tasks, seconds, inline, cluster,
                           f"in this process (about {_duration(inline)}; a {count}-worker "
                           f"cluster would take {_duration(cluster)} with its {start:.0f} s "
                           "start-up)")


def _duration(seconds: float) -> str:
    """``42 s``, ``3.5 min`` or ``2.1 h``."""
    if seconds < 120:
        return f"{seconds:.0f} s"
    if seconds < 7200:
        return f"{seconds / 60:.1f} min"
    return f"{seconds / 3600:.1f} h"


def announce(progress: bool, message: str) -> None:
    """A phase of a campaign on stderr (nothing when ``progress`` is False)."""
    if progress:
        tqdm.write(message, file=sys.stderr)
        sys.stderr.flush()


class ClusterStartError(MitsarError):
    """A local Dask cluster could not start (the message names the cause and the fix)."""


_GUARD = re.compile(r"""__name__\s*==\s*['"]__main__['"]|['"]__main__['"]\s*==\s*__name__""")


def missing_main_guard() -> str | None:
    """The calling script when it lacks ``if __name__ == "__main__":``, else None.

    Dask starts a local cluster's workers with ``spawn``, which re-imports the main module:
    without the guard each worker would run the script's campaign again (Python then refuses,
    and Dask reports ``Nanny failed to start``). Interactive sessions, ``python -c`` and the
    ``mitsar`` command have no such script.
    """
    main = sys.modules.get("__main__")
    path = getattr(main, "__file__", None)
    if not path or not str(path).endswith(".py"):
        return None
    try:
        text = Path(path).read_text(encoding="utf-8", errors="replace")
    except OSError:
        return None
    return None if _GUARD.search(text) else str(path)


def _bootstrapping() -> bool:
    """Whether this process is a spawned child still importing the parent's main module."""
    return bool(getattr(multiprocessing.current_process(), "_inheriting", False))


def _guard_message(script: str) -> str:
    return (f"{script} has no `if __name__ == '__main__':` guard, and a local Dask cluster "
            "starts its workers by re-importing the script (Python's 'spawn'); wrap the call "
            "in `if __name__ == '__main__':`, or pass scheduler='inline'")


def _local_workers(scheduler: str, workers: int | None) -> int:
    """Worker count of a ``local`` / ``local:N`` scheduler (``workers`` wins when given)."""
    match = re.fullmatch(r"local(?::(\d+))?", scheduler)
    if match is None:
        raise ParameterError("campaign", "scheduler", "'inline', 'local', 'local:N' or a Dask "
                             "scheduler address such as tcp://host:8786", scheduler)
    count = workers if workers is not None else (
        int(match.group(1)) if match.group(1) else local_worker_count())
    if count < 1:
        raise ParameterError("campaign", "workers", "at least 1 worker", count)
    return count


@contextlib.contextmanager
def dask_client(scheduler: str | None = None, workers: int | None = None) -> Iterator[Any]:
    """A Dask client for ``scheduler`` (module docstring), closed (with its cluster) on exit.

    Parameters
    ----------
    scheduler : str, optional
        ``"inline"`` (yields None), ``"local"``/``"local:N"``, or a scheduler address; default
        :func:`resolve_scheduler` (``"auto"`` is a local cluster here: a client was asked for).
    workers : int, optional
        Worker processes of a local cluster (default: one per CPU core).

    Yields
    ------
    distributed.Client or None
    """
    scheduler = resolve_scheduler(scheduler)
    if scheduler == INLINE:
        yield None
        return
    if _bootstrapping():
        raise ClusterStartError("campaign: called while a worker process imports the main "
                                "script: " + _guard_message(_main_file()))
    # lazy: Dask's distributed scheduler is heavy and only needed for campaigns
    from distributed import Client, LocalCluster

    if "://" in scheduler or not (scheduler.startswith(LOCAL) or scheduler == AUTO):
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as error:
            raise MitsarError(f"campaign: cannot reach the Dask scheduler {scheduler!r} "
                              f"({error}); start it (dask scheduler) or pass --scheduler local"
                              ) from error
        with client:
            yield client
        return
    count = _local_workers(LOCAL if scheduler == AUTO else scheduler, workers)
    script = missing_main_guard()
    if script is not None:
        raise ClusterStartError("campaign: cannot start a local Dask cluster: "
                                + _guard_message(script))
    # One single-threaded process per worker: runs are CPU-bound NumPy / Dr.Jit work and the
    # nanny already pins OMP/MKL/OpenBLAS to one thread each.
    try:
        cluster = LocalCluster(n_workers=count, threads_per_worker=1, processes=True,
                               dashboard_address=":0", silence_logs=logging.ERROR)
    except (RuntimeError, OSError, TimeoutError) as error:
        raise ClusterStartError(
            f"campaign: a local Dask cluster of {count} workers could not start "
            f"({type(error).__name__}: {error}); if mitsar is called from a script, the call "
            "must sit under `if __name__ == '__main__':` (the workers re-import the script); "
            "else run in this process with --scheduler inline (scheduler='inline')") from error
    with cluster, Client(cluster) as client:
        yield client


def _main_file() -> str:
    """The main script's path (in a spawned child: the one it is importing)."""
    for name in ("__mp_main__", "__main__"):
        path = getattr(sys.modules.get(name), "__file__", None)
        if path:
            return str(path)
    return "the main script"


def _call(function: Callable[..., Any], args: tuple) -> dict:
    """Run one task and wrap its outcome in a record (the error text when it raised)."""
    try:
        return {"status": "ok", "result": to_jsonable(function(*args))}
    except Exception as error:  # noqa: BLE001 - recorded, the campaign goes on
        return {"status": "failed", "error": f"{type(error).__name__}: {error}",
                "traceback": traceback.format_exc(limit=8)}


def _recorded(tasks: Sequence[Task], store: RecordStore) -> dict[str, dict]:
    """The records in ``store`` of ``tasks`` that need not run again (same key and inputs)."""
    stored = store.finished()
    return {task.key: stored[task.key] for task in tasks if task.key in stored
            and stored[task.key].get("inputs", task.inputs) == task.inputs}


def pending(tasks: Sequence[Task], store: RecordStore) -> list[Task]:
    """The tasks :func:`run_tasks` would run: those without a record in ``store`` (by key,
    with the same inputs)."""
    records = _recorded(tasks, store)
    return [task for task in tasks if task.key not in records]


def run_tasks(function: Callable[..., Any], tasks: Sequence[Task], store: RecordStore, *,
              scheduler: str | None = None, workers: int | None = None, client: Any = None,
              progress: bool = True, desc: str = "campaign",
              on_record: Callable[[Task, dict], None] | None = None,
              task_seconds: float | None = None, what: str = "runs") -> dict[str, dict]:
    """Run the tasks not yet finished in ``store``, recording each as it completes.

    Parameters
    ----------
    function : callable
        ``function(*task.args)`` makes one task's result (JSON-able); a module-level function
        (it is sent to the workers by reference).
    tasks : sequence of Task
    store : RecordStore
        Gives the finished records and keeps new ones (written by this process, atomically).
    scheduler, workers
        See :func:`dask_client`; ignored when ``client`` is given. ``"auto"`` (the default
        unless ``$MITSAR_DASK_SCHEDULER`` says otherwise) is :func:`choose_scheduler` on the
        tasks left to run and ``task_seconds``, or a local cluster of ``workers`` when a
        worker count is given.
    client : distributed.Client, optional
        An existing client to submit to (e.g. one shared by several campaigns).
    progress : bool
        Say on stderr where the tasks run and why, and show a progress bar (tqdm).
    desc : str
        Label of the messages and the progress bar.
    on_record : callable, optional
        Called with every new record (after the store kept it).
    task_seconds : float, optional
        Estimated cost of one task [s], for the ``"auto"`` scheduler.
    what : str
        What the tasks are, for the messages (e.g. "realisations").

    Returns
    -------
    dict
        Record of every task, by key: ``status`` ("ok" or "failed"), ``result`` or ``error``
        and ``traceback``, ``key``, ``inputs``.

    Raises
    ------
    ClusterStartError
        A local cluster that was asked for could not start (the message says why and what to
        do); a cost-chosen one falls back to this process with a ``MitsarWarning``.
    KeyboardInterrupt
        Passed on after cancelling what was still running; finished tasks stay recorded.
    """
    keys = [task.key for task in tasks]
    if len(set(keys)) != len(keys):
        raise ParameterError("run_tasks", "tasks", "unique keys", keys)
    records = _recorded(tasks, store)
    todo = [task for task in tasks if task.key not in records]
    if not todo:  # nothing left to do starts no cluster
        announce(progress, f"{desc}: all {len(tasks)} {what} already recorded, nothing to run")
        return records
    if _bootstrapping():  # a spawned worker re-running a script that has no main guard
        raise ClusterStartError(f"{desc}: started while a worker process imports the main "
                                "script: " + _guard_message(_main_file()))
    name = INLINE if client is not None else resolve_scheduler(scheduler)
    if client is None and name == AUTO and workers is not None:
        name = f"{LOCAL}:{workers}"  # a worker count asks for a local cluster of that size
    if client is None and name == AUTO:
        choice = choose_scheduler(len(todo), task_seconds, workers)
        name = choice.scheduler
        done = f", {len(records)} recorded before" if records else ""
        announce(progress, f"{desc}: {len(todo)} {what} to run{done}, about "
                           f"{choice.task_seconds:.2g} s each: {choice.reason}")
        fallback = True
    else:
        where = ("on the given Dask client" if client is not None else
                 "in this process" if name == INLINE else f"on {name}")
        announce(progress, f"{desc}: {len(todo)} {what} to run {where}")
        fallback = False
    bar = tqdm(total=len(tasks), initial=len(tasks) - len(todo), disable=not progress,
               desc=desc, unit="run", file=sys.stderr)

    def keep(task: Task, record: dict) -> None:
        record = {"key": task.key, "inputs": task.inputs, **record}
        store.add(task, record)
        records[task.key] = record
        if record["status"] != "ok":
            tqdm.write(f"{desc}: {task.key} failed: {record['error']}", file=sys.stderr)
        if on_record is not None:
            on_record(task, record)
        bar.update(1)

    try:
        if client is not None:
            _run_on(client, function, todo, keep)
        elif name == INLINE:
            _run_inline(function, todo, keep)
        else:
            try:
                with dask_client(name, workers) as own:
                    bar.set_postfix_str("cluster up")
                    _run_on(own, function, todo, keep)
            except ClusterStartError as error:
                if not fallback:
                    raise
                warnings.warn(f"{error}; running the {what} in this process instead (the same "
                              "numbers, one process)", MitsarWarning, stacklevel=2)
                _run_inline(function, [t for t in todo if t.key not in records], keep)
    finally:
        bar.close()
    return records


def _run_inline(function: Callable[..., Any], todo: Sequence[Task],
                keep: Callable[[Task, dict], None]) -> None:
    """Run ``todo`` one after another in this process."""
    for task in todo:
        keep(task, _call(function, task.args))


def _run_on(client: Any, function: Callable[..., Any], todo: Sequence[Task],
            keep: Callable[[Task, dict], None]) -> None:
    """Submit ``todo`` to a Dask client and keep each record as it completes."""
    # lazy: Dask's distributed scheduler is heavy and only needed for campaigns
    from distributed import as_completed

    tag = os.urandom(4).hex()
    futures = {client.submit(_call, function, task.args, key=f"mitsar-{tag}-{task.key}",
                             pure=False): task for task in todo}
    try:
        for future in as_completed(futures):
            try:
                record = future.result()
            except Exception as error:  # noqa: BLE001 - a lost worker: recorded, go on
                record = {"status": "failed", "error": f"{type(error).__name__}: {error}",
                          "traceback": ""}
            keep(futures[future], record)
    finally:
        client.cancel(list(futures))


@dataclass
class PointFolder:
    """Records of a campaign, one JSON file per task in ``folder/points/`` (atomic writes).

    :func:`run_tasks` reuses a record only when its ``inputs`` hash matches the task's; a
    failed record is not reused (the task runs again). ``restart=True`` forgets every record.
    """

    folder: Path
    restart: bool = False

    def __post_init__(self) -> None:
        self.folder = Path(self.folder)
        self.points = self.folder / POINTS_FOLDER
        self.points.mkdir(parents=True, exist_ok=True)
        if self.restart:
            for path in self.points.glob("*.json"):
                path.unlink()

    def finished(self) -> dict[str, dict]:
        out = {}
        for path in sorted(self.points.glob("*.json")):
            record = self.read(path.stem)
            if record and record.get("status") == "ok":
                out[path.stem] = record
        return out

    def read(self, key: str) -> dict | None:
        """The stored record of ``key``, or None (missing or unreadable)."""
        path = self.points / f"{key}.json"
        try:
            return json.loads(path.read_text(encoding="utf-8"))
        except (OSError, json.JSONDecodeError):
            return None

    def add(self, task: Task, record: dict) -> None:
        write_json(record, self.points / f"{task.key}.json", overwrite=True)

