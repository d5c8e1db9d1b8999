"""The ``mitsar`` command line: simulate, focus, measure and plot; ``mitsar demo`` for the paper.

::

    mitsar simulate EXPERIMENT.toml -o raw.nc [--overwrite]
    mitsar range raw.nc -o profile.nc [--window W]
    mitsar focus raw.nc -o image.nc [-a bpa] [--window W] [--azimuth-resolution M]
                 [--grid GRID.toml]
    mitsar metrics image.nc [--target X Y Z] [--islr-extent paper] [--json] [-o metrics.json]
    mitsar plot FILE -o FIG.png
    mitsar demo [-o DIR] [--overwrite]
    mitsar sweep EXPERIMENT.toml --vary KEY=A:B:STEP [--vary ...] [-n N] -o DIR

Errors in the input (bad files, invalid parameters) print one message on stderr and exit with
status 2; ``--debug`` shows the traceback instead. See ``docs/cli.md``.
"""

from __future__ import annotations

import argparse
import dataclasses
import json
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from mitsar.ambiguity.run import run_ambiguity_experiment
from mitsar.ambiguity.sweep import is_ambiguity_document, run_ambiguity_sweep
from mitsar.budget import set_memory_limit
from mitsar.errors import MitsarError
from mitsar.experiment import montecarlo
from mitsar.experiment.examples import example_path, examples_dir
from mitsar.experiment.loading import (
    focus_options_from_config,
    load_experiment,
    load_grid,
    read_toml,
)
from mitsar.experiment.options import (
    ALGORITHMS,
    AUTOFOCUS_METHODS,
    ISLR_EXTENTS,
    WINDOWS,
    FocusOptions,
)
from mitsar.experiment.paper import PAPER_TABLES
from mitsar.experiment.parsers import MAX_SEED
from mitsar.experiment.rays import run_rays
from mitsar.experiment.runs import run_focus, run_metrics, run_simulation, simulate_to
from mitsar.experiment.sweep import run_sweep
from mitsar.export import write_cphd, write_sicd
from mitsar.focus.compression import range_compress
from mitsar.io import ProductFileError, check_writable, load, save, to_jsonable, write_json
from mitsar.plots.footprint import scene_range_marks
from mitsar.plots.products import (
    background_samples,
    plot_background_histograms,
    plot_cuts,
    plot_file,
    plot_image,
    plot_range_compressed,
    save_figure,
    target_marks,
)
from mitsar.report.html import RUN_RECORD, build_report
from mitsar.report.preview import preview
from mitsar.report.run import run_experiment
from mitsar.scene import load_scene
from mitsar.version import __version__

__all__ = ["build_parser", "main"]

EXIT_USAGE = 2
"""Exit status for bad input (same as argparse's usage errors)."""

PAPER_TABLE4_BPA = {direction: {metric: values[0] for metric, values in cuts.items()}
                    for direction, cuts in PAPER_TABLES[-20.0]["bpa"].items()}
"""Paper Table 4, BPA row (point target on a -20 dB background, means over realisations)."""

DEMO_FILES = {
    "raw": "raw.nc",
    "image": "image.nc",
    "metrics": "metrics.json",
    "range_figure": "range_compressed.png",
    "image_figure": "image.png",
    "cuts_figure": "cuts.png",
    "histogram_figure": "background_histograms.png",
}
"""Files written by ``mitsar demo`` in its output folder."""


def _log(args: argparse.Namespace, message: str) -> None:
    """A progress message on stderr (silenced by ``--quiet``)."""
    if not getattr(args, "quiet", False):
        print(message, file=sys.stderr, flush=True)


# --- commands -------------------------------------------------------------------------------
def cmd_simulate(args: argparse.Namespace) -> int:
    """``mitsar simulate``: experiment file -> raw product."""
    check_writable(args.output, args.overwrite)
    experiment = load_experiment(args.experiment, args.set)
    if args.seed is not None:
        if not 0 <= args.seed <= MAX_SEED:
            raise MitsarError(f"--seed: expected an integer in [0, {MAX_SEED}] (products "
                              f"record it as 64 bits), found {args.seed}")
        experiment.simulation = dataclasses.replace(experiment.simulation, seed=args.seed)
        experiment.config.setdefault("simulation", {})["seed"] = args.seed
    start = time.perf_counter()
    _log(args, f"simulating {args.experiment} ...")
    sweeps = simulate_to(experiment, args.output, overwrite=args.overwrite,
                         progress=not args.quiet)
    _log(args, f"wrote {args.output}: raw product, {sweeps} sweeps x "
               f"{experiment.radar.samples_per_sweep} samples "
               f"({time.perf_counter() - start:.1f} s)")
    return 0


