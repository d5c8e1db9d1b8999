"""The aperture's geometry seen from a pixel: phase centres, centre of aperture, track tangent.

A focused pixel p is evaluated at its **centre of aperture**, the aperture sample closest to it
(``argmin_a |P(a) - p|``), where the track direction is the finite-difference tangent of the
platform positions ``P``; body-frame phase centres are at ``P(a) + R(a) offset`` in the world
(:func:`mitsar.model.geometry.attitude.body_to_world`). docs/interferometry.md §1. The
interferometry stage (the pair's exact geometry) and the scene stage (layover and shadow masks)
both read pixels this way, from these functions.

The **mean track** (:func:`mean_track_velocity`) is the velocity averaged over three passes of
a boxcar of ``MEAN_TRACK_TIME`` (a quadratic B-spline window, 3 T wide): the direction
a multirotor's heading follows and the frame in which back-projection measures a pixel's aspect
angle (:func:`mitsar.focus.aperture.aspect_frames`), so that a few centimetres of cross-track
wander move neither (docs/navigation.md, "Heading without attitude data").
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import body_to_world

__all__ = ["MEAN_TRACK_PASSES", "MEAN_TRACK_TIME", "aperture_centre", "mean_track_velocity",
           "phase_centres", "track_direction"]

MEAN_TRACK_TIME = 1.0
"""Length T [s] of each of the three boxcars that make the mean track's window.

The three passes multiply a sinusoidal wander of period P by ``sinc^3(T / P)``
(``sinc(x) = sin(pi x) / (pi x)``): 0 at P = T, T/2, ..., 0.0058 at P = 0.8 s (a 3 cm
wander at 0.5 m/s swings the velocity by +-25 deg; the mean track by 0.15 deg), below 0.03 for
every P < 0.8 T; a slow wander is followed (0.26 at P = 2 T). A turn at constant rate keeps
its direction in the middle of the window (the window is symmetric); a turn's entry and exit
are rounded over +-1.5 T."""


MEAN_TRACK_PASSES = 3
"""Boxcar passes of the mean track (three: the window's sidelobes fall as ``(T/P)^-3``)."""


def phase_centres(aperture_position: ArrayLike, aperture_attitude: ArrayLike,
                  offsets: ArrayLike) -> NDArray[np.float64]:
    """World positions of body-frame phase centres along the aperture.

    Parameters
    ----------
    aperture_position : array_like, shape (A, 3)
        Platform reference point per aperture sample [m].
    aperture_attitude : array_like, shape (A, 3)
        Heading, pitch, roll [rad] per aperture sample.
    offsets : array_like, shape (C, 3)
        Body-frame phase-centre offsets [m].

    Returns
    -------
    ndarray, shape (A, C, 3)
        ``P(a) + R(a) offset_c`` [m].
    """
    pos = np.asarray(aperture_position, float)
    att = np.asarray(aperture_attitude, float)
    rot = body_to_world(att[:, 0], att[:, 1], att[:, 2])
    return pos[:, None, :] + np.einsum("aij,cj->aci", rot, np.asarray(offsets, float))


def aperture_centre(aperture_position: ArrayLike, pixels: ArrayLike) -> NDArray[np.int64]:
    """Index of the aperture sample closest to each pixel, ``argmin_a |P(a) - p|``.

    Parameters
    ----------
    aperture_position : array_like, shape (A, 3)
        Platform reference point per aperture sample [m].
    pixels : array_like, shape (..., 3)
        Pixel positions [m].

    Returns
    -------
    ndarray of int, shape (...)
    """
    pixels = np.asarray(pixels, float)
    from scipy.spatial import cKDTree  # lazy: SciPy's spatial tools are heavy

    _, index = cKDTree(np.asarray(aperture_position, float)).query(pixels.reshape(-1, 3))
    return np.asarray(index, np.int64).reshape(pixels.shape[:-1])


def track_direction(aperture_position: ArrayLike) -> NDArray[np.float64]:
    """Unit tangent of the track at each aperture sample (central differences), shape (A, 3)."""
    pos = np.asarray(aperture_position, float)
    if pos.ndim != 2 or pos.shape[0] < 2:
        raise ParameterError("interferometry", "aperture_position",
                             "at least two aperture samples (the track direction)", pos.shape)
    tangent = np.gradient(pos, axis=0)
    norm = np.linalg.norm(tangent, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise ParameterError("interferometry", "aperture_position",
                             "a moving platform (distinct successive positions)",
                             "repeated positions")
    return tangent / norm


def mean_track_velocity(velocities: ArrayLike, interval: float,
                        smoothing_time: float = MEAN_TRACK_TIME) -> NDArray[np.float64]:
    """Velocity of the mean track: the velocities averaged over a smooth window.

    :data:`MEAN_TRACK_PASSES` passes of a boxcar of ``m ~ T / interval`` samples (the odd
    number nearest), each renormalised by the samples it holds, so that the ends average over
    the part of the window inside the track; the response to a sinusoid of period P is
    ``sinc^3(T / P)`` (see :data:`MEAN_TRACK_TIME`). The boxcar mean of a velocity is the
    chord of the positions over the boxcar, so the result is the direction of the track on the
    scale T, not of its wander.

    Parameters
    ----------
    velocities : array_like, shape (n, 3)
        Velocities sampled every ``interval`` seconds [m/s] (any (n, k) samples are averaged
        the same way, e.g. a velocity with a fourth column to average alongside).
    interval : float
        Sampling interval [s] (> 0).
    smoothing_time : float
        Boxcar length T [s] (>= 0; 0 returns the velocities).

    Returns
    -------
    ndarray, shape (n, 3) (or the input's)
        Mean-track velocity [m/s] (its norm is below the speed where the track bends).
    """
    velocities = np.asarray(velocities, dtype=float)
    if velocities.ndim != 2 or velocities.shape[1] < 1:
        raise ParameterError("mean_track_velocity", "velocities", "shape (n, 3)",
                             velocities.shape)
    if not (np.isfinite(interval) and interval > 0):
        raise ParameterError("mean_track_velocity", "interval", "a finite time > 0 s", interval)
    if not (np.isfinite(smoothing_time) and smoothing_time >= 0):
        raise ParameterError("mean_track_velocity", "smoothing_time", "a finite time >= 0 s",
                             smoothing_time)
    half = int(round((smoothing_time / interval - 1) / 2))  # 2 half + 1 samples span T
    if half < 1 or len(velocities) < 2:
        return velocities.copy()
    for _ in range(MEAN_TRACK_PASSES):
        velocities = _boxcar(velocities, half)
    return velocities


def _boxcar(values: NDArray, half: int) -> NDArray[np.float64]:
    """Mean over the ``2 half + 1`` samples centred on each row, truncated at the ends
    (cumulative sums: O(n))."""
    n = len(values)
    total = np.vstack([np.zeros((1,) + values.shape[1:]), np.cumsum(values, axis=0)])
    index = np.arange(n)
    low, high = np.maximum(index - half, 0), np.minimum(index + half + 1, n)
    return (total[high] - total[low]) / (high - low)[:, None]
