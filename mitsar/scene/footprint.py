"""Where the antenna beam meets a scene: the footprint on its surfaces and NR / CS / FR.

The paper draws the illuminated area along the trajectory (Figs. 12 and 14) and marks near
range, centre scene and far range (NR, CS, FR: where the lower edge, the boresight and the upper
edge of the elevation beam meet the scene; §4.2-4.3). Here both come from rays cast into the
Mitsuba scene, so walls, boxes and corners cut the beam where they stand (a floor-only
intersection gives 2.81 m of far range on the dihedral experiment where its wall cuts the beam
at 2.24 m):

- :func:`beam_directions`: a grid of directions inside the beam, in direction sines
  ``|u_az| <= c beta_az / 2``, ``|u_el| <= c beta_el / 2`` of the antenna frame (``c = 1``: the
  nominal beamwidth, the -3.9 dB one-way contour of the sinc^2 pattern), world frame;
- :func:`beam_footprint`: the first hit of every such ray, per antenna position;
- :func:`beam_marks`: NR, CS and FR at one antenna position, as slant distances from the
  antenna and as distances from a track line (the slant grid's range coordinate).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.radar import Radar

__all__ = ["beam_directions", "beam_footprint", "beam_marks"]


def beam_directions(radar: Radar, frame: ArrayLike, count: tuple[int, int] = (15, 15),
                    cover: float = 1.0) -> NDArray[np.float64]:
    """Unit directions on a regular grid of direction sines inside the beam, world frame.

    Parameters
    ----------
    radar : Radar
    frame : array_like, shape (3, 3)
        Antenna-to-world rotation (columns: azimuth axis, elevation axis, boresight).
    count : (int, int)
        Directions across azimuth and elevation (odd counts include the boresight).
    cover : float
        Half-width of the grid in half beamwidths (1: the nominal beam edge).

    Returns
    -------
    ndarray, shape (count_az * count_el, 3)
    """
    frame = np.asarray(frame, dtype=float)
    if frame.shape != (3, 3):
        raise ParameterError("beam_directions", "frame", "a 3 x 3 rotation", frame.shape)
    u_az = np.linspace(-1.0, 1.0, count[0]) * cover * radar.azimuth_beamwidth / 2
    u_el = np.linspace(-1.0, 1.0, count[1]) * cover * radar.elevation_beamwidth / 2
    az, el = np.meshgrid(u_az, u_el, indexing="ij")
    local = np.stack([az.ravel(), el.ravel(), np.sqrt(1.0 - az.ravel()**2 - el.ravel()**2)], -1)
    return local @ frame.T


def beam_footprint(scene: Any, positions: ArrayLike, frames: ArrayLike, radar: Radar,
                   count: tuple[int, int] = (15, 15)) -> tuple[NDArray, NDArray]:
    """First hits of the beam's rays in a scene, for every antenna position.

    Parameters
    ----------
    scene : mitsuba.Scene
    positions : array_like, shape (P, 3)
        Antenna positions [m].
    frames : array_like, shape (P, 3, 3)
        Antenna frames.
    radar : Radar
    count : (int, int)
        Rays across azimuth and elevation.

    Returns
    -------
    hits : ndarray, shape (P, count_az * count_el, 3)
        Hit points [m] (NaN where a ray leaves the scene).
    distance : ndarray, shape (P, count_az * count_el)
        Distances from the antenna [m] (inf where nothing is hit).
    """
    import mitsuba as mi  # lazy: the caller has set a variant (mitsar.scene.load_scene)

    positions = np.asarray(positions, dtype=float).reshape(-1, 3)
    frames = np.asarray(frames, dtype=float).reshape(-1, 3, 3)
    directions = np.stack([beam_directions(radar, f, count) for f in frames])  # (P, n, 3)
    origins = np.broadcast_to(positions[:, None, :], directions.shape).reshape(-1, 3)
    flat = directions.reshape(-1, 3)
    ray = mi.Ray3f(mi.Point3f(*(mi.Float(origins[:, i]) for i in range(3))),
                   mi.Vector3f(*(mi.Float(flat[:, i]) for i in range(3))))
    hit = scene.ray_intersect(ray)
    valid = np.array(hit.is_valid(), dtype=bool)
    t = np.where(valid, np.array(hit.t, dtype=np.float64), np.inf)
    points = np.full(origins.shape, np.nan)
    points[valid] = origins[valid] + t[valid, None] * flat[valid]
    return points.reshape(directions.shape), t.reshape(directions.shape[:2])


def beam_marks(scene: Any, position: ArrayLike, frame: ArrayLike, radar: Radar,
               track_origin: ArrayLike | None = None, track_direction: ArrayLike | None = None
               ) -> dict[str, float]:
    """NR, CS and FR of the beam in a scene at one antenna position.

    The lower edge, the boresight and the upper edge of the elevation beam (azimuth sine 0)
    are cast into the scene; each mark is the distance of its first hit from the antenna, or,
    when a track line is given, from that line (the range coordinate of a slant grid). A mark
    whose ray hits nothing is left out.

    Returns
    -------
    dict
        Some of ``"NR"``, ``"CS"``, ``"FR"`` [m].
    """
    frame = np.asarray(frame, dtype=float)
    position = np.asarray(position, dtype=float)
    half = radar.elevation_beamwidth / 2
    edges = [frame @ np.array([0.0, sine, np.sqrt(1.0 - sine**2)]) for sine in (half, -half)]
    edges.sort(key=lambda d: -d[2], reverse=True)  # nearer nadir first: the near-range edge
    rays = {"NR": edges[0], "CS": frame[:, 2], "FR": edges[1]}
    marks = {}
    for name, direction in rays.items():
        hit, t = _cast(scene, position, direction)
        if not np.isfinite(t):
            continue
        if track_origin is None or track_direction is None:
            marks[name] = float(t)
        else:
            along = np.asarray(track_direction, dtype=float)
            along = along / np.linalg.norm(along)
            offset = hit - np.asarray(track_origin, dtype=float)
            marks[name] = float(np.linalg.norm(offset - (offset @ along) * along))
    return marks


def _cast(scene: Any, origin: NDArray, direction: NDArray) -> tuple[NDArray, float]:
    import mitsuba as mi  # lazy: the caller has set a variant (mitsar.scene.load_scene)

    ray = mi.Ray3f(mi.Point3f(*(float(v) for v in origin)),
                   mi.Vector3f(*(float(v) for v in direction)))
    hit = scene.ray_intersect(ray)
    if not bool(np.array(hit.is_valid()).ravel()[0]):
        return np.full(3, np.nan), float("inf")
    t = float(np.array(hit.t).ravel()[0])
    return origin + t * direction, t
