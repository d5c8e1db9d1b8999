"""The argument parser of the ``mitsar`` command: every sub-command, its options and help."""

from __future__ import annotations

import argparse
from collections.abc import Callable
from importlib import import_module
from types import ModuleType
from typing import Any

from mitsar.experiment.options import (
    ALGORITHMS,
    AUTOFOCUS_METHODS,
    ISLR_EXTENTS,
    RESUME_CHUNK_SWEEPS,
    WINDOWS,
)
from mitsar.version import __version__

__all__ = ["build_parser"]


def _command(name: str, load: Callable[[], ModuleType]) -> Callable[[argparse.Namespace], int]:
    """The command function ``name`` of the module that ``load`` imports, imported when the
    command runs: a command loads only its own stages (a no-op campaign rerun never loads
    Mitsuba or Matplotlib)."""
    def run(args: argparse.Namespace) -> int:
        return getattr(load(), name)(args)
    run.__name__ = run.__qualname__ = name
    return run


cmd_ambiguity = _command("cmd_ambiguity", lambda: import_module("mitsar.cli.ambiguity"))
cmd_montecarlo = _command("cmd_montecarlo", lambda: import_module("mitsar.cli.campaigns"))
cmd_sweep = _command("cmd_sweep", lambda: import_module("mitsar.cli.campaigns"))
cmd_demo = _command("cmd_demo", lambda: import_module("mitsar.cli.demo"))
cmd_interferogram = _command("cmd_interferogram",
                              lambda: import_module("mitsar.cli.interferometry"))
cmd_report = _command("cmd_report", lambda: import_module("mitsar.cli.report"))
cmd_run = _command("cmd_run", lambda: import_module("mitsar.cli.report"))
cmd_preview = _command("cmd_preview", lambda: import_module("mitsar.cli.scene"))
cmd_rays = _command("cmd_rays", lambda: import_module("mitsar.cli.scene"))
cmd_export = _command("cmd_export", lambda: import_module("mitsar.cli.stages"))
cmd_focus = _command("cmd_focus", lambda: import_module("mitsar.cli.stages"))
cmd_metrics = _command("cmd_metrics", lambda: import_module("mitsar.cli.stages"))
cmd_plot = _command("cmd_plot", lambda: import_module("mitsar.cli.stages"))
cmd_range = _command("cmd_range", lambda: import_module("mitsar.cli.stages"))
cmd_simulate = _command("cmd_simulate", lambda: import_module("mitsar.cli.stages"))


class _DefaultsFormatter(argparse.HelpFormatter):
    """Help that shows an option's default once, and only when it says something.

    ``argparse.ArgumentDefaultsHelpFormatter`` appends ``(default: ...)`` to every option,
    which gave ``(default: None)`` for options whose default is "from the experiment" and a
    second default after help texts that already state theirs. Here a default is appended only
    when the help text does not mention one, and only when it is a value (not ``None``, a flag's
    ``False``, an empty list or ``SUPPRESS``); positional arguments show none.
    """

    def _get_help_string(self, action: argparse.Action) -> str:
        text = action.help or ""
        default = action.default
        if ("default" in text.lower() or not action.option_strings
                or default is None or default is argparse.SUPPRESS
                or isinstance(default, bool) or default in ([], ())):
            return text
        shown = (" ".join(str(v) for v in default) if isinstance(default, list | tuple)
                 else str(default))
        return f"{text} (default: {shown.replace('%', '%%')})"


_HELP = _DefaultsFormatter
"""Sub-command help shows each meaningful default once."""


def _add_output(parser: argparse.ArgumentParser, help_text: str, required: bool = True) -> None:
    """``-o/--output FILE`` and ``--overwrite``."""
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
    else:  # a resumable campaign: say what to do instead of argparse's "unrecognized"
        sub.add_argument("--overwrite", nargs=0, action=_NoOverwrite, help=argparse.SUPPRESS)
    sub.set_defaults(func=func)
    return sub


class _NoOverwrite(argparse.Action):
    """``--overwrite`` on a command that resumes its output folder instead: a clear error."""

    def __call__(self, parser: argparse.ArgumentParser, namespace: argparse.Namespace,
                 values: Any, option_string: str | None = None) -> None:
        parser.error("--overwrite does not apply: this command resumes an interrupted run from "
                     "the record in its output folder (-o DIR) instead of replacing it; pass "
                     "--restart to discard that record and start again, or choose another -o")


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


