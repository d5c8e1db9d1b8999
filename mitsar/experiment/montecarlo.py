"""Monte Carlo over background realisations: impulse-response statistics per algorithm (paper
Tables 4-5).

For realisation ``i`` the experiment is simulated with seed ``first_seed + i`` (a new draw of the
fluctuating background, paper eq. 4), focused with every requested algorithm on the experiment's
grid, and the target's IRW, PSLR and ISLR are measured in range and azimuth
(:func:`mitsar.quality.impulse.measure_impulse_response`, at the target's position mapped onto the
image grid). The result is the mean and variance of every metric over the realisations.

Resumable runs: with ``out_dir`` every finished realisation is appended to
``out_dir/montecarlo.json`` (rewritten atomically: a temporary file replaced with
:func:`os.replace`, so an interrupted run never leaves a broken file), together with a
fingerprint of the configuration. A new run with ``resume=True`` skips the seeds already there
and refuses a file made with another configuration. The summary is written to
``out_dir/summary.nc`` and ``out_dir/summary.txt``.

The realisations are the tasks of a campaign (:mod:`mitsar.experiment.campaign`): by default in
this process or on a local Dask cluster, whichever the estimated cost favours
(:func:`estimate_run_seconds`, :func:`~mitsar.experiment.campaign.choose_scheduler`), or where
``scheduler`` says. A realisation that raises is recorded with its error (``errors`` in the
record, its metrics left out of the statistics) and is tried again by the next resumed run.

Cuts (paper Figs. 8-9, :func:`draw_cuts`): the nominal response and a few realisations are
simulated once each and focused by every algorithm; the figures' inputs are hashed into
``out_dir/cuts.json``, so a rerun with nothing new draws nothing.
"""

from __future__ import annotations

import dataclasses
import hashlib
import json
import math
import os
import sys
import warnings
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from tqdm.auto import tqdm

from mitsar.checks import integer
from mitsar.errors import MitsarError, ParameterError
from mitsar.experiment.campaign import (
    Task,
    announce,
    fingerprint,
    outputs_match,
    pending,
    record_outputs,
    run_tasks,
)
from mitsar.experiment.cost import FOCUS_SECONDS_PER_PIXEL_SWEEP as FOCUS_SECONDS_PER_PIXEL_SWEEP
from mitsar.experiment.cost import MEASURE_SECONDS as MEASURE_SECONDS
from mitsar.experiment.cost import SCENE_RUN_SECONDS as SCENE_RUN_SECONDS
from mitsar.experiment.cost import SIMULATE_SECONDS_PER_ECHO as SIMULATE_SECONDS_PER_ECHO
from mitsar.experiment.cost import estimate_run_seconds
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.options import ALGORITHMS, Experiment
from mitsar.experiment.paper import paper_table
from mitsar.lazy import LazyModule
from mitsar.version import __version__

# The stages a realisation runs, imported at its first use: a finished Monte Carlo run again
# (every realisation on disk) loads no focuser, simulator, measurement or Matplotlib
# (docs/reliability.md §7).
runs = LazyModule("mitsar.experiment.runs")
coverage = LazyModule("mitsar.experiment.coverage")
focus_grid = LazyModule("mitsar.focus.grid")
product_io = LazyModule("mitsar.io")
plots = LazyModule("mitsar.plots.figures")
impulse = LazyModule("mitsar.quality.impulse")

RECORD_FILE = "montecarlo.json"
SUMMARY_FILE = "summary.nc"
TABLE_FILE = "summary.txt"
DIRECTIONS = ("range", "azimuth")
METRICS = ("irw_cells", "pslr_db", "islr_db")
CUTS_RECORD = "cuts.json"


def _fingerprint(config: dict) -> str:
    text = json.dumps(config, sort_keys=True, default=str)
    return hashlib.sha256(text.encode()).hexdigest()[:16]