def cmd_range(args: argparse.Namespace) -> int:
    """``mitsar range``: raw product -> range-compressed product."""
    check_writable(args.output, args.overwrite)
    raw = load(args.raw, product="raw")
    profile = range_compress(raw, window=args.window)
    save(profile, args.output, overwrite=args.overwrite)
    _log(args, f"wrote {args.output}: range-compressed product, "
               f"{profile.sizes['sweep']} sweeps x {profile.sizes['range']} range bins")
    return 0


def _focus_options(args: argparse.Namespace, raw: Any) -> Any:
    """Focus options: command-line flags over ``--grid`` over the raw's experiment."""
    config = raw.attrs.get("experiment")
    options = (focus_options_from_config(config, where=f"{args.raw} (experiment)")
               if config else FocusOptions())
    changes: dict[str, Any] = {}
    if args.algorithm is not None:
        changes["algorithm"] = args.algorithm
    if args.window is not None:
        changes["window"] = args.window
    if args.azimuth_resolution is not None:
        if not args.azimuth_resolution > 0:
            raise MitsarError(f"--azimuth-resolution: expected a resolution > 0 m, found "
                              f"{args.azimuth_resolution}")
        changes["azimuth_resolution"] = args.azimuth_resolution
    if args.full_aperture:
        changes["azimuth_resolution"] = None
    if args.autofocus is not None:
        changes["autofocus"] = None if args.autofocus == "none" else args.autofocus
    if args.grid is not None:
        changes["grid"] = load_grid(args.grid)
    if args.default_grid:
        changes["grid"] = None
    return dataclasses.replace(options, **changes)


def cmd_focus(args: argparse.Namespace) -> int:
    """``mitsar focus``: raw product -> image product."""
    check_writable(args.output, args.overwrite)
    raw = load(args.raw, product="raw")
    options = _focus_options(args, raw)
    start = time.perf_counter()
    _log(args, f"focusing {args.raw} with {options.algorithm.upper()} ...")
    image = run_focus(raw, options, progress=not args.quiet)
    save(image, args.output, overwrite=args.overwrite)
    shape = " x ".join(f"{image.sizes[d]} {d}" for d in image["image"].dims)
    _log(args, f"wrote {args.output}: image product, {shape} "
               f"({time.perf_counter() - start:.1f} s)")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    """``mitsar export``: image product -> SICD, raw product -> CPHD (docs/products.md)."""
    check_writable(args.output, args.overwrite)
    if args.format == "sicd":
        if not args.raw:
            raise MitsarError("mitsar export -f sicd: pass --raw RAW.nc, the raw product the "
                              "image was focused from (SICD needs the antenna track)")
        written = write_sicd(load(args.product, product="image"), args.output,
                             raw=load(args.raw, product="raw"), overwrite=args.overwrite)
    else:
        written = write_cphd(load(args.product, product="raw"), args.output,
                             overwrite=args.overwrite)
    _log(args, f"wrote {written}: {args.format.upper()}")
    return 0


def format_metrics(metrics: dict[str, Any]) -> str:
    """Impulse-response metrics as a small text table."""
    target = ", ".join(f"{v:.3f}" for v in metrics.get("target", []))
    lines = [f"target [{target}] m, peak offset {metrics.get('peak_offset_m', float('nan')):.4f}"
             f" m, ISLR extent {metrics.get('islr_extent')!r}",
             f"{'':9}{'IRW [m]':>10}{'IRW [cells]':>13}{'PSLR [dB]':>11}{'ISLR [dB]':>11}"]
    for name in ("range", "azimuth"):
        m = metrics[name]
        lines.append(f"{name:9}{m['irw_m']:>10.4f}{m['irw_cells']:>13.3f}"
                     f"{m['pslr_db']:>11.2f}{m['islr_db']:>11.2f}")
    if "islr_2d_db" in metrics:
        lines.append(f"2-D ISLR {metrics['islr_2d_db']:.2f} dB")
    if "snr_db" in metrics:  # images of raw data with a noise figure (docs/metrics.md §Noise)
        lines.append(f"SNR {metrics['snr_db']:.2f} dB, NESZ {metrics['nesz_db']:.2f} dB")
    lines.extend(f"warning: {message}" for message in metrics.get("warnings", []))
    return "\n".join(lines)


