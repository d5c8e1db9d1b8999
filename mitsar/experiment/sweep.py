"""Parameter sweeps: the Cartesian product of variations of an experiment, one tidy table.

``--vary KEY=a:b:step`` (inclusive arithmetic range) or ``--vary KEY=v1,v2,...`` (TOML values)
over any experiment key (the same dotted keys as ``--set``,
:func:`mitsar.experiment.loading.apply_overrides`). Every point of the product of the variations
is an experiment; each is simulated ``realisations`` times, focused with each algorithm and
measured (IRW, PSLR, ISLR in range and azimuth; :func:`mitsar.experiment.montecarlo.
measure_realisation`), as the tasks of a campaign (:mod:`mitsar.experiment.campaign`, on Dask).
Realisation r of point i uses the seed :func:`~mitsar.experiment.campaign.task_seed`
(campaign seed, i, r), recorded in the table.

The table is an :class:`xarray.Dataset` with one dimension per varied key (named by the key),
then ``realisation`` and ``algorithm``; it is written as ``sweep.nc`` and, one row per run and
algorithm, ``sweep.csv``, with one figure per metric in ``figures/`` (docs/experiments.md
§Campaigns). The hash of what these outputs were made from (every task's key, inputs and status,
and the sweep's arguments) is written last, to ``outputs.json``: a rerun that finds every run
recorded and that hash unchanged rewrites nothing (a no-op rerun), and says so.

Stages above this one add their own measurements of every point without being imported here
(imports run down, docs/design.md §3): a :class:`PointMeasure` names a module-level function of
the point's document, and its quantities become further variables of the same table, with the
dimension the measure names (e.g. ``trajectory`` for the ambiguity fractions of
:mod:`mitsar.ambiguity.sweep`). ``images=False`` sweeps a file that is not an experiment (an
ambiguity file) with its measures only.
"""

from __future__ import annotations

import copy
import itertools
import json
import math
import os
import sys
import tomllib
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from tqdm.auto import tqdm

from mitsar.checks import integer
from mitsar.errors import ParameterError
from mitsar.experiment.campaign import (
    PointFolder,
    Task,
    announce,
    fingerprint,
    outputs_match,
    record_outputs,
    run_tasks,
    task_seed,
)
from mitsar.experiment.loading import apply_overrides, experiment_from_dict, read_toml
from mitsar.experiment.montecarlo import (
    DIRECTIONS,
    METRICS,
    estimate_run_seconds,
    measure_realisation,
)
from mitsar.experiment.options import ALGORITHMS
from mitsar.io import atomic_writer, save
from mitsar.plots.figures import pyplot, save_figure
from mitsar.plots.labels import key_label, quantity_label
from mitsar.version import __version__

__all__ = ["PointMeasure", "Variation", "measure_table", "parse_variation", "run_sweep",
           "sweep_points", "sweep_table"]

TABLE_FILE = "sweep.nc"
CSV_FILE = "sweep.csv"
FIGURES_FOLDER = "figures"
QUANTITIES = tuple(f"{d}_{m}" for d in DIRECTIONS for m in METRICS) + ("peak_offset_m",
                                                                         "peak_db")
"""Measured quantities, one table variable each (dims: varied keys, realisation, algorithm)."""

MAX_POINTS = 100_000
"""Largest sweep accepted (points x realisations)."""


@dataclass(frozen=True)
class Variation:
    """One varied experiment key and its values.

    Attributes
    ----------
    key : str
        Dotted experiment key (``look.off_nadir_deg``).
    values : tuple
        Values in order (numbers, strings, booleans or lists, as TOML gives them).
    """

    key: str
    values: tuple


@dataclass(frozen=True)
class PointMeasure:
    """A measurement of every sweep point, supplied by a stage above the experiment's.

    Attributes
    ----------
    name : str
        Name of the measure (letters, digits, ``_``): record keys ``pNNNNN-NAME``, the CSV
        ``sweep_NAME.csv`` and the error variable ``NAME_error``.
    measure : callable
        ``measure(document, source) -> {label: {quantity: value}}``: the point's TOML
        document (variations applied) and the absolute path of the swept file (relative
        paths resolve against its folder). Module level (Dask sends it by reference);
        deterministic, as its record is reused when the point's inputs hash matches.
    check : callable
        ``check(document, source, where)``: raises :class:`~mitsar.errors.ParameterError`
        naming the key when the point's document is invalid (called before anything runs).
    label : str
        Name of the dimension of the labels (e.g. ``trajectory``).
    quantities : tuple of str
        The measured quantities, one table variable each (dims: varied keys, ``label``).
    units : str
        Units of the quantities.
    seconds : float, optional
        Rough cost of one measurement [s], for the choice of scheduler
        (:func:`~mitsar.experiment.campaign.choose_scheduler`; None: unknown).
    """

    name: str
    measure: Callable[[dict, str], dict[str, dict[str, float]]]
    check: Callable[[dict, str, str], None]
    label: str
    quantities: tuple[str, ...]
    units: str = "1"
    seconds: float | None = None