def _write_atomic(path: Path, data: dict) -> None:
    tmp = path.with_name(f".{path.name}.{os.getpid()}.tmp")
    tmp.write_text(json.dumps(data, indent=1) + "\n", encoding="utf-8")
    os.replace(tmp, path)


class _Record:
    """The campaign record store of a Monte Carlo run: ``montecarlo.json`` (module docstring),
    or memory only without an output folder."""

    def __init__(self, path: Path | None, fingerprint: str, config: dict,
                 records: list[dict], errors: dict[str, str]) -> None:
        self.path, self.fingerprint, self.config = path, fingerprint, config
        self.records, self.errors = records, errors

    def finished(self) -> dict[str, dict]:
        return {_key(r["seed"]): {"status": "ok", "result": r} for r in self.records}

    def add(self, task: Task, record: dict) -> None:
        seed = task.args[1]
        if record["status"] == "ok":
            self.records.append(record["result"])
            self.errors.pop(str(seed), None)
        else:
            self.errors[str(seed)] = record["error"]
        if self.path is not None:
            _write_atomic(self.path, {"fingerprint": self.fingerprint, "config": self.config,
                                      "records": self.records, "errors": self.errors})


def _key(seed: int) -> str:
    """Campaign key of the realisation with ``seed``."""
    return f"seed-{seed}"


def measure_realisation(experiment: Experiment, seed: int, algorithms: Sequence[str],
                        target: Sequence[float], islr_extent: str | float) -> dict[str, Any]:
    """Simulate one realisation (``seed``), focus it with each algorithm and measure the target.

    One whole run of a campaign (Monte Carlo and sweeps alike).

    Parameters
    ----------
    experiment : Experiment
        The experiment; its ``[simulation] seed`` is replaced by ``seed``.
    seed : int
        Seed of the realisation (background draw, noise).
    algorithms : sequence of str
        Focusing algorithms, each with the experiment's ``[focus]`` options.
    target : sequence of 3 floats
        World position of the measured target [m].
    islr_extent : str or float
        ISLR sidelobe extent.

    Returns
    -------
    dict
        ``seed``; ``metrics`` {algorithm: {"range_irw_cells", ..., "azimuth_islr_db",
        "peak_offset_m", "peak_db"}}; ``failures`` {algorithm: reason} for responses that could
        not be measured.
    """
    trial = dataclasses.replace(
        experiment, simulation=dataclasses.replace(experiment.simulation, seed=int(seed)))
    raw = runs.run_simulation(trial)
    entry: dict[str, Any] = {"seed": int(seed), "metrics": {}, "failures": {}}
    for algorithm in algorithms:
        options = dataclasses.replace(experiment.focus, algorithm=algorithm)
        image = runs.run_focus(raw, options)
        try:
            entry["metrics"][algorithm] = _measure(image, target, islr_extent)
        except ParameterError:
            # The target outside (or at the edge of) the image, or a bad extent: the same for
            # every realisation, so the campaign stops here rather than "measure" N failures.
            raise
        except (ValueError, MitsarError) as error:
            # A realisation whose response cannot be measured (e.g. clutter filling a
            # first null) is recorded as such, not retried forever on resume, and said.
            entry["failures"][algorithm] = str(error)
            tqdm.write(f"seed {seed} {algorithm}: not measurable: {error}")
    return entry


def _measure(image: xr.Dataset, target: Sequence[float], islr_extent: str | float) -> dict:
    where = focus_grid.equivalent_position(image, target)
    metrics = impulse.measure_impulse_response(image, where, islr_extent=islr_extent)
    out = {f"{d}_{m}": float(metrics[d][m]) for d in DIRECTIONS for m in METRICS}
    out["peak_offset_m"] = float(metrics["peak_offset_m"])
    out["peak_db"] = float(metrics["peak_db"])
    return out


