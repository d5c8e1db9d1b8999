"""Guidance: candidate trajectories compared on the same surface points."""

from __future__ import annotations

import json
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr

from mitsar.ambiguity.maps import ambiguity, overall_fractions, points_and_scene, surface_summary
from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import Look
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import Radar

__all__ = ["compare_trajectories", "comparison_from_products", "comparison_table"]


def compare_trajectories(radar: Radar, look: Look | Mapping[str, Look], scene: Any,
                         trajectories: Mapping[str, Trajectory],
                         required_resolution: float = 0.10, *, spacing: float = 0.25,
                         return_products: bool = False,
                         **options: Any) -> xr.Dataset | tuple[xr.Dataset, dict]:
    """Compare candidate trajectories on the same surface points.

    Parameters
    ----------
    radar : Radar
    look : Look or mapping name -> Look
        One antenna mounting for all, or one per trajectory.
    scene : scene, path, name or point set
        As ``scene_or_grid`` of :func:`ambiguity`; a scene is sampled once.
    trajectories : mapping name -> Trajectory
    required_resolution : float
    spacing : float
        Point spacing on scene surfaces [m].
    return_products : bool
        Also return the per-trajectory ambiguity products.
    **options
        Passed to :func:`ambiguity` (``per_state`` defaults to False here).

    Returns
    -------
    xarray.Dataset
        ``product = "ambiguity_comparison"``: per (trajectory, surface) the fractions of
        :func:`surface_summary`; per trajectory the overall fractions (``total_*``); per
        (trajectory, point) ``status`` and the best resolutions; per point ``position``,
        ``surface_index``, ``area``, ``map_u``, ``map_v``; and ``union_fraction_resolved``
        (surface): the area resolved by at least one trajectory.
    """
    if not trajectories:
        raise ParameterError("compare_trajectories", "trajectories",
                             "at least one name -> Trajectory", trajectories)
    points, shadow_scene = points_and_scene(scene, spacing, options.pop("shapes", None),
                                            options.pop("exclude", ()), options.pop("scene", None))
    options.setdefault("per_state", False)
    products = {}
    for name, trajectory in trajectories.items():
        this_look = look[name] if isinstance(look, Mapping) else look
        products[name] = ambiguity(radar, trajectory, this_look, points, required_resolution,
                                   scene=shadow_scene, spacing=spacing, **options)
    out = comparison_from_products(products)
    if return_products:
        return out, products
    return out


def comparison_from_products(products: Mapping[str, xr.Dataset]) -> xr.Dataset:
    """The comparison dataset of :func:`compare_trajectories` from ambiguity products.

    The products must share their surface points (same ``position``).
    """
    names = list(products)
    if not names:
        raise ParameterError("comparison_from_products", "products", "at least one product",
                             0)
    first = products[names[0]]
    for name in names[1:]:
        if not np.array_equal(products[name]["position"].values, first["position"].values):
            raise ParameterError("comparison_from_products", name,
                                 "a product on the same surface points", "other points")
    tables = [surface_summary(products[name]) for name in names]
    table = xr.concat(tables, dim=xr.DataArray(names, dims="trajectory", name="trajectory"))
    overall = [overall_fractions(products[name]) for name in names]
    out = xr.Dataset(coords={"trajectory": names, "surface": first["surface"].values,
                             "facet": first["facet"].values, "point": first["point"].values,
                             "xyz": ["x", "y", "z"]})
    for key in table.data_vars:
        out[key] = table[key] if key != "surface_area" else table[key].isel(trajectory=0,
                                                                            drop=True)
    for key in overall[0]:
        if key != "surface_area":
            out[f"total_{key}"] = ("trajectory", [o[key] for o in overall], {"units": "1"})
    for key in ("status", "best_range_resolution", "best_azimuth_resolution", "best_time"):
        out[key] = xr.concat([products[n][key] for n in names], dim="trajectory")
    for key in ("position", "surface_index", "facet_index", "area", "map_u", "map_v"):
        out[key] = first[key]
    resolved_any = (out["status"] == 3).any("trajectory").values
    index = first["surface_index"].values
    area = first["area"].values
    total = np.bincount(index, weights=area, minlength=out.sizes["surface"])
    out["union_fraction_resolved"] = ("surface", np.bincount(
        index, weights=area * resolved_any, minlength=out.sizes["surface"])
        / np.where(total > 0, total, 1.0), {
            "units": "1", "long_name": "area fraction resolved by at least one trajectory"})
    out["total_union_fraction_resolved"] = ((), float(area @ resolved_any / area.sum()),
                                            {"units": "1"})
    out.attrs.update({k: v for k, v in first.attrs.items()
                      if k.startswith(("radar_", "look_")) or k in (
                          "required_resolution", "required_range_resolution",
                          "required_azimuth_resolution", "min_angle_deg", "beam_threshold_db",
                          "integration_time_mode", "integration_time", "criterion",
                          "shadowing", "spacing", "mitsar_version")})
    out.attrs.update(
        product="ambiguity_comparison",
        trajectories=json.dumps({n: json.loads(products[n].attrs["trajectory"])
                                 for n in names}),
        looks=json.dumps({n: [products[n].attrs["look_off_nadir_deg"],
                              products[n].attrs["look_squint_deg"]] for n in names}),
        tracks=json.dumps({n: products[n]["platform_position"].values.tolist()
                           for n in names}))
    return out


def comparison_table(comparison: xr.Dataset) -> str:
    """The comparison as a Markdown table (percent of area resolved per surface)."""
    names = [str(n) for n in comparison["trajectory"].values]
    surfaces = [str(s) for s in comparison["surface"].values]
    header = "| surface | area [m^2] | " + " | ".join(names) + " | any |"
    lines = [header, "|" + "---|" * (len(names) + 3)]
    for j, surface in enumerate(surfaces):
        values = [f"{100 * comparison['fraction_resolved'].values[i, j]:.1f}"
                  for i in range(len(names))]
        lines.append(f"| {surface} | {comparison['surface_area'].values[j]:.1f} | "
                     + " | ".join(values)
                     + f" | {100 * comparison['union_fraction_resolved'].values[j]:.1f} |")
    totals = [f"{100 * v:.1f}" for v in comparison["total_fraction_resolved"].values]
    area = comparison["area"].values
    union = float(comparison["total_union_fraction_resolved"])
    lines.append(f"| **all** | {area.sum():.1f} | " + " | ".join(totals)
                 + f" | {100 * union:.1f} |")
    return "\n".join(lines) + "\n"