def _toml_value(text: str) -> Any:
    """A TOML value, or the text itself when it is not one (as ``--set`` reads values)."""
    try:
        return tomllib.loads(f"value = {text.strip()}")["value"]
    except tomllib.TOMLDecodeError:
        return text.strip()


def parse_variation(text: str) -> Variation:
    """Read ``KEY=a:b:step`` or ``KEY=v1,v2,...`` (the CLI's ``--vary``).

    ``a:b:step`` is the arithmetic range a, a + step, ... up to b inclusive (within 1e-9 of a
    step), e.g. ``40:70:5`` gives 40, 45, ..., 70; a list holds TOML values, a value that is not
    one being taken as text (``focus.algorithm=bpa,wda``).

    Raises
    ------
    ParameterError
        Naming the key: no ``=``, an empty key or value, a range with a step of the wrong sign
        or zero, or with more than :data:`MAX_POINTS` values.
    """
    key, sep, spec = text.partition("=")
    key = key.strip()
    if not sep or not key or not all(p.strip() for p in key.split(".")) or not spec.strip():
        raise ParameterError("--vary", text, "KEY=START:STOP:STEP or KEY=V1,V2,... with a "
                             "dotted experiment key, e.g. look.off_nadir_deg=40:70:5", text)
    parts = spec.split(":")
    if len(parts) == 3 and "," not in spec:
        numbers = [_toml_value(p) for p in parts]
        if not all(isinstance(n, int | float) and not isinstance(n, bool) for n in numbers):
            raise ParameterError("--vary", key, "START:STOP:STEP of numbers", spec)
        start, stop, step = numbers
        if step == 0 or (stop - start) * step < 0:
            raise ParameterError("--vary", key, f"a step that leads from {start} to {stop} "
                                 "(non-zero, same sign as STOP - START)", step)
        count = int(math.floor((stop - start) / step + 1e-9)) + 1
        if count > MAX_POINTS:
            raise ParameterError("--vary", key, f"at most {MAX_POINTS} values", count)
        exact = all(isinstance(n, int) for n in numbers)
        values = tuple(start + i * step if exact else float(round(start + i * step, 12))
                       for i in range(count))
        return Variation(key, values)
    values = tuple(_toml_value(v) for v in spec.split(","))
    if any(v == "" for v in values):
        raise ParameterError("--vary", key, "a comma-separated list without empty values", spec)
    return Variation(key, values)


def _override(key: str, value: Any) -> str:
    """``key=value`` with the value written as TOML (read back by ``apply_overrides``)."""
    if isinstance(value, bool):
        text = "true" if value else "false"
    elif isinstance(value, str | list):
        text = json.dumps(value)
    else:
        text = repr(value)
    return f"{key}={text}"


def sweep_points(variations: Sequence[Variation]) -> list[dict[str, Any]]:
    """The Cartesian product of the variations, first key slowest: [{key: value, ...}, ...]."""
    keys = [v.key for v in variations]
    if len(set(keys)) != len(keys):
        raise ParameterError("--vary", "keys", "each key varied once", keys)
    return [dict(zip(keys, combo, strict=True))
            for combo in itertools.product(*(v.values for v in variations))]


def _sweep_run(document: dict, source: str | None, seed: int, algorithms: Sequence[str]
               ) -> dict[str, Any]:
    """One task of a sweep (module level, so Dask sends it by reference): validate the point's
    experiment and run :func:`measure_realisation` on it."""
    experiment = experiment_from_dict(document, source=source)
    return measure_realisation(experiment, seed, algorithms, experiment.metrics_target(),
                               experiment.metrics.islr_extent)


def _sweep_task(measure: Callable[..., Any] | None, *args: Any) -> Any:
    """One task of a sweep: a run (``measure`` None, :func:`_sweep_run`) or a point measure."""
    return _sweep_run(*args) if measure is None else measure(*args)


