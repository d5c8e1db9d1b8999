"""Delay and Doppler gradients and the resolutions they give (paper §2; Moccia & Renga 2011).

For a point ``x`` on a surface and a platform state (antenna at ``p``, velocity ``v``), with
``u = (x - p) / R`` the unit line of sight from the antenna to the point and ``R = |x - p|``:

* delay gradient ``grad tau = (2 / c) u``;
* Doppler gradient ``grad f_D = (2 / lambda) (v - (v . u) u) / R``
  (``f_D = (2 / lambda) v . u`` for a static point);
* both are projected on the local tangent plane of the surface, ``g_t = g - (g . n) n``;
* range resolution ``rho_r = 1 / (B |grad_t tau|)`` along ``grad_t tau``, azimuth resolution
  ``rho_a = 1 / (T_int |grad_t f_D|)`` along ``grad_t f_D``, and the angle ``Theta`` between
  the two projected gradients (folded into [0, 90] deg). The impulse response on the surface is
  ``sinc(B grad_t tau . dx) sinc(T_int grad_t f_D . dx)``; ``rho`` is its nominal width (the
  -3 dB width is 0.886 rho). The resolution cell is the parallelogram with sides
  ``rho_r / sin Theta`` (along the iso-Doppler line) and ``rho_a / sin Theta`` (along the
  iso-range line), area ``rho_r rho_a / sin Theta``.

Pure NumPy; :mod:`mitsar.ambiguity.maps` evaluates these over points x states.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.model.radar import SPEED_OF_LIGHT, Radar

__all__ = ["delay_gradient", "doppler_gradient", "gradient_resolution"]


def _line_of_sight(points: ArrayLike, antenna: ArrayLike) -> tuple[NDArray, NDArray]:
    """Unit line of sight ``u = (x - p) / R`` and range ``R = |x - p|`` [m] (kept last axis)."""
    offset = np.asarray(points, dtype=float) - np.asarray(antenna, dtype=float)
    distance = np.linalg.norm(offset, axis=-1, keepdims=True)
    return offset / distance, distance


def delay_gradient(points: ArrayLike, antenna: ArrayLike) -> NDArray[np.float64]:
    """Gradient of the two-way delay with respect to the point position [s/m].

    ``grad tau = (2 / c) (x - p) / |x - p|``; shapes broadcast, last axis xyz.
    """
    unit, _ = _line_of_sight(points, antenna)
    return 2.0 / SPEED_OF_LIGHT * unit


def doppler_gradient(points: ArrayLike, antenna: ArrayLike, velocity: ArrayLike,
                     wavelength: float) -> NDArray[np.float64]:
    """Gradient of the Doppler frequency with respect to the point position [Hz/m].

    ``grad f_D = (2 / lambda) (v - (v . u) u) / R`` with ``u = (x - p) / R`` and
    ``f_D = (2 / lambda) v . u`` (static point, platform velocity ``v``).
    """
    unit, distance = _line_of_sight(points, antenna)
    velocity = np.asarray(velocity, dtype=float)
    radial = np.sum(velocity * unit, axis=-1, keepdims=True)
    return 2.0 / wavelength * (velocity - radial * unit) / distance


def _project(vectors: NDArray, normals: NDArray | None) -> NDArray:
    """Component of ``vectors`` in the tangent plane of unit ``normals`` (None: unchanged)."""
    if normals is None:
        return vectors
    return vectors - np.sum(vectors * normals, axis=-1, keepdims=True) * normals


def gradient_resolution(points: ArrayLike, normals: ArrayLike | None, antenna: ArrayLike,
                        velocity: ArrayLike, radar: Radar,
                        integration_time: ArrayLike) -> dict[str, NDArray]:
    """Gradient-method resolutions of points seen from one or more platform states.

    Parameters
    ----------
    points : array_like, shape (..., 3)
        Points on a surface [m].
    normals : array_like, shape (..., 3), or None
        Unit surface normals; ``None`` keeps the 3-D gradients (slant plane).
    antenna, velocity : array_like, shape (..., 3)
        Antenna phase centre [m] and platform velocity [m/s]; broadcast against ``points``.
    radar : Radar
    integration_time : array_like
        Integration time T_int [s], broadcast against the leading shape.

    Returns
    -------
    dict
        ``range_resolution`` and ``azimuth_resolution`` [m] (inf where the projected gradient
        vanishes), ``angle`` between the projected gradients [rad, 0..pi/2], ``range_direction``
        and ``azimuth_direction`` (unit vectors of the projected gradients), ``delay_gradient``
        and ``doppler_gradient`` (projected, s/m and Hz/m).

    Examples
    --------
    Broadside over a flat floor: ground-range resolution c / (2 B sin theta_inc).

    >>> r = gradient_resolution([0, 4, 0], [0, 0, 1], [0, 0, 3], [0.5, 0, 0], Radar(), 0.16)
    >>> round(float(r["range_resolution"]), 4), round(float(np.degrees(r["angle"])), 1)
    (0.1249, 90.0)
    """
    points = np.asarray(points, dtype=float)
    normals = None if normals is None else np.asarray(normals, dtype=float)
    g_tau = _project(delay_gradient(points, antenna), normals)
    g_fd = _project(doppler_gradient(points, antenna, velocity, radar.wavelength), normals)
    n_tau = np.linalg.norm(g_tau, axis=-1)
    n_fd = np.linalg.norm(g_fd, axis=-1)
    with np.errstate(divide="ignore", invalid="ignore"):
        rho_r = 1.0 / (radar.bandwidth * n_tau)
        rho_a = 1.0 / (np.asarray(integration_time, dtype=float) * n_fd)
        cosine = np.abs(np.sum(g_tau * g_fd, axis=-1)) / (n_tau * n_fd)
        angle = np.arccos(np.clip(np.where(np.isfinite(cosine), cosine, 1.0), 0.0, 1.0))
        range_direction = g_tau / n_tau[..., None]
        azimuth_direction = g_fd / n_fd[..., None]
    return {"range_resolution": rho_r, "azimuth_resolution": rho_a, "angle": angle,
            "range_direction": range_direction, "azimuth_direction": azimuth_direction,
            "delay_gradient": g_tau, "doppler_gradient": g_fd}
