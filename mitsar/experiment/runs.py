"""The workflow of an experiment: simulate its raw product, focus it, measure the image.

Each step takes the validated configuration of :mod:`mitsar.experiment.options`. The raw
product records what the experiment asks of the later steps (focus options, metrics target and
ISLR extent, point targets, scene: :mod:`mitsar.products.requests`) and the image carries it, so
that a later step (or a later session reading the saved product) reads the target and options
from the product, never by parsing the experiment again.
"""

from __future__ import annotations

import dataclasses
import os
import warnings
from pathlib import Path
from typing import Any

import xarray as xr

from mitsar.errors import MitsarError, MitsarWarning
from mitsar.experiment.options import Experiment, FocusOptions, MetricsOptions
from mitsar.focus.dispatch import focus
from mitsar.io import ZarrStream, is_zarr, save
from mitsar.products.image import carry_requests
from mitsar.products.requests import metrics_request, request_attrs
from mitsar.quality.impulse import measure_impulse_response
from mitsar.raw.analytic import simulate_point_targets, stream_point_targets
from mitsar.raw.traced import simulate_scene

EMPTY_SCENE_WARNING = "simulate_scene: raw data of exact zeros"
"""Start of :func:`simulate_scene`'s warning for an acquisition that sees nothing."""

__all__ = ["run_focus", "run_metrics", "run_simulation", "simulate_to"]


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
        string of :attr:`Experiment.config`) and its source file (``experiment_source``).
    """
    options = experiment.simulation  # the experiment's layer of the trace request
    if experiment.scene is not None:
        # An experiment whose echoes are all zero is refused (the API only warns).
        with warnings.catch_warnings():
            warnings.filterwarnings("error", EMPTY_SCENE_WARNING, MitsarWarning)
            try:
                raw = simulate_scene(
                    experiment.radar, experiment.trajectory, experiment.look, experiment.scene,
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
    return raw


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
        Number of sweeps written.
    """
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