def run_sweep(experiment_path: str | os.PathLike, variations: Sequence[Variation | str],
              out_dir: str | os.PathLike, *, realisations: int = 1,
              algorithms: Sequence[str] | None = None, seed: int | None = None,
              overrides: Sequence[str] = (), scheduler: str | None = None,
              workers: int | None = None, client: Any = None, restart: bool = False,
              progress: bool = True, figures: bool = True,
              measures: Sequence[PointMeasure] = (), images: bool = True,
              table: bool = True) -> xr.Dataset | None:
    """Run a sweep of an experiment file (module docstring) into ``out_dir``.

    Parameters
    ----------
    experiment_path : path-like
        The TOML experiment.
    variations : sequence of Variation or str
        The varied keys (strings as for :func:`parse_variation`).
    out_dir : path-like
        Folder of the records (``points/``), the table (``sweep.nc``, ``sweep.csv``) and the
        figures; created if needed.
    realisations : int
        Simulations of every point (seeds :func:`~mitsar.experiment.campaign.task_seed`).
    algorithms : sequence of str, optional
        Focusing algorithms (default: the experiment's ``[focus] algorithm``).
    seed : int, optional
        Campaign seed (default: the experiment's ``[simulation] seed``).
    overrides : sequence of str
        ``--set`` changes applied to every point before the variations.
    scheduler, workers, client
        Where the runs go (:func:`mitsar.experiment.campaign.run_tasks`); default
        ``$MITSAR_DASK_SCHEDULER``, else "auto": this process or a local cluster, by the
        estimated cost (:func:`~mitsar.experiment.montecarlo.estimate_run_seconds`).
    restart : bool
        Forget the records of an earlier run in ``out_dir`` (default: finished points are
        reused, a rerun computes only the missing ones).
    progress, figures : bool
        Phases and progress bars on stderr; figures of each metric against the varied keys.
    measures : sequence of PointMeasure
        Further measurements of every point (one task per point and measure), their
        quantities added to the table (:func:`measure_table`) and written to
        ``sweep_NAME.csv``.
    images : bool
        Simulate, focus and measure images (the file is an experiment). False: the file is
        swept with ``measures`` only (e.g. an ambiguity file), ``realisations`` must be 1.

    table : bool
        Return the table. False: return None when the outputs are up to date (a no-op rerun,
        which the command line reports by its counts: making an xarray table imports Dask,
        a third of such a rerun's time).

    Returns
    -------
    xarray.Dataset or None
        The table (:func:`sweep_table` merged with a :func:`measure_table` per measure); None
        for a no-op rerun with ``table=False``.

    Raises
    ------
    ParameterError
        For a bad variation or a point whose experiment is invalid (names the key and value).
    """
    path = Path(experiment_path)
    variations = [v if isinstance(v, Variation) else parse_variation(v) for v in variations]
    if not variations:
        raise ParameterError("sweep", "--vary", "at least one KEY=VALUES variation", [])
    realisations = integer("sweep", "realisations", realisations, 1)
    base = apply_overrides(read_toml(path), overrides, str(path))
    source = str(path.resolve())
    if images:
        nominal = experiment_from_dict(base, source=path)
        config = nominal.config
        algorithms = [nominal.focus.algorithm] if algorithms is None else list(algorithms)
        unknown = [a for a in algorithms if a not in ALGORITHMS]
        if not algorithms or unknown:
            raise ParameterError("sweep", "algorithms", f"a non-empty list of {ALGORITHMS}",
                                 algorithms)
        seed = nominal.simulation.seed if seed is None else integer("sweep", "seed", seed, 0)
    else:
        if not measures:
            raise ParameterError("sweep", "measures", "at least one measure when images are "
                                 "not simulated (e.g. --ambiguity)", [])
        if realisations != 1:
            raise ParameterError("sweep", "realisations", "1 (nothing random is simulated "
                                 "without images; drop -n)", realisations)
        config, algorithms = base, []
        seed = 0 if seed is None else integer("sweep", "seed", seed, 0)
    names = [m.name for m in measures]
    if len(set(names)) != len(names):
        raise ParameterError("sweep", "measures", "measures with distinct names", names)
    points = sweep_points(variations)
    if len(points) * realisations > MAX_POINTS:
        raise ParameterError("sweep", "--vary", f"at most {MAX_POINTS} runs",
                             len(points) * realisations)
    tasks, extra = [], {m.name: [] for m in measures}
    for index, point in enumerate(points):
        where = f"{path} --vary " + " ".join(f"{k}={v}" for k, v in point.items())
        document = apply_overrides(copy.deepcopy(base),
                                   [_override(k, v) for k, v in point.items()], where)
        if images:
            experiment = experiment_from_dict(document, source=where)  # errors name the key
            if experiment.metrics_target() is None:
                raise ParameterError(where, "metrics.target", "a target to measure ([metrics] "
                                     "target or a [[targets]] entry)", None)
        for measure in measures:
            measure.check(document, source, where)
            extra[measure.name].append(Task(
                f"p{index:05d}-{measure.name}", (measure.measure, document, source),
                fingerprint([document, measure.name, measure.quantities, __version__])))
        for realisation in range(realisations if images else 0):
            run_seed = task_seed(seed, index, realisation)
            args = (None, document, source, run_seed, algorithms)
            tasks.append(Task(f"p{index:05d}-r{realisation:03d}", args,
                              fingerprint([document, run_seed, algorithms, __version__])))
    every = tasks + [t for m in measures for t in extra[m.name]]
    announce(progress, f"sweep: {len(points)} points validated, {len(every)} tasks "
                       f"({len(tasks)} runs" + "".join(f", {len(extra[m.name])} {m.name}"
                                                        for m in measures) + ")")
    costs = ([estimate_run_seconds(nominal, algorithms)] * len(tasks) if images else []) + [
        m.seconds for m in measures for _ in extra[m.name]]
    known = [c for c in costs if c is not None]
    store = PointFolder(Path(out_dir), restart=restart)
    ran: list[str] = []
    records = run_tasks(_sweep_task, every, store, scheduler=scheduler, workers=workers,
                        client=client, progress=progress, desc="sweep",
                        task_seconds=sum(known) / len(known) if known else None,
                        on_record=lambda task, _: ran.append(task.key))
    out = Path(out_dir)
    outputs = fingerprint([[(t.key, t.inputs, (records.get(t.key) or {}).get("status"))
                            for t in every], [v.key for v in variations], realisations,
                           algorithms, names, images, figures, seed, source, list(overrides),
                           __version__])
    expected = [TABLE_FILE] + ([CSV_FILE] if images else []) + [
        f"sweep_{m.name}.csv" for m in measures]
    drawn = ([f"{FIGURES_FOLDER}/{q}.png" for q in QUANTITIES[:-1]] if images else []) + [
        f"{FIGURES_FOLDER}/{q}.png" for m in measures for q in m.quantities]
    up_to_date = not ran and outputs_match(out, outputs, expected + (drawn if figures else []))
    if up_to_date and not table:
        failed = sum((records.get(t.key) or {}).get("status") != "ok" for t in every)
        announce(progress, f"sweep: {out / TABLE_FILE}, its CSV and figures are up to date "
                           f"({len(every)} runs, {failed} failed), not rewritten")
        return None
    parts = [sweep_table(variations, realisations, algorithms,
                         [records.get(t.key) for t in tasks], [t.args[3] for t in tasks])
             ] if images else []
    parts += [measure_table(variations, m, [records.get(t.key) for t in extra[m.name]])
              for m in measures]
    table = xr.merge(parts, combine_attrs="override")
    failed = sum(int(np.sum(p[e].values != "")) for p in parts
                 for e in ("error", *(f"{m.name}_error" for m in measures)) if e in p)
    table.attrs.update(product="sweep", varied=json.dumps([v.key for v in variations]),
                       runs=len(tasks) + sum(len(t) for t in extra.values()),
                       failed_runs=failed, measures=json.dumps(names), images=int(images),
                       campaign_seed=seed, experiment_source=source,
                       overrides=json.dumps(list(overrides)), mitsar_version=__version__,
                       experiment=json.dumps(config))
    if up_to_date:
        announce(progress, f"sweep: {out / TABLE_FILE}, its CSV and figures are up to date, "
                           "not rewritten")
        return table
    announce(progress, f"sweep: table -> {out / TABLE_FILE}, " + ", ".join(expected[1:]))
    save(table, out / TABLE_FILE, overwrite=True)
    csvs: dict[str, str] = {}
    if images:
        frame = table[list(QUANTITIES) + ["failure"]].to_dataframe().reset_index()
        frame = frame.merge(table[["seed", "error"]].to_dataframe().reset_index())
        csvs[CSV_FILE] = frame.to_csv(index=False)
    for m in measures:
        frame = table[list(m.quantities)].to_dataframe().reset_index().merge(
            table[[f"{m.name}_error"]].to_dataframe().reset_index())
        csvs[f"sweep_{m.name}.csv"] = frame.to_csv(index=False)
    for name, csv in csvs.items():
        atomic_writer(out / name, True,
                      lambda tmp, csv=csv: tmp.write_text(csv, encoding="utf-8"))
    if figures:
        announce(progress, f"sweep: drawing {len(drawn)} figures -> {out / FIGURES_FOLDER}...")
        with tqdm(total=len(drawn), desc="figures", unit="figure", disable=not progress,
                  file=sys.stderr) as bar:
            if images:
                plot_sweep(table, out / FIGURES_FOLDER, bar=bar)
            for m in measures:
                plot_measure(table, m, out / FIGURES_FOLDER, bar=bar)
    record_outputs(out, outputs, expected + (drawn if figures else []))
    return table


