"""The workflow of an experiment: simulate its raw product, focus it, measure the image.

Each step takes the validated configuration of :mod:`mitsar.experiment.options`. The raw
product records what the experiment asks of the later steps (focus options, metrics target and
ISLR extent, point targets, scene: :mod:`mitsar.products.requests`) and the image carries it, so
that a later step (or a later session reading the saved product) reads the target and options
from the product, never by parsing the experiment again.

An experiment with ``[[passes]]`` gives one raw product per pass (:func:`simulate_passes`),
made by the producers of a single acquisition; the passes share the scene and what belongs to
it (docs/experiments.md §Passes).

:func:`simulate_to` (``mitsar simulate``) writes a product chunk by chunk of sweeps through a
work folder beside it, so that an interrupted run resumes from its last finished chunk to the
same bits (:class:`mitsar.io.WorkFolder`, docs/reliability.md §5).
"""

from __future__ import annotations

import dataclasses
import json
import os
import warnings
from collections.abc import Callable, Iterator
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr
from tqdm.auto import tqdm

from mitsar.errors import MemoryBudgetError, MitsarError, MitsarWarning, ParameterError
from mitsar.experiment.options import (
    PASS_SEED_RULE,
    RESUME_CHUNK_SWEEPS,
    Experiment,
    FocusOptions,
    MetricsOptions,
)
from mitsar.focus.dispatch import focus
from mitsar.io import (
    ProductFileError,
    WorkFolder,
    ZarrStream,
    check_writable,
    file_digest,
    is_zarr,
    load,
    save,
)
from mitsar.model.noise import check_noise, thermal_noise
from mitsar.model.signal import sweep_count
from mitsar.products.image import carry_requests
from mitsar.products.requests import metrics_request, request_attrs
from mitsar.quality.impulse import measure_impulse_response
from mitsar.raw.analytic import simulate_point_targets, stream_point_targets
from mitsar.raw.product import require_raw_memory
from mitsar.raw.traced import simulate_scene
from mitsar.scene import load_scene

EMPTY_SCENE_WARNING = "simulate_scene: raw data of exact zeros"
"""Start of :func:`simulate_scene`'s warning for an acquisition that sees nothing."""

__all__ = ["RESUME_CHUNK_SWEEPS", "pass_experiment", "pass_path", "run_focus",
           "run_focus_passes", "run_metrics", "run_simulation", "simulate_pass",
           "simulate_passes", "simulate_to"]


def run_simulation(experiment: Experiment, progress: bool = False) -> xr.Dataset:
    """Simulate the raw product of an experiment.

    Parameters
    ----------
    experiment : Experiment
        From :func:`load_experiment`.
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        The raw product; its attributes also record the experiment (``experiment``, a JSON
        string of :attr:`Experiment.config`) and its source file (``experiment_source``). Of an
        experiment with ``[[passes]]``: pass 0's (:func:`simulate_pass`; all of them:
        :func:`simulate_passes`).
    """
    if experiment.passes:
        return simulate_pass(experiment, 0, progress=progress)
    return _simulate(experiment, progress)


def _simulate(experiment: Experiment, progress: bool, scene: Any = None,
              empty: str = "error") -> xr.Dataset:
    """The raw product of a one-acquisition experiment (``scene``: its scene, already loaded;
    ``empty``: ``"error"`` refuses a traced acquisition of exact zeros, ``"ignore"`` returns
    it, for a chunk of sweeps whose neighbours may see the scene)."""
    options = experiment.simulation  # the experiment's layer of the trace request
    if experiment.scene is not None:
        # An experiment whose echoes are all zero is refused (the API only warns).
        with warnings.catch_warnings():
            warnings.filterwarnings(empty, EMPTY_SCENE_WARNING, MitsarWarning)
            try:
                raw = simulate_scene(
                    experiment.radar, experiment.trajectory, experiment.look,
                    experiment.scene if scene is None else scene,
                    targets=experiment.targets, background=experiment.background,
                    options=options, navigation=experiment.navigation,
                    motion=experiment.motion, progress=progress)
            except MitsarWarning as warning:
                where = experiment.source or "experiment"
                raise MitsarError(f"{where}: scene {experiment.scene!r}: {warning}") from None
    else:
        options = options.resolve(str(experiment.source or "experiment"))
        raw = simulate_point_targets(
            experiment.radar, experiment.trajectory, experiment.look, experiment.targets,
            background=experiment.background, seed=options.seed, rvp=options.rvp,
            normalized=options.normalized, noise=options.noise, progress=progress,
            navigation=experiment.navigation)
    raw.attrs.update(_experiment_attrs(experiment))
    if scene is not None:  # traced from the loaded scene: record its name, not the object
        raw.attrs["scene"] = str(experiment.scene)
    return raw


