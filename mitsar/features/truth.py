"""Ground truth of a map, from the Mitsuba scene: surfaces, geometric features, what is observable.

mitsar owns what no real campaign has, the scene itself; a map made from its images can be
scored against it (:func:`mitsar.features.scores.map_scores`, docs/features.md "Map scores").
The truth has three parts:

- **surface samples**: points with normals about ``spacing`` apart on every shape but point
  targets, from the sampler the ambiguity maps use
  (:func:`mitsar.scene.surfaces.sample_surface_points`), each standing for its area;
- **geometric features** of the meshes (:func:`scene_features`): straight edges where two planar
  faces meet, classified by the angle of the air wedge between them (the side the normals point
  to; mitsar's scenes point them into the room): a concave right angle is a ``"dihedral"``, any
  other concave angle a ``"concave_edge"``, a convex fold a ``"convex_edge"``; a point where
  three mutually perpendicular dihedral edges meet is a ``"trihedral"`` corner. Faces of
  different shapes count as meeting where one face's edge lies on the other face within a
  tolerance (the canned rooms build their corners from separate rectangles that share no mesh
  edge; a cabinet stands on a floor whose triangle it does not share); a face lying back to back
  on another (a cabinet's bottom on the floor) is hidden and makes no edge;
- **observability** (:func:`observe_points`): a point is observable when, from at least one
  antenna position of the flight, it is inside the nominal beam (direction sines within half the
  beamwidths, the footprint's convention of :func:`mitsar.scene.footprint.beam_directions`, and
  within ``max_range``) and nothing in the scene blocks the segment between them (one batched
  Mitsuba ``ray_test``, :func:`mitsar.scene.facets.segments_visible`). A feature no pass
  observes is "not visible" in the scores, not "missed".

The features are :mod:`mitsar.features.mesh_features`'s and the observability
:mod:`mitsar.features.observability`'s (their names are imported here); this module samples
the surfaces and assembles :class:`SceneTruth`.
"""

from __future__ import annotations

import math
from dataclasses import dataclass, field
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.features.mesh_features import (
    FEATURE_KINDS,
    TruthFeatures,
    point_segment_distance,
    scene_features,
    unit_vectors,
)
from mitsar.features.observability import Observer, as_observer, observe_points, observer_from_track
from mitsar.scene.loading import load_scene
from mitsar.scene.surfaces import sample_surface_points

__all__ = ["FEATURE_KINDS", "Observer", "SceneTruth", "TruthFeatures", "observe_points",
           "point_segment_distance",
           "observer_from_track", "scene_features", "scene_truth"]


def _feature_samples(features: TruthFeatures, spacing: float, offset: float
                     ) -> tuple[NDArray, NDArray, NDArray]:
    """Points about ``spacing`` apart along every feature, moved ``offset`` into the air along
    the bisector of its faces' normals; their normals and the feature each belongs to."""
    length = np.linalg.norm(features.end - features.start, axis=1)
    count = np.maximum(1, np.ceil(length / spacing).astype(int) + 1)
    owner = np.repeat(np.arange(len(features)), count)
    first = np.cumsum(count) - count
    step = np.arange(len(owner)) - first[owner]
    fraction = np.where(count[owner] > 1, step / np.maximum(count[owner] - 1, 1), 0.5)
    points = features.start[owner] + fraction[:, None] * (features.end - features.start)[owner]
    bisector = unit_vectors(np.nansum(features.normals, axis=1))[owner]
    return points + offset * bisector, bisector, owner