def cmd_metrics(args: argparse.Namespace) -> int:
    """``mitsar metrics``: image product -> IRW, PSLR, ISLR."""
    if args.output is not None:
        check_writable(args.output, args.overwrite)
    image = load(args.image, product="image")
    extent: str | float | None = args.islr_extent
    if extent is not None:
        try:
            extent = float(extent)
        except ValueError:
            pass  # a named extent ("paper", "isce3", ...), checked by measure_impulse_response
    metrics = to_jsonable(run_metrics(image, target=args.target, islr_extent=extent))
    if args.output is not None:
        write_json(metrics, args.output, overwrite=args.overwrite)
        _log(args, f"wrote {args.output}")
    print(json.dumps(metrics, indent=2) if args.json else format_metrics(metrics))
    return 0


def _scene_marks(path: str) -> dict[str, float] | None:
    """NR / CS / FR of an image of a scene experiment from the beam's hits in its scene."""
    product = load(path)
    config = json.loads(product.attrs.get("experiment", "{}") or "{}")
    if product.attrs.get("product") != "image" or not config.get("scene"):
        return None
    return scene_range_marks(product, None, load_scene(config["scene"])) or None


def cmd_plot(args: argparse.Namespace) -> int:
    """``mitsar plot``: product file -> figure."""
    if args.dynamic_range is not None and not args.dynamic_range > 0:
        raise MitsarError(f"--dynamic-range: expected a colour scale depth > 0 dB, found "
                          f"{args.dynamic_range}")
    plot_file(args.file, args.output, overwrite=args.overwrite,
              dynamic_range_db=args.dynamic_range, range_marks=_scene_marks(args.file))
    _log(args, f"wrote {args.output}")
    return 0


def cmd_demo(args: argparse.Namespace) -> int:
    """``mitsar demo``: the paper's point-target experiment end to end."""
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ProductFileError(f"{out}: exists and is not a folder")
    paths = {key: out / name for key, name in DEMO_FILES.items()}
    if out.is_dir():
        for path in paths.values():
            check_writable(path, args.overwrite)
    experiment = load_experiment(example_path(args.example))
    out.mkdir(parents=True, exist_ok=True)
    results = run_demo(experiment, paths, overwrite=args.overwrite, progress=not args.quiet,
                       log=lambda message: _log(args, message))
    print(demo_summary(experiment, results, out))
    return 0


def run_demo(experiment: Any, paths: dict[str, Path], overwrite: bool = False,
             progress: bool = True, log: Any = None) -> dict[str, Any]:
    """Simulate, focus, measure and plot an experiment, writing ``paths`` (see DEMO_FILES).

    Returns
    -------
    dict
        ``raw`` and ``image`` datasets, ``metrics`` (dict), ``seconds`` per step.
    """
    log = log or (lambda message: None)
    seconds: dict[str, float] = {}
    clock = time.perf_counter()
    log("[1/4] simulating raw data ...")
    raw = run_simulation(experiment, progress=progress)
    save(raw, paths["raw"], overwrite=overwrite)
    seconds["simulate"] = time.perf_counter() - clock
    clock = time.perf_counter()
    log(f"[2/4] focusing ({experiment.focus.algorithm.upper()}) ...")
    image = run_focus(raw, experiment.focus, progress=progress)
    save(image, paths["image"], overwrite=overwrite)
    seconds["focus"] = time.perf_counter() - clock
    clock = time.perf_counter()
    log("[3/4] measuring the impulse response ...")
    metrics = to_jsonable(run_metrics(image))
    metrics["paper_table4_bpa"] = PAPER_TABLE4_BPA
    write_json(metrics, paths["metrics"], overwrite=overwrite)
    seconds["metrics"] = time.perf_counter() - clock
    clock = time.perf_counter()
    log("[4/4] plotting ...")
    _demo_figures(raw, image, metrics, paths, overwrite)
    seconds["plots"] = time.perf_counter() - clock
    return {"raw": raw, "image": image, "metrics": metrics, "seconds": seconds}


