"""``mitsar run``: everything an experiment asks for, into one folder with one report.

:func:`run_experiment` takes an experiment file and, in an output folder:

1. an **ambiguity** file (``[trajectories]`` / ``[ambiguity]``, ``docs/ambiguity.md``) runs the
   gradient method (:func:`mitsar.ambiguity.run_ambiguity_experiment`) and reports its figures
   and the trajectory comparison;
2. any other experiment (``docs/experiments.md``) is **simulated** (``raw.nc``; the
   range-compressed figure; true and navigation tracks when it has navigation errors), its
   beam's **footprint** on a scene (paper Figs. 12, 14), its multipath **rays** drawn when it
   traces a scene with ``max_depth > 1``
   (:func:`mitsar.experiment.rays.run_rays`), then **focused** with every requested algorithm
   (``image_<algorithm>.nc`` and figures), **measured** at its target (IRW, PSLR, ISLR, with the
   cuts), and optionally put through a **Monte Carlo** over background realisations; a radar
   with two or more receive channels also gets the **interferogram** of its BPA image (else
   the first algorithm's)
   (``[interferometry]``; :mod:`mitsar.experiment.interferometry`: ``interferometry/`` with
   the product, the point cloud and the maps);
   an experiment with ``[[passes]]`` gets one raw product, image and metrics per pass
   (``raw_pass<i>.nc``, ``image_<algorithm>_pass<i>.nc``, metrics ``"<algorithm> pass<i>"``;
   :func:`pass_files`), all focused on the experiment's ``[focus.grid]``, with a table and a
   figure of the passes (``record["passes"]``), and on a grid in the scene frame the image of
   all passes combined coherently (``image_<algorithm>_passes.nc``, metrics
   ``"<algorithm> passes"``; :func:`mitsar.experiment.runs.run_focus_passes`);
3. the run record ``run.json`` (configuration, metrics, figures, timings, seeds, versions) and
   ``report.html`` (:func:`mitsar.report.html.build_report`) are written last.

A step that cannot run for this experiment (an algorithm that refuses the track, a target
outside the image) is reported as a warning in the record and the report, and the run goes on.
Outputs are written atomically and never replace files unless ``overwrite``.

The run is made in a work folder beside the output folder (``.DIR.partial``,
:class:`mitsar.io.WorkFolder`) and moved into it when finished, ``run.json`` and
``report.html`` last. Its stages are recorded there as they finish (the raw product, chunk by
chunk; each image; the Monte Carlo realisations and their cuts), so a run interrupted by SIGINT
or SIGKILL and started again with the same inputs reuses them, and what follows a stage reads
its products from their files either way: the products and figures of a resumed run are those
of an uninterrupted one, bit for bit (docs/reliability.md §5).
"""

from __future__ import annotations

import dataclasses
import math
import sys
import time
from collections.abc import Sequence
from pathlib import Path
from typing import Any

import matplotlib.pyplot as plt
import numpy as np

from mitsar.ambiguity.run import run_ambiguity_experiment
from mitsar.errors import MitsarError, ParameterError
from mitsar.experiment import montecarlo
from mitsar.experiment.interferometry import (
    INTERFEROMETRY_FILES,
    interferometry_figure_entries,
    interferometry_summary,
    run_interferometry,
    write_interferometry,
)
from mitsar.experiment.loading import apply_overrides, experiment_from_dict, read_toml
from mitsar.experiment.mapping import (
    MAPPING_FILES,
    MAPPING_FOLDER,
    mapping_figure,
    mapping_summary,
    run_mapping,
)
from mitsar.experiment.options import ALGORITHMS, Experiment
from mitsar.experiment.paper import paper_table
from mitsar.experiment.rays import run_rays
from mitsar.experiment.runs import (
    pass_experiment,
    run_focus_passes,
    run_metrics,
    simulate_passes,
)
from mitsar.features.scores import scores_dataset
from mitsar.io import ProductFileError, WorkFolder, check_writable, scene_digest, write_json
from mitsar.plots import navigation as plots_navigation
from mitsar.plots.figures import plot_cuts, plot_image, target_marks
from mitsar.plots.footprint import plot_footprint
from mitsar.plots.preview import plot_preview
from mitsar.products.requests import metrics_request
from mitsar.report.html import RUN_RECORD, build_report, provenance
from mitsar.report.pipeline import PipelineFiles, PipelineResult, RunFolder, run_pipeline
from mitsar.report.preview import scene_or_stand_in
from mitsar.scene import load_scene