def run(experiment: Any, realisations: int = 10,
        algorithms: Sequence[str] = ("bpa", "rda", "wda", "fsa"), *,
        first_seed: int | None = None, out_dir: str | os.PathLike | None = None,
        resume: bool = True, progress: bool = True, target: Sequence[float] | None = None,
        islr_extent: str | float | None = None, scheduler: str | None = None,
        workers: int | None = None, client: Any = None) -> xr.Dataset:
    """Monte Carlo over background realisations of an experiment (module docstring).

    Parameters
    ----------
    experiment : Experiment or path-like
        A :class:`mitsar.experiment.options.Experiment` or a TOML file; its ``[focus]``
        options (window, azimuth resolution, grid) are used for every algorithm, its
        ``[metrics]`` target and ISLR extent for the measurements.
    realisations : int
        Number of realisations N.
    algorithms : sequence of str
        Focusing algorithms to compare.
    first_seed : int, optional
        Seed of realisation 0 (default the experiment's ``[simulation] seed``); realisation i
        uses ``first_seed + i``.
    out_dir : path-like, optional
        Folder for the resumable record and the summary (created if needed).
    resume : bool
        Continue a run recorded in ``out_dir`` (False: start afresh, replacing it).
    progress : bool
        Say where the realisations run and what is written (stderr), with a progress bar.
    target : sequence of 3 floats, optional
        World position of the measured target (default: the experiment's).
    islr_extent : str or float, optional
        ISLR sidelobe extent (default: the experiment's, i.e. "paper" = +-5 cells).
    scheduler : str, optional
        Where the realisations run (:func:`mitsar.experiment.campaign.dask_client`): None
        (default: ``$MITSAR_DASK_SCHEDULER``, else "auto": this process or a local cluster by
        the estimated cost, :func:`estimate_run_seconds`), "inline" (this process),
        "local[:N]" or a Dask scheduler address. The numbers do not depend on it.
    workers : int, optional
        Workers of a local cluster (default: one per CPU core).
    client : distributed.Client, optional
        A Dask client to run on (overrides ``scheduler``).

    Returns
    -------
    xarray.Dataset
        ``value`` (realisation, algorithm, direction, metric): every measurement;
        ``mean``, ``variance`` (sample variance, ddof=1) and ``count`` (algorithm, direction,
        metric); ``peak_offset_m`` (realisation, algorithm); coordinate ``seed``
        (realisation). See :func:`format_table`.
    """
    plan = _plan(experiment, realisations, algorithms, first_seed, out_dir, resume, target,
                 islr_extent)
    experiment, algorithms, target = plan.experiment, plan.algorithms, plan.target
    todo = pending(plan.tasks, plan.store)
    if todo:  # a target outside the image is refused before the first realisation runs
        coverage.check_target_in_grid(experiment, target, algorithms, "montecarlo")
    if out_dir is not None:
        Path(out_dir).mkdir(parents=True, exist_ok=True)
    ran: list[str] = []
    run_tasks(measure_realisation, plan.tasks, plan.store, scheduler=scheduler, workers=workers,
              client=client, progress=progress, desc="montecarlo", what="realisations",
              task_seconds=estimate_run_seconds(experiment, algorithms) if todo else None,
              on_record=lambda task, _: ran.append(task.key))
    records = plan.records()
    summary = summarise(records, algorithms)
    summary.attrs.update(_summary_attrs(plan, records))
    if out_dir is not None:
        folder, files = Path(out_dir), [SUMMARY_FILE, TABLE_FILE]
        # what the files are made from; a rerun that ran nothing rewrites nothing (issue 27)
        outputs = fingerprint([summary.attrs, records])
        if not ran and outputs_match(folder, outputs, files):
            announce(progress, f"montecarlo: {folder / SUMMARY_FILE} and {TABLE_FILE} are up "
                               "to date, not rewritten")
            return summary
        announce(progress, f"montecarlo: table of {len(plan.seeds)} realisations -> "
                           f"{folder / SUMMARY_FILE}, {TABLE_FILE}")
        product_io.save(summary, folder / SUMMARY_FILE, overwrite=True)
        table = format_table(summary)
        tmp = folder / f".{TABLE_FILE}.{os.getpid()}.tmp"
        tmp.write_text(table + "\n", encoding="utf-8")
        os.replace(tmp, folder / TABLE_FILE)
        record_outputs(folder, outputs, files)
    return summary


