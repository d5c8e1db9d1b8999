"""Layover and shadow masks of an image's pixels, from the scene's geometry.

A focused pixel p gathers the echoes of every scene point that shares its range-azimuth cell.
Seen from the pixel's centre of aperture (the aperture sample closest to p,
docs/interferometry.md §1; :mod:`mitsar.model.geometry.aperture`), those points lie on the
**iso-range arc**: the circle about the antenna position A, of radius the pixel's slant range
``r_p = |p - A|``, in the plane through p perpendicular to the track direction there (the
zero-Doppler plane), inside the antenna's elevation beam. Only the first surface a ray from A
meets along that arc echoes; so the arc is sampled by rays from A at elevation angles ``psi``
in the plane (all pixels times a few hundred angles cast together,
``scene.ray_intersect``), and each ray keeps its first hit (a visible surface point), its
slant range and its surface normal. Then, with the range window ``delta`` (half the radar's
slant range resolution ``c / 2B``):

- the visible points within ``|r - r_p| <= delta`` form **stretches**: maximal runs of
  consecutive rays whose hits lie on one smooth surface piece (two neighbouring hits are on one
  piece when the step between them lies in both hits' tangent planes, to within ``smooth``,
  the sine of the angle; an occlusion edge, where the ray jumps from an occluder to the
  surface behind it, and a crease, such as a box's edge or a wall's foot, both end a stretch).
  A stretch crossing the window between two rays counts (the range is interpolated along the
  segment between two hits of one piece), so no sampling step can hide a continuous surface;
- ``visible_surfaces`` is the number of stretches; **shadow** is zero stretches (nothing
  visible at the pixel's range: the reference-surface point itself is hidden and nothing else
  is there); **layover** is two or more (separate scatterers, e.g. a box top and the floor in
  front of it, share the cell); ``mask = shadow | layover``: the pixels whose interferometric
  phase is not that of one surface (docs/interferometry.md §"Layover and shadow masks").

Closed forms (``tests/test_masks.py``): a wall of height h at ground distance Y0, antenna at
height H, off-nadir angle psi: floor pixels of slant range in ``[r_t - delta, r_b + delta]``
are in layover (``r_b = sqrt(Y0^2 + H^2)`` the wall's foot, ``r_t = sqrt(Y0^2 + (H - h)^2)``
its top: on the ground h H / Y0 = h cot(psi) nearer, plus ``2 delta / sin(psi)``), and those in
``(r_b + delta, r_s - delta)`` in shadow (``r_s = r_t H / (H - h)``: on the ground
``Y0 h / (H - h)`` ~ h tan(psi), less ``2 delta / sin(psi)``).

Elevation sampling: rays ``elevation_step`` apart (default 1 mrad, 8 mm between neighbouring
rays at 8 m) over the beam's ``beam_cover`` half-widths on either side of the boresight (direction
sines, as :func:`mitsar.scene.footprint.beam_directions`), widened to include the pixel itself.
Because ranges are interpolated between the hits of one piece, the step does not limit which
ranges are seen; it limits (a) where a mask's edge falls, to the range step between
neighbouring rays, ``r tan(psi) d(psi)`` ~ 12 mm on the paper's floor (8 m, 55.7 deg), an eighth
of its 0.1 m cell and below any pixel worth focusing, and (b) the narrowest occluder or gap that
is seen, ``r d(psi)`` ~ 8 mm. Surfaces seen at a grazing angle below ``asin(smooth)`` (5.7 deg
by default) are taken as one piece only where they are planar.
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.checks import integer, positive
from mitsar.errors import ParameterError
from mitsar.model.geometry.aperture import aperture_centre, phase_centres, track_direction
from mitsar.model.geometry.attitude import body_to_world
from mitsar.plugins.variant import import_mitsuba
from mitsar.products.raw import look_of, radar_of
from mitsar.scene.loading import load_scene

__all__ = ["MASK_VARIABLES", "elevation_arcs", "layover_shadow_masks", "stretch_count"]

WHERE = "layover_shadow_masks"

MASK_VARIABLES: dict[str, str] = {
    "shadow": "pixel in radar shadow: no visible surface within half a range cell of its range",
    "layover": "pixel in layover: two or more separate visible surfaces share its range cell",
    "mask": "shadow or layover: the pixel's phase is not that of one surface",
    "visible_surfaces": "separate visible surface stretches within half a range cell of the "
                        "pixel's slant range",
}
"""Variables of :func:`layover_shadow_masks` (long names)."""

_MAX_RAYS = 1 << 22
"""Rays cast per ``ray_intersect`` call (the pixels are taken in chunks of this many rays)."""


def elevation_arcs(image: xr.Dataset, pair: tuple[int, int] = (0, 1), beam_cover: float = 1.0,
                   elevation_step: float = 1e-3) -> dict[str, NDArray[np.float64]]:
    """Each pixel's zero-Doppler plane, antenna position and the elevation angles to cast.

    Parameters
    ----------
    image : xarray.Dataset
        An image product (docs/interferometry.md §1: ``position``, ``aperture_position``,
        ``aperture_attitude``, optionally ``transmitter_offset``/``receiver_offset``; the
        ``look_*`` and ``radar_*`` attributes).
    pair : (int, int)
        The interferometric pair; the antenna is channel ``pair[0]``'s phase centre
        ``(t + r) / 2`` (the origin for a single-channel image).
    beam_cover : float
        Half-width of the elevation span in half beamwidths (direction sines about the
        boresight).
    elevation_step : float
        Largest angle between neighbouring rays [rad].

    Returns
    -------
    dict
        ``pixels`` (N, 3) [m]; ``antenna`` (N, 3) [m], the phase centre at the pixel's centre
        of aperture moved along the track into the pixel's plane; ``e1``, ``e2`` (N, 3), the
        plane's unit axes (``e1`` towards the pixel); ``angles`` (N, S) [rad], elevation angles
        from ``e1`` towards ``e2``; ``slant_range`` (N,) [m], ``|p - antenna|``.
    """
    for name in ("position", "aperture_position", "aperture_attitude"):
        if name not in image.variables:
            raise ParameterError(WHERE, name, "an image product with the pixel positions and "
                                 "the processed aperture (docs/interferometry.md §1)",
                                 sorted(map(str, image.variables)))
    beam_cover = positive(WHERE, "beam_cover", beam_cover)
    elevation_step = positive(WHERE, "elevation_step", elevation_step)
    pixels = np.asarray(image["position"].values, float).reshape(-1, 3)
    track = np.asarray(image["aperture_position"].values, float)
    attitude = np.asarray(image["aperture_attitude"].values, float)
    offset = np.zeros(3)
    if "transmitter_offset" in image.variables and "receiver_offset" in image.variables:
        channel = int(pair[0])
        offset = 0.5 * (np.asarray(image["transmitter_offset"].values, float)[channel]
                        + np.asarray(image["receiver_offset"].values, float)[channel])
    index = aperture_centre(track, pixels)
    antenna = phase_centres(track, attitude, offset[None])[index, 0]
    along = track_direction(track)[index]
    antenna = antenna - np.sum((antenna - pixels) * along, axis=-1, keepdims=True) * along
    to_pixel = pixels - antenna
    slant_range = np.linalg.norm(to_pixel, axis=-1)
    e1 = to_pixel / slant_range[:, None]
    e2 = np.cross(along, e1)
    e2 /= np.linalg.norm(e2, axis=-1, keepdims=True)
    rotation = body_to_world(*attitude[index].T)
    boresight = rotation @ look_of(image).boresight_body()
    psi_b = np.arctan2(np.sum(boresight * e2, -1), np.sum(boresight * e1, -1))
    half = math.asin(min(1.0, beam_cover * radar_of(image).elevation_beamwidth / 2))
    low, high = np.minimum(psi_b - half, 0.0), np.maximum(psi_b + half, 0.0)
    count = int(math.ceil(float(np.max(high - low)) / elevation_step)) + 1
    fraction = np.linspace(0.0, 1.0, count)
    angles = low[:, None] + (high - low)[:, None] * fraction[None, :]
    return {"pixels": pixels, "antenna": antenna, "e1": e1, "e2": e2, "angles": angles,
            "slant_range": slant_range}


def _cast(scene: Any, origins: NDArray, directions: NDArray
          ) -> tuple[NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """First hits of rays (one ``ray_intersect`` call): distance (inf on a miss), point and
    geometric normal (NaN on a miss)."""
    mi = import_mitsuba()

    def f(a: NDArray) -> Any:
        return mi.Float(np.ascontiguousarray(a, dtype=np.float32))

    ray = mi.Ray3f(mi.Point3f(f(origins[:, 0]), f(origins[:, 1]), f(origins[:, 2])),
                   mi.Vector3f(f(directions[:, 0]), f(directions[:, 1]), f(directions[:, 2])))
    hit = scene.ray_intersect(ray)
    valid = np.asarray(hit.is_valid(), dtype=bool)
    t = np.where(valid, np.asarray(hit.t, dtype=np.float64), np.inf)
    points = np.where(valid[:, None], origins + np.where(valid, t, 0.0)[:, None] * directions,
                      np.nan)
    normal = np.stack([np.asarray(hit.n.x, dtype=np.float64), np.asarray(hit.n.y, np.float64),
                       np.asarray(hit.n.z, dtype=np.float64)], axis=-1)
    return t, points, np.where(valid[:, None], normal, np.nan)


def _joined(points_a: NDArray, normals_a: NDArray, points_b: NDArray, normals_b: NDArray,
            smooth: float) -> NDArray[np.bool_]:
    """Two hits on one smooth surface piece: both hits exist and the step between them lies in
    both tangent planes to within ``smooth`` (sine of the angle)."""
    step = points_b - points_a
    length = np.linalg.norm(step, axis=-1)
    with np.errstate(invalid="ignore"):
        return ((np.abs(np.sum(step * normals_a, -1)) <= smooth * length)
                & (np.abs(np.sum(step * normals_b, -1)) <= smooth * length))


def stretch_count(distance: NDArray, points: NDArray, normals: NDArray, slant_range: NDArray,
                  window: float, smooth: float = 0.1, reach: tuple[NDArray, NDArray] | None = None
                  ) -> NDArray[np.int64]:
    """Number of separate visible surface stretches within ``window`` of each pixel's range.

    Parameters
    ----------
    distance : ndarray, shape (N, S)
        Slant range of each ray's first hit [m] (inf on a miss), rays in elevation order.
    points, normals : ndarray, shape (N, S, 3)
        Hit points [m] and unit surface normals (NaN on a miss).
    slant_range : ndarray, shape (N,)
        The pixels' slant ranges [m].
    window : float
        Half-width of the range interval [m] (half a range resolution cell).
    smooth : float
        Two neighbouring hits lie on one smooth piece when the sine of the angle between their
        step and either hit's tangent plane is at most this.
    reach : (ndarray, ndarray), optional
        Least and greatest slant range [m], shape (N, S), of the piece each hit continues
        into up to its piece's refined edges (:func:`layover_shadow_masks`); default the hit's
        own range.

    Returns
    -------
    ndarray of int, shape (N,)
        0: shadow; 1: one surface; 2 or more: layover (module docstring).
    """
    joined = _joined(points[:, :-1], normals[:, :-1], points[:, 1:], normals[:, 1:], smooth)
    low = (slant_range - window)[:, None]
    high = (slant_range + window)[:, None]
    least, most = (distance, distance) if reach is None else reach
    inside = (most >= low) & (least <= high)
    near = np.minimum(distance[:, 1:], distance[:, :-1])
    far = np.maximum(distance[:, 1:], distance[:, :-1])
    crossed = joined & (far >= low) & (near <= high)   # segment i -> i + 1 meets the window
    rows = distance.shape[0]
    before = np.concatenate([np.zeros((rows, 1), bool), crossed], axis=1)  # segment i-1 -> i
    after = np.concatenate([crossed, np.zeros((rows, 1), bool)], axis=1)   # segment i -> i+1
    touched = (inside & np.isfinite(distance)) | before | after
    return np.count_nonzero(touched & ~before, axis=1)


def _edge_reach(scene: Any, arcs: dict[str, NDArray], part: slice, distance: NDArray,
                points: NDArray, normals: NDArray, smooth: float, refinements: int
                ) -> tuple[NDArray, NDArray]:
    """Each hit's range reach up to the edges of its piece, found by bisection.

    Between two neighbouring rays not on one piece (an occlusion edge, a crease, a surface's
    end), the angle is bisected ``refinements`` times (one ray cast for all edges a step): the
    last hit still on the left ray's piece and the first hit after it bound the two pieces'
    ranges to ``elevation_step / 2**refinements``. Returns the least and greatest range [m]
    each hit's piece reaches beyond its neighbouring segments, shape (N, S).
    """
    angles = arcs["angles"][part]
    least, most = distance.copy(), distance.copy()
    joined = _joined(points[:, :-1], normals[:, :-1], points[:, 1:], normals[:, 1:], smooth)
    valid = np.isfinite(distance)
    pixel, index = np.nonzero(~joined & (valid[:, :-1] | valid[:, 1:]))
    if pixel.size == 0 or refinements == 0:
        return least, most
    lo, hi = angles[pixel, index].copy(), angles[pixel, index + 1].copy()
    left = [distance[pixel, index].copy(), points[pixel, index].copy(),
            normals[pixel, index].copy()]
    right = [distance[pixel, index + 1].copy(), points[pixel, index + 1].copy(),
             normals[pixel, index + 1].copy()]
    origin = arcs["antenna"][part][pixel]
    e1, e2 = arcs["e1"][part][pixel], arcs["e2"][part][pixel]
    for _ in range(refinements):
        middle = 0.5 * (lo + hi)
        hit = _cast(scene, origin, np.cos(middle)[:, None] * e1 + np.sin(middle)[:, None] * e2)
        on_left = _joined(left[1], left[2], hit[1], hit[2], smooth)
        lo, hi = np.where(on_left, middle, lo), np.where(on_left, hi, middle)
        for side, keep in ((left, on_left), (right, ~on_left)):
            for k in range(3):
                side[k] = np.where(keep.reshape((-1,) + (1,) * (side[k].ndim - 1)), hit[k],
                                   side[k])
    # The left ray's piece runs to the last left hit; the right ray's piece starts at the first
    # hit after the edge when that hit is on it (else a third piece lies within the step).
    start = _joined(right[1], right[2], points[pixel, index + 1], normals[pixel, index + 1],
                    smooth) | (right[0] == distance[pixel, index + 1])
    ends = (left[0], np.where(start, right[0], distance[pixel, index + 1]))
    for column, end in ((index, ends[0]), (index + 1, ends[1])):
        ok = np.isfinite(end) & np.isfinite(distance[pixel, column])
        np.minimum.at(least, (pixel[ok], column[ok]), end[ok])
        np.maximum.at(most, (pixel[ok], column[ok]), end[ok])
    return least, most


def layover_shadow_masks(scene: Any, image: xr.Dataset, pair: tuple[int, int] = (0, 1), *,
                         range_resolution: float | None = None, beam_cover: float = 1.0,
                         elevation_step: float = 1e-3, smooth: float = 0.1,
                         edge_refinements: int = 8,
                         scene_params: Mapping[str, Any] | None = None) -> xr.Dataset:
    """Layover and shadow masks of an image's pixels from the scene's geometry.

    The pixels' iso-range arcs in their zero-Doppler planes are sampled by rays from the
    antenna at each pixel's centre of aperture; a pixel is in shadow when no visible surface
    lies within half a range cell of its slant range, in layover when two or more separate
    visible surfaces do (module docstring; docs/interferometry.md §"Layover and shadow masks").

    Parameters
    ----------
    scene : mitsuba.Scene, str or os.PathLike
        A loaded scene, an XML file or a canned scene name (:func:`mitsar.scene.load_scene`).
    image : xarray.Dataset
        The image product (docs/interferometry.md §1) with the ``radar_*`` and ``look_*``
        attributes of the raw product it was focused from.
    pair : (int, int)
        The interferometric pair; channel ``pair[0]``'s phase centre is the antenna.
    range_resolution : float, optional
        Slant range resolution [m]; default the radar's ``c / 2B``
        (:func:`mitsar.products.raw.radar_of`). The window is half of it.
    beam_cover : float
        Elevation span of the rays in half beamwidths about the boresight (1: the nominal
        beam, :func:`mitsar.scene.footprint.beam_directions`).
    elevation_step : float
        Largest angle between neighbouring rays [rad] (1 mrad: module docstring).
    smooth : float
        Tangent-plane tolerance of one smooth surface piece (sine of the angle) [1].
    edge_refinements : int
        Bisections of the angle at each surface piece's edge (module docstring): edges to
        ``elevation_step / 2**edge_refinements``.
    scene_params : mapping, optional
        ``<default>`` parameters of an XML scene (:func:`mitsar.scene.load_scene`).

    Returns
    -------
    xarray.Dataset
        On the image's (ROW, COL) grid: ``shadow``, ``layover``, ``mask`` (bool) and
        ``visible_surfaces`` (int16; :data:`MASK_VARIABLES`); attributes ``range_window``
        [m], ``elevation_step`` [rad], ``elevation_samples``, ``beam_cover``, ``smooth``,
        ``pair``.

    Raises
    ------
    ParameterError
        An image without positions, aperture or radar/look attributes; a non-positive
        parameter.
    """
    if range_resolution is None:
        if "radar_carrier_frequency" not in image.attrs:
            raise ParameterError(WHERE, "range_resolution", "a value [m], or an image with "
                                 "the radar_* attributes of its raw product", sorted(image.attrs))
        range_resolution = radar_of(image).range_resolution
    range_resolution = positive(WHERE, "range_resolution", range_resolution)
    smooth = positive(WHERE, "smooth", smooth)
    edge_refinements = integer(WHERE, "edge_refinements", edge_refinements, minimum=0)
    loaded = load_scene(scene, **dict(scene_params or {}))
    arcs = elevation_arcs(image, pair, beam_cover, elevation_step)
    samples = arcs["angles"].shape[1]
    count = np.empty(len(arcs["pixels"]), np.int64)
    chunk = max(1, _MAX_RAYS // samples)
    for start in range(0, len(count), chunk):   # chunks of pixels, one ray cast each
        part = slice(start, start + chunk)
        psi = arcs["angles"][part][..., None]
        directions = np.cos(psi) * arcs["e1"][part, None] + np.sin(psi) * arcs["e2"][part, None]
        origins = np.broadcast_to(arcs["antenna"][part, None], directions.shape)
        t, points, normals = _cast(loaded, origins.reshape(-1, 3), directions.reshape(-1, 3))
        shape = directions.shape
        t, points, normals = t.reshape(shape[:2]), points.reshape(shape), normals.reshape(shape)
        reach = _edge_reach(loaded, arcs, part, t, points, normals, smooth, edge_refinements)
        count[part] = stretch_count(t, points, normals, arcs["slant_range"][part],
                                    range_resolution / 2, smooth, reach)
    dims = tuple(map(str, image["position"].dims[:2]))
    grid = image["position"].shape[:2]
    count = count.reshape(grid)
    shadow, layover = count == 0, count >= 2
    coords = {d: image[d] for d in dims if d in image.coords}
    out = xr.Dataset({name: (dims, values, {"long_name": MASK_VARIABLES[name], "units": "1"})
                      for name, values in (("shadow", shadow), ("layover", layover),
                                           ("mask", shadow | layover),
                                           ("visible_surfaces", count.astype(np.int16)))},
                     coords=coords)
    out.attrs.update(range_window=float(range_resolution / 2),
                     elevation_step=float(elevation_step), elevation_samples=int(samples),
                     beam_cover=float(beam_cover), smooth=float(smooth),
                     edge_refinements=int(edge_refinements),
                     pair=[int(k) for k in pair])
    return out
