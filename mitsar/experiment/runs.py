"""The workflow of an experiment: simulate its raw product, focus it, measure the image.

Each step takes the validated configuration of :mod:`mitsar.experiment.options`. The raw
product records what the experiment asks of the later steps (focus options, metrics target and
ISLR extent, point targets, scene: :mod:`mitsar.products.requests`) and the image carries it, so
that a later step (or a later session reading the saved product) reads the target and options
from the product, never by parsing the experiment again.

An experiment with ``[[passes]]`` gives one raw product per pass (:func:`simulate_passes`),
made by the producers of a single acquisition; the passes share the scene and what belongs to
it (docs/experiments.md §Passes).
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from pathlib import Path
from typing import Any

import numpy as np
import xarray as xr

from mitsar.errors import MitsarError, MitsarWarning, ParameterError
from mitsar.experiment.options import PASS_SEED_RULE, Experiment, FocusOptions, MetricsOptions
from mitsar.focus.dispatch import focus
from mitsar.io import ZarrStream, check_writable, is_zarr, save
from mitsar.model.noise import check_noise, thermal_noise
from mitsar.products.image import carry_requests
from mitsar.products.requests import metrics_request, request_attrs
from mitsar.quality.impulse import measure_impulse_response
from mitsar.raw.analytic import simulate_point_targets, stream_point_targets
from mitsar.raw.traced import simulate_scene
from mitsar.scene import load_scene

EMPTY_SCENE_WARNING = "simulate_scene: raw data of exact zeros"
"""Start of :func:`simulate_scene`'s warning for an acquisition that sees nothing."""

__all__ = ["pass_experiment", "pass_path", "run_focus", "run_focus_passes", "run_metrics",
           "run_simulation", "simulate_pass", "simulate_passes", "simulate_to"]


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


def _simulate(experiment: Experiment, progress: bool, scene: Any = None) -> xr.Dataset:
    """The raw product of a one-acquisition experiment (``scene``: its scene, already loaded)."""
    options = experiment.simulation  # the experiment's layer of the trace request
    if experiment.scene is not None:
        # An experiment whose echoes are all zero is refused (the API only warns).
        with warnings.catch_warnings():
            warnings.filterwarnings("error", EMPTY_SCENE_WARNING, MitsarWarning)
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
    raw = _simulate(quiet, progress, scene)
    if noise:
        _add_noise(raw, experiment.radar, seed)
    chosen = experiment.passes[index]
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
                progress: bool = False, chunk_sweeps: int = 1024) -> int:
    """Simulate an experiment's raw product straight into a file or Zarr store.

    To a ``.zarr`` path, a point-target experiment is simulated ``chunk_sweeps`` sweeps at a
    time and each chunk appended to the store (:func:`mitsar.raw.analytic.stream_point_targets`,
    :class:`mitsar.io.ZarrStream`), so memory holds one chunk, not the acquisition; a scene
    experiment is traced whole and written chunked. Any other path gets
    :func:`run_simulation` and :func:`mitsar.io.save`.

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
        Sweeps per streamed chunk (and per Zarr chunk).

    Returns
    -------
    int
        Number of sweeps written (of all passes).

    Notes
    -----
    An experiment with ``[[passes]]`` writes one product per pass, ``path`` with ``_pass<i>``
    before its suffix (:func:`pass_path`: ``raw_pass0.nc``, ``raw_pass1.nc``, ...), each whole
    (:func:`simulate_passes`); every file is checked before anything is simulated.
    """
    if experiment.passes:
        paths = [pass_path(path, index) for index in range(len(experiment.passes))]
        for each in paths:
            check_writable(each, overwrite)
        raws = simulate_passes(experiment, progress=progress)
        for raw, each in zip(raws, paths, strict=True):
            save(raw, each, overwrite=overwrite)
        return sum(int(raw.sizes["sweep"]) for raw in raws)
    if not is_zarr(path) or experiment.scene is not None:
        raw = run_simulation(experiment, progress=progress)
        save(raw, path, overwrite=overwrite)
        return int(raw.sizes["sweep"])
    options = experiment.simulation.resolve(str(experiment.source or "experiment"))
    chunks = stream_point_targets(
        experiment.radar, experiment.trajectory, experiment.look, experiment.targets,
        background=experiment.background, seed=options.seed, rvp=options.rvp,
        normalized=options.normalized, noise=options.noise, progress=progress,
        navigation=experiment.navigation, sweeps_per_chunk=chunk_sweeps)
    with ZarrStream(Path(path), overwrite=overwrite, chunk_sweeps=chunk_sweeps) as out:
        for chunk in chunks:
            chunk.attrs.update(_experiment_attrs(experiment))
            out.append(chunk)
    return out.sweeps


def run_focus(raw: xr.Dataset, options: FocusOptions, progress: bool = False) -> xr.Dataset:
    """Focus a raw product with the given options.

    The image keeps the raw product's experiment record and requests
    (:data:`mitsar.products.requests.CARRIED_ATTRS`), so that metrics find their target.

    Parameters
    ----------
    raw : xarray.Dataset
        A raw product.
    options : FocusOptions
        Algorithm, window, azimuth resolution, grid and autofocus.
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
                  progress=progress, **extra)
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
                  progress=progress, combine=combine)
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