def finished_table(experiment: Any, realisations: int = 10,
                   algorithms: Sequence[str] = ("bpa", "rda", "wda", "fsa"), *,
                   out_dir: str | os.PathLike, first_seed: int | None = None,
                   target: Sequence[float] | None = None, islr_extent: str | float | None = None,
                   progress: bool = True) -> str | None:
    """The table of a finished Monte Carlo whose files are up to date, or None.

    What :func:`run` with the same arguments (and ``resume=True``) would print through
    :func:`format_table` when it has nothing to run and nothing to rewrite: every realisation
    recorded in ``out_dir``, and ``summary.nc`` and ``summary.txt`` made from these records
    (``outputs.json``). Read from ``summary.txt``, without building the summary (xarray makes
    Dask import itself for any Dataset: ~0.35 CPU-s of a no-op rerun, docs/reliability.md §7).
    None when anything is left to run or write, or when no realisation was measured (then
    :func:`run` says why).

    Parameters
    ----------
    experiment, realisations, algorithms, out_dir, first_seed, target, islr_extent, progress
        As for :func:`run`.

    Raises
    ------
    ParameterError, MitsarError
        As :func:`run`, for arguments it would refuse.
    """
    plan = _plan(experiment, realisations, algorithms, first_seed, out_dir, True, target,
                 islr_extent)
    if pending(plan.tasks, plan.store):
        return None
    records = plan.records()
    if not any(metrics for r in records for metrics in r["metrics"].values()):
        return None
    folder, files = Path(out_dir), [SUMMARY_FILE, TABLE_FILE]
    if not outputs_match(folder, fingerprint([_summary_attrs(plan, records), records]), files):
        return None
    try:
        table = (folder / TABLE_FILE).read_text(encoding="utf-8").removesuffix("\n")
    except (OSError, UnicodeDecodeError):
        return None
    announce(progress, f"montecarlo: all {len(plan.seeds)} realisations already recorded, "
                       "nothing to run")  # as run_tasks and run say it
    announce(progress, f"montecarlo: {folder / SUMMARY_FILE} and {TABLE_FILE} are up to date, "
                       "not rewritten")
    return table


@dataclasses.dataclass
class _Plan:
    """A Monte Carlo's checked arguments, its record and its tasks (:func:`_plan`)."""

    experiment: Experiment
    algorithms: list[str]
    target: tuple[float, ...]
    islr_extent: str | float
    first_seed: int
    config_key: str
    seeds: list[int]
    store: _Record
    tasks: list[Task]

    def records(self) -> list[dict]:
        """One record per seed, in seed order; a realisation that failed as a whole stands
        as every algorithm's failure."""
        records = [r for r in self.store.records if r["seed"] in set(self.seeds)]
        for seed in self.seeds:
            if str(seed) in self.store.errors and seed not in {r["seed"] for r in records}:
                records.append({"seed": seed, "metrics": {}, "failures": {
                    algorithm: f"run failed: {self.store.errors[str(seed)]}"
                    for algorithm in self.algorithms}})
        by_seed = {r["seed"]: r for r in records}
        return [by_seed[s] for s in self.seeds]