def pass_experiment(experiment: Experiment, index: int) -> Experiment:
    """The one-acquisition experiment of pass ``index``: the experiment with the pass's track,
    look and navigation errors (and no passes); its configuration record stays the whole
    experiment's.

    Raises
    ------
    ParameterError
        If the experiment has no such pass.
    """
    if not 0 <= index < len(experiment.passes):
        raise ParameterError(str(experiment.source or "experiment"), "passes",
                             f"a pass index in 0..{len(experiment.passes) - 1}", index)
    chosen = experiment.passes[index]
    return dataclasses.replace(experiment, trajectory=chosen.trajectory, look=chosen.look,
                               navigation=chosen.navigation, passes=())


def simulate_pass(experiment: Experiment, index: int, progress: bool = False,
                  scene: Any = None) -> xr.Dataset:
    """The raw product of pass ``index`` of a multi-pass experiment.

    The pass is simulated by the producer of a single acquisition
    (:func:`mitsar.simulate_point_targets`, or :func:`mitsar.simulate_scene` with a scene) on
    its own track, look and navigation errors, with the experiment's ``[simulation] seed`` for
    what belongs to the scene (its surface scatterers and speckle, the analytic background),
    so that every pass sees the same scene, and with the pass's own seed
    (:meth:`Experiment.pass_seed`) for its receiver noise: the noise of sample n of sweep k of
    channel c is :func:`mitsar.model.noise.thermal_noise` of (pass seed, k, n, c), the very
    noise the producer draws for that seed.

    Parameters
    ----------
    experiment : Experiment
        With ``[[passes]]``.
    index : int
        The pass.
    progress : bool
        Show a progress bar.
    scene : mitsuba.Scene, optional
        The experiment's scene, already loaded (:func:`mitsar.scene.load_scene`); share one
        between passes so that its scatterer set is drawn once.

    Returns
    -------
    xarray.Dataset
        The raw product, with the attributes ``pass`` (index), ``pass_count``, ``pass_name``,
        ``pass_seed`` (its noise seed, also ``noise_seed`` when noise is on),
        ``pass_seed_rule``, ``pass_offset`` [m] and, with navigation errors,
        ``pass_navigation_seed``; ``seed`` stays the experiment's (the scene's draws).

    Raises
    ------
    ParameterError
        For an index out of range, or noise asked without a noise figure.
    """
    single = pass_experiment(experiment, index)
    where = str(experiment.source or "experiment")
    noise = bool(experiment.simulation.noise)
    check_noise(where, experiment.radar, noise, bool(experiment.simulation.normalized))
    seed = experiment.pass_seed(index)
    quiet = dataclasses.replace(single, simulation=dataclasses.replace(single.simulation,
                                                                       noise=False))
    chosen = experiment.passes[index]
    with warnings.catch_warnings(record=True) as said:  # said again, naming the pass
        warnings.simplefilter("always")
        raw = _simulate(quiet, progress, scene)
    for warning in said:  # (e.g. its reception warnings: issue 27, docs/reliability.md §3)
        warnings.warn_explicit(f"pass {index} ({chosen.name}): {warning.message}",
                               warning.category, warning.filename, warning.lineno)
    if noise:
        _add_noise(raw, experiment.radar, seed)
    raw.attrs.update({"pass": index, "pass_count": len(experiment.passes),
                      "pass_name": chosen.name, "pass_seed": seed,
                      "pass_seed_rule": PASS_SEED_RULE,
                      "pass_offset": [float(v) for v in chosen.offset]})
    if chosen.navigation is not None:
        raw.attrs["pass_navigation_seed"] = int(chosen.navigation.seed)
    return raw