def measure_table(variations: Sequence[Variation], measure: PointMeasure,
                  records: Sequence[dict | None]) -> xr.Dataset:
    """The variables of one :class:`PointMeasure` from its records (in point order).

    Returns
    -------
    xarray.Dataset
        Dims: the varied keys, then ``measure.label`` (the labels in order of first
        appearance). A variable per quantity (NaN where not measured: a failed point, or a
        label that point does not have) and ``NAME_error`` (the error text, "" when it ran).
    """
    shape = tuple(len(v.values) for v in variations)
    results = [r["result"] if r is not None and r.get("status") == "ok" else None
               for r in records]
    labels = list(dict.fromkeys(label for r in results if r for label in r))
    values = np.full((len(records), len(labels), len(measure.quantities)), np.nan)
    error = np.array([("not run" if r is None else r.get("error", "failed"))
                      if res is None else "" for r, res in zip(records, results, strict=True)],
                     dtype=object)
    for i, result in enumerate(results):
        for j, label in enumerate(labels):
            got = (result or {}).get(label, {})
            values[i, j] = [np.nan if got.get(q) is None else got[q] for q in measure.quantities]
    dims = tuple(v.key for v in variations)
    data = {q: (dims + (measure.label,), values[..., k].reshape(shape + (len(labels),)),
                {"units": measure.units, "measure": measure.name})
            for k, q in enumerate(measure.quantities)}
    data[f"{measure.name}_error"] = (dims, error.astype(str).reshape(shape))
    coords = {v.key: list(v.values) if not any(isinstance(x, list) for x in v.values)
              else [json.dumps(x) for x in v.values] for v in variations}
    coords[measure.label] = labels
    return xr.Dataset(data, coords=coords)