@dataclass(frozen=True)
class SceneTruth:
    """Ground truth of a map: surface samples, features and what the flight observes.

    Attributes
    ----------
    points, normals : numpy.ndarray, shape (N, 3)
        Surface samples [m] and their unit normals.
    area : numpy.ndarray, shape (N,)
        Area each sample stands for [m²].
    surface : numpy.ndarray of int, shape (N,)
        Index of each sample's shape in ``names``.
    names : tuple of str
        Ids of the sampled shapes.
    in_footprint, observable : numpy.ndarray of bool, shape (N,)
        Per sample, as :func:`observe_points` (all True without a flight).
    features : TruthFeatures
    spacing : float
        Sample spacing [m].
    seed : int
        Seed of the sampler (random samples on analytic shapes and small triangles only).
    bounds : numpy.ndarray or None
        Box ``[[x0, y0, z0], [x1, y1, z1]]`` [m] the truth was cut to, None for the whole scene.
    observed : bool
        Whether observability comes from a flight (False: everything counts as observable).
    tolerance : float
        Geometric tolerance of the feature extraction [m].
    """

    points: NDArray[np.float64]
    normals: NDArray[np.float64]
    area: NDArray[np.float64]
    surface: NDArray[np.int64]
    names: tuple[str, ...]
    in_footprint: NDArray[np.bool_]
    observable: NDArray[np.bool_]
    features: TruthFeatures
    spacing: float
    seed: int
    bounds: NDArray[np.float64] | None = None
    observed: bool = False
    tolerance: float = 1e-3
    attrs: dict[str, Any] = field(default_factory=dict)

    def __len__(self) -> int:
        return int(self.points.shape[0])

    def to_dataset(self) -> xr.Dataset:
        """Surface samples (dim ``sample``) and features (dim ``feature``) as one Dataset."""
        data = self.features.to_dataset().rename({"kind": "feature_kind",
                                                  "position": "feature_position",
                                                  "in_footprint": "feature_in_footprint",
                                                  "observable": "feature_observable"})
        data["sample_position"] = (("sample", "xyz"), self.points, {"units": "m"})
        data["sample_normal"] = (("sample", "xyz"), self.normals, {"units": "1"})
        data["sample_area"] = ("sample", self.area, {"units": "m2"})
        data["sample_surface"] = ("sample", np.array(self.names, dtype=str)[self.surface])
        data["sample_in_footprint"] = ("sample", self.in_footprint)
        data["sample_observable"] = ("sample", self.observable)
        data.attrs.update(spacing=self.spacing, seed=self.seed, observed=int(self.observed),
                          tolerance=self.tolerance, **self.attrs)
        if self.bounds is not None:
            data.attrs["bounds"] = self.bounds.ravel().tolist()
        return data


def _check_bounds(bounds: Any) -> NDArray | None:
    """A (2, 3) box [m] from an array, a grid with ``axes()`` (``VolumeGrid``: its voxel
    centres' extent) or an image product (its ``position`` extent)."""
    if bounds is None:
        return None
    if hasattr(bounds, "axes") and callable(bounds.axes):
        axes = bounds.axes()
        bounds = [[float(np.min(a)) for a in axes], [float(np.max(a)) for a in axes]]
    elif isinstance(bounds, xr.Dataset) and "position" in bounds.variables:
        position = bounds["position"]
        flat = position.transpose(*[d for d in position.dims if d != "xyz"], "xyz").values
        flat = flat.reshape(-1, 3)
        bounds = [np.nanmin(flat, axis=0), np.nanmax(flat, axis=0)]
    box = np.asarray(bounds, dtype=float)
    if box.shape != (2, 3) or not np.all(np.isfinite(box)) or not np.all(box[1] > box[0]):
        raise ParameterError("scene_truth", "bounds", "[[x0, y0, z0], [x1, y1, z1]] with "
                             "x1 > x0, y1 > y0, z1 > z0 [m]", bounds)
    return box


def _clip_segments(start: NDArray, end: NDArray, box: NDArray, tolerance: float
                   ) -> tuple[NDArray, NDArray, NDArray]:
    """Segments clipped to a box (slab method), and which keep a part."""
    seg = end - start
    with np.errstate(divide="ignore", invalid="ignore"):
        t0 = (box[0] - tolerance - start) / seg
        t1 = (box[1] + tolerance - start) / seg
    parallel = np.abs(seg) < 1e-12
    inside = (start >= box[0] - tolerance) & (start <= box[1] + tolerance)
    low = np.where(parallel, np.where(inside, -np.inf, np.inf), np.minimum(t0, t1))
    high = np.where(parallel, np.where(inside, np.inf, -np.inf), np.maximum(t0, t1))
    lo = np.clip(low.max(axis=1), 0.0, 1.0)
    hi = np.clip(high.min(axis=1), 0.0, 1.0)
    keep = (hi >= lo) & ~((parallel & ~inside).any(axis=1))
    return start + lo[:, None] * seg, start + hi[:, None] * seg, keep


