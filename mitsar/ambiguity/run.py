"""Run an ambiguity TOML file: maps of every trajectory, their comparison, figures, summary."""

from __future__ import annotations

import json
import os
from collections.abc import Callable
from pathlib import Path
from typing import Any

import xarray as xr

from mitsar.ambiguity.comparison import comparison_from_products, comparison_table
from mitsar.ambiguity.config import load_ambiguity_experiment
from mitsar.ambiguity.maps import ambiguity, overall_fractions, surface_summary
from mitsar.ambiguity.plots import plot_ambiguity, plot_comparison
from mitsar.ambiguity.points import SurfacePoints, plane_points, sample_surfaces
from mitsar.ambiguity.shadows import planes_scene
from mitsar.io import (
    ProductFileError,
    WorkFolder,
    atomic_output,
    check_writable,
    load,
    save,
    scene_digest,
    write_json,
)
from mitsar.scene.loading import load_scene

__all__ = ["ambiguity_products", "run_ambiguity_experiment"]


def ambiguity_products(spec: dict[str, Any], progress: bool = False, *,
                       cached: Callable[[str], xr.Dataset | None] | None = None,
                       keep: Callable[[str, xr.Dataset], xr.Dataset] | None = None
                       ) -> dict[str, xr.Dataset]:
    """The ambiguity product of every trajectory of a validated ambiguity file.

    Parameters
    ----------
    spec : dict
        As returned by :func:`~mitsar.ambiguity.config.load_ambiguity_experiment` (or
        :func:`~mitsar.ambiguity.config.ambiguity_from_dict`).
    progress : bool
        Progress bars of the map evaluation.
    cached : callable, optional
        ``cached(name)``: the product of trajectory ``name`` when it is already made (a
        resumed run, :func:`run_ambiguity_experiment`), else None; the surface points are
        only sampled when some trajectory is not.
    keep : callable, optional
        ``keep(name, product)`` is called with each product as soon as it is made (e.g. to
        write it) and returns the product to use in its place.

    Returns
    -------
    dict
        Trajectory name -> product of :func:`~mitsar.ambiguity.maps.ambiguity`
        (docs/ambiguity.md, the product), with the file's effective values in ``config``.
    """
    products: dict[str, xr.Dataset] = {}
    for name in spec["trajectories"]:
        made = None if cached is None else cached(name)
        if made is not None:
            products[name] = made
    if len(products) == len(spec["trajectories"]):
        return products
    options = dict(spec["options"])
    shapes, exclude = options.pop("shapes", None), options.pop("exclude", ())
    spacing = options.pop("spacing")
    if spec["scene"] is not None:
        scene = load_scene(spec["scene"])
        points = sample_surfaces(scene, spacing, shapes=shapes, exclude=exclude)
    else:
        planes = spec["planes"]
        points = SurfacePoints.concatenate([
            plane_points(p["origin"], p["axis_u"], p["axis_v"], p["size"], spacing, p["name"])
            for p in planes])
        scene = planes_scene(planes) if options.get("shadowing", True) else None
    for name, trajectory in spec["trajectories"].items():
        if name in products:
            continue
        look = spec["look"][name] if isinstance(spec["look"], dict) else spec["look"]
        product = ambiguity(spec["radar"], trajectory, look, points,
                            spec["required_resolution"], scene=scene, spacing=spacing,
                            progress=progress, **options)
        product.attrs["config"] = json.dumps(spec["config"])
        products[name] = product if keep is None else keep(name, product)
    return {name: products[name] for name in spec["trajectories"]}


