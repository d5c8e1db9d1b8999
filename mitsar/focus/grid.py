"""Output grids of image formation: slant range / along track, planes, and point lists.

A grid is resolved against a raw product (it needs the track) and gives the world position of
every pixel, the image's dimension names and metre coordinates, and the directions of range and
azimuth within the image (for impulse-response cuts).

Two sets of directions are recorded. ``range_axis`` / ``azimuth_axis`` (with
``range_resolution`` / ``azimuth_resolution``) describe the grid: on a slant grid its own axes,
on a plane the projected line of sight and velocity. ``response_range_axis`` /
``response_azimuth_axis`` (with ``response_range_resolution`` / ``response_azimuth_resolution``)
are the axes of the focused impulse response itself (:func:`response_frame`): under squint its
spectral support is the processed band of wavenumbers ``2f/c l`` for line-of-sight directions
``l`` in the processed Doppler band, a rectangle rotated by the squint, so its range axis is the
line of sight and its azimuth axis the direction normal to it in which the line of sight turns
(Cumming & Wong 2005 §2.6 measure the response along those axes).

* :class:`SlantGrid` (default): along-track coordinate ``a`` from the first sweep's antenna
  position along the mean velocity, and slant range ``r`` from the track, in the half-plane that
  holds the mean boresight. A pixel is at ``o + a v + r e`` (``e`` the boresight's component
  normal to the track). For a straight track the image of a point depends only on its
  (a, r), so any world point maps onto this grid by cylindrical coordinates
  (:func:`equivalent_position`). By default it covers what the beam saw: the track's own
  along-track extent and where every sweep's boresight meets the near and far slant ranges
  (squint moves the illuminated strip along the track by ``r tan(squint)``; a curved track
  moves it with the heading).
* :class:`PlaneGrid`: ``origin + u axis_u + v axis_v`` (ground plane, a wall, ...).
* :class:`PointsGrid`: any list of 3-D points.
* :class:`VolumeGrid`: voxels ``(x, y, z)`` of the scene frame, image dims ``("z", "y", "x")``
  (x fastest): slice ``k`` of a volume is the horizontal plane ``z = z_k`` with the dims
  ``(v, u) = (y, x)`` of a :class:`PlaneGrid` with ``axis_u = x``, ``axis_v = y``, pixel for
  pixel (docs/focusing.md, "3-D focusing from several passes").
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar import checks
from mitsar.budget import require_memory
from mitsar.errors import ParameterError
from mitsar.model.radar import Radar
from mitsar.products.image import vector_attr

PIXEL_BYTES = 160
"""Peak bytes per image pixel: position (24), complex image (16), coverage and weights, the
back-projection's per-pixel lanes and the product's copy."""


def axis_count(start: float, stop: float, step: float) -> float:
    """Number of coordinates of an axis ``[start, stop, step]`` (stop included on the step)."""
    return math.floor((stop - start) / step + 1e-9) + 1.0


def require_pixels(where: str, name: str, pixels: float) -> None:
    """Refuse, before any work, a focus grid whose image would not fit in memory
    (:func:`mitsar.budget.require_memory`; docs/reliability.md §2)."""
    require_memory(where, name, pixels * PIXEL_BYTES,
                   f"{pixels:.3g} pixels: a coarser step or a smaller extent (or focus the "
                   "scene in tiles, one grid each)")


def axis_values(spec: ArrayLike, name: str) -> NDArray[np.float64]:
    """Coordinates from ``[start, stop, step]`` (stop included when on the step) or an array."""
    try:
        values = np.asarray(spec, dtype=float)
    except (TypeError, ValueError):
        values = np.full(0, np.nan)
    if (values.ndim == 1 and len(values) == 3 and np.all(np.isfinite(values))
            and values[2] > 0 and values[1] > values[0]):
        count = axis_count(*values)
        require_memory("grid", name, count * 32.0, f"{count:.3g} coordinates along {name!r}: "
                       "a coarser step or a smaller extent")
        return values[0] + values[2] * np.arange(int(count))
    if values.ndim == 1 and len(values) >= 2 and np.all(np.diff(values) > 0):
        return values
    raise ParameterError("grid", name, "[start, stop, step] with stop > start and step > 0, "
                         "or increasing coordinates", spec)


def _unit(vector: ArrayLike, name: str = "axis") -> NDArray[np.float64]:
    vector = checks.vector("grid", name, vector, 3, "a non-zero direction: 3 finite numbers")
    norm = float(np.linalg.norm(vector))
    if not norm > 0:
        raise ParameterError("grid", name, "a non-zero direction: 3 finite numbers",
                             vector.tolist())
    return vector / norm


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


def response_frame(line_of_sight: ArrayLike, turning: ArrayLike, range_resolution: float,
                   transverse_resolution: float) -> dict[str, Any]:
    """Range and azimuth axes of a focused point response in an image plane, and their cells.

    The response's spectral support is the band of wavenumbers ``2f/c l`` swept by the line of
    sight ``l`` over the processed aperture: width ``1/rho_r`` along ``l`` and ``1/rho_t`` along
    the direction ``t`` in which ``l`` turns (Cumming & Wong 2005 §2.6; a rectangle rotated by
    the squint). A 2-D image samples its projection onto the image plane, the parallelogram
    spanned by the in-plane components ``L`` and ``T``; the response is ``sinc(L.x / rho_r)
    sinc(T.x / rho_t)``. A cut is a pure sinc only along a direction normal to one of them: the
    range cut runs normal to ``T``, the azimuth cut normal to ``L``, and one cell along each is
    ``rho_r / |L.d_r|`` and ``rho_t / |T.d_a|``.

    Parameters
    ----------
    line_of_sight, turning : array_like, shape (2,)
        In-plane components of the unit line of sight ``l`` and of the unit turning direction
        ``t`` (``t`` normal to ``l`` in 3-D), in the image's (dim0, dim1) metre coordinates.
    range_resolution : float
        Slant-range resolution ``c / 2B``, m.
    transverse_resolution : float
        Resolution normal to the line of sight, ``lambda / (2 dphi)`` for the processed angle
        ``dphi``, m; ``rho cos(squint)`` for the along-track resolution ``rho``.

    Returns
    -------
    dict
        ``response_range_axis``, ``response_azimuth_axis`` (unit vectors, lists of 2 floats,
        in (dim0, dim1)) and ``response_range_resolution``, ``response_azimuth_resolution`` (one
        cell along each, m). Empty when the plane holds no range or no azimuth extent.
    """
    los = np.asarray(line_of_sight, dtype=float)
    turn = np.asarray(turning, dtype=float)
    los_norm, turn_norm = float(np.linalg.norm(los)), float(np.linalg.norm(turn))
    if los_norm < 1e-6 or turn_norm < 1e-6:
        return {}
    d_range = np.array([-turn[1], turn[0]]) / turn_norm
    d_range *= np.sign(d_range @ los) or 1.0
    d_azimuth = np.array([-los[1], los[0]]) / los_norm
    d_azimuth *= np.sign(d_azimuth @ turn) or 1.0
    along_range, along_azimuth = abs(float(los @ d_range)), abs(float(turn @ d_azimuth))
    if along_range < 1e-6 or along_azimuth < 1e-6:
        return {}
    return {"response_range_axis": d_range.tolist(),
            "response_azimuth_axis": d_azimuth.tolist(),
            "response_range_resolution": float(range_resolution / along_range),
            "response_azimuth_resolution": float(transverse_resolution / along_azimuth)}


def _centroid_sines(raw: xr.Dataset) -> NDArray[np.float64]:
    """Doppler-centroid direction sine per sweep, ``v_hat . boresight`` (as the processors)."""
    velocity = np.asarray(raw["platform_velocity"].values, dtype=float)
    speed = np.linalg.norm(velocity, axis=-1)
    boresight = np.asarray(raw["boresight"].values, dtype=float)
    return np.einsum("si,si->s", boresight, velocity) / np.where(speed > 0, speed, 1.0)


def _extend(values: NDArray[np.float64], low: float, high: float,
            step: float) -> NDArray[np.float64]:
    """``values`` (a uniform axis) extended by whole steps to cover ``[low, high]``."""
    before = max(int(math.ceil((values[0] - low) / step - 1e-6)), 0)
    after = max(int(math.ceil((high - values[-1]) / step - 1e-6)), 0)
    return values[0] + step * np.arange(-before, values.size + after)


def beam_along_track(raw: xr.Dataset, origin: NDArray, along: NDArray,
                     slant_ranges: tuple[float, float]) -> tuple[float, float]:
    """Along-track interval a slant grid needs to hold what the beam saw, m.

    The track's own extent and, for every sweep, the along-track coordinate where its boresight
    reaches the near and far slant ranges (distance from the track line): with squint angle
    ``s`` the illuminated strip lies ``r tan(s)`` ahead of (or behind) the antenna, and on a
    curved track it moves with the heading.
    """
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    boresight = np.asarray(raw["boresight"].values, dtype=float)
    a_track = (positions - origin) @ along
    normal = np.linalg.norm(boresight - np.outer(boresight @ along, along), axis=-1)
    reach = np.where(normal > 1e-6, 1.0 / np.maximum(normal, 1e-6), 0.0)
    ends = [a_track]
    for r in slant_ranges:
        ends.append(((positions + (r * reach)[:, None] * boresight) - origin) @ along)
    stacked = np.concatenate(ends)
    return float(stacked.min()), float(stacked.max())


@dataclass(frozen=True)
class SlantGrid:
    """Slant-range / along-track grid (see module docstring).

    Parameters
    ----------
    along_track, slant_range : array_like or None
        ``[start, stop, step]`` or increasing coordinates [m]. By default slant range runs from
        0.5 m to ``max_range`` at half the range resolution, and along track at half the azimuth
        resolution over the track and where the boresight meets the first and last slant range
        (:func:`beam_along_track`), aligned to the first sweep (``a = 0``): a squinted or curved
        acquisition images what the beam saw without a hand-made grid.
    """

    along_track: Any = None
    slant_range: Any = None

    def resolve(self, raw: xr.Dataset, radar: Radar, azimuth_resolution: float) -> dict:
        origin, along, look = track_frame(raw)
        if self.slant_range is None:
            r = np.arange(0.5, radar.max_range, radar.range_resolution / 2)
        else:
            r = axis_values(self.slant_range, "slant_range")
        if self.along_track is None:
            step = azimuth_resolution / 2
            low, high = beam_along_track(raw, origin, along, (float(r[0]), float(r[-1])))
            a = _extend(np.zeros(1), low, high, step)
        else:
            a = axis_values(self.along_track, "along_track")
        require_pixels("SlantGrid", "along_track x slant_range", float(len(a)) * len(r))
        pixel = origin + a[:, None, None] * along + r[None, :, None] * look
        # The response is the processed band seen at the Doppler-centroid squint (module doc).
        sine = float(np.clip(np.mean(_centroid_sines(raw)), -0.999, 0.999))
        cosine = math.sqrt(1.0 - sine * sine)
        response = response_frame((sine, cosine), (cosine, -sine), radar.range_resolution,
                                  azimuth_resolution * cosine)
        return {"dims": ("azimuth", "range"), "coords": {"azimuth": a, "range": r},
                "position": pixel, "range_axis": (0.0, 1.0), "azimuth_axis": (1.0, 0.0),
                "range_resolution": radar.range_resolution,
                "azimuth_resolution": azimuth_resolution,
                "attrs": {"grid_kind": "slant", "grid_origin": origin.tolist(),
                          "grid_along_track": along.tolist(), "grid_look": look.tolist(),
                          **response}}


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
        axis_u, axis_v = _unit(self.axis_u, "axis_u"), _unit(self.axis_v, "axis_v")
        if abs(axis_u @ axis_v) > 1e-6:
            raise ParameterError("PlaneGrid", "axis_u/axis_v", "orthogonal directions",
                                 (list(self.axis_u), list(self.axis_v)))
        u, v = axis_values(self.u, "u"), axis_values(self.v, "v")
        require_pixels("PlaneGrid", "u x v", float(len(u)) * len(v))
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
        response = _plane_response(raw, centre, axis_v, axis_u, radar.range_resolution,
                                   azimuth_resolution)
        return {"dims": ("v", "u"), "coords": {"v": v, "u": u}, "position": pixel,
                "range_axis": tuple(los_in_plane / los_norm),
                "azimuth_axis": tuple(vel_in_plane / vel_norm),
                "range_resolution": radar.range_resolution / los_norm,
                "azimuth_resolution": azimuth_resolution / vel_norm,
                "attrs": {"grid_kind": "plane", "grid_origin": origin.tolist(),
                          "grid_axis_u": axis_u.tolist(), "grid_axis_v": axis_v.tolist(),
                          **response}}


def _plane_response(raw: xr.Dataset, centre: NDArray, axis0: NDArray, axis1: NDArray,
                    range_resolution: float, azimuth_resolution: float) -> dict[str, Any]:
    """:func:`response_frame` of a plane at ``centre``, seen from the aperture centre.

    The aperture centre is the sweep whose direction sine to ``centre`` is nearest its Doppler
    centroid (where the processed band is centred, for any track); the turning direction is the
    velocity's component normal to the line of sight there.
    """
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    velocity = np.asarray(raw["platform_velocity"].values, dtype=float)
    sight = centre - positions
    sight /= np.maximum(np.linalg.norm(sight, axis=-1), 1e-12)[:, None]
    speed = np.maximum(np.linalg.norm(velocity, axis=-1), 1e-12)
    sines = np.einsum("si,si->s", sight, velocity) / speed
    k = int(np.argmin(np.abs(sines - _centroid_sines(raw))))
    los = sight[k]
    turning = velocity[k] / speed[k] - sines[k] * los
    cosine = float(np.linalg.norm(turning))
    if cosine < 1e-6:
        return {}
    turning /= cosine
    return response_frame((los @ axis0, los @ axis1), (turning @ axis0, turning @ axis1),
                          range_resolution, azimuth_resolution * cosine)


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


@dataclass(frozen=True)
class VolumeGrid:
    """Voxels of the scene frame: ``(x_i, y_j, z_k)`` for three axes.

    The image dims are ``("z", "y", "x")``: x varies fastest, so the volume's slice at ``z_k``
    is, pixel for pixel, the image of the :class:`PlaneGrid` ``origin = (0, 0, z_k)``,
    ``axis_u = x``, ``axis_v = y``, ``u = x``, ``v = y`` (dims ``(v, u)``), and a stack of
    horizontal planes is a volume. The voxels do not depend on the raw product: several passes
    (and channels) are back-projected onto the same voxels (:mod:`mitsar.focus.passes`).

    Parameters
    ----------
    x, y, z : array_like
        ``[start, stop, step]`` (stop included when on the step) or increasing coordinates [m].
    """

    x: Any
    y: Any
    z: Any

    def axes(self) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
        """The x, y and z coordinates [m], the volume refused before it is built if its voxels
        would not fit in memory (:func:`require_pixels`)."""
        x, y, z = (axis_values(spec, name) for spec, name in ((self.x, "x"), (self.y, "y"),
                                                              (self.z, "z")))
        require_pixels("VolumeGrid", "x x y x z", float(len(x)) * len(y) * len(z))
        return x, y, z

    def resolve(self, raw: xr.Dataset, radar: Radar, azimuth_resolution: float) -> dict:
        x, y, z = self.axes()
        pixel = np.empty((len(z), len(y), len(x), 3))
        pixel[..., 0] = x[None, None, :]
        pixel[..., 1] = y[None, :, None]
        pixel[..., 2] = z[:, None, None]
        # Range and azimuth directions at the volume's centre, seen from mid-aperture, as
        # 3-D unit vectors in the image's (z, y, x) component order.
        centre = np.array([x.mean(), y.mean(), z.mean()])
        mid = len(raw["sweep"]) // 2
        line_of_sight = _unit(centre - raw["platform_position"].values[mid])
        velocity = _unit(raw["platform_velocity"].values[mid])
        return {"dims": ("z", "y", "x"), "coords": {"z": z, "y": y, "x": x},
                "position": pixel, "range_axis": tuple(line_of_sight[::-1]),
                "azimuth_axis": tuple(velocity[::-1]),
                "range_resolution": radar.range_resolution,
                "azimuth_resolution": azimuth_resolution,
                "attrs": {"grid_kind": "volume"}}


Grid = SlantGrid | PlaneGrid | PointsGrid | VolumeGrid


def from_dict(spec: dict) -> Grid:
    """Make a grid from a dict (a TOML table) with a ``kind`` (or ``type``) key.

    ``{kind = "slant", along_track = [start, stop, step], slant_range = [...]}``,
    ``{kind = "plane", origin, axis_u, axis_v, u, v}``, ``{kind = "points", points}``,
    ``{kind = "volume", x = [start, stop, step], y = [...], z = [...]}``.
    """
    kinds = {"slant": SlantGrid, "plane": PlaneGrid, "points": PointsGrid,
             "volume": VolumeGrid}
    spec = dict(spec)
    if "kind" in spec and "type" in spec:
        raise ParameterError("grid", "type", "one of 'kind' and 'type' (the same key)",
                             (spec["kind"], spec["type"]))
    kind = spec.pop("kind", spec.pop("type", "slant"))
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
    origin = vector_attr(image, "grid_origin")
    along = vector_attr(image, "grid_along_track")
    look = vector_attr(image, "grid_look")
    offset = position - origin
    a = offset @ along
    r = np.linalg.norm(offset - a * along)
    return origin + a * along + r * look
