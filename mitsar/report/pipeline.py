"""One run of an experiment: simulate -> focus -> measure -> plot, into a folder.

:func:`run_pipeline` is the one place that chains the stages; ``mitsar run``
(:func:`mitsar.report.run.run_experiment`) and ``mitsar demo`` (:mod:`mitsar.cli.demo`) both
call it, with their own file names (:class:`PipelineFiles`). What the figures and metrics need
(targets, metrics target, ISLR extent) they read from the products
(:mod:`mitsar.products`), not from the experiment. In a resumable run (a :class:`RunFolder`
with a work folder, ``mitsar run``) the stages ``simulate`` and ``focus`` are recorded as they
finish and reused after an interruption (docs/reliability.md §5).
"""

from __future__ import annotations

import dataclasses
import time
from collections.abc import Callable, Sequence
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import xarray as xr

from mitsar.errors import MitsarError, ParameterError
from mitsar.experiment.options import Experiment
from mitsar.experiment.runs import run_focus, run_metrics, run_simulation, simulate_to
from mitsar.io import WorkFolder, load, save
from mitsar.plots.figures import (
    background_samples,
    beam_range_marks,
    plot_background_histograms,
    plot_cuts,
    plot_image,
    plot_range_compressed,
    save_figure,
    target_marks,
)
from mitsar.plots.footprint import scene_range_marks
from mitsar.plots.navigation import plot_autofocus_phase
from mitsar.products.requests import metrics_request

__all__ = ["PipelineFiles", "PipelineResult", "RunFolder", "run_pipeline"]


class RunFolder:
    """An output folder and the record being built in it, with a timer per step.

    Parameters
    ----------
    out : Path
        The folder (file names below are relative to it; absolute ones are kept).
    overwrite : bool
        Replace existing files.
    work : WorkFolder, optional
        The resumable run's work folder (``mitsar run``; ``out`` lies inside it): a stage whose
        products it records as finished is reused (:meth:`reuse`) instead of run again, and a
        stage's products are read back from their files once written (:meth:`finished`), so
        that what follows reads the same bits whether the stage ran now or before an
        interruption.
    """

    def __init__(self, out: Path, overwrite: bool, work: WorkFolder | None = None) -> None:
        self.out, self.overwrite, self.work = Path(out), overwrite, work
        self.record: dict[str, Any] = {"steps": {}, "products": [], "figures": [],
                                       "metrics": {}, "tables": [], "warnings": []}
        self.plot_seconds = 0.0

    def reuse(self, stage: str, files: Sequence[str]) -> list[xr.Dataset] | None:
        """The products of ``stage`` when an interrupted run finished it (listed, with the
        stage's recorded step times), else None (no work folder, not finished, or a file
        missing)."""
        if self.work is None or not self.work.done(stage):
            return None
        paths = [self.out / file for file in files]
        if not all(path.exists() for path in paths):
            return None
        self.record["steps"].update(self.work.info(stage).get("steps", {}))
        self.record["products"].extend(str(file) for file in files)
        return [load(path) for path in paths]

    def finished(self, stage: str, files: Sequence[str], steps: Sequence[str] = ()
                 ) -> list[xr.Dataset] | None:
        """Record ``stage`` (its products ``files`` written) as finished in the work folder and
        return the products read back; None without a work folder."""
        if self.work is None:
            return None
        self.work.mark(stage, {"files": list(files), "steps": {
            step: self.record["steps"][step] for step in steps if step in self.record["steps"]}})
        return [load(self.out / file) for file in files]

    def stage_done(self, stage: str, files: Sequence[str]) -> bool:
        """True when an interrupted run finished ``stage`` and its files are there (a stage
        without products, e.g. a slow figure, that need not run again)."""
        return (self.work is not None and self.work.done(stage)
                and all((self.out / file).exists() for file in files))

    def step(self, name: str, start: float) -> None:
        """Record the wall time [s] of step ``name`` started at ``start``."""
        self.record["steps"][name] = round(time.perf_counter() - start, 3)

    def figure(self, figure: Any, file: str, title: str, caption: str = "",
               section: str | None = None) -> None:
        """Save a figure (110 dpi) and list it in the record (shown in the report's
        ``section``, e.g. "Autofocus", instead of "Figures" when given)."""
        start = time.perf_counter()
        save_figure(figure, self.out / file, overwrite=self.overwrite, dpi=110)
        plt.close(figure)
        entry = {"file": str(file), "title": title, "caption": caption}
        if section:
            entry["section"] = section
        self.record["figures"].append(entry)
        self.plot_seconds += time.perf_counter() - start

    def product(self, data: Any, file: str) -> None:
        """Save a product and list it in the record."""
        save(data, self.out / file, overwrite=self.overwrite)
        self.record["products"].append(str(file))

    def warn(self, message: str) -> None:
        """Record a warning (a step that could not run)."""
        self.record["warnings"].append(message)


