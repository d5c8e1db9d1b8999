"""Output grids of image formation: slant range / along track, planes, and point lists.

A grid is resolved against a raw product (it needs the track) and gives the world position of
every pixel, the image's dimension names and metre coordinates, and the directions of range and
azimuth within the image (for impulse-response cuts).

* :class:`SlantGrid` (default): along-track coordinate ``a`` from the first sweep's antenna
  position along the mean velocity, and slant range ``r`` from the track, in the half-plane that
  holds the mean boresight. A pixel is at ``o + a v + r e`` (``e`` the boresight's component
  normal to the track). For a straight track the image of a point depends only on its
  (a, r), so any world point maps onto this grid by cylindrical coordinates
  (:func:`equivalent_position`).
* :class:`PlaneGrid`: ``origin + u axis_u + v axis_v`` (ground plane, a wall, ...).
* :class:`PointsGrid`: any list of 3-D points.
"""

from __future__ import annotations

import json
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.radar import Radar


def axis_values(spec: ArrayLike, name: str) -> NDArray[np.float64]:
    """Coordinates from ``[start, stop, step]`` (stop included when on the step) or an array."""
    values = np.asarray(spec, dtype=float)
    if values.ndim == 1 and len(values) == 3 and values[2] > 0 and values[1] > values[0]:
        count = int(np.floor((values[1] - values[0]) / values[2] + 1e-9)) + 1
        return values[0] + values[2] * np.arange(count)
    if values.ndim == 1 and len(values) >= 2 and np.all(np.diff(values) > 0):
        return values
    raise ParameterError("grid", name, "[start, stop, step] with stop > start and step > 0, "
                         "or increasing coordinates", spec)


def _unit(vector: ArrayLike) -> NDArray[np.float64]:
    vector = np.asarray(vector, dtype=float)
    return vector / np.linalg.norm(vector)


def track_frame(raw: xr.Dataset) -> tuple[NDArray, NDArray, NDArray]:
    """Track origin, along-track unit vector and cross-track look unit vector of a raw product.

    The along-track direction is the mean velocity; the look direction is the mean boresight's
    component normal to it.
    """
    origin = raw["platform_position"].values[0]
    along = _unit(raw["platform_velocity"].values.mean(axis=0))
    look = raw["boresight"].values.mean(axis=0)
    look = _unit(look - (look @ along) * along)
    return origin, along, look


@dataclass(frozen=True)
class SlantGrid:
    """Slant-range / along-track grid (see module docstring).

    Parameters
    ----------
    along_track, slant_range : array_like or None
        ``[start, stop, step]`` or increasing coordinates [m]; by default the whole track at
        half the azimuth resolution and 0.5 m to ``max_range`` at half the range resolution.
    """

    along_track: Any = None
    slant_range: Any = None

    def resolve(self, raw: xr.Dataset, radar: Radar, azimuth_resolution: float) -> dict:
        origin, along, look = track_frame(raw)
        positions = raw["platform_position"].values
        if self.along_track is None:
            extent = (positions[-1] - origin) @ along
            a = np.arange(0.0, extent + 1e-9, azimuth_resolution / 2)
        else:
            a = axis_values(self.along_track, "along_track")
        if self.slant_range is None:
            r = np.arange(0.5, radar.max_range, radar.range_resolution / 2)
        else:
            r = axis_values(self.slant_range, "slant_range")
        pixel = origin + a[:, None, None] * along + r[None, :, None] * look
        return {"dims": ("azimuth", "range"), "coords": {"azimuth": a, "range": r},
                "position": pixel, "range_axis": (0.0, 1.0), "azimuth_axis": (1.0, 0.0),
                "range_resolution": radar.range_resolution,
                "azimuth_resolution": azimuth_resolution,
                "attrs": {"grid_kind": "slant", "grid_origin": origin.tolist(),
                          "grid_along_track": along.tolist(), "grid_look": look.tolist()}}