def _demo_figures(raw: Any, image: Any, metrics: dict[str, Any], paths: dict[str, Path],
                  overwrite: bool) -> None:
    """The four demo figures."""
    figure, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    plot_range_compressed(raw, ax=ax)
    save_figure(figure, paths["range_figure"], overwrite)
    figure, ax = plt.subplots(figsize=(7, 6), layout="constrained")
    plot_image(image, ax=ax, marks=target_marks(image))
    save_figure(figure, paths["image_figure"], overwrite)
    figure, axes = plt.subplots(1, 2, figsize=(12, 4.5), layout="constrained")
    plot_cuts(image, metrics, axes=axes)
    save_figure(figure, paths["cuts_figure"], overwrite)
    if "background_reflectivity" in raw:
        amplitudes, phases = background_samples(raw)
        figure, axes = plt.subplots(1, 2, figsize=(12, 4.5), layout="constrained")
        level = raw.attrs.get("background_cell_rcs_db")
        label = (f"{level:g} dB background, first sweep" if level is not None
                 else "background, first sweep")
        plot_background_histograms(amplitudes, phases, axes=axes, label=label)
        save_figure(figure, paths["histogram_figure"], overwrite)


def demo_summary(experiment: Any, results: dict[str, Any], out: Path) -> str:
    """A short text summary of a demo run."""
    raw, image, metrics = results["raw"], results["image"], results["metrics"]
    shape = " x ".join(f"{image.sizes[d]} {d}" for d in image["image"].dims)
    lines = [f"mitsar demo: {experiment.name or 'experiment'} -> {out}/"]
    if experiment.description:
        lines.append(f"  {experiment.description}")
    lines += [f"  raw:   {raw.sizes['sweep']} sweeps x {raw.sizes['sample']} samples",
             f"  image: {image.attrs.get('algorithm', '?').upper()}, {shape}", "",
             format_metrics(metrics), "",
             "paper Table 4 (BPA, -20 dB background, mean over realisations):",
             f"{'':9}{'IRW [cells]':>23}{'PSLR [dB]':>11}{'ISLR [dB]':>11}"]
    for name in ("range", "azimuth"):
        ref = PAPER_TABLE4_BPA[name]
        lines.append(f"{name:9}{ref['irw_cells']:>23.3f}{ref['pslr_db']:>11.2f}"
                     f"{ref['islr_db']:>11.2f}")
    timing = ", ".join(f"{k} {v:.1f} s" for k, v in results["seconds"].items())
    lines += ["", f"time: {timing}", "files: " + ", ".join(DEMO_FILES.values())]
    return "\n".join(lines)


# --- parser ---------------------------------------------------------------------------------
def cmd_montecarlo(args: argparse.Namespace) -> int:
    """``mitsar montecarlo``: metric statistics over background realisations (Tables 4-5)."""
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ProductFileError(f"{out}: exists and is not a folder (-o names the Monte Carlo "
                               "folder; choose another name)")
    _log(args, f"Monte Carlo: {args.realisations} realisations x {', '.join(args.algorithms)}")
    experiment = load_experiment(args.experiment, args.set)
    summary = montecarlo.run(experiment, args.realisations, args.algorithms, out_dir=out,
                             resume=not args.restart, progress=not args.quiet,
                             scheduler=args.scheduler, workers=args.workers)
    print(montecarlo.format_table(summary))
    if int(summary["count"].max()) == 0:
        reasons = json.loads(summary.attrs.get("failures", "{}") or "{}")
        first = next(iter(reasons.items()), ("", "unknown"))
        raise MitsarError(f"montecarlo: no realisation of {args.experiment} could be measured, "
                          f"nothing to average; seed {first[0]}: {first[1]}")
    if args.cuts:
        for algorithm in args.algorithms:
            cuts = montecarlo.realisation_cuts(experiment, algorithm, args.cuts)
            figure = montecarlo.plot_realisation_cuts(cuts, out / f"cuts_{algorithm}.png",
                                                      overwrite=True)
            _log(args, f"wrote {figure}")
    return 0


