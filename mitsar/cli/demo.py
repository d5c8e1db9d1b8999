"""``mitsar demo``: the paper's point-target experiment end to end, and the bundled examples it
can run."""

from __future__ import annotations

import argparse
import time
from pathlib import Path
from typing import Any

from mitsar.cli.common import log
from mitsar.cli.stages import format_metrics
from mitsar.errors import ParameterError
from mitsar.experiment.examples import example_path, examples_dir
from mitsar.experiment.loading import load_experiment, read_toml
from mitsar.experiment.paper import PAPER_TABLES
from mitsar.io import ProductFileError, check_writable, to_jsonable, write_json
from mitsar.report.pipeline import PipelineFiles, RunFolder, run_pipeline

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
    """Bundled experiments the demo can run: point targets to measure in one acquisition (not
    ambiguity files, not ``[[passes]]``: ``mitsar run`` runs those).

    Read from the example files, so only when ``mitsar demo`` runs (the argument parser lists
    no data files: ``mitsar --help`` works without them)."""
    names = []
    for path in sorted(examples_dir().glob("*.toml")):
        document = read_toml(path)
        measurable = document.get("targets") or (document.get("metrics") or {}).get("target")
        if measurable and "trajectories" not in document and "passes" not in document:
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
    runnable = demo_examples()
    if args.example not in runnable:
        raise ParameterError("mitsar demo", "--example", "a bundled example with a point target "
                             f"in one acquisition (one of {runnable}; 'mitsar run' runs the "
                             "others)", args.example)
    experiment = load_experiment(example_path(args.example))
    out.mkdir(parents=True, exist_ok=True)
    results = run_demo(experiment, paths, overwrite=args.overwrite, progress=not args.quiet,
                       log=lambda message: log(args, message))
    print(demo_summary(experiment, results, out))
    return 0


def run_demo(experiment: Any, paths: dict[str, Path], overwrite: bool = False,
             progress: bool = True, log: Any = None) -> dict[str, Any]:
    """Simulate, focus, measure and plot an experiment, writing ``paths`` (see DEMO_FILES),
    with the one pipeline of ``mitsar run`` (:func:`mitsar.report.pipeline.run_pipeline`).

    Returns
    -------
    dict
        ``raw`` and ``image`` datasets, ``metrics`` (dict), ``seconds`` per step.
    """
    algorithm = experiment.focus.algorithm
    run = RunFolder(paths["raw"].parent, overwrite)
    # absolute: RunFolder takes relative names relative to its folder ('-o out' wrote out/out/)
    where = {key: str(Path(path).resolve()) for key, path in paths.items()}
    files = PipelineFiles(raw=where["raw"], range_figure=where["range_figure"],
                          background_figure=where["histogram_figure"], image=where["image"],
                          image_figure=where["image_figure"], cuts_figure=where["cuts_figure"])
    result = run_pipeline(run, experiment, [algorithm], progress=progress, strict=True,
                          files=files, log=log)
    start = time.perf_counter()
    metrics = to_jsonable(result.metrics[algorithm])
    metrics["paper_table4_bpa"] = PAPER_TABLE4_BPA
    write_json(metrics, paths["metrics"], overwrite=overwrite)
    steps = run.record["steps"]
    seconds = {"simulate": steps["simulate"], "focus": steps[f"focus {algorithm}"],
               "metrics": steps[f"metrics {algorithm}"] + time.perf_counter() - start,
               "plots": run.plot_seconds}
    return {"raw": result.raw, "image": result.images[algorithm], "metrics": metrics,
            "seconds": seconds}


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