__all__ = ["paper_comparison", "run_experiment", "scene_label"]


def run_title(experiment: Experiment) -> str:
    """A figure title for an experiment: its name or its file's stem."""
    return experiment.name or (experiment.source.stem if experiment.source else "experiment")


def _is_ambiguity(document: dict[str, Any]) -> bool:
    return "trajectories" in document or ("ambiguity" in document and "targets" not in document)


def run_experiment(path: str | Path, out_dir: str | Path, *, overrides: Sequence[str] = (),
                   algorithms: Sequence[str] | None = None, realisations: int = 0,
                   overwrite: bool = False, progress: bool = False) -> Path:
    """Run an experiment file completely and write its report (module docstring).

    Parameters
    ----------
    path : path-like
        An experiment or ambiguity TOML file.
    out_dir : path-like
        Output folder (created).
    overrides : sequence of str
        ``"key=value"`` changes (the CLI's ``--set``; experiments only).
    algorithms : sequence of str, optional
        Focusing algorithms (default: the experiment's ``[focus] algorithm``).
    realisations : int
        Monte Carlo realisations over the background (0: none).
    overwrite : bool
        Replace existing outputs.
    progress : bool
        Show progress bars.

    Returns
    -------
    Path
        ``report.html``.

    Raises
    ------
    OutputExistsError
        If the folder holds a run record (or, when the run ends, any file it would write) and
        ``overwrite`` is false; the finished run then waits in the work folder and a rerun
        with ``overwrite`` only moves it.
    MitsarError
        If another process is making the same run (its work folder is locked).
    """
    path, out = Path(path), Path(out_dir)
    out.parent.mkdir(parents=True, exist_ok=True)
    if out.exists() and not out.is_dir():
        raise ProductFileError(f"{out}: is a file, expected an output folder")
    if out.is_dir():
        check_writable(out / RUN_RECORD, overwrite)
    document = read_toml(path)
    ambiguity = _is_ambiguity(document)
    if ambiguity and overrides:
        raise ParameterError(str(path), "--set", "no overrides for an ambiguity file "
                             "(edit the file)", list(overrides))
    experiment = None if ambiguity else experiment_from_dict(
        apply_overrides(document, overrides, str(path)), source=path)
    inputs = {"command": "run", "document": document, "overrides": list(overrides),
              "algorithms": list(algorithms or []), "realisations": int(realisations),
              "scene": scene_digest(path, document.get("scene"))}
    say = (lambda message: print(message, file=sys.stderr, flush=True)) if progress else None
    with WorkFolder(out, inputs, command="run", log=say) as work:
        folder = work.file(RUN_FOLDER)
        folder.mkdir(exist_ok=True)
        run = RunFolder(folder, overwrite=True, work=work)
        if experiment is None:
            _ambiguity(run, path, document, progress)
        else:
            _experiment(run, experiment, algorithms, realisations, progress)
        run.record.setdefault("title", document.get("name") or path.stem)
        run.record.setdefault("description", document.get("description", ""))
        run.record["source"] = str(path.resolve())
        if work.resumed:
            run.record["resumed"] = list(work.resumed)
        write_json(run.record, folder / RUN_RECORD, overwrite=True)
        report = build_report(folder)
        work.move_folder(folder, out, overwrite=overwrite, last=(RUN_RECORD, report.name))
        work.remove()
    return out / report.name


def _resolution_text(required: Any) -> str:
    """A required resolution [m]: one number, or range and azimuth."""
    values = [float(v) for v in np.ravel(required)]
    if len(values) == 1 or values[0] == values[1]:
        return f"{values[0]:g} m"
    return f"{values[0]:g} m (range) x {values[1]:g} m (azimuth)"


def _ambiguity_heading(key: str) -> str:
    """A column of the ambiguity table: ``fraction_outside_beam`` -> "outside the beam [%]",
    ``surface_area`` -> "surface area [m²]"."""
    if key.startswith("fraction_"):
        words = key.removeprefix("fraction_").replace("_", " ")
        return ("outside the beam" if words == "outside beam" else words) + " [%]"
    if key.endswith("_area"):
        return key.replace("_", " ") + " [m²]"
    return key.replace("_", " ")