@dataclass(frozen=True)
class PipelineFiles:
    """File names of one run; ``{algorithm}`` is replaced by the focusing algorithm."""

    raw: str = "raw.nc"
    range_figure: str = "range_compressed.png"
    background_figure: str = "background.png"
    image: str = "image_{algorithm}.nc"
    image_figure: str = "image_{algorithm}.png"
    cuts_figure: str = "cuts_{algorithm}.png"
    autofocus_figure: str = "autofocus_{algorithm}.png"


@dataclass
class PipelineResult:
    """What :func:`run_pipeline` made: the raw product, and per algorithm the image and its
    metrics (a dict, or the reason it could not be measured)."""

    raw: xr.Dataset
    images: dict[str, xr.Dataset] = dataclasses.field(default_factory=dict)
    metrics: dict[str, Any] = dataclasses.field(default_factory=dict)


def run_pipeline(run: RunFolder, experiment: Experiment, algorithms: Sequence[str], *,
                 raw: xr.Dataset | None = None, scene: Any = None, progress: bool = False,
                 strict: bool = False, files: PipelineFiles = PipelineFiles(),
                 log: Callable[[str], None] | None = None,
                 after_simulation: Callable[[xr.Dataset], None] | None = None
                 ) -> PipelineResult:
    """Simulate an experiment, focus it with each algorithm, measure and plot each image.

    Parameters
    ----------
    run : RunFolder
        Where the products and figures go, and the record of steps, metrics and warnings.
    experiment : Experiment
        The loaded experiment.
    algorithms : sequence of str
        Focusing algorithms, in order.
    raw : xarray.Dataset, optional
        The raw product when it is already simulated (then not simulated or saved again).
    scene : mitsuba.Scene, optional
        The experiment's loaded scene: the images' near / centre / far range marks come from
        its surfaces (else from the beam on a horizontal floor).
    progress : bool
        Show progress bars.
    strict : bool
        Raise when an image cannot be focused or measured (else record a warning and go on).
    files : PipelineFiles
        Output file names.
    log : callable, optional
        Receives one line per step.
    after_simulation : callable, optional
        Called with the raw product before focusing (further figures of the acquisition).

    Returns
    -------
    PipelineResult
    """
    log = log or (lambda message: None)
    if raw is None:
        raw = _simulated(run, experiment, files, progress, log)
    result = PipelineResult(raw)
    label = f" (pass {raw.attrs['pass']})" if "pass" in raw.attrs else ""
    for message in str(raw.attrs.get("reception_warnings", "")).splitlines():  # issue 27
        run.warn(f"reception{label}: {message}")  # echoes a real radar cannot receive
    figure, ax = plt.subplots(figsize=(8, 5), layout="constrained")
    plot_range_compressed(raw, ax=ax)
    run.figure(figure, files.range_figure, "Range-compressed data",
               "slant range across, slow time down (paper eq. 1, one FFT per sweep)")
    if "background_reflectivity" in raw.variables:
        level = None if experiment.background is None else experiment.background.cell_rcs_db
        label = (f"{level:g} dB background, first sweep" if level is not None
                 else "background, first sweep")
        axes = plot_background_histograms(*background_samples(raw), label=label)
        run.figure(axes[0].figure, files.background_figure, "Background reflectivity",
                   "amplitude against the Rayleigh density and phase against the uniform one, "
                   "one sweep (paper Fig. 7)")
    if after_simulation is not None:
        after_simulation(raw)
    for algorithm in algorithms:
        _focus_and_measure(run, experiment, result, algorithm, scene, progress, strict, files,
                           log)
    return result


def _simulated(run: RunFolder, experiment: Experiment, files: PipelineFiles, progress: bool,
               log: Callable[[str], None]) -> xr.Dataset:
    """The raw product of the stage ``simulate``: reused from an interrupted run, or simulated
    (in a resumable run chunk by chunk, :func:`mitsar.experiment.runs.simulate_to`, so that
    an interruption inside it resumes from the last chunk), saved and listed."""
    stage = f"simulate {files.raw}"
    reused = run.reuse(stage, [files.raw])
    if reused is not None:
        log(f"simulate: reusing {files.raw} of the interrupted run")
        return reused[0]
    log("simulating raw data ...")
    start = time.perf_counter()
    if run.work is None:
        raw = run_simulation(experiment, progress=progress)
        run.step("simulate", start)
        run.product(raw, files.raw)
        return raw
    simulate_to(experiment, run.out / files.raw, overwrite=True, progress=progress, log=log)
    run.step("simulate", start)
    run.record["products"].append(str(files.raw))
    return run.finished(stage, [files.raw], ["simulate"])[0]