def cmd_sweep(args: argparse.Namespace) -> int:
    """``mitsar sweep``: metrics over the Cartesian product of varied experiment keys."""
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ProductFileError(f"{out}: exists and is not a folder (-o names the sweep folder; "
                               "choose another name)")
    if args.ambiguity:
        table = run_ambiguity_sweep(args.experiment, args.vary, out, overrides=args.set,
                                    realisations=args.realisations, scheduler=args.scheduler,
                                    workers=args.workers, restart=args.restart,
                                    progress=not args.quiet)
        _log(args, f"wrote {out / 'sweep.nc'}, {out / 'sweep_ambiguity.csv'} and figures/: "
                   f"{table.attrs['runs']} points, {table.attrs['failed_runs']} failed")
        return 0
    if is_ambiguity_document(read_toml(Path(args.experiment))):
        raise MitsarError(f"sweep: {args.experiment} is an ambiguity file (docs/ambiguity.md); "
                          "pass --ambiguity to sweep its ambiguity fractions")
    table = run_sweep(args.experiment, args.vary, out, realisations=args.realisations,
                      algorithms=args.algorithms, seed=args.seed, overrides=args.set,
                      scheduler=args.scheduler, workers=args.workers, restart=args.restart,
                      progress=not args.quiet)
    _log(args, f"wrote {out / 'sweep.nc'}, {out / 'sweep.csv'} and figures/: "
               f"{table.attrs['runs']} runs, {table.attrs['failed_runs']} failed")
    return 0