def _plan(experiment: Any, realisations: int, algorithms: Sequence[str],
          first_seed: int | None, out_dir: str | os.PathLike | None, resume: bool,
          target: Sequence[float] | None, islr_extent: str | float | None) -> _Plan:
    """Check :func:`run`'s arguments and read its record (no simulation, no xarray object)."""
    if not isinstance(experiment, Experiment):
        experiment = load_experiment(experiment)
    realisations = integer("montecarlo", "realisations", realisations, 1)
    algorithms = list(algorithms)
    unknown = [a for a in algorithms if a not in ALGORITHMS]
    if not algorithms or unknown:
        raise ParameterError("montecarlo", "algorithms", f"a non-empty list of {ALGORITHMS}",
                             algorithms)
    if experiment.background is None:
        raise ParameterError("montecarlo", "experiment.background",
                             "a [background] table (realisations differ only by it)", None)
    target = experiment.metrics_target() if target is None else tuple(map(float, target))
    if target is None:
        raise ParameterError("montecarlo", "target", "a target position ([metrics] target or "
                             "a [[targets]] entry)", None)
    islr_extent = experiment.metrics.islr_extent if islr_extent is None else islr_extent
    first_seed = experiment.simulation.seed if first_seed is None else int(first_seed)
    config = {"experiment": experiment.config, "algorithms": algorithms,
              "first_seed": first_seed, "target": list(target), "islr_extent": islr_extent,
              "mitsar_version": __version__}
    config_key = _fingerprint({k: v for k, v in config.items() if k != "mitsar_version"})

    records: list[dict] = []
    errors: dict[str, str] = {}
    record_path = None
    if out_dir is not None:
        record_path = Path(out_dir) / RECORD_FILE
        if resume and record_path.exists():
            try:
                stored = json.loads(record_path.read_text(encoding="utf-8"))
            except (OSError, json.JSONDecodeError) as error:
                raise MitsarError(f"{record_path}: unreadable Monte Carlo record ({error}); "
                                  "remove it or pass resume=False") from error
            if stored.get("fingerprint") != config_key:
                raise MitsarError(f"{record_path}: recorded with another configuration "
                                  "(experiment, algorithms, seeds, target or ISLR extent); "
                                  "use another out_dir or resume=False to start afresh")
            records = list(stored.get("records", []))
            errors = dict(stored.get("errors", {}))
    store = _Record(record_path, config_key, config, records, errors)
    seeds = [first_seed + i for i in range(realisations)]
    tasks = [Task(_key(seed), (experiment, seed, algorithms, target, islr_extent))
             for seed in seeds]
    return _Plan(experiment, algorithms, target, islr_extent, first_seed, config_key, seeds,
                 store, tasks)


def _summary_attrs(plan: _Plan, records: Sequence[dict]) -> dict[str, Any]:
    """The attributes of the summary of ``records`` (:func:`run`)."""
    failures = {f"{record['seed']} {algorithm}": reason for record in records
                for algorithm, reason in record.get("failures", {}).items()}
    attrs = {"failures": json.dumps(failures), "product": "montecarlo",
             "fingerprint": plan.config_key, "islr_extent": str(plan.islr_extent),
             "first_seed": plan.first_seed, "mitsar_version": __version__,
             "experiment": json.dumps(plan.experiment.config)}
    if plan.experiment.background is not None:
        attrs["background_cell_rcs_db"] = float(plan.experiment.background.cell_rcs_db)
    return attrs


def summarise(records: Sequence[dict], algorithms: Sequence[str]) -> xr.Dataset:
    """Statistics of recorded realisations (see :func:`run` for the layout)."""
    values = np.full((len(records), len(algorithms), len(DIRECTIONS), len(METRICS)), np.nan)
    offsets = np.full((len(records), len(algorithms)), np.nan)
    for i, record in enumerate(records):
        for j, algorithm in enumerate(algorithms):
            metrics = record["metrics"].get(algorithm)
            if metrics is None:
                continue
            for k, direction in enumerate(DIRECTIONS):
                for m, metric in enumerate(METRICS):
                    values[i, j, k, m] = metrics[f"{direction}_{metric}"]
            offsets[i, j] = metrics["peak_offset_m"]
    count = np.sum(np.isfinite(values), axis=0)
    with np.errstate(invalid="ignore"), _quiet():
        mean = np.nanmean(values, axis=0)
        variance = np.where(count > 1, np.nanvar(values, axis=0, ddof=1), np.nan)
    dims = ("algorithm", "direction", "metric")
    return xr.Dataset(
        {"value": (("realisation",) + dims, values),
         "mean": (dims, mean), "variance": (dims, variance), "count": (dims, count),
         "peak_offset_m": (("realisation", "algorithm"), offsets, {"units": "m"})},
        coords={"realisation": np.arange(len(records)),
                "seed": ("realisation", np.array([r["seed"] for r in records], dtype=int)),
                "algorithm": list(algorithms), "direction": list(DIRECTIONS),
                "metric": list(METRICS)})