def sweep_table(variations: Sequence[Variation], realisations: int, algorithms: Sequence[str],
                records: Sequence[dict | None], seeds: Sequence[int]) -> xr.Dataset:
    """The tidy table of a sweep from its task records (in task order: points, realisations).

    Returns
    -------
    xarray.Dataset
        Dims: the varied keys (coordinates: their values), ``realisation``, ``algorithm``.
        Variables :data:`QUANTITIES` (NaN where not measured), ``seed`` and ``error`` (the run's
        error text, "" when it ran), ``failure`` (why an algorithm's response was not
        measurable, "" when it was).
    """
    shape = tuple(len(v.values) for v in variations) + (realisations,)
    count = int(np.prod(shape))
    values = np.full((count, len(algorithms), len(QUANTITIES)), np.nan)
    failure = np.full((count, len(algorithms)), "", dtype=object)
    error = np.full(count, "", dtype=object)
    for i, record in enumerate(records):
        if record is None or record.get("status") != "ok":
            error[i] = "not run" if record is None else record.get("error", "failed")
            continue
        result = record["result"]
        for j, algorithm in enumerate(algorithms):
            metrics = result["metrics"].get(algorithm)
            if metrics is None:
                failure[i, j] = result.get("failures", {}).get(algorithm, "not measured")
                continue
            values[i, j] = [np.nan if metrics.get(q) is None else metrics[q] for q in QUANTITIES]
    dims = tuple(v.key for v in variations) + ("realisation",)
    units = {"irw_cells": "cells", "pslr_db": "dB", "islr_db": "dB", "peak_offset_m": "m",
             "peak_db": "dB"}
    data = {q: (dims + ("algorithm",), values[..., k].reshape(shape + (len(algorithms),)),
                {"units": next(u for s, u in units.items() if q.endswith(s))})
            for k, q in enumerate(QUANTITIES)}
    data["seed"] = (dims, np.asarray(seeds, dtype=np.int64).reshape(shape))
    data["error"] = (dims, error.astype(str).reshape(shape))
    data["failure"] = (dims + ("algorithm",),
                       failure.astype(str).reshape(shape + (len(algorithms),)))
    coords = {v.key: list(v.values) if not any(isinstance(x, list) for x in v.values)
              else [json.dumps(x) for x in v.values] for v in variations}
    coords.update(realisation=np.arange(realisations), algorithm=list(algorithms))
    table = xr.Dataset(data, coords=coords)
    table.attrs.update(product="sweep", varied=json.dumps([v.key for v in variations]),
                       runs=count, failed_runs=int(np.sum(error != "")))
    return table