def _add_scheduler(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("--scheduler", metavar="ADDRESS",
                     help="Dask scheduler: an address (tcp://host:8786), 'local[:N]' or "
                     "'inline' (default: $MITSAR_DASK_SCHEDULER, else a local cluster with one "
                     "worker per core)")
    sub.add_argument("--workers", type=int, metavar="N",
                     help="worker processes of the local cluster (default: one per core)")


def cmd_rays(args: argparse.Namespace) -> int:
    """``mitsar rays``: ray geometry and echo figures of a scene experiment."""
    _log(args, f"tracing rays of {args.experiment} (sweep {args.sweep}) ...")
    summary = run_rays(load_experiment(args.experiment, args.set), args.output, args.rays,
                       args.sweep, overwrite=args.overwrite)
    ratio = summary.get("reflections_over_backscatter_amplitude")
    print(f"captured reflected rays: {summary['captures']}; reflections / backscatter peak "
          f"amplitude after the range FFT: {'none' if not ratio else f'{ratio:.3g}'}")
    for name in summary["figures"].values():
        _log(args, f"wrote {name}")
    return 0


def cmd_run(args: argparse.Namespace) -> int:
    """``mitsar run``: everything an experiment asks for, and its report."""
    _log(args, f"running {args.experiment} into {args.output} ...")
    report = run_experiment(args.experiment, args.output, overrides=args.set,
                            algorithms=args.algorithms, realisations=args.realisations,
                            overwrite=args.overwrite, progress=not args.quiet)
    record = json.loads((report.parent / RUN_RECORD).read_text())
    for warning in record.get("warnings", []):
        print(f"warning: {warning}", file=sys.stderr)
    print(f"wrote {report}")
    return 0


def cmd_preview(args: argparse.Namespace) -> int:
    """``mitsar preview``: the scene, the flight and the beam, before simulating."""
    print(f"wrote {preview(args.experiment, args.output, overwrite=args.overwrite)}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    """``mitsar report``: rebuild the report of a run folder."""
    print(f"wrote {build_report(args.folder)}")
    return 0


def cmd_ambiguity(args: argparse.Namespace) -> int:
    """``mitsar ambiguity``: gradient-method maps of one or more trajectories."""
    _log(args, f"ambiguity maps of {args.experiment} ...")
    summary = run_ambiguity_experiment(args.experiment, args.output, overwrite=args.overwrite,
                                       figures=False if args.no_figures else None,
                                       progress=not args.quiet)
    if summary.get("comparison_table"):
        print(summary["comparison_table"])
    for name in summary.get("files", []):
        _log(args, f"wrote {name}")
    return 0


def _add_output(parser: argparse.ArgumentParser, help_text: str, required: bool = True) -> None:
    parser.add_argument("-o", "--output", required=required, metavar="FILE", help=help_text)
    parser.add_argument("--overwrite", action="store_true",
                        help="replace the output if it exists (never replaced otherwise)")


def _folder_command(commands: Any, common: argparse.ArgumentParser, name: str, func: Any,
                    summary: str, description: str, metavar: str,
                    overwrite: bool = True) -> argparse.ArgumentParser:
    """A sub-command reading an experiment file and writing several files into a folder."""
    sub = commands.add_parser(name, parents=[common], help=summary, description=description,
                              formatter_class=_HELP)
    sub.add_argument("experiment", metavar=metavar)
    sub.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    if overwrite:
        sub.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    sub.set_defaults(func=func)
    return sub


def _file_command(commands: Any, common: argparse.ArgumentParser, name: str, func: Any,
                  summary: str, description: str, argument: tuple[str, str],
                  output: str, output_required: bool = True) -> argparse.ArgumentParser:
    """A sub-command reading one file (``argument``: name, metavar) and writing ``output``."""
    sub = commands.add_parser(name, parents=[common], help=summary, description=description,
                              formatter_class=_HELP)
    sub.add_argument(argument[0], metavar=argument[1])
    _add_output(sub, output, required=output_required)
    sub.set_defaults(func=func)
    return sub


_HELP = argparse.ArgumentDefaultsHelpFormatter
"""Sub-command help shows every option's default."""


def demo_examples() -> list[str]:
    """Bundled experiments the demo can run: point targets to measure (not ambiguity files)."""
    names = []
    for path in sorted(examples_dir().glob("*.toml")):
        document = read_toml(path)
        measurable = document.get("targets") or (document.get("metrics") or {}).get("target")
        if measurable and "trajectories" not in document:
            names.append(path.stem)
    return names


def _add_set(sub: argparse.ArgumentParser) -> None:
    sub.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override an experiment key, e.g. --set background.cell_rcs_db=-10 "
                     "(repeatable; TOML values, dotted keys)")


def build_parser() -> argparse.ArgumentParser:
    """The argument parser of the ``mitsar`` command."""
    parser = argparse.ArgumentParser(
        prog="mitsar", description="FMCW mm-wave SAR simulation and processing "
        "(Scannapieco et al. 2016). See docs/cli.md.")
    parser.add_argument("--version", action="version", version=f"mitsar {__version__}")
    # Global options work before or after the sub-command: the sub-commands' copies default
    # to SUPPRESS so that they do not reset what was given before the sub-command.
    common = argparse.ArgumentParser(add_help=False)
    for owner, default in ((parser, False), (common, argparse.SUPPRESS)):
        owner.add_argument("--debug", action="store_true", default=default,
                           help="show the full traceback on errors")
        owner.add_argument("-q", "--quiet", action="store_true", default=default,
                           help="no progress bars or messages on stderr")
        owner.add_argument("--memory-limit", metavar="SIZE",
                           default=None if default is False else argparse.SUPPRESS,
                           help="memory a command may use, e.g. 4G (default: "
                           "$MITSAR_MEMORY_LIMIT, else the machine's available memory); "
                           "larger requests are refused before any work")
    commands = parser.add_subparsers(dest="command", metavar="COMMAND", required=True)

    sub = _file_command(commands, common, "simulate", cmd_simulate,
                        "simulate raw data from a TOML experiment", "Simulate the raw product "
                        "of a TOML experiment file (docs/experiments.md).",
                        ("experiment", "EXPERIMENT.toml"), "raw product to write (.nc)")
    sub.add_argument("--seed", type=int, help="override [simulation] seed")
    _add_set(sub)

    sub = _file_command(commands, common, "range", cmd_range, "range-compress raw data",
                        "Range-compress a raw product (RVP removed).", ("raw", "RAW.nc"),
                        "range-compressed product to write (.nc)")
    sub.add_argument("--window", choices=WINDOWS, default="rect", help="range window")

    sub = _file_command(commands, common, "focus", cmd_focus, "focus raw data into an image",
                        "Focus a raw product. Options default to the [focus] table of the "
                        "experiment the raw data came from.", ("raw", "RAW.nc"),
                        "image product to write (.nc)")
    sub.add_argument("-a", "--algorithm", choices=ALGORITHMS, help="focusing algorithm")
    sub.add_argument("--autofocus", choices=AUTOFOCUS_METHODS + ("none",),
                     help="autofocus after back-projection (bpa, ffbp): phase gradient or "
                     "minimum entropy")
    sub.add_argument("--window", choices=WINDOWS, help="range and azimuth window")
    sub.add_argument("--azimuth-resolution", type=float, metavar="M",
                     help="processed azimuth resolution [m]")
    sub.add_argument("--full-aperture", action="store_true",
                     help="process the whole beam (ignore any azimuth resolution)")
    sub.add_argument("--grid", metavar="GRID.toml",
                     help="output grid: a TOML file with a [grid] table (or [focus.grid])")
    sub.add_argument("--default-grid", action="store_true",
                     help="use the algorithm's default slant grid (ignore the experiment's)")

    sub = _file_command(commands, common, "export", cmd_export,
                        "write an NGA SICD (image) or CPHD (raw) file",
                        "Export an image product as SICD 1.4.0 or a raw product as CPHD 1.0.1 "
                        "(needs mitsar[nga]; docs/products.md).", ("product", "PRODUCT.nc"),
                        "SICD (.nitf) or CPHD (.cphd) file to write")
    sub.add_argument("-f", "--format", choices=("sicd", "cphd"), required=True,
                     help="output format")
    sub.add_argument("--raw", metavar="RAW.nc",
                     help="sicd: the raw product the image was focused from")

    sub = _file_command(commands, common, "metrics", cmd_metrics, "IRW, PSLR, ISLR of a target",
                        "Impulse-response metrics of a point target.", ("image", "IMAGE.nc"),
                        "also write the metrics as JSON", output_required=False)
    sub.add_argument("--target", type=float, nargs=3, metavar=("X", "Y", "Z"),
                     help="target world position [m] (default: from the experiment)")
    sub.add_argument("--islr-extent", metavar="EXTENT",
                     help=f"ISLR side-lobe extent: {', '.join(ISLR_EXTENTS)} or a number of "
                     "cells (default: from the experiment, else 'paper')")
    sub.add_argument("--json", action="store_true", help="print JSON instead of a table")

    sub = _file_command(commands, common, "plot", cmd_plot, "plot a product file",
                        "Plot a product: raw/range-compressed -> range-compressed matrix; "
                        "image -> image in dB.", ("file", "FILE.nc"),
                        "figure to write (.png, .pdf, .svg)")
    sub.add_argument("--dynamic-range", type=float, metavar="DB",
                     help="colour scale depth below the peak [dB]")

    sub = commands.add_parser("demo", parents=[common], help="run the paper's point-target "
                              "experiment", description="Simulate, focus and measure the "
                              "bundled paper experiment; write products, metrics and figures.",
                              formatter_class=_HELP)
    sub.add_argument("-o", "--output", default="mitsar-demo", metavar="DIR",
                     help="output folder")
    sub.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    sub.add_argument("--example", default="paper_point_target", choices=demo_examples(),
                     help="bundled example with a point target to run")
    sub.set_defaults(func=cmd_demo)

    sub = _folder_command(commands, common, "montecarlo", cmd_montecarlo,
                          "metric statistics over background realisations",
                          "Monte Carlo over background realisations of an experiment, for each "
                          "algorithm: mean and variance of IRW, PSLR, ISLR (paper Tables 4-5). "
                          "Interrupted runs resume from the record in the output folder.",
                          "EXPERIMENT.toml", overwrite=False)
    sub.add_argument("-n", "--realisations", type=int, default=10, help="realisations")
    sub.add_argument("-a", "--algorithms", nargs="+", choices=ALGORITHMS,
                     default=list(ALGORITHMS), help="algorithms")
    sub.add_argument("--restart", action="store_true",
                     help="discard a previous record in DIR instead of resuming it")
    sub.add_argument("--cuts", type=int, default=5, metavar="N",
                     help="also plot cuts of N realisations over the nominal response "
                     "(paper Figs. 8-9; 0: none)")
    _add_set(sub)
    _add_scheduler(sub)

    sub = _folder_command(commands, common, "sweep", cmd_sweep,
                          "metrics over a grid of experiment parameters (on Dask)",
                          "Simulate, focus and measure every point of the Cartesian product of "
                          "the --vary keys (any experiment key, as --set), -n realisations "
                          "each, on a Dask cluster; write one table (sweep.nc, sweep.csv) and a "
                          "figure per metric. Interrupted sweeps resume: finished points are "
                          "kept in DIR/points/.", "EXPERIMENT.toml", overwrite=False)
    sub.add_argument("--vary", action="append", required=True, metavar="KEY=VALUES",
                     help="a varied key: KEY=START:STOP:STEP (inclusive) or KEY=V1,V2,... "
                     "(repeatable; e.g. look.off_nadir_deg=40:70:5)")
    sub.add_argument("-n", "--realisations", type=int, default=1,
                     help="simulations of every point (seeded from --seed and the point)")
    sub.add_argument("-a", "--algorithms", nargs="+", choices=ALGORITHMS,
                     help="algorithms (default: the experiment's [focus] algorithm)")
    sub.add_argument("--seed", type=int, help="campaign seed (default: [simulation] seed)")
    sub.add_argument("--ambiguity", action="store_true",
                     help="the file is an ambiguity file (docs/ambiguity.md): map every point "
                     "and tabulate the area fractions per trajectory (sweep_ambiguity.csv)")
    sub.add_argument("--restart", action="store_true",
                     help="discard the records of an earlier run in DIR instead of reusing them")
    _add_set(sub)
    _add_scheduler(sub)

    sub = _folder_command(commands, common, "rays", cmd_rays,
                          "ray geometry and echoes of a scene (paper Figs. 6, 10, 11)",
                          "Trace one sweep of a scene experiment with multipath and plot the ray "
                          "geometry (2D or 3D) and the echoes after the range FFT, backscatter "
                          "only and with reflections, near range / centre scene / far range "
                          "marked.", "EXPERIMENT.toml")
    sub.add_argument("--rays", type=int, metavar="N", help="rays drawn from the path log")
    sub.add_argument("--sweep", type=int, default=0, help="sweep to trace")
    _add_set(sub)

    sub = _folder_command(commands, common, "run", cmd_run,
                          "everything an experiment asks for, with an HTML report",
                          "Simulate, trace rays, focus with every requested algorithm, measure, "
                          "draw and (with -n) run a Monte Carlo; or run an ambiguity file. "
                          "Writes the products, run.json and a self-contained report.html.",
                          "EXPERIMENT.toml")
    sub.add_argument("-a", "--algorithms", nargs="+", choices=ALGORITHMS,
                     help="focusing algorithms (default: the experiment's [focus] algorithm)")
    sub.add_argument("-n", "--realisations", type=int, default=0,
                     help="Monte Carlo realisations over the background (0: none)")
    _add_set(sub)
    sub = _file_command(commands, common, "preview", cmd_preview,
                        "picture of the scene, the flight and the beam",
                        "Render the experiment's scene with Mitsuba (a stand-in floor and "
                        "targets without one), with the trajectory, the antenna and the beam "
                        "footprint at the first, middle and last sweep; and a top view.",
                        ("experiment", "EXPERIMENT.toml"), "figure to write (.png, .pdf, .svg)")
    sub = commands.add_parser("report", parents=[common], help="rebuild a run's report.html",
                              description="Write report.html of a 'mitsar run' folder again "
                              "from its run.json.", formatter_class=_HELP)
    sub.add_argument("folder", metavar="DIR")
    sub.set_defaults(func=cmd_report)

    sub = _folder_command(commands, common, "ambiguity", cmd_ambiguity,
                          "resolution and ambiguity maps of a trajectory",
                          "Resolution and ambiguity maps by the gradient method "
                          "(docs/ambiguity.md); several trajectories in one file are compared "
                          "side by side.", "AMBIGUITY.toml")
    sub.add_argument("--no-figures", action="store_true", help="write products only")
    return parser


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``mitsar`` command line.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 on success, 2 for bad input (message on stderr), 130 if interrupted.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        set_memory_limit(args.memory_limit)
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("mitsar: interrupted", file=sys.stderr)
        return 130
    except (MitsarError, ValueError, OSError) as error:
        if args.debug:
            raise
        print(f"mitsar {args.command}: error: {error}", file=sys.stderr)
        return EXIT_USAGE


if __name__ == "__main__":
    sys.exit(main())
