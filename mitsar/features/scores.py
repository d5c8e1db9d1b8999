"""Map accuracy against the scene: the 3-D reconstruction benchmarks' scores (docs/features.md).

Definitions (Knapitsch et al. 2017, "Tanks and Temples", ACM TOG 36(4) 78, §4; Schöps et al.
2017, "A multi-view stereo benchmark with high-resolution images and multi-camera videos"
(ETH3D), CVPR, §4), with the map ``M`` (detected points) and the truth ``G`` (surface samples
of the scene, :func:`mitsar.features.truth.scene_truth`) at a distance threshold ``tau``:

- **accuracy**: the distance ``e(m)`` from each map point to the nearest truth surface, reported
  as mean, median and 90th percentile [m] (the 90 % figure is Seitz et al. 2006's "accuracy");
- **precision** ``P(tau)``: the fraction of map points with ``e(m) <= tau``;
- **completeness** = **recall** ``R(tau)``: the fraction of the *observable* truth surface
  within ``tau`` of a map point (each sample weighted by the area it stands for, so uneven
  sampling does not bias it; with even sampling it is Knapitsch's point fraction);
- **F-score** ``F(tau) = 2 P R / (P + R)`` (0 when both are 0).

Feature scores: a truth feature (trihedral corner, dihedral edge, ...) is *found* when a point
detection lies within ``radius`` of it (of the corner, or of the edge segment), default one
resolution cell of the detections (the largest of their ``resolution`` attribute);
*feature recall* is the fraction of the observable features of the scored kinds found,
*feature precision* the fraction of point detections within ``radius`` of a truth feature of
those kinds, and the *localisation error* of a found feature its distance to the nearest
detection [m]. A feature that no antenna position has in its beam unoccluded is "not_visible",
never "missed".
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from scipy.spatial import cKDTree

from mitsar.errors import ParameterError
from mitsar.features.truth import (
    FEATURE_KINDS,
    SceneTruth,
    point_segment_distance,
    scene_truth,
)

__all__ = ["FeatureScores", "map_scores", "scores_dataset", "scores_table"]

SCORED_KINDS = ("trihedral", "dihedral")
"""Feature kinds scored by default: the corner reflectors a radar map is expected to show
(the paper's conclusions: dihedral and trihedral corners are "relevant features")."""


class FeatureScores(list):
    """Per-feature records (dicts) that also answer their summary by name.

    ``scores["features"][0]`` is the first feature's record (``id``, ``kind``, ``position``,
    ``start``, ``end``, ``shapes``, ``normals``, ``observable``, ``in_footprint``, ``reason``,
    ``found``, ``error``, ``status``, ``detection``); ``scores["features"]["recall"]`` is a
    summary value (``recall``, ``precision``, ``radius``, ``localisation_error_mean``,
    ``localisation_error_max``, ``found``, ``missed``, ``not_visible``, ``kinds``).
    """

    def __init__(self, records: Sequence[dict[str, Any]], summary: dict[str, Any]) -> None:
        super().__init__(records)
        self.summary = dict(summary)

    def __getitem__(self, key: Any) -> Any:
        if isinstance(key, str):
            return self.summary[key]
        return super().__getitem__(key)

    def keys(self) -> list[str]:
        """Names of the summary values."""
        return list(self.summary)


def _positions(found: Any, name: str) -> NDArray[np.float64]:
    """An (n, 3) float array from a detections Dataset variable, a DataArray or an array."""
    if isinstance(found, xr.Dataset):
        if name not in found.variables:
            raise ParameterError("map_scores", "found", f"a Dataset with a '{name}' variable "
                                 "(detection, xyz) [m]", sorted(map(str, found.variables)))
        value = found[name]
        other = [d for d in value.dims if d != "xyz"]
        value = value.transpose(*other, "xyz").values if "xyz" in value.dims else value.values
    elif isinstance(found, xr.DataArray):
        value = found.values
    else:
        value = found
    array = np.asarray(value, dtype=float)
    if array.size == 0:
        return np.zeros((0, 3))
    if array.ndim != 2 or array.shape[1] != 3 or not np.all(np.isfinite(array)):
        raise ParameterError("map_scores", "found", "finite positions of shape (n, 3) [m]",
                             array.shape)
    return array


def _surface_distance(points: NDArray, truth: SceneTruth) -> NDArray[np.float64]:
    """Distance [m] from points to the nearest truth surface.

    The nearest sample stands for the patch around it: a disk of radius ``spacing / sqrt(2)``
    (the half diagonal of its cell) in its tangent plane, so that a point on the surface between
    samples is at distance 0 and a point ``d`` off the surface along its normal at ``d``:
    ``sqrt(z^2 + max(0, q - r)^2)`` with ``z`` and ``q`` the normal and in-plane parts of the
    offset from the sample.
    """
    if len(points) == 0:
        return np.zeros(0)
    if len(truth) == 0:
        return np.full(len(points), np.inf)
    _, nearest = cKDTree(truth.points).query(points)
    offset = points - truth.points[nearest]
    normal_part = np.einsum("ij,ij->i", offset, truth.normals[nearest])
    in_plane = np.sqrt(np.maximum(np.einsum("ij,ij->i", offset, offset) - normal_part**2, 0.0))
    radius = truth.spacing / math.sqrt(2.0)
    return np.hypot(normal_part, np.maximum(in_plane - radius, 0.0))


def _radius(found: Any, radius: float | None, tau: float) -> tuple[float, str]:
    """The feature radius [m] and where it comes from."""
    if radius is not None:
        if not (isinstance(radius, int | float) and math.isfinite(radius) and radius > 0):
            raise ParameterError("map_scores", "radius", "a radius > 0 m", radius)
        return float(radius), "argument"
    if isinstance(found, xr.Dataset) and "resolution" in found.attrs:
        cell = np.asarray(found.attrs["resolution"], dtype=float).ravel()
        cell = cell[np.isfinite(cell) & (cell > 0)]
        if cell.size:
            return float(cell.max()), "resolution cell (largest of the detections' resolution)"
    return float(tau), "tau (the detections record no resolution)"


def map_scores(found: Any, scene_or_truth: Any, tau: float = 0.05, *,
               radius: float | None = None, kinds: Sequence[str] = SCORED_KINDS,
               track: Any = None, bounds: Any = None,
               spacing: float | None = None, seed: int = 0,
               map_points: str = "auto", feature_points: Any = None) -> dict[str, Any]:
    """Score a map of detections against the scene it was made of.

    Definitions in the module docstring (Knapitsch et al. 2017; Schöps et al. 2017).

    Parameters
    ----------
    found : xarray.Dataset or array_like
        Detections (:func:`mitsar.detect`): ``position`` (detection, xyz) [m], one per point
        feature, and optionally ``cell_position`` (cell, xyz) [m], every detected cell; or an
        (n, 3) array of points [m] standing for both.
    scene_or_truth : mitsuba.Scene, str or SceneTruth
        The scene (loaded, a path or a canned name) or a truth already built
        (:func:`mitsar.features.truth.scene_truth`; then ``track``, ``bounds``, ``spacing`` and
        ``seed`` are its own).
    tau : float
        Distance threshold [m] of precision, completeness and F-score (default 5 cm).
    radius : float, optional
        Feature search radius [m]; default one resolution cell of ``found`` (the largest of
        its ``resolution`` attribute), else ``tau``.
    kinds : sequence of str
        Feature kinds scored (default trihedral and dihedral; every feature is listed).
    track : raw product(s) or Observer, optional
        The flight, for what is observable (:func:`mitsar.features.truth.scene_truth`);
        without it everything in ``bounds`` counts as observable.
    bounds : array_like of shape (2, 3), VolumeGrid or image product, optional
        Box [m] of the map, or the grid / volume image whose extent it is: truth outside it is
        not scored, nor are map points more than ``tau`` outside it.
    spacing : float, optional
        Truth sample spacing [m]; default ``tau``.
    seed : int
        Seed of the truth sampler (recorded).
    map_points : {"auto", "cells", "detections"}
        Which points are the map: every detected cell (``cell_position``, the default when
        present) or the point detections (``position``).
    feature_points : array_like or Dataset, optional
        Point detections scored against the features (default the ``position`` of ``found``).

    Returns
    -------
    dict
        ``tau`` [m]; ``accuracy`` (mean distance) [m], ``accuracy_median``,
        ``accuracy_p90`` [m]; ``precision``, ``completeness``, ``recall`` (= completeness),
        ``f_score`` [1]; ``map_points``, ``truth_samples`` (observable), ``truth_area``
        (observable) [m²], ``spacing`` [m], ``seed``; ``features`` (:class:`FeatureScores`);
        ``feature_recall``, ``feature_precision``, ``feature_radius`` [m],
        ``feature_radius_source``, ``localisation_error_mean``, ``localisation_error_max`` [m];
        ``not_visible``, ``missed``, ``found_features`` (feature ids); ``observed`` (whether a
        flight decided observability). NaN where a mean has nothing to average.
    """
    if not (isinstance(tau, int | float) and math.isfinite(tau) and tau > 0):
        raise ParameterError("map_scores", "tau", "a distance threshold > 0 m", tau)
    if isinstance(kinds, str) or not set(kinds) <= set(FEATURE_KINDS):
        raise ParameterError("map_scores", "kinds", f"a sequence of {FEATURE_KINDS}", kinds)
    if map_points not in ("auto", "cells", "detections"):
        raise ParameterError("map_scores", "map_points", "'auto', 'cells' or 'detections'",
                             map_points)
    if isinstance(scene_or_truth, SceneTruth):
        truth = scene_or_truth
    else:
        truth = scene_truth(scene_or_truth, float(spacing) if spacing is not None else tau,
                            track=track, bounds=bounds, seed=seed)
    has_cells = isinstance(found, xr.Dataset) and "cell_position" in found.variables
    if map_points == "cells" and not has_cells:
        raise ParameterError("map_scores", "map_points", "a Dataset with 'cell_position' for "
                             "'cells'", sorted(map(str, getattr(found, "variables", []))))
    use_cells = has_cells and map_points != "detections"
    points = _positions(found, "cell_position" if use_cells else "position")
    features_at = _positions(found if feature_points is None else feature_points, "position")
    if truth.bounds is not None:
        box = truth.bounds
        points = points[np.all((points >= box[0] - tau) & (points <= box[1] + tau), axis=1)]

    # Accuracy and precision: map -> truth (every truth surface, observable or not).
    error = _surface_distance(points, truth)
    precision = float(np.mean(error <= tau)) if len(points) else 0.0
    # Completeness: observable truth -> map, area-weighted.
    seen = truth.observable
    area = truth.area[seen]
    if len(points) and area.size:
        reach, _ = cKDTree(points).query(truth.points[seen], distance_upper_bound=2 * tau)
        completeness = float(np.sum(area[reach <= tau]) / np.sum(area))
    else:
        completeness = 0.0
    f_score = (2 * precision * completeness / (precision + completeness)
               if precision + completeness > 0 else 0.0)

    features = _feature_scores(features_at, truth, found, radius, tau, tuple(kinds))
    summary = features.summary

    def stat(function: Any) -> float:
        return float(function(error)) if len(error) else math.nan

    return {
        "tau": float(tau),
        "accuracy": stat(np.mean), "accuracy_median": stat(np.median),
        "accuracy_p90": stat(lambda e: np.percentile(e, 90)),
        "precision": precision, "completeness": completeness, "recall": completeness,
        "f_score": float(f_score),
        "map_points": int(len(points)), "map_points_source": "cells" if use_cells
        else "detections",
        "truth_samples": int(seen.sum()), "truth_area": float(np.sum(area)),
        "spacing": truth.spacing, "seed": truth.seed, "observed": truth.observed,
        "features": features,
        "feature_recall": summary["recall"], "feature_precision": summary["precision"],
        "feature_radius": summary["radius"], "feature_radius_source": summary["radius_source"],
        "localisation_error_mean": summary["localisation_error_mean"],
        "localisation_error_max": summary["localisation_error_max"],
        "not_visible": summary["not_visible"], "missed": summary["missed"],
        "found_features": summary["found"],
    }


def _feature_scores(detections: NDArray, truth: SceneTruth, found: Any, radius: float | None,
                    tau: float, kinds: tuple[str, ...]) -> FeatureScores:
    """Per-feature found / missed / not visible, and the feature recall and precision."""
    feats = truth.features
    search, source = _radius(found, radius, tau)
    if len(feats) and len(detections):
        distance = point_segment_distance(detections, feats.start, feats.end)   # (D, F)
        nearest = np.argmin(distance, axis=0)
        error = distance[nearest, np.arange(len(feats))]
    else:
        distance = np.zeros((len(detections), len(feats)))
        nearest = np.full(len(feats), -1)
        error = np.full(len(feats), np.inf)
    hit = error <= search
    scored = np.isin(feats.kind, kinds)
    status = np.where(~feats.observable, "not_visible", np.where(hit, "found", "missed"))
    ids = feats.ids
    records = [
        {"id": ids[f], "kind": str(feats.kind[f]), "position": feats.position[f].tolist(),
         "start": feats.start[f].tolist(), "end": feats.end[f].tolist(),
         "shapes": feats.shapes[f], "normals": feats.normals[f].tolist(),
         "scored": bool(scored[f]), "observable": bool(feats.observable[f]),
         "in_footprint": bool(feats.in_footprint[f]), "reason": str(feats.reason[f]),
         "observable_fraction": float(feats.observable_fraction[f]),
         "found": bool(hit[f]), "error": float(error[f]) if hit[f] else math.nan,
         "distance": float(error[f]), "status": str(status[f]),
         "detection": int(nearest[f]) if hit[f] else -1}
        for f in range(len(feats))]                             # one record per feature
    counted = scored & feats.observable
    found_errors = error[counted & hit]
    near_feature = (distance[:, scored] <= search).any(axis=1) if scored.any() else \
        np.zeros(len(detections), dtype=bool)
    summary = {
        "recall": float(np.mean(hit[counted])) if counted.any() else math.nan,
        "precision": float(np.mean(near_feature)) if len(detections) else math.nan,
        "radius": search, "radius_source": source, "kinds": list(kinds),
        "localisation_error_mean": float(np.mean(found_errors)) if found_errors.size
        else math.nan,
        "localisation_error_max": float(np.max(found_errors)) if found_errors.size
        else math.nan,
        "found": [ids[f] for f in np.flatnonzero(scored & (status == "found"))],
        "missed": [ids[f] for f in np.flatnonzero(scored & (status == "missed"))],
        "not_visible": [ids[f] for f in np.flatnonzero(scored & (status == "not_visible"))],
    }
    return FeatureScores(records, summary)


_UNITS = {"tau": "m", "accuracy": "m", "accuracy_median": "m", "accuracy_p90": "m",
          "precision": "1", "completeness": "1", "recall": "1", "f_score": "1",
          "map_points": "1", "truth_samples": "1", "truth_area": "m2", "spacing": "m",
          "feature_recall": "1", "feature_precision": "1", "feature_radius": "m",
          "localisation_error_mean": "m", "localisation_error_max": "m"}
_LONG_NAMES = {
    "tau": "distance threshold", "accuracy": "mean distance, map point to truth surface",
    "accuracy_median": "median distance, map point to truth surface",
    "accuracy_p90": "90th percentile distance, map point to truth surface",
    "precision": "fraction of map points within tau of the truth (Knapitsch 2017)",
    "completeness": "fraction of the observable truth area within tau of the map",
    "recall": "= completeness", "f_score": "2PR/(P+R) at tau",
    "map_points": "map points scored", "truth_samples": "observable truth samples",
    "truth_area": "observable truth area", "spacing": "truth sample spacing",
    "feature_recall": "fraction of observable scored features found",
    "feature_precision": "fraction of point detections within the radius of a feature",
    "feature_radius": "feature search radius",
    "localisation_error_mean": "mean distance, found feature to nearest detection",
    "localisation_error_max": "largest distance, found feature to nearest detection"}


def scores_table(scores: dict[str, Any]) -> list[tuple[str, float, str, str]]:
    """The scalar scores as rows ``(name, value, units, meaning)`` for a report table."""
    return [(name, float(scores[name]), _UNITS[name], _LONG_NAMES[name])
            for name in _UNITS if name in scores]


def scores_dataset(scores: dict[str, Any]) -> xr.Dataset:
    """The scores as an ``xarray.Dataset``: scalars with units, per-feature variables on dim
    ``feature`` (kind, position, status, localisation error ...), provenance attributes."""
    records = list(scores["features"])
    data = xr.Dataset(
        {name: ((), value, {"units": units, "long_name": meaning})
         for name, value, units, meaning in scores_table(scores)},
        coords={"feature": [r["id"] for r in records], "xyz": ["x", "y", "z"]})
    if records:
        data["feature_kind"] = ("feature", [r["kind"] for r in records])
        data["feature_position"] = (("feature", "xyz"), [r["position"] for r in records],
                                    {"units": "m"})
        data["feature_status"] = ("feature", [r["status"] for r in records])
        data["feature_reason"] = ("feature", [r["reason"] for r in records])
        data["feature_scored"] = ("feature", [r["scored"] for r in records])
        data["feature_error"] = ("feature", [r["error"] for r in records],
                                 {"units": "m", "long_name": "localisation error (NaN: not "
                                  "found)"})
    data.attrs.update(product="map_scores", seed=int(scores["seed"]),
                      observed=int(scores["observed"]), map_points_source=scores[
                          "map_points_source"], feature_radius_source=scores[
                          "feature_radius_source"],
                      feature_kinds=list(scores["features"]["kinds"]))
    return data