def _ambiguity_value(key: str, value: Any) -> Any:
    """A fraction as a percentage; other values as they are."""
    if key.startswith("fraction_") and isinstance(value, int | float):
        return 100.0 * float(value)
    return value


def _ambiguity_figure(stem: str) -> tuple[str, str]:
    """Title and caption of an ambiguity figure from its file name
    (``ambiguity_<trajectory>_<kind>`` or ``comparison``;
    :func:`mitsar.ambiguity.plots.plot_ambiguity`)."""
    kinds = {"maps": ("maps", "per surface: status, best range and azimuth resolution"),
             "3d": ("3-D view", "status of every surface point"),
             "timeline": ("time line", "resolution reached along the track")}
    if stem == "comparison":
        return "Trajectories compared", "area resolved per surface and status from above"
    for kind, (title, caption) in kinds.items():
        if stem.startswith("ambiguity_") and stem.endswith(f"_{kind}"):
            name = stem.removeprefix("ambiguity_").removesuffix(f"_{kind}")
            return f"Ambiguity, {name}: {title}", f"gradient method, {caption}"
    return stem, "gradient-method figure"


RUN_FOLDER = "run"
"""Sub-folder of a ``mitsar run``'s work folder (:class:`mitsar.io.WorkFolder`) where the run
is made; moved into the output folder when finished."""


def _ambiguity(run: RunFolder, path: Path, document: dict[str, Any], progress: bool) -> None:
    start = time.perf_counter()
    summary = run_ambiguity_experiment(path, run.out / "ambiguity", overwrite=run.overwrite,
                                       figures=True, progress=progress)
    run.step("ambiguity", start)
    run.record.update(kind="ambiguity", experiment=document, provenance=provenance())
    overall = {name: entry["overall"] for name, entry in summary["trajectories"].items()}
    keys = sorted({key for fractions in overall.values() for key in fractions})
    run.record["tables"].append({
        "title": "Ambiguity: parts of the surfaces observed at "
                 f"{_resolution_text(summary['required_resolution'])}",
        "header": ["trajectory"] + [_ambiguity_heading(key) for key in keys],
        "rows": [[name] + [_ambiguity_value(key, fractions.get(key)) for key in keys]
                 for name, fractions in overall.items()]})
    for file in summary.get("files", []):
        name = Path(file).name
        relative = f"ambiguity/{name}"
        if name.endswith(".png"):
            title, caption = _ambiguity_figure(Path(name).stem)
            run.record["figures"].append({"file": relative, "title": title,
                                          "caption": caption + " (docs/ambiguity.md)"})
        else:
            run.record["products"].append(relative)


