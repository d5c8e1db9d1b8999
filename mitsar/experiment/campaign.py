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

Schedulers: ``None`` means the environment variable ``MITSAR_DASK_SCHEDULER`` when set, else a
local cluster of one single-threaded worker process per CPU core (``"local"``; ``"local:N"``
for N workers); any other text is the address of a running Dask scheduler
(``tcp://host:8786``); ``"inline"`` runs the tasks one after another in this process.
"""

from __future__ import annotations

import contextlib
import hashlib
import json
import logging
import os
import re
import traceback
from collections.abc import Callable, Iterator, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any, Protocol

import numpy as np
from tqdm.auto import tqdm

from mitsar.errors import MitsarError, ParameterError
from mitsar.io import to_jsonable, write_json

__all__ = ["INLINE", "LOCAL", "SCHEDULER_ENV", "PointFolder", "RecordStore", "Task",
           "dask_client", "fingerprint", "local_worker_count", "resolve_scheduler", "run_tasks",
           "task_seed"]

SCHEDULER_ENV = "MITSAR_DASK_SCHEDULER"
"""Environment variable naming the default scheduler (an address, ``local[:N]`` or ``inline``)."""

INLINE = "inline"
"""Scheduler name: run the tasks in this process, one after another (no Dask)."""

LOCAL = "local"
"""Scheduler name: a Dask LocalCluster on this machine (``local:N`` for N workers)."""

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
    """The scheduler to use: ``scheduler``, else ``$MITSAR_DASK_SCHEDULER``, else ``"local"``."""
    if scheduler is None or not str(scheduler).strip():
        scheduler = os.environ.get(SCHEDULER_ENV, "").strip() or LOCAL
    return str(scheduler).strip()


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
        :func:`resolve_scheduler`.
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
    # lazy: Dask's distributed scheduler is heavy and only needed for campaigns
    from distributed import Client, LocalCluster

    if "://" in scheduler or not scheduler.startswith(LOCAL):
        try:
            client = Client(scheduler, timeout="20s")
        except (OSError, TimeoutError) as error:
            raise MitsarError(f"campaign: cannot reach the Dask scheduler {scheduler!r} "
                              f"({error}); start it (dask scheduler) or pass --scheduler local"
                              ) from error
        with client:
            yield client
        return
    count = _local_workers(scheduler, workers)
    # One single-threaded process per worker: runs are CPU-bound NumPy / Dr.Jit work and the
    # nanny already pins OMP/MKL/OpenBLAS to one thread each.
    with LocalCluster(n_workers=count, threads_per_worker=1, processes=True,
                      dashboard_address=":0", silence_logs=logging.ERROR) as cluster, \
            Client(cluster) as client:
        yield client


def _call(function: Callable[..., Any], args: tuple) -> dict:
    """Run one task and wrap its outcome in a record (the error text when it raised)."""
    try:
        return {"status": "ok", "result": to_jsonable(function(*args))}
    except Exception as error:  # noqa: BLE001 - recorded, the campaign goes on
        return {"status": "failed", "error": f"{type(error).__name__}: {error}",
                "traceback": traceback.format_exc(limit=8)}


def run_tasks(function: Callable[..., Any], tasks: Sequence[Task], store: RecordStore, *,
              scheduler: str | None = None, workers: int | None = None, client: Any = None,
              progress: bool = True, desc: str = "campaign",
              on_record: Callable[[Task, dict], None] | None = None) -> dict[str, dict]:
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
        See :func:`dask_client`; ignored when ``client`` is given.
    client : distributed.Client, optional
        An existing client to submit to (e.g. one shared by several campaigns).
    progress : bool
        Show a progress bar (tqdm).
    desc : str
        Label of the progress bar.
    on_record : callable, optional
        Called with every new record (after the store kept it).

    Returns
    -------
    dict
        Record of every task, by key: ``status`` ("ok" or "failed"), ``result`` or ``error``
        and ``traceback``, ``key``, ``inputs``.

    Raises
    ------
    KeyboardInterrupt
        Passed on after cancelling what was still running; finished tasks stay recorded.
    """
    keys = [task.key for task in tasks]
    if len(set(keys)) != len(keys):
        raise ParameterError("run_tasks", "tasks", "unique keys", keys)
    stored = store.finished()
    records = {task.key: stored[task.key] for task in tasks if task.key in stored
               and stored[task.key].get("inputs", task.inputs) == task.inputs}
    todo = [task for task in tasks if task.key not in records]
    bar = tqdm(total=len(tasks), initial=len(tasks) - len(todo), disable=not progress,
               desc=desc, unit="run")

    def keep(task: Task, record: dict) -> None:
        record = {"key": task.key, "inputs": task.inputs, **record}
        store.add(task, record)
        records[task.key] = record
        if record["status"] != "ok":
            tqdm.write(f"{desc}: {task.key} failed: {record['error']}")
        if on_record is not None:
            on_record(task, record)
        bar.update(1)

    try:
        if todo and client is None and resolve_scheduler(scheduler) == INLINE:
            for task in todo:
                keep(task, _call(function, task.args))
        elif todo and client is not None:
            _run_on(client, function, todo, keep)
        elif todo:  # nothing left to do starts no cluster
            with dask_client(scheduler, workers) as own:
                _run_on(own, function, todo, keep)
    finally:
        bar.close()
    return records


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

