"""``mitsar demo``: the paper's point-target experiment end to end, and the bundled examples it
can run."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt

from mitsar.cli.common import log
from mitsar.cli.products import format_metrics
from mitsar.experiment.examples import example_path, examples_dir
from mitsar.experiment.loading import load_experiment, read_toml
from mitsar.experiment.paper import PAPER_TABLES
from mitsar.experiment.runs import run_focus, run_metrics, run_simulation
from mitsar.io import ProductFileError, check_writable, save, to_jsonable, write_json
from mitsar.plots.products import (
    background_samples,
    plot_background_histograms,
    plot_cuts,
    plot_image,
    plot_range_compressed,
    save_figure,
    target_marks,
)

__all__ = ["DEMO_FILES", "PAPER_TABLE4_BPA", "cmd_demo", "demo_examples", "demo_summary",
           "run_demo"]

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


def demo_examples() -> list[str]:
    """Bundled experiments the demo can run: point targets to measure (not ambiguity files)."""
    names = []
    for path in sorted(examples_dir().glob("*.toml")):
        document = read_toml(path)
        measurable = document.get("targets") or (document.get("metrics") or {}).get("target")
        if measurable and "trajectories" not in document:
            names.append(path.stem)
    return names


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
                       log=lambda message: log(args, message))
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