def plot_measure(table: xr.Dataset, measure: PointMeasure, folder: Path,
                 overwrite: bool = True, bar: Any = None) -> list[Path]:
    """One figure per quantity of a measure against the first varied key, a line per label
    (and combination of the other varied keys; at most 8 lines); ``bar`` (a tqdm bar) is
    advanced by one a figure."""
    folder.mkdir(parents=True, exist_ok=True)
    keys = json.loads(table.attrs["varied"])
    first, others = keys[0], keys[1:]
    x = table[first].values
    numeric = np.issubdtype(x.dtype, np.number)
    combos = list(itertools.product(table[measure.label].values,
                                    *(range(table.sizes[k]) for k in others)))[:8]
    written = []
    for quantity in measure.quantities:
        figure, ax = pyplot().subplots(figsize=(5.5, 3.6), constrained_layout=True)
        for label, *combo in combos:
            cut = table[quantity].sel({measure.label: label}).isel(
                dict(zip(others, combo, strict=True)))
            text = ", ".join([str(label)] + [f"{k}={table[k].values[i]}"
                                             for k, i in zip(others, combo, strict=True)])
            ax.plot(x if numeric else np.arange(len(x)), cut.values, marker="o", label=text)
        if not numeric:
            ax.set_xticks(np.arange(len(x)), [str(v) for v in x])
        ax.set(xlabel=key_label(first), ylabel=quantity_label(quantity, measure.units),
               title=measure.name)
        ax.grid(alpha=0.3)
        ax.legend(fontsize=7)
        written.append(save_figure(figure, folder / f"{quantity}.png", overwrite=overwrite))
        if bar is not None:
            bar.update(1)
    return written


def plot_sweep(table: xr.Dataset, folder: Path, overwrite: bool = True,
               bar: Any = None) -> list[Path]:
    """One figure per measured quantity against the first varied key.

    A panel per algorithm; a line per combination of the other varied keys (at most 8 drawn);
    markers at the mean over realisations, bars +- one standard deviation. ``bar`` (a tqdm
    bar) is advanced by one a figure.
    """
    folder.mkdir(parents=True, exist_ok=True)
    keys = json.loads(table.attrs["varied"])
    first, others = keys[0], keys[1:]
    x = table[first].values
    numeric = np.issubdtype(x.dtype, np.number)
    combos = list(itertools.product(*(range(table.sizes[k]) for k in others)))[:8]
    written = []
    for quantity in QUANTITIES[:-1]:
        algorithms = table["algorithm"].values
        figure, axes = pyplot().subplots(1, len(algorithms), figsize=(4.5 * len(algorithms), 3.6),
                                    squeeze=False, constrained_layout=True)
        for ax, algorithm in zip(axes[0], algorithms, strict=True):
            data = table[quantity].sel(algorithm=algorithm)
            for combo in combos:
                cut = data.isel(dict(zip(others, combo, strict=True)))
                mean = cut.mean("realisation", skipna=True).values
                std = cut.std("realisation", skipna=True).values
                label = ", ".join(f"{k}={table[k].values[i]}"
                                  for k, i in zip(others, combo, strict=True)) or None
                ax.errorbar(x if numeric else np.arange(len(x)), mean, yerr=std, marker="o",
                            capsize=3, label=label)
            if not numeric:
                ax.set_xticks(np.arange(len(x)), [str(v) for v in x])
            ax.set(xlabel=key_label(first),
                   ylabel=quantity_label(quantity, table[quantity].attrs["units"]),
                   title=str(algorithm).upper())
            ax.grid(alpha=0.3)
            if others:
                ax.legend(fontsize=7)
        written.append(save_figure(figure, folder / f"{quantity}.png", overwrite=overwrite))
        if bar is not None:
            bar.update(1)
    return written