def _experiment(run: RunFolder, experiment: Experiment, algorithms: Sequence[str] | None,
                realisations: int, progress: bool) -> None:
    seeds: dict[str, Any] = {"simulation": experiment.simulation.seed}
    if experiment.navigation is not None:
        seeds["navigation"] = experiment.navigation.seed
    if experiment.passes:
        seeds["passes"] = [experiment.pass_seed(i) for i in range(len(experiment.passes))]
        seeds["pass_navigation"] = [None if p.navigation is None else p.navigation.seed
                                    for p in experiment.passes]
    run.record.update(kind="scene" if experiment.scene is not None else "point targets",
                      experiment=experiment.config, provenance=provenance(seeds))
    chosen = list(algorithms) if algorithms else [experiment.focus.algorithm]
    unknown = [a for a in chosen if a not in ALGORITHMS]
    if unknown:
        raise ParameterError("run", "algorithms", f"names among {ALGORITHMS}", unknown)
    # The scene is loaded once, here, for every figure that draws it.
    scene = None if experiment.scene is None else load_scene(experiment.scene)
    if experiment.passes:
        _passes(run, experiment, chosen, scene, progress)
        if experiment.radar.channel_count >= 2:
            run.warn("interferometry: not formed in a multi-pass run (form it from one pass's "
                     "image: mitsar interferogram image_bpa_pass0.nc)")
        if realisations > 0:
            run.warn("montecarlo: not run for a multi-pass experiment")
        return
    # 1. simulate, 2. figures of the acquisition, 3. focus and measure with every algorithm
    result = run_pipeline(run, experiment, chosen, scene=scene, progress=progress,
                          after_simulation=lambda raw: _acquisition_figures(run, experiment,
                                                                            raw, scene))
    comparison = paper_comparison(result.metrics, experiment.background)
    if comparison is not None:
        run.record["tables"].append(comparison)
    if experiment.radar.channel_count >= 2:
        _interferometry(run, experiment, result, progress)
    # 4. Monte Carlo
    if realisations > 0:
        start = time.perf_counter()
        summary = montecarlo.run(experiment, realisations, chosen,
                                 out_dir=run.out / "montecarlo", progress=progress)
        run.step("montecarlo", start)
        run.record["tables"].append(_montecarlo_table(summary, realisations,
                                                      experiment.background))
        files = {algorithm: f"montecarlo/cuts_{algorithm}.png" for algorithm in chosen}
        missing = [a for a, file in files.items() if not run.stage_done(f"figure {file}",
                                                                         [file])]
        # each realisation simulated once and focused by every algorithm still to draw
        drawn = (montecarlo.realisations_cuts(experiment, missing, min(realisations, 5),
                                              progress=progress) if missing else {})
        for algorithm in chosen:
            file = files[algorithm]
            if algorithm in drawn:
                montecarlo.plot_realisation_cuts(drawn[algorithm], run.out / file,
                                                 overwrite=True)
                if run.work is not None:
                    run.work.mark(f"figure {file}")
            run.record["figures"].append({
                "file": file, "title": f"Realisations, {algorithm.upper()}",
                "caption": "range and azimuth cuts of several realisations over the response "
                           "on an absorbing background (paper Figs. 8-9)"})


def pass_files(index: int) -> PipelineFiles:
    """File names of pass ``index`` in a ``mitsar run`` folder: ``raw_pass<i>.nc``,
    ``image_<algorithm>_pass<i>.nc`` and their figures."""
    return PipelineFiles(raw=f"raw_pass{index}.nc",
                         range_figure=f"range_compressed_pass{index}.png",
                         background_figure=f"background_pass{index}.png",
                         image=f"image_{{algorithm}}_pass{index}.nc",
                         image_figure=f"image_{{algorithm}}_pass{index}.png",
                         cuts_figure=f"cuts_{{algorithm}}_pass{index}.png",
                         autofocus_figure=f"autofocus_{{algorithm}}_pass{index}.png")


def _passes(run: RunFolder, experiment: Experiment, algorithms: Sequence[str], scene: Any,
            progress: bool) -> None:
    """Every pass of a multi-pass experiment: simulated together (one scene, one scatterer
    set: :func:`mitsar.experiment.runs.simulate_passes`), then each saved, focused with every
    algorithm on the experiment's grid and measured as a one-pass run (:func:`pass_files`);
    metrics, steps and figures named by pass, a table of the passes and a figure of their
    tracks."""
    names = [pass_files(index).raw for index in range(len(experiment.passes))]
    raws = run.reuse("simulate passes", names)
    if raws is None:
        start = time.perf_counter()
        raws = simulate_passes(experiment, progress=progress, scene=scene)
        run.step("simulate", start)
        for raw, name in zip(raws, names, strict=True):
            run.product(raw, name)
        raws = run.finished("simulate passes", names, ["simulate"]) or raws
    rows, summary = [], []
    for index, raw in enumerate(raws):
        files = pass_files(index)
        single = pass_experiment(experiment, index)
        marks = (len(run.record["figures"]), len(run.record["warnings"]))
        run_pipeline(run, single, algorithms, raw=raw, scene=scene, progress=progress,
                     files=files, after_simulation=None if index else (
                         lambda raw, single=single: _acquisition_figures(run, single, raw,
                                                                         scene)))
        _name_by_pass(run, index, algorithms, marks)
        positions = raw["platform_position"].values
        seed = int(raw.attrs["pass_seed"])
        chosen = experiment.passes[index]
        rows.append([index, chosen.name, [round(float(v), 4) for v in positions[0]],
                     [round(float(v), 4) for v in positions[-1]], chosen.look.off_nadir_deg,
                     chosen.look.squint_deg, seed])
        summary.append({"index": index, "name": chosen.name, "raw": files.raw, "seed": seed,
                        "navigation_seed": raw.attrs.get("pass_navigation_seed"),
                        "offset": list(chosen.offset), "sweeps": int(raw.sizes["sweep"])})
    run.record["passes"] = summary
    run.record["tables"].append({
        "title": f"Passes ({len(raws)}): first and last antenna position, look and noise seed",
        "header": ["pass", "name", "first position [m]", "last position [m]",
                   "off-nadir [deg]", "squint [deg]", "noise seed"], "rows": rows})
    run.figure(_pass_tracks(raws, experiment), "passes.png", "Passes",
               "antenna tracks of every pass, seen from above and across the tracks")
    if len(raws) > 1:
        _combined(run, experiment, raws, algorithms, progress)
    if experiment.mapping is not None:
        _mapping(run, experiment, raws, scene)