def scene_truth(scene: Any, spacing: float = 0.05, *, track: Any = None,
                bounds: Any = None, seed: int = 0, samples: int | None = None,
                cover: float = 1.0, tolerance: float = 1e-3, angle_tolerance_deg: float = 5.0,
                min_fold_deg: float = 20.0, feature_offset: float = 0.01) -> SceneTruth:
    """The ground truth of a map of ``scene``, and what a flight over it observes.

    Parameters
    ----------
    scene : mitsuba.Scene or str
        A loaded scene, or a path / canned scene name.
    spacing : float
        Surface sample spacing [m] (default 5 cm; the scores' threshold ``tau`` or finer).
    track : raw product, sequence of raw products, or Observer, optional
        The flight (one raw product per pass, :func:`observer_from_track`); without it every
        sample and feature counts as observable.
    bounds : array_like of shape (2, 3), VolumeGrid or image product, optional
        Keep the truth inside this box [m]: ``[[x0, y0, z0], [x1, y1, z1]]``, or the extent of
        a grid's voxel centres or of an image's ``position`` (the focused volume).
    seed : int
        Seed of :func:`mitsar.scene.surfaces.sample_surface_points` (recorded).
    samples, cover
        Antenna positions per pass and beam cover (:func:`observer_from_track`).
    tolerance, angle_tolerance_deg, min_fold_deg
        Feature extraction (:func:`scene_features`).
    feature_offset : float
        Distance [m] a feature's samples are moved into the air (along the bisector of its
        faces' normals) before the ray tests, so that the faces that make the corner do not
        hide it (default 1 cm).

    Returns
    -------
    SceneTruth
    """
    if not (isinstance(spacing, int | float) and math.isfinite(spacing) and spacing > 0):
        raise ParameterError("scene_truth", "spacing", "a spacing > 0 m", spacing)
    if isinstance(seed, bool) or not isinstance(seed, int | np.integer) or seed < 0:
        raise ParameterError("scene_truth", "seed", "an integer >= 0", seed)
    box = _check_bounds(bounds)
    if isinstance(scene, str):
        scene = load_scene(scene)
    surface = sample_surface_points(scene, float(spacing), seed=int(seed))
    keep = np.ones(len(surface.positions), dtype=bool)
    if box is not None:
        keep = np.all((surface.positions >= box[0]) & (surface.positions <= box[1]), axis=1)
    points, normals = surface.positions[keep], surface.normals[keep]
    features = scene_features(scene, tolerance=tolerance, angle_tolerance_deg=angle_tolerance_deg,
                              min_fold_deg=min_fold_deg)
    if box is not None:
        start, end, inside = _clip_segments(features.start, features.end, box, tolerance)
        features = TruthFeatures(features.kind, start, end, features.normals,
                                 features.angle_deg, features.shapes, features.in_footprint,
                                 features.visible, features.observable,
                                 features.observable_fraction).select(inside)
    in_footprint = observable = np.ones(len(points), dtype=bool)
    attrs: dict[str, Any] = {"observer_positions": 0, "passes": 0}
    if track is not None:
        observer = as_observer(track, samples, cover)
        in_footprint, observable = observe_points(scene, points, normals, observer)
        fpoints, fnormals, owner = _feature_samples(features, float(spacing),
                                                    float(feature_offset))
        f_in, f_seen = observe_points(scene, fpoints, fnormals, observer)
        count = np.maximum(np.bincount(owner, minlength=len(features)), 1)
        fraction = np.bincount(owner, f_seen, minlength=len(features)) / count
        f_in_any = np.bincount(owner, f_in, minlength=len(features)) > 0
        features = TruthFeatures(features.kind, features.start, features.end, features.normals,
                                 features.angle_deg, features.shapes, f_in_any, fraction > 0,
                                 fraction > 0, fraction)
        attrs = {"observer_positions": len(observer.positions), "passes": observer.passes,
                 "beam_cover": observer.cover}
    return SceneTruth(points=points, normals=normals, area=surface.area[keep],
                      surface=surface.surface[keep], names=surface.names,
                      in_footprint=in_footprint, observable=observable, features=features,
                      spacing=float(spacing), seed=int(seed), bounds=box,
                      observed=track is not None, tolerance=float(tolerance), attrs=attrs)