class _quiet:
    """Silence NumPy's mean-of-empty warnings (algorithms with no record yet)."""

    def __enter__(self) -> None:
        self._catch = warnings.catch_warnings()
        self._catch.__enter__()
        warnings.simplefilter("ignore", RuntimeWarning)

    def __exit__(self, *exc: object) -> None:
        self._catch.__exit__(*exc)


def format_table(summary: xr.Dataset) -> str:
    """The summary as a text table in the layout of paper Tables 4-5.

    One block per algorithm, first row range, second azimuth; columns IRW (cells), PSLR (dB),
    ISLR (dB), each mean and variance. For a -20 or -10 dB background the paper's Table 4 or 5
    (:mod:`mitsar.experiment.paper`) follows in the same layout.
    """
    lines = [f"{'':6s}{'':8s}{'IRW (cells)':>22s}{'PSLR (dB)':>22s}{'ISLR (dB)':>22s}",
             f"{'':14s}" + "".join(f"{'mean':>11s}{'var':>11s}" for _ in METRICS)]
    for algorithm in summary["algorithm"].values:
        for direction in DIRECTIONS:
            cells = []
            for metric in METRICS:
                mean = float(summary["mean"].sel(algorithm=algorithm, direction=direction,
                                                 metric=metric))
                var = float(summary["variance"].sel(algorithm=algorithm, direction=direction,
                                                    metric=metric))
                cells.append(f"{mean:11.3f}" + (f"{var:11.3f}" if math.isfinite(var)
                                                 else f"{'-':>11s}"))
            name = str(algorithm).upper() if direction == "range" else ""
            lines.append(f"{name:6s}{direction:8s}" + "".join(cells))
    paper = paper_table(summary.attrs.get("background_cell_rcs_db"))
    if paper is not None:
        number = 4 if summary.attrs["background_cell_rcs_db"] == -20.0 else 5
        lines.append(f"paper Table {number} "
                     f"({summary.attrs['background_cell_rcs_db']:g} dB background):")
        for algorithm in summary["algorithm"].values:
            if str(algorithm) not in paper:
                continue
            for direction in DIRECTIONS:
                cells = "".join(f"{paper[str(algorithm)][direction][metric][0]:11.3f}"
                                f"{paper[str(algorithm)][direction][metric][1]:11.3f}"
                                for metric in METRICS)
                name = str(algorithm).upper() if direction == "range" else ""
                lines.append(f"{name:6s}{direction:8s}" + cells)
    total = int(summary.sizes["realisation"])
    measured = int(summary["count"].min())
    missing = f"; {total - measured} not measurable, left out" if measured < total else ""
    lines.append(f"({total} realisations, seeds "
                 f"{int(summary['seed'].min())}..{int(summary['seed'].max())}{missing})")
    failures = json.loads(summary.attrs.get("failures", "{}"))
    if failures:
        lines.append("not measurable (seed algorithm: reason):")
        lines.extend(f"  {key}: {reason}" for key, reason in failures.items())
    return "\n".join(lines)


