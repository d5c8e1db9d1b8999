"""Line features: straight edges (walls seen edge-on, wall–floor lines) fitted to detections.

Sequential RANSAC (Fischler & Bolles 1981): draw ``hypotheses`` lines through random pairs of
points (seeded ``numpy.random.default_rng(seed)``), keep the one with most points within
``tolerance``, refit it to its inliers by total least squares (the principal axis of their
scatter), take those inliers out and repeat until fewer than ``min_points`` remain on the best
line. The hypotheses of one round are scored together (no loop over points).

Each line carries its endpoints (the extreme inlier projections), unit direction, length, the
rms perpendicular residual ``s`` and the standard errors of a least-squares line
(docs/features.md eq. 6; Press et al. 2007 §15.2): across the line at its centroid
``s / sqrt(n)``, in direction ``s / sqrt(sum (t_i - t_mean)^2)`` [rad], and at an endpoint
``sqrt(s^2/n + (L/2)^2 sigma_theta^2)`` [m].
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar import checks
from mitsar.errors import ParameterError

__all__ = ["fit_line", "line_features"]

WHERE = "mitsar.features.line_features"
PAIR_BUDGET = 4_000_000
"""Point-to-hypothesis distances scored at once (memory: 8 bytes x 3 each)."""


def fit_line(points: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Total-least-squares line through ``points`` (n, 3) [m]: (centroid, unit direction), the
    direction the principal axis of the scatter (largest singular vector)."""
    centre = points.mean(axis=0)
    direction = np.linalg.svd(points - centre, full_matrices=False)[2][0]
    return centre, direction * (np.sign(direction[np.argmax(np.abs(direction))]) or 1.0)


def _distances(points: NDArray[np.float64], origin: NDArray[np.float64],
               direction: NDArray[np.float64]) -> NDArray[np.float64]:
    """Distance of every point (n, 3) to lines ``origin + t direction`` (h, 3): (h, n) [m]."""
    rel = points[None, :, :] - origin[:, None, :]
    along = np.einsum("hnc,hc->hn", rel, direction)
    return np.sqrt(np.maximum(np.einsum("hnc,hnc->hn", rel, rel) - along ** 2, 0.0))


