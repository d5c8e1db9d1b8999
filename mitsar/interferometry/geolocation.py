"""From unwrapped flat phase to the scatterer's 3-D position: the exact two-path solution.

A scatterer q focused into pixel p lies on channel 1's iso-path surface through p,
``L_1(q) = L_1(p)`` (same delay), in p's zero-Doppler plane (through p, perpendicular to the
track direction at p's centre of aperture). With the flat phase ``phi = (2 pi / lambda)
[(L_1(q) - L_2(q)) - (L_1(p) - L_2(p))]`` (docs/interferometry.md §2) and ``L_1(q) = L_1(p)``, the
second condition is ``L_2(q) = L_2(p) - lambda phi / (2 pi)``: q is where the plane and the two
iso-path ellipsoids (foci t_k, r_k) meet, the root next to p. No flat-earth or far-field
approximation (Rosen et al. 2000 give the first-order forms this replaces at indoor ranges).

The curve ``L_1 = L_1(p)`` in the plane is parametrised by the angle psi about the projection c
of channel 1's phase centre ``(t_1 + r_1)/2``: ``q(psi) = c + rho(psi)(cos psi e_1 + sin psi e_2)``
with ``e_1`` towards p (psi = 0 at p). rho(psi) is found by Newton's method on the ray, psi by
Newton's method on ``L_2(q(psi))`` with the implicit derivative ``rho' = -rho (grad L_1 . d') /
(grad L_1 . d)``; all pixels at once (vectorised), steps limited to 0.1 rad.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.interferometry.geometry import PairGeometry, path_gradient, path_length

__all__ = ["ambiguity_height", "first_order_ambiguity_height", "height_sensitivity",
           "phase_to_position"]

_MAX_STEP = 0.1
"""Largest angular Newton step [rad] (about 0.8 m at 8 m range)."""


def _dot(a: NDArray, b: NDArray) -> NDArray:
    return np.einsum("...i,...i->...", a, b)


def phase_to_position(phase: ArrayLike, pixels: ArrayLike, geometry: PairGeometry,
                      wavelength: float, *, tolerance: float = 1e-10,
                      max_iterations: int = 60) -> NDArray[np.float64]:
    """3-D position of the scatterer whose unwrapped flat phase is ``phase`` (module docstring).

    Parameters
    ----------
    phase : array_like, shape (...)
        Unwrapped flat phase ``phi_abs - phi_ref(p)`` [rad] (zero: the scatterer is at p).
    pixels : array_like, shape (..., 3)
        Pixel positions p [m].
    geometry : PairGeometry
        The pair's geometry at the pixels (:func:`mitsar.interferometry.geometry.pair_geometry`).
    wavelength : float
        Carrier wavelength [m].
    tolerance : float
        Convergence tolerance on both path lengths [m].
    max_iterations : int
        Most Newton steps on the angle.

    Returns
    -------
    ndarray, shape (..., 3)
        World position of the scatterer [m] (Rosen et al. 2000, exact two-path form); NaN where
        the phase is NaN or the iteration did not converge.
    """
    p = np.asarray(pixels, float)
    phi = np.broadcast_to(np.asarray(phase, float), p.shape[:-1])
    g = geometry
    t1, r1, t2, r2 = g.transmitter1, g.receiver1, g.transmitter2, g.receiver2
    v = g.along_track
    centre1 = 0.5 * (t1 + r1)
    c = centre1 - _dot(centre1 - p, v)[..., None] * v
    e1 = p - c
    rho = np.linalg.norm(e1, axis=-1)
    e1 = e1 / rho[..., None]
    e2 = np.cross(v, e1)
    target1 = path_length(p, t1, r1)
    target2 = path_length(p, t2, r2) - wavelength * phi / (2.0 * np.pi)
    psi = np.zeros_like(phi)
    converged = np.zeros(phi.shape, bool)
    q = p.copy()
    for _ in range(max_iterations):
        cos, sin = np.cos(psi)[..., None], np.sin(psi)[..., None]
        d, dd = cos * e1 + sin * e2, cos * e2 - sin * e1
        for _ in range(20):  # rho on the ray: L_1 is convex and increasing along it
            q = c + rho[..., None] * d
            f = path_length(q, t1, r1) - target1
            rho = rho - f / _dot(path_gradient(q, t1, r1), d)
            if not np.nanmax(np.abs(f), initial=0.0) > tolerance:
                break
        q = c + rho[..., None] * d
        g1, g2 = path_gradient(q, t1, r1), path_gradient(q, t2, r2)
        drho = -rho * _dot(g1, dd) / _dot(g1, d)
        slope = _dot(g2, drho[..., None] * d + rho[..., None] * dd)
        residual = path_length(q, t2, r2) - target2
        converged = np.abs(residual) <= tolerance
        if converged[np.isfinite(residual)].all():
            break
        with np.errstate(divide="ignore", invalid="ignore"):
            step = np.clip(-residual / slope, -_MAX_STEP, _MAX_STEP)
        psi = np.where(converged, psi, psi + step)
    return np.where(converged[..., None], q, np.nan)


def height_sensitivity(phase: ArrayLike, pixels: ArrayLike, geometry: PairGeometry,
                       wavelength: float, step: float = 1e-2) -> NDArray[np.float64]:
    """``dz/dphi`` of the solved scatterer [m/rad], by central differences of the exact solution.

    The first-order form is ``lambda R sin(theta) / (2 pi B_perp)`` with B_perp the effective
    perpendicular baseline (Rosen et al. 2000); this differentiates :func:`phase_to_position`.

    Parameters
    ----------
    phase : array_like, shape (...)
        Unwrapped flat phase [rad].
    pixels : array_like, shape (..., 3)
        Pixel positions [m].
    geometry : PairGeometry
        The pair's geometry at the pixels.
    wavelength : float
        Carrier wavelength [m].
    step : float
        Half the phase difference of the central difference [rad].

    Returns
    -------
    ndarray, shape (...)
        Signed derivative of the world z of the scatterer with respect to the phase [m/rad].
    """
    phi = np.asarray(phase, float)
    up = phase_to_position(phi + step, pixels, geometry, wavelength)[..., 2]
    down = phase_to_position(phi - step, pixels, geometry, wavelength)[..., 2]
    return (up - down) / (2.0 * step)


def ambiguity_height(pixels: ArrayLike, geometry: PairGeometry, wavelength: float,
                     phase: ArrayLike = 0.0) -> NDArray[np.float64]:
    """Exact height of one 2 pi cycle, ``|z(phi + pi) - z(phi - pi)|`` [m], per pixel.

    Numerical counterpart of ``h_amb = lambda R sin(theta) / B_perp`` (Rosen et al. 2000;
    :func:`first_order_ambiguity_height`), from :func:`phase_to_position`.

    Parameters
    ----------
    pixels : array_like, shape (..., 3)
        Pixel positions [m].
    geometry : PairGeometry
        The pair's geometry at the pixels.
    wavelength : float
        Carrier wavelength [m].
    phase : array_like
        Flat phase about which the cycle is taken [rad] (0: the reference surface).
    """
    # the central difference of height_sensitivity over a whole cycle (step pi)
    return np.abs(2 * np.pi * height_sensitivity(phase, pixels, geometry, wavelength,
                                                 step=np.pi))


def first_order_ambiguity_height(wavelength: ArrayLike, slant_range: ArrayLike,
                                 look_angle: ArrayLike, perpendicular_baseline: ArrayLike
                                 ) -> NDArray[np.float64]:
    """First-order ambiguity height ``lambda R sin(theta) / B_perp`` [m] (Rosen et al. 2000).

    Parameters
    ----------
    wavelength : array_like
        Carrier wavelength [m].
    slant_range : array_like
        Range R [m].
    look_angle : array_like
        Look angle theta from the vertical [rad].
    perpendicular_baseline : array_like
        Effective perpendicular baseline p B_perp [m] (p = 1 single-pass, 2 ping-pong).
    """
    return (np.asarray(wavelength, float) * np.asarray(slant_range, float)
            * np.sin(np.asarray(look_angle, float)) / np.asarray(perpendicular_baseline, float))