def _mapping(run: RunFolder, experiment: Experiment, raws: Sequence[Any], scene: Any) -> None:
    """``[mapping]``: the map of the scene from every pass and its scores against the scene
    (:func:`mitsar.experiment.mapping.run_mapping`): the detections and the scores as products
    in :data:`MAPPING_FOLDER`, the scores and the features' verdicts as tables, the map over
    the truth as a figure; ``record["mapping"]`` holds the summary."""
    start = time.perf_counter()
    try:
        result = run_mapping(raws, scene if scene is not None else experiment.scene,
                             experiment.mapping)
    except MitsarError as error:
        run.warn(f"mapping: not made: {error}")
        return
    run.step("mapping", start)
    (run.out / MAPPING_FOLDER).mkdir(exist_ok=True)
    run.product(result.detections, f"{MAPPING_FOLDER}/{MAPPING_FILES['detections']}")
    run.product(scores_dataset(result.scores), f"{MAPPING_FOLDER}/{MAPPING_FILES['scores']}")
    summary = mapping_summary(result)
    run.record["mapping"] = summary
    options = experiment.mapping
    run.record["tables"].append({
        "title": f"Map of the scene from {len(raws)} passes against its ground truth "
                 f"({options.method.upper()}-CFAR, pfa {options.pfa:g}, tau {options.tau:g} m; "
                 "docs/features.md)",
        "header": ["score", "value", "units", "meaning"],
        "rows": [[name, round(value, 4), units, meaning]
                 for name, value, units, meaning in summary["scores"]],
        "formats": [None, ".4g"]})  # one quantity per row
    if summary["features"]:
        run.record["tables"].append({
            "title": "Map features of the scene (found within one resolution cell, missed, or "
                     "not visible from the passes)",
            "header": ["kind", "status", "position [m]", "localisation error [m]"],
            "rows": [[f["kind"], f["status"], f["position"], f["error_m"]]
                     for f in summary["features"]]})
    run.figure(mapping_figure(result), f"{MAPPING_FOLDER}/{MAPPING_FILES['figure']}",
               "Map of the scene",
               f"{summary['detections']} point features; detected cells over the scene's "
               "surface, scored features found (circle) or not (cross)")


COMBINED_IMAGE = "image_{algorithm}_passes.nc"
"""The image of all passes combined coherently, in a ``mitsar run`` folder."""