def run_montecarlo(experiment_path: str | os.PathLike, realisations: int,
                   algorithms: Sequence[str], out_dir: str | os.PathLike,
                   resume: bool = True) -> xr.Dataset:
    """CLI entry point: :func:`run` on a TOML experiment, recording into ``out_dir``.

    Writes ``out_dir/montecarlo.json`` (resumable record), ``out_dir/summary.nc`` and
    ``out_dir/summary.txt`` (:func:`format_table`); returns the summary.
    """
    return run(experiment_path, realisations, algorithms, out_dir=out_dir, resume=resume)


def realisation_cuts(experiment: Any, algorithm: str = "bpa", realisations: int = 5,
                     first_seed: int | None = None) -> dict[str, Any]:
    """Range and azimuth cuts through the target for a few realisations and the nominal case.

    The nominal response is the experiment without its background (absorbing background);
    each realisation is the experiment with seed ``first_seed + i`` (paper Figs. 8-9). For
    several algorithms, :func:`realisations_cuts` simulates each realisation once.

    Returns
    -------
    dict
        ``range_offset`` and ``azimuth_offset`` [m] axes; ``nominal`` and ``realisations``
        (list) of dicts with ``range`` and ``azimuth`` cuts in dB relative to the nominal peak;
        ``seeds``.
    """
    return realisations_cuts(experiment, [algorithm], realisations, first_seed,
                             progress=False)[algorithm]


def realisations_cuts(experiment: Any, algorithms: Sequence[str], realisations: int = 5,
                      first_seed: int | None = None, progress: bool = True
                      ) -> dict[str, dict[str, Any]]:
    """:func:`realisation_cuts` for several algorithms, each realisation simulated once.

    The nominal case and the ``realisations`` seeds are simulated one after another and each
    raw product is focused by every algorithm (the simulation is most of the cost: 5
    algorithms used to simulate every realisation 5 times).

    Parameters
    ----------
    experiment : Experiment or path-like
    algorithms : sequence of str
    realisations : int
        Realisations drawn (seeds ``first_seed + i``).
    first_seed : int, optional
        Default the experiment's ``[simulation] seed``.
    progress : bool
        A progress bar on stderr, one step a simulation.

    Returns
    -------
    dict
        :func:`realisation_cuts`'s dict, by algorithm.
    """
    if not isinstance(experiment, Experiment):
        experiment = load_experiment(experiment)
    target = experiment.metrics_target()
    if target is None:
        raise ParameterError("montecarlo", "target", "a [metrics] target or a [[targets]] entry",
                             None)
    first_seed = experiment.simulation.seed if first_seed is None else int(first_seed)
    options = {a: dataclasses.replace(experiment.focus, algorithm=a) for a in algorithms}

    def cuts(raw: xr.Dataset, algorithm: str) -> tuple[dict, xr.Dataset]:
        image = runs.run_focus(raw, options[algorithm])
        if image.attrs.get("grid_kind") != "slant":
            raise ParameterError("montecarlo", "focus.grid.kind", "a slant grid for the cuts",
                                 image.attrs.get("grid_kind"))
        where = focus_grid.equivalent_position(image, target)
        distance = np.linalg.norm(image["position"].values - where, axis=-1)
        row, col = np.unravel_index(np.argmin(distance), distance.shape)
        magnitude = np.abs(image["image"].values)
        return {"range": magnitude[row, :], "azimuth": magnitude[:, col]}, image

    seeds = [first_seed + i for i in range(realisations)]
    trials = [dataclasses.replace(experiment, background=None)] + [
        dataclasses.replace(experiment, simulation=dataclasses.replace(experiment.simulation,
                                                                       seed=seed))
        for seed in seeds]
    drawn: dict[str, list[tuple[dict, xr.Dataset]]] = {a: [] for a in algorithms}
    for trial in tqdm(trials, desc="cuts", unit="simulation", disable=not progress,
                      file=sys.stderr):
        raw = runs.run_simulation(trial)
        for algorithm in algorithms:
            drawn[algorithm].append(cuts(raw, algorithm))
    out = {}
    for algorithm in algorithms:
        (nominal, image), *rest = drawn[algorithm]
        peak = max(nominal["range"].max(), 1e-300)
        azimuth = image["azimuth"].values
        range_ = image["range"].values
        row_axis = azimuth - azimuth[np.argmax(nominal["azimuth"])]
        col_axis = range_ - range_[np.argmax(nominal["range"])]

        def decibel(cut: dict, peak: float = peak) -> dict:
            return {k: 20 * np.log10(np.maximum(v, 1e-300) / peak) for k, v in cut.items()}

        out[algorithm] = {"range_offset": col_axis, "azimuth_offset": row_axis,
                          "nominal": decibel(nominal),
                          "realisations": [decibel(c) for c, _ in rest], "seeds": seeds,
                          "algorithm": algorithm}
    return out