def run_ambiguity_experiment(path: str | os.PathLike, out_dir: str | os.PathLike, *,
                             overwrite: bool = False, figures: bool | None = None,
                             progress: bool = False,
                             log: Callable[[str], None] | None = None) -> dict[str, Any]:
    """Run an ambiguity TOML file and write its products into ``out_dir``.

    One trajectory: ``ambiguity.nc``, ``ambiguity_maps``, ``ambiguity_3d`` and
    ``ambiguity_timeline`` figures, ``summary.json``. Several (``[trajectories.NAME]``): one
    ``ambiguity_NAME.nc`` and figure set each, plus ``comparison.nc``, ``comparison.md``
    (table), ``comparison`` figure and ``summary.json``.

    The files are made in a work folder beside ``out_dir`` (``.NAME.partial``,
    :class:`mitsar.io.WorkFolder`), each trajectory's product recorded there as it is
    finished, and moved into ``out_dir`` at the end (``summary.json`` last). A run
    interrupted (SIGINT, SIGKILL) and started again with the same file and options maps only
    the trajectories not yet finished; the figures, comparison and summary are made from the
    products read back from their files, so they are the same bits either way.

    Parameters
    ----------
    path : path-like
        The ambiguity TOML file.
    out_dir : path-like
        Output folder (created).
    overwrite : bool
        Replace existing files.
    figures : bool, optional
        Draw the figures (default: the file's ``[output] figures``).
    progress : bool
        Progress bars.
    log : callable, optional
        Receives the messages of a resumed or restarted run.

    Returns
    -------
    dict
        The summary written to ``summary.json`` (per-trajectory, per-surface fractions) with
        the list of written ``files``.

    Raises
    ------
    OutputExistsError
        If ``out_dir`` holds a ``summary.json`` (or, at the end, any file the run writes) and
        ``overwrite`` is false.
    """
    spec = load_ambiguity_experiment(path)

    out_dir = Path(out_dir)
    out_dir.parent.mkdir(parents=True, exist_ok=True)
    if out_dir.exists() and not out_dir.is_dir():
        raise ProductFileError(f"{out_dir}: is a file, expected an output folder")
    if out_dir.is_dir():
        check_writable(out_dir / SUMMARY, overwrite)
    make_figures = spec["outputs"]["figures"] if figures is None else figures
    inputs = {"command": "ambiguity", "config": spec["config"], "figures": bool(make_figures),
              "scene": scene_digest(path, spec["scene"])}
    with WorkFolder(out_dir, inputs, command="ambiguity", log=log) as work:
        folder = work.file("out")
        folder.mkdir(exist_ok=True)
        summary = _write_ambiguity(spec, work, folder, out_dir, make_figures, progress)
        work.move_folder(folder, out_dir, overwrite=overwrite, last=(SUMMARY,))
        work.remove()
    return summary


SUMMARY = "summary.json"
"""The summary of an ambiguity run, written last."""


def _write_ambiguity(spec: dict[str, Any], work: WorkFolder, folder: Path, out_dir: Path,
                     make_figures: bool, progress: bool) -> dict[str, Any]:
    """The files of :func:`run_ambiguity_experiment` in ``folder`` (inside ``work``), each
    trajectory's product marked finished when written; the summary lists them under
    ``out_dir``, where they will be."""
    suffix = "." + spec["outputs"]["format"]
    files: list[str] = []
    summary: dict[str, Any] = {"name": spec["name"], "description": spec["description"],
                               "required_resolution": spec["required_resolution"],
                               "trajectories": {}}
    several = len(spec["trajectories"]) > 1
    names = {name: f"ambiguity_{name}" if several else "ambiguity"
             for name in spec["trajectories"]}

    def cached(name: str) -> xr.Dataset | None:
        file = folder / f"{names[name]}.nc"
        return load(file) if work.done(f"trajectory {name}") and file.exists() else None

    def keep(name: str, product: xr.Dataset) -> xr.Dataset:
        file = save(product, folder / f"{names[name]}.nc", overwrite=True)
        work.mark(f"trajectory {name}")
        return load(file)

    products = ambiguity_products(spec, progress=progress, cached=cached, keep=keep)
    for name, product in products.items():
        prefix = names[name]
        files.append(str(out_dir / f"{prefix}.nc"))
        if make_figures:
            files.extend(str(out_dir / Path(p).name)
                         for p in plot_ambiguity(product, folder, prefix, overwrite=True,
                                                 suffix=suffix))
        table = surface_summary(product)
        summary["trajectories"][name] = {
            "overall": overall_fractions(product),
            "surfaces": {str(s): {k: float(table[k].values[j]) for k in table.data_vars}
                         for j, s in enumerate(table["surface"].values)}}
    if several:
        comparison = comparison_from_products(products)
        comparison.attrs["config"] = json.dumps(spec["config"])
        save(comparison, folder / "comparison.nc", overwrite=True)
        files.append(str(out_dir / "comparison.nc"))
        markdown = comparison_table(comparison)
        with atomic_output(folder / "comparison.md", True) as tmp:
            tmp.write_text(markdown, encoding="utf-8")
        files.append(str(out_dir / "comparison.md"))
        if make_figures:
            plot_comparison(comparison, folder / f"comparison{suffix}", overwrite=True)
            files.append(str(out_dir / f"comparison{suffix}"))
        summary["comparison_table"] = markdown
    summary["files"] = files + [str(out_dir / SUMMARY)]
    write_json(summary, folder / SUMMARY, overwrite=True)
    return summary