def _add_noise(raw: xr.Dataset, radar: Any, seed: int) -> None:
    """Add the receiver noise of ``seed`` to a noiseless raw product, in place: what its
    producer adds for that seed (each channel its own stream; under TDM-MIMO only in the
    sweeps the channel fires)."""
    sweeps = np.asarray(raw["sweep"].values, dtype=np.int64)
    samples = np.array(raw["raw"].values, dtype=complex)
    if samples.ndim == 3:
        fires = radar.firing(sweeps)
        for channel in range(samples.shape[0]):
            samples[channel, fires[channel]] += thermal_noise(
                radar, seed, sweeps[fires[channel]], channel)
    else:
        samples += thermal_noise(radar, seed, sweeps)
    raw["raw"] = raw["raw"].copy(data=samples)
    raw.attrs.update(noise=1, noise_power=radar.noise_power, noise_seed=int(seed))


def simulate_passes(experiment: Experiment, progress: bool = False,
                    scene: Any = None) -> list[xr.Dataset]:
    """The raw products of every pass of an experiment, in pass order.

    The scene of a traced experiment is loaded once (or ``scene`` is used) and handed to every
    pass, so the ray tracer draws its scatterer set once
    (:data:`mitsar.raw.trace_run._SCATTERER_SETS`) and the passes image the same scatterers;
    seeds as :func:`simulate_pass`.

    Parameters
    ----------
    experiment : Experiment
        An experiment; without ``[[passes]]`` the list holds its one raw product
        (:func:`run_simulation`).
    progress : bool
        Show progress bars.
    scene : mitsuba.Scene, optional
        The experiment's scene, already loaded.

    Returns
    -------
    list of xarray.Dataset
        One raw product per pass (attributes: :func:`simulate_pass`).

    Examples
    --------
    >>> experiment = load_experiment(example_path("vertical_stack_passes"))  # doctest: +SKIP
    >>> [raw.attrs["pass"] for raw in simulate_passes(experiment)]  # doctest: +SKIP
    [0, 1, 2, 3]
    """
    if not experiment.passes:
        return [run_simulation(experiment, progress=progress)]
    if experiment.scene is not None and scene is None:
        scene = load_scene(experiment.scene)
    return [simulate_pass(experiment, index, progress=progress, scene=scene)
            for index in range(len(experiment.passes))]


def pass_path(path: str | os.PathLike, index: int) -> Path:
    """The file of pass ``index`` for an output ``path``: ``raw.nc`` -> ``raw_pass0.nc``,
    ``raw.zarr`` -> ``raw_pass0.zarr``."""
    path = Path(path)
    return path.with_name(f"{path.stem}_pass{index}{path.suffix}")


def _experiment_attrs(experiment: Experiment) -> dict[str, Any]:
    """The experiment record a raw product carries, and what the experiment asks of the later
    steps (:func:`mitsar.products.requests.request_attrs`; see :func:`run_simulation`)."""
    return request_attrs(
        config=experiment.config, source=None if experiment.source is None
        else str(experiment.source), name=experiment.name, scene=experiment.scene,
        targets=[t.position for t in experiment.targets],
        metrics_target=experiment.metrics.target, islr_extent=experiment.metrics.islr_extent,
        focus=dataclasses.asdict(experiment.focus))