def draw_cuts(experiment: Experiment, algorithms: Sequence[str], realisations: int,
              out_dir: str | os.PathLike, progress: bool = True) -> list[Path]:
    """Draw ``out_dir/cuts_ALGORITHM.png`` for every algorithm, unless already drawn.

    The figures' inputs (the experiment, algorithms, realisations, mitsar version) are hashed
    into ``out_dir/cuts.json``; when the hash matches and every figure is there nothing is
    simulated (a rerun of a finished Monte Carlo). Else the cuts are computed
    (:func:`realisations_cuts`, announced on stderr with a progress bar) and the figures
    written (a progress bar of their own).

    Returns
    -------
    list of Path
        The figures, one per algorithm.
    """
    folder = Path(out_dir)
    figures = [folder / f"cuts_{algorithm}.png" for algorithm in algorithms]
    key = fingerprint([experiment.config, list(algorithms), int(realisations), __version__])
    record = folder / CUTS_RECORD
    try:
        stored = json.loads(record.read_text(encoding="utf-8")).get("fingerprint")
    except (OSError, ValueError, AttributeError):
        stored = None
    if stored == key and all(f.is_file() for f in figures):
        announce(progress, f"cuts: {len(figures)} figures up to date in {folder}, not redrawn")
        return figures
    announce(progress, f"cuts: drawing {len(figures)} figures of {realisations} realisations "
                       f"and the nominal response ({realisations + 1} simulations, each "
                       f"focused by {len(algorithms)} algorithms; --cuts 0 skips them)...")
    cuts = realisations_cuts(experiment, algorithms, realisations, progress=progress)
    for algorithm, figure in zip(tqdm(algorithms, desc="figures", unit="figure",
                                      disable=not progress, file=sys.stderr), figures,
                                 strict=True):
        plot_realisation_cuts(cuts[algorithm], figure, overwrite=True)
    _write_atomic(record, {"fingerprint": key, "figures": [f.name for f in figures]})
    return figures


def plot_realisation_cuts(cuts: dict[str, Any], path: str | os.PathLike,
                          overwrite: bool = False) -> Path:
    """Figure like paper Figs. 8-9: cuts of several realisations over the nominal response."""
    figure, axes = plots.pyplot().subplots(1, 2, figsize=(11, 4), constrained_layout=True)
    for ax, direction in zip(axes, DIRECTIONS, strict=True):
        offset = cuts[f"{direction}_offset"]
        for seed, cut in zip(cuts["seeds"], cuts["realisations"], strict=True):
            ax.plot(offset, cut[direction], lw=0.8, alpha=0.8, label=f"seed {seed}")
        ax.plot(offset, cuts["nominal"][direction], "k", lw=1.8, label="nominal (absorbing)")
        ax.set(xlabel=f"{direction} offset [m]", ylabel="dB (nominal peak = 0)",
               title=f"{cuts['algorithm'].upper()}: {direction} cut", ylim=(-45, 3),
               xlim=(max(offset.min(), -1.0), min(offset.max(), 1.0)))
        ax.grid(alpha=0.3)
    axes[0].legend(fontsize=7)
    return plots.save_figure(figure, path, overwrite=overwrite)
