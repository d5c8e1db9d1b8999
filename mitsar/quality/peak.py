"""Finding a point target's peak in an image: the brightest pixel near the target, the brightest
upsampled sample (which must be a local maximum) and its quadratic refinement (docs/metrics.md).
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.quality.cuts import MeasurementError
from mitsar.quality.geometry import ImageGeometry, dim_offsets

__all__ = ["fine_peak", "peak_pixel", "refine_peak_2d"]


def peak_pixel(geometry: ImageGeometry, target_index: NDArray, search_m: float) -> NDArray:
    """Brightest pixel within ``search_m`` of the target (disc in the image's metres; a radius
    beyond the image's diagonal searches the whole image, as that radius would)."""
    shape = np.array(geometry.values.shape)
    search_m = min(float(search_m), float(np.linalg.norm(shape * np.abs(geometry.spacing))))
    half = np.ceil(search_m / np.abs(geometry.spacing)).astype(int) + 1
    centre = np.rint(target_index).astype(int)
    lo = np.clip(centre - half, 0, shape - 1)
    hi = np.clip(centre + half + 1, 1, shape)
    d0, d1 = dim_offsets(lo, tuple(hi - lo), 1, target_index, geometry.spacing)
    inside = d0**2 + d1**2 <= (search_m + 0.5 * np.abs(geometry.spacing).max()) ** 2
    window = np.where(inside, np.abs(geometry.values[lo[0] : hi[0], lo[1] : hi[1]]), -1.0)
    pixel = lo + np.array(np.unravel_index(int(np.argmax(window)), window.shape))
    if np.any(pixel == 0) or np.any(pixel == shape - 1):
        raise ParameterError(
            "measure_impulse_response", "target",
            "a target whose peak is inside the image; the target is too close to the image "
            f"edge to measure: its peak is on the border pixel {pixel.tolist()} of "
            f"{shape.tolist()}: extend the focusing grid around the target",
            [round(float(v), 6) for v in geometry.position[tuple(pixel)]])
    return pixel


def refine_peak_2d(
    power: NDArray[np.float64], k: tuple[int, int]
) -> tuple[NDArray[np.float64], float]:
    """Fractional peak index and peak power from a quadratic fit of the 3×3 neighbourhood.

    The fit uses the central-difference gradient ``g`` and Hessian ``H``: offset ``−H⁻¹g``,
    value ``p + g·offset / 2``.
    """
    k0, k1 = k
    origin = np.array(k, dtype=float)
    if not (0 < k0 < power.shape[0] - 1 and 0 < k1 < power.shape[1] - 1):
        return origin, float(power[k])
    w = power[k0 - 1 : k0 + 2, k1 - 1 : k1 + 2]
    gradient = 0.5 * np.array([w[2, 1] - w[0, 1], w[1, 2] - w[1, 0]])
    cross = 0.25 * (w[2, 2] - w[2, 0] - w[0, 2] + w[0, 0])
    hessian = np.array(
        [[w[2, 1] - 2 * w[1, 1] + w[0, 1], cross], [cross, w[1, 2] - 2 * w[1, 1] + w[1, 0]]]
    )
    if np.linalg.det(hessian) <= 0.0 or hessian[0, 0] >= 0.0:
        return origin, float(power[k])
    offset = np.clip(-np.linalg.solve(hessian, gradient), -0.5, 0.5)
    return origin + offset, max(float(w[1, 1] + 0.5 * gradient @ offset), float(w[1, 1]))


def fine_peak(power: NDArray[np.float64], inside: NDArray[np.bool_], search_m: float,
               distance: NDArray[np.float64]) -> tuple[int, int]:
    """Brightest upsampled sample within the search disc; it must be a local maximum.

    Raises :class:`MeasurementError` when the brightest sample inside is on the disc's boundary,
    rising towards something brighter outside (a stronger neighbour's main lobe).
    """
    k = np.unravel_index(int(np.argmax(np.where(inside, power, -1.0))), power.shape)
    lo = np.maximum(np.array(k) - 1, 0)
    hi = np.minimum(np.array(k) + 2, power.shape)
    if power[k] < power[lo[0] : hi[0], lo[1] : hi[1]].max():
        raise MeasurementError(
            f"no peak within search_radius_m={search_m:.4g} m of the target: the brightest "
            f"sample there is on the search boundary, {float(distance[k]):.4f} m away, rising "
            "towards a brighter response outside (a stronger neighbour, or the target farther "
            "off than the radius); check the target position ([metrics] target in the "
            "experiment, mitsar metrics --target X Y Z), or widen the search in Python: "
            "mitsar.measure_impulse_response(image, target, search_radius_m=...)"
        )
    return int(k[0]), int(k[1])