def simulate_to(experiment: Experiment, path: str | os.PathLike, overwrite: bool = False,
                progress: bool = False, chunk_sweeps: int = RESUME_CHUNK_SWEEPS,
                log: Callable[[str], None] | None = None) -> int:
    """Simulate an experiment's raw product into a file or Zarr store, resumably.

    The acquisition is simulated ``chunk_sweeps`` sweeps at a time (a point-target experiment
    by :func:`mitsar.raw.analytic.stream_point_targets`, a scene experiment by
    :func:`mitsar.simulate_scene` of each chunk's sweeps, its scatterer set drawn once from the
    scene and seed) and each chunk is written, atomically, to the work folder
    ``.NAME.partial`` beside ``path`` (:class:`mitsar.io.WorkFolder`). When every chunk is
    there the product is assembled and moved into place (a ``.zarr`` store chunk by chunk,
    :class:`mitsar.io.ZarrStream`, so memory holds one chunk; a netCDF file whole) and the work
    folder removed. A run interrupted (SIGINT, SIGKILL, a crash) and run again with the same
    experiment, options and mitsar version simulates only the chunks not yet written and gives
    the same bits as an uninterrupted run; with other inputs it starts over.

    Parameters
    ----------
    experiment : Experiment
    path : path-like
        ``*.nc`` or ``*.zarr``.
    overwrite : bool
        Replace an existing product.
    progress : bool
        Show a progress bar.
    chunk_sweeps : int
        Sweeps per chunk (and per Zarr chunk). A multiple of 128 keeps a traced product equal
        to one :func:`mitsar.simulate_scene` call (:data:`RESUME_CHUNK_SWEEPS`).
    log : callable, optional
        Receives the messages of a resumed or restarted run.

    Returns
    -------
    int
        Number of sweeps written (of all passes).

    Raises
    ------
    OutputExistsError
        If a destination exists and ``overwrite`` is false (checked before any work).
    MitsarError
        For a scene experiment whose echoes are all zero (nothing of the scene in the beam).

    Notes
    -----
    An experiment with ``[[passes]]`` writes one product per pass, ``path`` with ``_pass<i>``
    before its suffix (:func:`pass_path`: ``raw_pass0.nc``, ``raw_pass1.nc``, ...), each whole
    (:func:`simulate_pass`) and resumed pass by pass; every file is checked before anything is
    simulated.
    """
    path = Path(path)
    if isinstance(chunk_sweeps, bool) or not isinstance(chunk_sweeps, int | np.integer) \
            or chunk_sweeps < 1:
        raise ParameterError("simulate_to", "chunk_sweeps", "an integer >= 1", chunk_sweeps)
    chunk_sweeps = int(chunk_sweeps)
    if experiment.passes:
        return _simulate_passes_to(experiment, path, overwrite, progress, log)
    check_writable(path, overwrite)
    total = sweep_count(experiment.radar, experiment.trajectory.duration)
    if not is_zarr(path):  # a netCDF file is assembled whole: refused before any chunk
        require_raw_memory(str(experiment.source or "experiment"), experiment.radar, total)
    if experiment.scene is not None and experiment.simulation.sweeps is not None:
        chunk_sweeps = max(total, 1)  # the experiment picks its sweeps: one chunk
    count = max(1, -(-total // chunk_sweeps))
    inputs = _simulate_inputs(experiment, path, chunk_sweeps)
    with WorkFolder(path, inputs, command="simulate", log=log) as work:
        first = 0
        while first < count and work.done(_chunk_key(first)) \
                and work.file(_chunk_file(first)).exists():
            first += 1
        if experiment.scene is not None:
            produced = _traced_chunks(experiment, total, chunk_sweeps, first, progress)
        else:
            produced = _analytic_chunks(experiment, chunk_sweeps, first, progress)
        try:
            for index, chunk in produced:
                save(chunk, work.file(_chunk_file(index)), overwrite=True)
                work.mark(_chunk_key(index), {"sweeps": int(chunk.sizes["sweep"]),
                                              "zero": not bool(np.any(chunk["raw"].values)),
                                              "variables": list(map(str, chunk.variables)),
                                              **_counters(chunk)})
        except ParameterError as error:  # the inputs refused (all echoes zero): none to resume
            if not isinstance(error, MemoryBudgetError):
                work.remove()
            raise
        return _assemble(work, experiment, path, count, chunk_sweeps, overwrite)


def _chunk_key(index: int) -> str:
    return f"chunk{index}"


def _chunk_file(index: int) -> str:
    return f"chunk{index:05d}.nc"


def _counters(raw: xr.Dataset) -> dict[str, int]:
    """The tracer's work counters of a chunk (``traced_*`` attributes), summed on assembly."""
    return {key: int(value) for key, value in raw.attrs.items() if key.startswith("traced_")}


def _simulate_inputs(experiment: Experiment, path: Path, chunk_sweeps: int) -> dict[str, Any]:
    """What a simulated product depends on, for :class:`mitsar.io.WorkFolder`: the effective
    experiment (``--set`` and ``--seed`` included), the content of a scene file, the chunking
    and the format."""
    scene = None
    if experiment.scene is not None:
        candidates = [Path(str(experiment.scene))]
        if experiment.source is not None:
            candidates.append(Path(experiment.source).parent / str(experiment.scene))
        scene = next((digest for digest in map(file_digest, candidates) if digest),
                     str(experiment.scene))
    return {"command": "simulate", "experiment": experiment.config, "scene": scene,
            "chunk_sweeps": chunk_sweeps, "format": path.suffix.lower(),
            "passes": len(experiment.passes)}


def _analytic_chunks(experiment: Experiment, chunk_sweeps: int, first: int,
                     progress: bool) -> Iterator[tuple[int, xr.Dataset]]:
    """(index, raw product) of the chunks from ``first`` on, of a point-target experiment."""
    options = experiment.simulation.resolve(str(experiment.source or "experiment"))
    chunks = stream_point_targets(
        experiment.radar, experiment.trajectory, experiment.look, experiment.targets,
        background=experiment.background, seed=options.seed, rvp=options.rvp,
        normalized=options.normalized, noise=options.noise, progress=progress,
        navigation=experiment.navigation, sweeps_per_chunk=chunk_sweeps, first_chunk=first)
    for index, chunk in enumerate(chunks, start=first):
        chunk.attrs.update(_experiment_attrs(experiment))
        yield index, chunk


def _traced_chunks(experiment: Experiment, total: int, chunk_sweeps: int, first: int,
                   progress: bool) -> Iterator[tuple[int, xr.Dataset]]:
    """(index, raw product) of the chunks from ``first`` on, of a scene experiment: each
    chunk's sweeps traced alone (``sweeps=``), the scene loaded once (its scatterer set is
    drawn from the scene, density and seed, whatever the sweeps)."""
    count = max(1, -(-total // chunk_sweeps))
    if first >= count:
        return
    scene = load_scene(experiment.scene)
    whole = experiment.simulation.sweeps is not None
    analytic = not whole and (bool(experiment.targets) or experiment.background is not None)
    for index in tqdm(range(first, count), disable=not progress or count == 1,
                      desc="simulate (traced)", unit="chunk", initial=first, total=count):
        chunked = experiment if whole else dataclasses.replace(
            experiment, simulation=dataclasses.replace(
                experiment.simulation,
                sweeps=slice(index * chunk_sweeps, min((index + 1) * chunk_sweeps, total))))
        if analytic:
            yield index, _traced_with_analytic(chunked, index, chunk_sweeps, scene,
                                               progress and count == 1)
        else:
            yield index, _simulate(chunked, progress and count == 1, scene, empty="ignore")


def _traced_with_analytic(experiment: Experiment, index: int, chunk_sweeps: int, scene: Any,
                          progress: bool) -> xr.Dataset:
    """Chunk ``index`` of a scene experiment with analytic targets or background: what
    :func:`mitsar.simulate_scene` makes of those sweeps (traced samples, plus the analytic
    ones, plus the receiver noise, in that order), with the analytic part of this chunk only
    (:func:`mitsar.raw.analytic.stream_point_targets`, earlier chunks' draws made and their
    echoes skipped) instead of the whole acquisition's for every chunk."""
    where = str(experiment.source or "experiment")
    noise = bool(experiment.simulation.resolve(where).noise)
    quiet = dataclasses.replace(experiment, targets=(), background=None,
                                simulation=dataclasses.replace(experiment.simulation,
                                                               noise=False))
    raw = _simulate(quiet, progress, scene, empty="ignore")
    seed = int(raw.attrs["seed"])  # the trace request's (the scene's integrator may set it)
    chunks = stream_point_targets(
        experiment.radar, experiment.trajectory, experiment.look, experiment.targets,
        background=experiment.background, seed=seed, rvp=bool(raw.attrs["rvp"]),
        normalized=bool(raw.attrs["normalized"]), navigation=experiment.navigation,
        sweeps_per_chunk=chunk_sweeps, first_chunk=index)
    echoes = next(chunks)
    chunks.close()
    if not np.array_equal(echoes["sweep"].values, raw["sweep"].values):
        raise MitsarError(f"{where}: the analytic chunk {index} does not cover the traced "
                          "sweeps (report this)")
    raw["raw"] = raw["raw"].copy(data=raw["raw"].values + echoes["raw"].values)
    raw.attrs["simulator"] = f"{raw.attrs['simulator']} + analytic point targets"
    raw.attrs["analytic_config"] = echoes.attrs.get("config", "{}")
    if noise:
        _add_noise(raw, experiment.radar, seed)
    raw.attrs.update(_experiment_attrs(experiment))  # the targets, for metrics and figures
    return raw


def _assemble(work: WorkFolder, experiment: Experiment, path: Path, count: int,
              chunk_sweeps: int, overwrite: bool) -> int:
    """The product of the finished chunks in ``work``, moved into ``path``; the work folder
    removed. Returns the number of sweeps."""
    infos = [work.info(_chunk_key(index)) for index in range(count)]
    files = [work.file(_chunk_file(index)) for index in range(count)]
    if experiment.scene is not None and all(info.get("zero") for info in infos):
        first = load(files[0], product="raw")
        work.remove()
        raise MitsarError(f"{experiment.source or 'experiment'}: scene {experiment.scene!r}: "
                          f"{_empty_scene_message(first.attrs)}")
    totals: dict[str, int] = {}
    for info in infos:
        for key, value in info.items():
            if key.startswith("traced_"):
                totals[key] = totals.get(key, 0) + int(value)
    if is_zarr(path):
        with ZarrStream(path, overwrite=overwrite, chunk_sweeps=chunk_sweeps) as out:
            for file in files:
                out.append(load(file, product="raw"))
            if totals:
                out.finish(totals)
        sweeps = out.sweeps
    else:
        raw = _concatenate(files, [int(info["sweeps"]) for info in infos],
                           infos[0].get("variables"))
        raw.attrs.update(totals)
        save(raw, path, overwrite=overwrite)
        sweeps = int(raw.sizes["sweep"])
    work.remove()
    return sweeps


def _concatenate(files: list[Path], counts: list[int], order: list[str] | None = None
                 ) -> xr.Dataset:
    """The chunk files of a product (``counts``: their sweeps) joined along ``sweep``, read one
    at a time into arrays of the whole acquisition (memory: the product and one chunk).
    Variables come in ``order`` (the producer's, which a file read back does not keep; default
    the first chunk's) and without the encodings of the files they were read from, so that the
    file written is the one a product made whole in memory gives, byte for byte; variables
    without a ``sweep`` dimension are the first chunk's."""
    first = load(files[0], product="raw")
    along = {name: variable for name, variable in first.variables.items()
             if "sweep" in variable.dims}
    arrays: dict[str, np.ndarray] = {}
    for name, variable in along.items():
        shape = list(variable.shape)
        shape[variable.dims.index("sweep")] = sum(counts)
        arrays[name] = np.empty(shape, dtype=variable.dtype)
    offset = 0
    for index, (file, count) in enumerate(zip(files, counts, strict=True)):
        part = first if index == 0 else load(file, product="raw")
        if part.sizes["sweep"] != count:
            raise ProductFileError(f"{file}: expected a chunk of {count} sweeps, found "
                                   f"{part.sizes['sweep']}")
        for name, variable in along.items():
            where = [slice(None)] * variable.ndim
            where[variable.dims.index("sweep")] = slice(offset, offset + count)
            arrays[name][tuple(where)] = part[name].values
        offset += count
    out = xr.Dataset(attrs=dict(first.attrs))
    names = [name for name in order or () if name in first.variables]
    names += [name for name in first.variables if name not in names]
    for name in names:  # the product's own order (coordinates among the others)
        source = first.variables[name]
        if name in arrays:
            variable = xr.Variable(source.dims, arrays[name], attrs=dict(source.attrs))
        else:
            variable = source.copy(deep=False)
            variable.encoding = {}
        if name in first.coords:
            out = out.assign_coords({name: variable})
        else:
            out[name] = variable
    return out


def _empty_scene_message(attrs: Any) -> str:
    """:func:`mitsar.simulate_scene`'s words for an acquisition of exact zeros."""
    orders = attrs.get("orders", [])
    if isinstance(orders, str):  # a product read back from a file: its list as JSON text
        try:
            orders = json.loads(orders)
        except ValueError:
            orders = []
    return (f"{EMPTY_SCENE_WARNING}: nothing of the scene is in the beam "
            f"({attrs.get('scatterer_count')} surface scatterers, "
            f"{attrs.get('point_target_count')} point targets, orders "
            f"{[int(o) for o in np.atleast_1d(orders)]}): check the look "
            "angles, the trajectory, the materials and the orders")


def _simulate_passes_to(experiment: Experiment, path: Path, overwrite: bool, progress: bool,
                        log: Callable[[str], None] | None) -> int:
    """:func:`simulate_to` of a multi-pass experiment: resumable pass by pass."""
    paths = [pass_path(path, index) for index in range(len(experiment.passes))]
    for each in paths:
        check_writable(each, overwrite)
    inputs = _simulate_inputs(experiment, path, 0)
    with WorkFolder(path, inputs, command="simulate", log=log) as work:
        scene, total = None, 0
        for index in range(len(paths)):
            key, file = f"pass{index}", work.file(f"pass{index}{path.suffix}")
            if not (work.done(key) and file.exists()):
                if experiment.scene is not None and scene is None:
                    scene = load_scene(experiment.scene)
                raw = simulate_pass(experiment, index, progress=progress, scene=scene)
                save(raw, file, overwrite=True)
                work.mark(key, {"sweeps": int(raw.sizes["sweep"])})
            total += int(work.info(key)["sweeps"])
        for index, each in enumerate(paths):
            work.move_file(work.file(f"pass{index}{path.suffix}"), each, overwrite=overwrite)
        work.remove()
    return total


def run_focus(raw: xr.Dataset, options: FocusOptions, progress: bool = False) -> xr.Dataset:
    """Focus a raw product with the given options.

    The image keeps the raw product's experiment record and requests
    (:data:`mitsar.products.requests.CARRIED_ATTRS`), so that metrics find their target.

    Parameters
    ----------
    raw : xarray.Dataset
        A raw product.
    options : FocusOptions
        Algorithm, window, azimuth resolution, grid, autofocus and band limit.
    progress : bool
        Show a progress bar when the algorithm supports one.

    Returns
    -------
    xarray.Dataset
        The image product.
    """
    extra = {} if options.autofocus is None else {"autofocus": options.autofocus}
    image = focus(raw, algorithm=options.algorithm, grid=options.make_grid(),
                  window=options.window, azimuth_resolution=options.azimuth_resolution,
                  progress=progress, band_limit=options.band_limit, **extra)
    return carry_requests(raw, image)


def run_focus_passes(raws: list[xr.Dataset], options: FocusOptions, combine: str = "coherent",
                     progress: bool = False) -> xr.Dataset:
    """Focus the passes of an experiment into one image (:func:`mitsar.focus` of the list:
    every pass back-projected onto the same pixels and combined; docs/focusing.md "3-D
    focusing from several passes").

    Parameters
    ----------
    raws : list of xarray.Dataset
        The passes' raw products (:func:`simulate_passes`).
    options : FocusOptions
        Algorithm (``"bpa"`` or ``"ffbp"``), window, azimuth resolution and a grid in the scene
        frame (``plane`` or ``points``; a ``slant`` grid belongs to one track and is refused).
    combine : {"coherent", "incoherent"}
        Mean of the complex images, or root mean of their intensities.
    progress : bool
        Show a progress bar.

    Returns
    -------
    xarray.Dataset
        The combined image product, with the first pass's requests (metrics target, ...).

    Raises
    ------
    ParameterError
        What :func:`mitsar.focus` refuses for several passes (a slant grid, autofocus with
        ``combine="coherent"``, ...).
    """
    image = focus(list(raws), algorithm=options.algorithm, grid=options.make_grid(),
                  window=options.window, azimuth_resolution=options.azimuth_resolution,
                  progress=progress, combine=combine, band_limit=options.band_limit)
    return carry_requests(raws[0], image)


def run_metrics(image: xr.Dataset, target: Any | None = None,
                islr_extent: str | float | None = None) -> dict[str, Any]:
    """Measure the impulse response of a target in an image product.

    Parameters
    ----------
    image : xarray.Dataset
        An image product.
    target : array_like of 3 floats, optional
        World position [m]; by default the image's ``metrics_target`` (the ``[metrics]
        target`` of its experiment, or its first point target).
    islr_extent : str or float, optional
        ISLR side-lobe extent; by default the image's ``metrics_islr_extent``, else
        ``"paper"``.

    Returns
    -------
    dict
        The result of :func:`mitsar.quality.impulse.measure_impulse_response`, plus ``target`` and
        ``islr_extent``.
    """
    recorded_target, recorded_extent = metrics_request(image)
    if target is None:
        target = recorded_target
    if target is None:
        raise MitsarError("metrics: no target position: give one (--target X Y Z) or set "
                          "[metrics] target in the experiment")
    target = [float(v) for v in target]
    if islr_extent is not None:
        extent = islr_extent
    else:
        extent = recorded_extent if recorded_extent is not None else MetricsOptions().islr_extent
    result = dict(measure_impulse_response(image, target=target, islr_extent=extent))
    result.setdefault("target", target)
    result.setdefault("islr_extent", extent)
    return result

