"""Run an ambiguity TOML file: maps of every trajectory, their comparison, figures, summary."""

from __future__ import annotations

import json
import os
from pathlib import Path
from typing import Any

import xarray as xr

from mitsar.ambiguity.comparison import comparison_from_products, comparison_table
from mitsar.ambiguity.config import load_ambiguity_experiment
from mitsar.ambiguity.maps import ambiguity, overall_fractions, surface_summary
from mitsar.ambiguity.plots import plot_ambiguity, plot_comparison
from mitsar.ambiguity.points import SurfacePoints, plane_points, sample_surfaces
from mitsar.ambiguity.shadows import planes_scene
from mitsar.io import atomic_output, save, write_json
from mitsar.scene.loading import load_scene

__all__ = ["ambiguity_products", "run_ambiguity_experiment"]


def ambiguity_products(spec: dict[str, Any], progress: bool = False
                       ) -> dict[str, xr.Dataset]:
    """The ambiguity product of every trajectory of a validated ambiguity file.

    Parameters
    ----------
    spec : dict
        As returned by :func:`~mitsar.ambiguity.config.load_ambiguity_experiment` (or
        :func:`~mitsar.ambiguity.config.ambiguity_from_dict`).
    progress : bool
        Progress bars of the map evaluation.

    Returns
    -------
    dict
        Trajectory name -> product of :func:`~mitsar.ambiguity.maps.ambiguity`
        (docs/ambiguity.md, the product), with the file's effective values in ``config``.
    """
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
    products = {}
    for name, trajectory in spec["trajectories"].items():
        look = spec["look"][name] if isinstance(spec["look"], dict) else spec["look"]
        product = ambiguity(spec["radar"], trajectory, look, points,
                            spec["required_resolution"], scene=scene, spacing=spacing,
                            progress=progress, **options)
        product.attrs["config"] = json.dumps(spec["config"])
        products[name] = product
    return products


def run_ambiguity_experiment(path: str | os.PathLike, out_dir: str | os.PathLike, *,
                             overwrite: bool = False, figures: bool | None = None,
                             progress: bool = False) -> dict[str, Any]:
    """Run an ambiguity TOML file and write its products into ``out_dir``.

    One trajectory: ``ambiguity.nc``, ``ambiguity_maps``, ``ambiguity_3d`` and
    ``ambiguity_timeline`` figures, ``summary.json``. Several (``[trajectories.NAME]``): one
    ``ambiguity_NAME.nc`` and figure set each, plus ``comparison.nc``, ``comparison.md``
    (table), ``comparison`` figure and ``summary.json``.

    Returns
    -------
    dict
        The summary written to ``summary.json`` (per-trajectory, per-surface fractions) with
        the list of written ``files``.
    """
    spec = load_ambiguity_experiment(path)

    out_dir = Path(out_dir)
    out_dir.mkdir(parents=True, exist_ok=True)
    make_figures = spec["outputs"]["figures"] if figures is None else figures
    suffix = "." + spec["outputs"]["format"]
    files: list[str] = []
    summary: dict[str, Any] = {"name": spec["name"], "description": spec["description"],
                               "required_resolution": spec["required_resolution"],
                               "trajectories": {}}
    several = len(spec["trajectories"]) > 1
    products = ambiguity_products(spec, progress=progress)
    for name, product in products.items():
        prefix = f"ambiguity_{name}" if several else "ambiguity"
        files.append(str(save(product, out_dir / f"{prefix}.nc", overwrite=overwrite)))
        if make_figures:
            files.extend(str(p) for p in plot_ambiguity(product, out_dir, prefix,
                                                        overwrite=overwrite, suffix=suffix))
        table = surface_summary(product)
        summary["trajectories"][name] = {
            "overall": overall_fractions(product),
            "surfaces": {str(s): {k: float(table[k].values[j]) for k in table.data_vars}
                         for j, s in enumerate(table["surface"].values)}}
    if several:
        comparison = comparison_from_products(products)
        comparison.attrs["config"] = json.dumps(spec["config"])
        files.append(str(save(comparison, out_dir / "comparison.nc", overwrite=overwrite)))
        markdown = comparison_table(comparison)
        with atomic_output(out_dir / "comparison.md", overwrite) as tmp:
            tmp.write_text(markdown, encoding="utf-8")
        files.append(str(out_dir / "comparison.md"))
        if make_figures:
            files.append(str(plot_comparison(comparison, out_dir / f"comparison{suffix}",
                                             overwrite=overwrite)))
        summary["comparison_table"] = markdown
    summary["files"] = files + [str(out_dir / "summary.json")]
    write_json(summary, out_dir / "summary.json", overwrite=overwrite)
    return summary