def _combined(run: RunFolder, experiment: Experiment, raws: Sequence[Any],
              algorithms: Sequence[str], progress: bool) -> None:
    """Every pass back-projected onto the experiment's grid and summed coherently
    (:func:`mitsar.experiment.runs.run_focus_passes`), per back-projection algorithm asked;
    saved, drawn and measured as ``"<algorithm> passes"``."""
    grid = experiment.focus.grid
    if grid is None or grid.get("kind", "slant") == "slant":
        run.warn("passes: not combined: that needs a [focus.grid] in the scene frame "
                 "(kind = 'plane' or 'points'); a slant grid belongs to one track")
        return
    for algorithm in algorithms:
        if algorithm not in ("bpa", "ffbp"):
            run.warn(f"passes: {algorithm}: not combined (back-projection only: -a bpa)")
            continue
        options = dataclasses.replace(experiment.focus, algorithm=algorithm, autofocus=None)
        label, file = f"{algorithm} passes", COMBINED_IMAGE.format(algorithm=algorithm)
        reused = run.reuse(f"focus {file}", [file])
        if reused is not None:
            image = reused[0]
        else:
            start = time.perf_counter()
            try:
                image = run_focus_passes(list(raws), options, progress=progress)
            except (ParameterError, MitsarError) as error:
                run.warn(f"passes: {algorithm}: not combined: {error}")
                continue
            run.step(f"focus {label}", start)
            run.product(image, file)
            image = (run.finished(f"focus {file}", [file], [f"focus {label}"]) or [image])[0]
        figure, ax = plt.subplots(figsize=(7, 6), layout="constrained")
        plot_image(image, ax=ax, marks=target_marks(image))
        run.figure(figure, f"image_{algorithm}_passes.png",
                   f"Image, {algorithm.upper()}, {len(raws)} passes combined",
                   "every pass back-projected onto the same pixels, complex images averaged "
                   f"(elevation resolution {image.attrs.get('elevation_resolution', 'n/a')} m "
                   "for the stack); dB re peak")
        if metrics_request(image)[0] is None:
            continue
        start = time.perf_counter()
        try:
            metrics = run_metrics(image)
        except (ParameterError, MitsarError, ValueError) as error:
            run.warn(f"passes: {algorithm}: not measured: {error}")
            continue
        run.step(f"metrics {label}", start)
        run.record["metrics"][label] = metrics
        axes = plot_cuts(image, metrics)
        run.figure(axes[0].figure, f"cuts_{algorithm}_passes.png",
                   f"Cuts, {algorithm.upper()}, {len(raws)} passes combined",
                   "range and azimuth cuts through the peak of the combined image")


def _name_by_pass(run: RunFolder, index: int, algorithms: Sequence[str],
                  marks: tuple[int, int]) -> None:
    """Suffix what one pass's pipeline recorded (metrics, steps, figure titles, warnings)
    with its pass, so that the passes do not overwrite each other in the record."""
    label = f"pass{index}"
    for algorithm in algorithms:
        if algorithm in run.record["metrics"]:
            run.record["metrics"][f"{algorithm} {label}"] = run.record["metrics"].pop(algorithm)
        if algorithm in run.record.get("autofocus", {}):
            run.record["autofocus"][f"{algorithm} {label}"] = run.record["autofocus"].pop(
                algorithm)
        for step in (f"focus {algorithm}", f"metrics {algorithm}"):
            if step in run.record["steps"]:
                run.record["steps"][f"{step} {label}"] = run.record["steps"].pop(step)
    for entry in run.record["figures"][marks[0]:]:
        entry["title"] = f"{entry['title']} (pass {index})"
    run.record["warnings"][marks[1]:] = [f"pass {index}: {warning}"
                                         for warning in run.record["warnings"][marks[1]:]]


def _pass_tracks(raws: Sequence[Any], experiment: Experiment) -> Any:
    """The passes' antenna tracks from above (x, y; targets marked) and across (y, z: a
    straight leg along x is a point there, so centimetre steps between passes show)."""
    figure, (above, across) = plt.subplots(1, 2, figsize=(10, 4), layout="constrained")
    for raw in raws:
        positions = raw["platform_position"].values
        line, = above.plot(positions[:, 0], positions[:, 1], label=f"pass {raw.attrs['pass']}")
        across.plot(positions[:, 1], positions[:, 2], "o-", color=line.get_color(),
                    markersize=4, label=f"pass {raw.attrs['pass']}")
    for target in experiment.targets:
        above.plot(target.position[0], target.position[1], "k+")
    for ax, (xlabel, ylabel), title in ((above, ("x [m]", "y [m]"), "from above (+: targets)"),
                                        (across, ("y [m]", "z [m]"), "across the tracks")):
        ax.set_xlabel(xlabel)
        ax.set_ylabel(ylabel)
        ax.set_title(title)
        ax.grid(True, alpha=0.3)
    across.legend(fontsize="small")
    return figure


INTERFEROMETRY_FOLDER = "interferometry"
"""Sub-folder of a run folder with the interferometry outputs."""


