"""The aperture's geometry seen from a pixel: phase centres, centre of aperture, track tangent.

A focused pixel p is evaluated at its **centre of aperture**, the aperture sample closest to it
(``argmin_a |P(a) - p|``), where the track direction is the finite-difference tangent of the
platform positions ``P``; body-frame phase centres are at ``P(a) + R(a) offset`` in the world
(:func:`mitsar.model.geometry.attitude.body_to_world`). docs/interferometry.md §1. The
interferometry stage (the pair's exact geometry) and the scene stage (layover and shadow masks)
both read pixels this way, from these functions.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray
from scipy.spatial import cKDTree

from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import body_to_world

__all__ = ["aperture_centre", "phase_centres", "track_direction"]


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