def _best_hypothesis(points: NDArray[np.float64], tolerance: float, hypotheses: int,
                     rng: np.random.Generator) -> NDArray[np.bool_]:
    """Inliers of the best of ``hypotheses`` random two-point lines."""
    pairs = rng.integers(0, len(points), size=(hypotheses, 2))
    origin, other = points[pairs[:, 0]], points[pairs[:, 1]]
    span = np.linalg.norm(other - origin, axis=1)
    keep = span > 0
    origin, direction = origin[keep], (other - origin)[keep] / span[keep, None]
    if not len(origin):
        return np.zeros(len(points), dtype=bool)
    chunk = max(1, PAIR_BUDGET // len(points))
    counts = np.concatenate([
        (_distances(points, origin[i:i + chunk], direction[i:i + chunk]) <= tolerance).sum(1)
        for i in range(0, len(origin), chunk)])
    best = int(np.argmax(counts))
    return _distances(points, origin[best:best + 1], direction[best:best + 1])[0] <= tolerance


def _points(found: xr.Dataset | NDArray[np.float64]) -> NDArray[np.float64]:
    if isinstance(found, xr.Dataset):
        name = "cell_position" if "cell_position" in found.variables else "position"
        if name not in found.variables:
            raise ParameterError(WHERE, "found", "detections of mitsar.detect (cell_position "
                                 "or position) or an (n, 3) array of points",
                                 sorted(map(str, found.variables)))
        return np.asarray(found[name].values, dtype=float).reshape(-1, 3)
    points = np.asarray(found, dtype=float)
    if points.ndim != 2 or points.shape[1] != 3 or not np.all(np.isfinite(points)):
        raise ParameterError(WHERE, "found", "an (n, 3) array of finite points [m]",
                             f"shape {points.shape}")
    return points


def _default_tolerance(found: xr.Dataset | NDArray[np.float64]) -> float:
    if isinstance(found, xr.Dataset) and "resolution" in found.attrs:
        return float(np.max(found.attrs["resolution"]))
    raise ParameterError(WHERE, "tolerance", "an inlier distance > 0 m (no resolution is "
                         "recorded with these points)", None)


def _attrs(units: str, long_name: str) -> dict[str, str]:
    return {"units": units, "long_name": long_name}


def line_features(found: xr.Dataset | NDArray[np.float64], tolerance: float | None = None,
                  min_points: int = 10, max_lines: int = 20, hypotheses: int = 256,
                  seed: int = 0) -> xr.Dataset:
    """Straight lines through detections by sequential RANSAC (module docstring).

    Parameters
    ----------
    found : xarray.Dataset or array_like, shape (n, 3)
        Detections of :func:`mitsar.detect` (their detected cells, ``cell_position``, or their
        ``position``) or world points [m].
    tolerance : float, optional
        Largest distance of an inlier from its line [m]; default the largest resolution cell
        recorded with the detections.
    min_points : int
        Fewest inliers a line needs (>= 2).
    max_lines : int
        Most lines returned.
    hypotheses : int
        Random two-point lines scored per round.
    seed : int
        Seed of ``numpy.random.default_rng``; recorded in the attributes.

    Returns
    -------
    xarray.Dataset
        Dim ``line`` (most inliers first): ``start``, ``end`` (line, xyz) [m], ``direction``
        (line, xyz) [1], ``length`` [m], ``inliers`` [1], ``residual`` (rms perpendicular
        distance) [m], ``offset_uncertainty`` [m], ``angle_uncertainty`` [rad],
        ``uncertainty`` (1-sigma endpoint error across the line) [m]. Attributes: the
        parameters, ``seed`` included.
    """
    points = _points(found)
    tolerance = checks.positive(WHERE, "tolerance", _default_tolerance(found)
                                if tolerance is None else tolerance,
                                "an inlier distance > 0 m")
    min_points = checks.integer(WHERE, "min_points", min_points, 2)
    max_lines = checks.integer(WHERE, "max_lines", max_lines, 0)
    hypotheses = checks.integer(WHERE, "hypotheses", hypotheses, 1)
    rng = np.random.default_rng(checks.seed(WHERE, "seed", seed))
    rows: list[tuple] = []
    remaining = points
    while len(rows) < max_lines and len(remaining) >= min_points:
        inliers = _best_hypothesis(remaining, tolerance, hypotheses, rng)
        if inliers.sum() < 2:
            break
        centre, direction = fit_line(remaining[inliers])
        inliers = _distances(remaining, centre[None], direction[None])[0] <= tolerance
        count = int(inliers.sum())
        if count < min_points:
            break
        centre, direction = fit_line(remaining[inliers])
        along = (remaining[inliers] - centre) @ direction
        residual2 = np.sum((remaining[inliers] - centre) ** 2, axis=1) - along ** 2
        residual = float(np.sqrt(np.maximum(residual2, 0.0).sum() / max(count - 2, 1)))
        spread = float(np.sqrt(np.sum((along - along.mean()) ** 2)))
        offset = residual / np.sqrt(count)
        angle = residual / spread if spread > 0 else np.inf
        length = float(along.max() - along.min())
        rows.append((centre + along.min() * direction, centre + along.max() * direction,
                     direction, length, count, residual, offset, angle,
                     float(np.hypot(offset, 0.5 * length * angle))))
        remaining = remaining[~inliers]
    columns = list(zip(*rows, strict=True)) if rows else [np.zeros((0, 3))] * 3 + [[]] * 6
    vector = ("line", "xyz")
    out = xr.Dataset(
        {"start": (vector, np.reshape(columns[0], (-1, 3)), _attrs("m", "first endpoint")),
         "end": (vector, np.reshape(columns[1], (-1, 3)), _attrs("m", "second endpoint")),
         "direction": (vector, np.reshape(columns[2], (-1, 3)),
                       _attrs("1", "unit direction, start to end")),
         "length": ("line", np.asarray(columns[3], float), _attrs("m", "line length")),
         "inliers": ("line", np.asarray(columns[4], int), _attrs("1", "points on the line")),
         "residual": ("line", np.asarray(columns[5], float),
                      _attrs("m", "rms perpendicular distance of the inliers")),
         "offset_uncertainty": ("line", np.asarray(columns[6], float), _attrs(
             "m", "1-sigma error across the line at its centroid (docs/features.md eq. 6)")),
         "angle_uncertainty": ("line", np.asarray(columns[7], float), _attrs(
             "rad", "1-sigma error of the direction (docs/features.md eq. 6)")),
         "uncertainty": ("line", np.asarray(columns[8], float), _attrs(
             "m", "1-sigma error across the line at an endpoint (docs/features.md eq. 6)"))},
        coords={"xyz": ["x", "y", "z"]})
    out.attrs.update(product="lines", method="ransac", seed=int(seed), tolerance=tolerance,
                     min_points=min_points, max_lines=max_lines, hypotheses=hypotheses,
                     points=len(points))
    return out