def _interferometry(run: RunFolder, experiment: Experiment, result: PipelineResult,
                    progress: bool) -> None:
    """The interferogram of the channels' image of a multi-channel radar (BPA's where it was
    focused, else the first algorithm's), its point cloud and maps
    (:func:`mitsar.experiment.interferometry.write_interferometry`) into
    :data:`INTERFEROMETRY_FOLDER`; ``record["interferometry"]`` holds the summary, the
    algorithm and the point cloud's file, the maps are figures of the section
    "Interferometry"."""
    focused = [name for name, image in result.images.items()
               if "channel" in image["image"].dims]
    if not focused:
        run.warn("interferometry: not formed: no image of the channels was focused (every "
                 "algorithm failed: see the warnings above; -a bpa is the default)")
        return
    start = time.perf_counter()
    for algorithm in sorted(focused, key=lambda name: name != "bpa"):  # BPA's first
        try:
            formed = run_interferometry(result.images[algorithm], experiment.interferometry,
                                        where="interferometry", quiet=not progress,
                                        scene=experiment.scene)
            write_interferometry(run.out / INTERFEROMETRY_FOLDER, formed,
                                 overwrite=run.overwrite)
            break
        except MitsarError as error:
            run.warn(f"interferometry: not formed from the {algorithm} image: {error}")
    else:
        return
    run.step("interferometry", start)
    prefix = f"{INTERFEROMETRY_FOLDER}/"
    run.record["products"] += [prefix + INTERFEROMETRY_FILES[k]
                               for k in ("interferogram", "points")]
    run.record["figures"] += [dict(entry, section="Interferometry")
                              for entry in interferometry_figure_entries(prefix)]
    run.record["interferometry"] = {"summary": interferometry_summary(formed),
                                    "algorithm": algorithm,
                                    "points": prefix + INTERFEROMETRY_FILES["points"]}


def _acquisition_figures(run: RunFolder, experiment: Experiment, raw: Any,
                         scene: Any) -> None:
    """Tracks, preview, footprint and multipath rays of a simulated acquisition."""
    if "true_platform_position" in raw.variables:
        axes = plots_navigation.plot_tracks(raw)
        run.figure(axes[0].figure, "tracks.png", "True and navigation track",
                   "the echoes come from the true track; focusers know the navigation track")
    truth = "true_" if "true_platform_position" in raw.variables else ""
    positions = raw[f"{truth}platform_position"].values
    shown = scene_or_stand_in(scene, [], [np.asarray(t.position, float)
                                          for t in experiment.targets], positions)
    run.figure(plot_preview(shown, experiment.radar, experiment.look, positions,
                            raw[f"{truth}attitude"].values, title=run_title(experiment)),
               "preview.png", "Scene preview",
               "rendered by Mitsuba, materials by kind; track, antenna and beam footprint at "
               "the first, middle and last sweep (a stand-in floor without a scene)")
    if scene is not None:
        run.figure(plot_footprint(scene, raw,
                                  title=f"beam footprint: {scene_label(experiment)}"),
                   "footprint.png", "Beam footprint",
                   "first hits of rays inside the nominal beam at the first, middle and last "
                   "sweep, surfaces in grey (paper Figs. 12, 14)")
    # rays of a traced multipath scene
    if scene is not None and (experiment.simulation.max_depth or 1) > 1:
        start = time.perf_counter()
        summary = run_rays(experiment, run.out / "rays", overwrite=run.overwrite)
        run.step("rays", start)
        for name, file in summary["figures"].items():
            run.record["figures"].append({"file": f"rays/{Path(file).name}",
                                          "title": f"Rays: {name}",
                                          "caption": "paper Figs. 6, 10, 11"})


def scene_label(experiment: Experiment) -> str:
    """How figures name an experiment's scene: a canned scene by its name, a scene file by its
    path relative to the experiment file's folder when it lies below it, else by its file name
    (never the absolute path of the machine that ran it)."""
    scene = str(experiment.scene)
    path = Path(scene)
    if not path.is_absolute():
        return scene
    folder = None if experiment.source is None else Path(experiment.source).resolve().parent
    if folder is not None and path.is_relative_to(folder):
        return str(path.relative_to(folder))
    return path.name


_QUANTITIES = {"irw_cells": ("IRW", "cells"), "pslr_db": ("PSLR", "dB"),
               "islr_db": ("ISLR", "dB")}
"""Heading and unit of each measured quantity in the report's tables."""

_PAPER_TABLE_NUMBER = {-20.0: 4, -10.0: 5}
"""The paper's table of each background level [dB] (:mod:`mitsar.experiment.paper`)."""