@dataclass(frozen=True)
class PlaneGrid:
    """A planar grid ``origin + u axis_u + v axis_v`` (ground plane, a wall, ...).

    Parameters
    ----------
    origin : array_like, shape (3,)
    axis_u, axis_v : array_like, shape (3,)
        Orthogonal directions (normalised here).
    u, v : array_like
        ``[start, stop, step]`` or increasing coordinates along each axis [m].
    """

    origin: Any
    axis_u: Any
    axis_v: Any
    u: Any
    v: Any

    def resolve(self, raw: xr.Dataset, radar: Radar, azimuth_resolution: float) -> dict:
        origin = np.asarray(self.origin, dtype=float)
        axis_u, axis_v = _unit(self.axis_u), _unit(self.axis_v)
        if abs(axis_u @ axis_v) > 1e-6:
            raise ParameterError("PlaneGrid", "axis_u/axis_v", "orthogonal directions",
                                 (list(self.axis_u), list(self.axis_v)))
        u, v = axis_values(self.u, "u"), axis_values(self.v, "v")
        pixel = origin + v[:, None, None] * axis_v + u[None, :, None] * axis_u
        # Range and azimuth directions in the plane, seen from the aperture centre.
        centre = pixel[len(v) // 2, len(u) // 2]
        mid = len(raw["sweep"]) // 2
        line_of_sight = _unit(centre - raw["platform_position"].values[mid])
        velocity = _unit(raw["platform_velocity"].values[mid])
        los_in_plane = np.array([line_of_sight @ axis_v, line_of_sight @ axis_u])
        vel_in_plane = np.array([velocity @ axis_v, velocity @ axis_u])
        los_norm = max(np.linalg.norm(los_in_plane), 1e-6)
        vel_norm = max(np.linalg.norm(vel_in_plane), 1e-6)
        return {"dims": ("v", "u"), "coords": {"v": v, "u": u}, "position": pixel,
                "range_axis": tuple(los_in_plane / los_norm),
                "azimuth_axis": tuple(vel_in_plane / vel_norm),
                "range_resolution": radar.range_resolution / los_norm,
                "azimuth_resolution": azimuth_resolution / vel_norm,
                "attrs": {"grid_kind": "plane", "grid_origin": origin.tolist(),
                          "grid_axis_u": axis_u.tolist(), "grid_axis_v": axis_v.tolist()}}


@dataclass(frozen=True)
class PointsGrid:
    """Arbitrary 3-D points, shape (n, 3) or (n0, n1, 3)."""

    points: Any

    def resolve(self, raw: xr.Dataset, radar: Radar, azimuth_resolution: float) -> dict:
        points = np.asarray(self.points, dtype=float)
        if points.ndim == 2:
            points = points[:, None, :]
        if points.ndim != 3 or points.shape[-1] != 3:
            raise ParameterError("PointsGrid", "points", "shape (n, 3) or (n0, n1, 3)",
                                 points.shape)
        return {"dims": ("row", "col"),
                "coords": {"row": np.arange(points.shape[0], dtype=float),
                           "col": np.arange(points.shape[1], dtype=float)},
                "position": points, "range_axis": (0.0, 1.0), "azimuth_axis": (1.0, 0.0),
                "range_resolution": radar.range_resolution,
                "azimuth_resolution": azimuth_resolution, "attrs": {"grid_kind": "points"}}


Grid = SlantGrid | PlaneGrid | PointsGrid


def from_dict(spec: dict) -> Grid:
    """Make a grid from a dict (a TOML table) with a ``kind`` key.

    ``{kind = "slant", along_track = [start, stop, step], slant_range = [...]}``,
    ``{kind = "plane", origin, axis_u, axis_v, u, v}``, ``{kind = "points", points}``.
    """
    kinds = {"slant": SlantGrid, "plane": PlaneGrid, "points": PointsGrid}
    spec = dict(spec)
    kind = spec.pop("kind", "slant")
    if kind not in kinds:
        raise ParameterError("grid", "kind", f"one of {sorted(kinds)}", kind)
    allowed = set(kinds[kind].__dataclass_fields__)
    unknown = set(spec) - allowed
    if unknown:
        raise ParameterError("grid", sorted(unknown)[0],
                             f"a key of a {kind} grid: {sorted(allowed)}", spec[sorted(unknown)[0]])
    try:
        return kinds[kind](**spec)
    except TypeError as error:
        raise ParameterError("grid", kind, f"keys {sorted(allowed)}", sorted(spec)) from error


def equivalent_position(image: xr.Dataset, position: ArrayLike) -> NDArray[np.float64]:
    """Where a world point images on the grid of ``image``.

    For a slant grid, the point with the same along-track coordinate and distance from the
    track in the grid's half-plane (a straight track cannot tell them apart); otherwise the
    point itself.
    """
    position = np.asarray(position, dtype=float)
    if image.attrs.get("grid_kind") != "slant":
        return position
    origin = np.asarray(_attr_vector(image.attrs["grid_origin"]))
    along = np.asarray(_attr_vector(image.attrs["grid_along_track"]))
    look = np.asarray(_attr_vector(image.attrs["grid_look"]))
    offset = position - origin
    a = offset @ along
    r = np.linalg.norm(offset - a * along)
    return origin + a * along + r * look


def _attr_vector(value: Any) -> list[float]:
    if isinstance(value, str):
        return json.loads(value)
    return list(np.asarray(value, dtype=float))
