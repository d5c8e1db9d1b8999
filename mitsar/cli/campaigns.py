"""Campaigns of many runs: ``montecarlo`` (metric statistics over background realisations) and
``sweep`` (metrics over a grid of experiment parameters, on Dask)."""

from __future__ import annotations

import argparse
import json
from pathlib import Path

from mitsar.checks import integer
from mitsar.cli.common import log
from mitsar.errors import MitsarError
from mitsar.experiment import montecarlo
from mitsar.experiment.loading import load_experiment, read_toml
from mitsar.io import ProductFileError
from mitsar.lazy import LazyModule

ambiguity_sweep = LazyModule("mitsar.ambiguity.sweep")  # each command imports its own stages
sweep = LazyModule("mitsar.experiment.sweep")

__all__ = ["cmd_montecarlo", "cmd_sweep"]


def cmd_montecarlo(args: argparse.Namespace) -> int:
    """``mitsar montecarlo``: metric statistics over background realisations (Tables 4-5)."""
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ProductFileError(f"{out}: exists and is not a folder (-o names the Monte Carlo "
                               "folder; choose another name)")
    log(args, f"Monte Carlo: {args.realisations} realisations x {', '.join(args.algorithms)}"
              f"; each simulated, focused and measured, then the table"
              + (f" and cut figures (--cuts {args.cuts})" if args.cuts else ""))
    integer("montecarlo", "--cuts", args.cuts, 0)
    experiment = load_experiment(args.experiment, args.set)
    table = None if args.restart else montecarlo.finished_table(  # no-op rerun: no Dataset
        experiment, args.realisations, args.algorithms, out_dir=out, progress=not args.quiet)
    summary = None if table is not None else montecarlo.run(
        experiment, args.realisations, args.algorithms, out_dir=out, resume=not args.restart,
        progress=not args.quiet, scheduler=args.scheduler, workers=args.workers)
    print(table if summary is None else montecarlo.format_table(summary), flush=True)
    if summary is not None and int(summary["count"].max()) == 0:
        reasons = json.loads(summary.attrs.get("failures", "{}") or "{}")
        first = next(iter(reasons.items()), ("", "unknown"))
        raise MitsarError(f"montecarlo: no realisation of {args.experiment} could be measured, "
                          f"nothing to average; seed {first[0]}: {first[1]}")
    if args.cuts:
        figures = montecarlo.draw_cuts(experiment, args.algorithms, args.cuts, out,
                                       progress=not args.quiet)
        log(args, f"cut figures: {', '.join(str(f) for f in figures)}")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """``mitsar sweep``: metrics over the Cartesian product of varied experiment keys."""
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ProductFileError(f"{out}: exists and is not a folder (-o names the sweep folder; "
                               "choose another name)")
    if args.ambiguity:
        table = ambiguity_sweep.run_ambiguity_sweep(
            args.experiment, args.vary, out, overrides=args.set,
            realisations=args.realisations, scheduler=args.scheduler, workers=args.workers,
            restart=args.restart, progress=not args.quiet)
        log(args, f"wrote {out / 'sweep.nc'}, {out / 'sweep_ambiguity.csv'} and figures/: "
                  f"{table.attrs['runs']} points, {table.attrs['failed_runs']} failed")
        return 0
    if ambiguity_sweep.is_ambiguity_document(read_toml(Path(args.experiment))):
        raise MitsarError(f"sweep: {args.experiment} is an ambiguity file (docs/ambiguity.md); "
                          "pass --ambiguity to sweep its ambiguity fractions")
    table = sweep.run_sweep(args.experiment, args.vary, out, realisations=args.realisations,
                            algorithms=args.algorithms, seed=args.seed, overrides=args.set,
                            scheduler=args.scheduler, workers=args.workers, restart=args.restart,
                            progress=not args.quiet, table=False)
    if table is not None:  # None: up to date, said by run_sweep
        log(args, f"sweep table {out / 'sweep.nc'}, {out / 'sweep.csv'} and figures/: "
                  f"{table.attrs['runs']} runs, {table.attrs['failed_runs']} failed")
    return 0