def _focus_and_measure(run: RunFolder, experiment: Experiment, result: PipelineResult,
                       algorithm: str, scene: Any, progress: bool, strict: bool,
                       files: PipelineFiles, log: Callable[[str], None]) -> None:
    options = dataclasses.replace(experiment.focus, algorithm=algorithm)
    file = files.image.format(algorithm=algorithm)
    stage = f"focus {file}"
    reused = run.reuse(stage, [file])
    if reused is not None:
        log(f"focus: reusing {file} of the interrupted run")
        image = reused[0]
    else:
        log(f"focusing ({algorithm.upper()}) ...")
        start = time.perf_counter()
        try:
            image = run_focus(result.raw, options, progress=progress)
        except (ParameterError, MitsarError) as error:
            if strict:
                raise
            run.warn(f"{algorithm}: not focused: {error}")
            return
        run.step(f"focus {algorithm}", start)
        run.product(image, file)
        image = (run.finished(stage, [file], [f"focus {algorithm}"]) or [image])[0]
    result.images[algorithm] = image
    if image.attrs.get("autofocus_warning"):  # a failed or degrading autofocus, in the report
        run.warn(f"{algorithm}: {image.attrs['autofocus_warning']}")
    if "autofocus_phase" in image.variables:
        _autofocus(run, result.raw, image, algorithm, files)
    figure, ax = plt.subplots(figsize=(7, 6), layout="constrained")
    marks = (beam_range_marks(image) if scene is None
             else scene_range_marks(image, result.raw, scene))
    plot_image(image, ax=ax, marks=target_marks(image), range_marks=marks)
    run.figure(figure, files.image_figure.format(algorithm=algorithm),
               f"Image, {algorithm.upper()}",
               f"{options.window} window, azimuth resolution "
               f"{options.azimuth_resolution or 'whole beam'} m; dB re peak")
    if not strict and metrics_request(image)[0] is None:
        return
    log("measuring the impulse response ...")
    start = time.perf_counter()
    try:
        metrics = run_metrics(image)
    except (ParameterError, MitsarError, ValueError) as error:
        if strict:
            raise
        run.warn(f"{algorithm}: not measured: {error}")
        run.record["metrics"][algorithm] = result.metrics[algorithm] = str(error)
        return
    run.step(f"metrics {algorithm}", start)
    run.record["metrics"][algorithm] = result.metrics[algorithm] = metrics
    for warning in metrics.get("warnings", []):
        run.warn(f"{algorithm}: {warning}")
    axes = plot_cuts(image, metrics)
    run.figure(axes[0].figure, files.cuts_figure.format(algorithm=algorithm),
               f"Cuts, {algorithm.upper()}",
               "range and azimuth cuts through the peak, IRW / PSLR / ISLR in the legends")


AUTOFOCUS_RECORD = ("method", "iterations", "converged", "scatterers", "entropy_before",
                    "entropy_after", "applied", "seconds", "warning")
"""Attributes ``autofocus_<key>`` of an autofocused image recorded in ``record["autofocus"]``
(:func:`mitsar.focus.autofocus.driver.run_autofocus`)."""


def _autofocus(run: RunFolder, raw: xr.Dataset, image: xr.Dataset, algorithm: str,
               files: PipelineFiles) -> None:
    """Record an autofocused image's results (``record["autofocus"][algorithm]``, the report's
    autofocus table) and draw its estimated phase error per sweep (against the injected one
    when the raw product knows the true track)."""
    entry: dict[str, Any] = {}
    for key in AUTOFOCUS_RECORD:
        value = image.attrs.get(f"autofocus_{key}")
        if value is None:
            continue
        if key in ("converged", "applied"):
            value = bool(value)
        elif hasattr(value, "item"):  # a NumPy scalar read back from netCDF
            value = value.item()
        entry[key] = value
    run.record.setdefault("autofocus", {})[algorithm] = entry
    method = str(entry.get("method", "autofocus"))
    ax = plot_autofocus_phase(raw, image)
    run.figure(ax.figure, files.autofocus_figure.format(algorithm=algorithm),
               f"Autofocus phase, {algorithm.upper()}",
               f"{method.upper()} estimate of the phase error per sweep (mean and linear trend "
               "removed: they only shift the image), against the phase the navigation error "
               "puts on the metrics target when the raw product knows the true track; "
               "docs/autofocus.md", section="Autofocus")
