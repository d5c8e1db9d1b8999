"""The two channels' exact bistatic geometry at each pixel's centre of aperture.

Channel k has its transmitter and receiver at the body-frame offsets ``t_k``, ``r_k`` [m]; at
aperture sample a they are in the world at ``P(a) + R(a) t_k`` and ``P(a) + R(a) r_k``, with
``P(a)`` the platform reference point and ``R(a)`` the attitude's body-to-world rotation
(:func:`mitsar.model.geometry.attitude.body_to_world`). A scatterer at q has the two-way path
``L_k(q) = |t_k - q| + |q - r_k|`` (Rosen et al. 2000: the exact bistatic form, no phase-centre
approximation). Each pixel p is evaluated at its centre of aperture, the aperture sample closest
to p (``argmin_a |P(a) - p|``), where the track direction is the finite-difference tangent of
``P``. The reference phase of the pair (1, 2) at p is ``phi_ref(p) = (2 pi / lambda)(L_1(p) -
L_2(p))``, removed from every pixel by back-projection (docs/interferometry.md §2). The
aperture's own geometry (:func:`phase_centres`, :func:`aperture_centre`, :func:`track_direction`)
is :mod:`mitsar.model.geometry.aperture`'s, re-exported here.
"""

from __future__ import annotations

from dataclasses import dataclass, fields
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.model.geometry.aperture import aperture_centre, phase_centres, track_direction

__all__ = ["PairGeometry", "aperture_centre", "baseline", "pair_geometry", "path_length",
           "phase_centres", "reference_phase", "track_direction"]


def path_length(q: ArrayLike, transmitter: ArrayLike, receiver: ArrayLike
                ) -> NDArray[np.float64]:
    """Two-way bistatic path ``|t - q| + |q - r|`` [m] (Rosen et al. 2000), over the last axis.

    Parameters
    ----------
    q, transmitter, receiver : array_like, shape (..., 3)
        Scatterer, transmitter and receiver positions [m], broadcast together.
    """
    q = np.asarray(q, float)
    return (np.linalg.norm(np.asarray(transmitter, float) - q, axis=-1)
            + np.linalg.norm(q - np.asarray(receiver, float), axis=-1))


def path_gradient(q: ArrayLike, transmitter: ArrayLike, receiver: ArrayLike
                  ) -> NDArray[np.float64]:
    """Gradient of :func:`path_length` with respect to q [1]: the sum of the two unit vectors."""
    q = np.asarray(q, float)
    u = q - np.asarray(transmitter, float)
    w = q - np.asarray(receiver, float)
    return (u / np.linalg.norm(u, axis=-1, keepdims=True)
            + w / np.linalg.norm(w, axis=-1, keepdims=True))


@dataclass(frozen=True)
class PairGeometry:
    """The pair's phase centres and track direction at each pixel's centre of aperture.

    Attributes
    ----------
    transmitter1, receiver1, transmitter2, receiver2 : ndarray, shape (..., 3)
        World positions [m] of the two channels' phase centres.
    along_track : ndarray, shape (..., 3)
        Unit track direction [1].
    platform : ndarray, shape (..., 3)
        Platform reference point [m].
    """

    transmitter1: NDArray[np.float64]
    receiver1: NDArray[np.float64]
    transmitter2: NDArray[np.float64]
    receiver2: NDArray[np.float64]
    along_track: NDArray[np.float64]
    platform: NDArray[np.float64]

    def at(self, index: Any) -> PairGeometry:
        """The geometry of the pixels ``index`` selects (NumPy indexing of the pixel dims)."""
        return PairGeometry(*(np.asarray(getattr(self, f.name))[index] for f in fields(self)))

    def path_lengths(self, q: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
        """``(L_1(q), L_2(q))`` [m] for scatterers q of shape (..., 3)."""
        return (path_length(q, self.transmitter1, self.receiver1),
                path_length(q, self.transmitter2, self.receiver2))


def pair_geometry(aperture_position: ArrayLike, aperture_attitude: ArrayLike,
                  transmitter_offset: ArrayLike, receiver_offset: ArrayLike,
                  pixels: ArrayLike, pair: tuple[int, int] = (0, 1)) -> PairGeometry:
    """The pair's exact geometry at each pixel's centre of aperture (module docstring).

    Parameters
    ----------
    aperture_position : array_like, shape (A, 3)
        Platform reference point per aperture sample [m].
    aperture_attitude : array_like, shape (A, 3)
        Heading, pitch, roll [rad].
    transmitter_offset, receiver_offset : array_like, shape (C, 3)
        Body-frame phase centres of each channel [m].
    pixels : array_like, shape (..., 3)
        Pixel positions [m].
    pair : (int, int)
        Channels (1, 2) of the interferogram ``s_1 s_2*``.

    Returns
    -------
    PairGeometry
    """
    tx = np.asarray(transmitter_offset, float)[list(pair)]
    rx = np.asarray(receiver_offset, float)[list(pair)]
    pos = np.asarray(aperture_position, float)
    index = aperture_centre(pos, pixels)
    tx_world = phase_centres(pos, aperture_attitude, tx)[index]
    rx_world = phase_centres(pos, aperture_attitude, rx)[index]
    return PairGeometry(tx_world[..., 0, :], rx_world[..., 0, :], tx_world[..., 1, :],
                        rx_world[..., 1, :], track_direction(pos)[index], pos[index])


def reference_phase(pixels: ArrayLike, geometry: PairGeometry, wavelength: float
                    ) -> NDArray[np.float64]:
    """``phi_ref(p) = (2 pi / lambda)(L_1(p) - L_2(p))`` [rad], the reference surface's phase.

    Parameters
    ----------
    pixels : array_like, shape (..., 3)
        Pixel positions [m].
    geometry : PairGeometry
        The pair's geometry at the pixels (:func:`pair_geometry`).
    wavelength : float
        Carrier wavelength [m].
    """
    l1, l2 = geometry.path_lengths(pixels)
    return 2.0 * np.pi / wavelength * (l1 - l2)


def baseline(geometry: PairGeometry, pixel: ArrayLike) -> tuple[NDArray[np.float64], float]:
    """Effective baseline vector and its component perpendicular to the line of sight.

    The effective baseline is ``(t_2 + r_2) - (t_1 + r_1)`` [m]: twice the separation of the
    channels' phase centres ``(t_k + r_k)/2``, so that ``phi ~ (2 pi / lambda) B . u`` with u
    the unit line of sight from the scatterer to the radar. It is the receivers' separation B
    in single-pass (common transmitter) and 2B in ping-pong, i.e. p B in Rosen et al. 2000.

    Parameters
    ----------
    geometry : PairGeometry
        Geometry at one pixel (arrays of shape (3,)).
    pixel : array_like, shape (3,)
        The pixel [m].

    Returns
    -------
    vector : ndarray, shape (3,)
        World-frame effective baseline [m].
    perpendicular : float
        Its norm perpendicular to the line of sight from the platform to the pixel [m].
    """
    vector = (geometry.transmitter2 + geometry.receiver2
              - geometry.transmitter1 - geometry.receiver1)
    los = np.asarray(pixel, float) - geometry.platform
    los = los / np.linalg.norm(los)
    return vector, float(np.linalg.norm(vector - np.dot(vector, los) * los))