def _add_set(sub: argparse.ArgumentParser) -> None:
    """``--set KEY=VALUE``: experiment overrides."""
    sub.add_argument("--set", action="append", default=[], metavar="KEY=VALUE",
                     help="override an experiment key, e.g. --set background.cell_rcs_db=-10 "
                     "(repeatable; TOML values, dotted keys)")


def _add_scheduler(sub: argparse.ArgumentParser) -> None:
    """``--scheduler`` and ``--workers`` of the Dask campaigns."""
    sub.add_argument("--scheduler", metavar="ADDRESS",
                     help="Dask scheduler: an address (tcp://host:8786), 'local[:N]' or "
                     "'inline' (default: $MITSAR_DASK_SCHEDULER, else 'auto': this process, or a "
                     "local cluster with one worker per core when the estimated cost pays for "
                     "its start-up)")
    sub.add_argument("--workers", type=int, metavar="N",
                     help="worker processes of the local cluster (default: one per core)")


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
    sub.add_argument("--chunk-sweeps", type=int, default=RESUME_CHUNK_SWEEPS, metavar="N",
                     help="sweeps simulated and kept at a time: an interrupted run resumes "
                     f"from its last finished chunk (default {RESUME_CHUNK_SWEEPS})")
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
    sub.add_argument("--band-limit", action=argparse.BooleanOptionalAction, default=None,
                     help="band-limit BPA/FFBP images off a straight track to the azimuth "
                     "resolution (default: the experiment's [focus] band_limit, else on)")
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
                     help="sicd: the raw product the image was focused from (optional: "
                     "an image focused by mitsar carries its aperture)")

    sub = _file_command(commands, common, "metrics", cmd_metrics, "IRW, PSLR, ISLR of a target",
                        "Impulse-response metrics of a point target.", ("image", "IMAGE.nc"),
                        "also write the metrics as JSON", output_required=False)
    sub.add_argument("--target", type=float, nargs=3, metavar=("X", "Y", "Z"),
                     help="target world position [m] (default: from the experiment)")
    sub.add_argument("--islr-extent", metavar="EXTENT",
                     help=f"ISLR side-lobe extent: {', '.join(ISLR_EXTENTS)} or a number of "
                     "cells (default: from the experiment, else 'paper')")
    sub.add_argument("--json", action="store_true", help="print JSON instead of a table")

    sub = commands.add_parser("interferogram", parents=[common],
                              help="interferogram, heights and point cloud of a multi-channel "
                              "image", description="Interferogram of two channels of a "
                              "multi-channel image (BPA of a radar with several receivers): "
                              "writes DIR/interferogram.nc, DIR/points.ply and maps of the "
                              "phase, coherence, unwrapped phase, height and height noise "
                              "(docs/interferometry.md). Options default to the image's "
                              "[interferometry] table, else the values shown.",
                              formatter_class=_HELP)
    sub.add_argument("image", metavar="IMAGE.nc")
    sub.add_argument("-o", "--output", required=True, metavar="DIR", help="output folder")
    sub.add_argument("--overwrite", action="store_true", help="replace existing outputs")
    sub.add_argument("--pair", type=int, nargs=2, metavar=("K1", "K2"),
                     help="channels of s1 s2* (default: [interferometry] pair, else 0 1)")
    sub.add_argument("--looks", type=int, nargs=2, metavar=("ROWS", "COLS"),
                     help="multilook window [pixels] (default: [interferometry] looks, else "
                     "1 1)")
    sub.add_argument("--no-unwrap", action="store_true",
                     help="take the wrapped phase (no SNAPHU): scatterers within half an "
                     "ambiguity height of the focusing grid")
    sub.add_argument("--min-coherence", type=float, metavar="GAMMA",
                     help="coherence below which pixels are not unwrapped and not in the "
                     "point cloud (default: [interferometry] min_coherence, else 0.3)")
    sub.add_argument("--scene", metavar="XML|NAME",
                     help="the scene the image was simulated from: its layover and shadow "
                     "pixels are masked (default: the scene the image records, if any)")
    sub.add_argument("--no-masks", action="store_true",
                     help="no layover/shadow masks even where the image records its scene")
    sub.set_defaults(func=cmd_interferogram)

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
    # no choices=: listing the examples would read data files while the parser is built
    sub.add_argument("--example", default="paper_point_target", metavar="NAME",
                     help="bundled example with a point target to run (an examples/*.toml "
                     "name, e.g. scene_point_target; a wrong name lists them)")
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