def _paper_number(background: Any) -> int | None:
    level = None if background is None else background.cell_rcs_db
    return None if paper_table(level) is None else _PAPER_TABLE_NUMBER.get(float(level))


def paper_comparison(metrics: dict[str, Any], background: Any) -> dict[str, Any] | None:
    """This run's impulse-response metrics beside the paper's Table 4 (a -20 dB background)
    or 5 (-10 dB), per algorithm the paper focused with and cut (None for another background,
    or when no such algorithm was measured).

    The paper gives the mean and variance over its Monte Carlo realisations of the background
    (Scannapieco et al. 2016, Tables 4-5, :mod:`mitsar.experiment.paper`); a run is one
    realisation, so the table shows the paper's mean +- one standard deviation (the square root
    of its variance) and the note counts this run's values within two of them.

    Parameters
    ----------
    metrics : dict
        Algorithm -> the metrics of :func:`mitsar.measure_impulse_response` (or the reason
        it was not measured).
    background : Background or None
        The experiment's ``[background]``.

    Returns
    -------
    dict or None
        A table of the run record (``title``, ``header``, ``rows``, ``note``).
    """
    paper = paper_table(None if background is None else background.cell_rcs_db)
    number = _paper_number(background)
    if paper is None or number is None:
        return None
    rows, within, count = [], 0, 0
    for algorithm, result in metrics.items():
        if algorithm not in paper or not isinstance(result, dict) or "range" not in result:
            continue
        for direction in ("range", "azimuth"):
            row: list[Any] = [f"{algorithm.upper()} {direction}"]
            for metric, (_, unit) in _QUANTITIES.items():
                mean, variance = paper[algorithm][direction][metric]
                deviation = math.sqrt(variance)
                ours = float(result[direction][metric])
                decimals = 3 if unit == "cells" else 2
                row += [ours, f"{mean:.{decimals}f} ± {deviation:.{decimals}f}"]
                count += 1
                within += abs(ours - mean) <= 2 * deviation
            rows.append(row)
    if not rows:
        return None
    header = ["algorithm, cut"]
    for name, unit in _QUANTITIES.values():
        header += [f"{name} [{unit}], this run", f"{name} [{unit}], paper"]
    level = background.cell_rcs_db
    return {"title": f"Comparison with the paper's Table {number} (point target on a "
                     f"{level:g} dB background)",
            "header": header, "rows": rows,
            "note": f"This run is one realisation of the background; the paper's values are "
                    f"the mean ± one standard deviation (square root of the variance) over its "
                    f"Monte Carlo realisations (Scannapieco et al. 2016, Table {number}). "
                    f"{within} of {count} values of this run lie within two standard "
                    "deviations of the paper's mean. 'mitsar run -n N' compares means over N "
                    "realisations."}


def _montecarlo_table(summary: Any, realisations: int, background: Any) -> dict[str, Any]:
    """Mean and variance per algorithm, cut and metric; the paper's Table 4 or 5 rows below
    ours for a -20 or -10 dB background (:mod:`mitsar.experiment.paper`)."""
    paper = paper_table(None if background is None else background.cell_rcs_db)
    number = _paper_number(background)
    rows = []
    for source in ("mitsar", "paper"):
        for algorithm in summary["algorithm"].values:
            for direction in summary["direction"].values:
                label = "mitsar" if source == "mitsar" else f"paper Table {number}"
                row = [f"{label}: {str(algorithm).upper()} {direction}"]
                for metric in summary["metric"].values:
                    if source == "mitsar":
                        row += [float(summary[k].sel(algorithm=algorithm, direction=direction,
                                                     metric=metric)) for k in ("mean",
                                                                              "variance")]
                    elif paper is not None and str(algorithm) in paper:
                        row += [float(v) for v in
                                paper[str(algorithm)][str(direction)][str(metric)]]
                if len(row) > 1:
                    rows.append(row)
    header = ["source: algorithm, cut"]
    for metric in summary["metric"].values:
        name, unit = _QUANTITIES.get(str(metric), (str(metric), ""))
        header += [f"{name} mean [{unit}]", f"{name} variance [{unit}²]"]
    return {"title": f"Monte Carlo over {realisations} background realisations"
            + (f" (the paper's Table {number} below ours)" if number is not None else ""),
            "header": header, "rows": rows}
