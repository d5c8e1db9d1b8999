"""Rigid motion of a scene body: translation, rotation about a centre, sampled paths
(docs/integrator.md §Moving objects).

A body (a shape of the scene) is given in its state at load, its points ``x0``, and a centre
``c`` (default: the centre of the shape's bounding box at load). At slow time t its points are

    x(t) = p(t) + R(t) (x0 − c),                                            (1)

``p(t)`` the position of the centre and ``R(t)`` the rotation from the state at load, and they
move with the rigid-body velocity

    ẋ(t) = ṗ(t) + ω(t) × (x(t) − p(t)),                                      (2)

``ω`` the angular velocity in the world frame [rad/s]. Two kinds of motion give p, R and ω:

* constant velocity ``v`` and angular velocity ``ω``: ``p(t) = c + v t``, ``R(t) = exp([ω t]×)``
  by Rodrigues' formula (3) (:func:`rotation_matrices`);
* a sampled path (:class:`BodyPath`): times, positions of the centre and optionally attitudes.
  Positions are interpolated by a **cubic Hermite** spline whose tangents are the second-order
  finite differences of the samples (``numpy.gradient``): the velocity of (2), which sets the
  Doppler of the in-sweep motion, is then continuous across samples (a linear interpolation would
  make it jump at every sample), and a uniform straight path is reproduced exactly. Attitudes are
  interpolated by **slerp** (constant angular velocity between samples, ``R(t) = R_k exp([s
  φ_k]×)``, ``φ_k = log(R_kᵀ R_k+1)``), the rotation of least angle between the samples; ω is
  then piecewise constant. Successive attitudes must differ by less than 170° (the logarithm is
  ill-conditioned near 180°).

Rodrigues' formula (3): ``exp([r]×) = I + (sin θ/θ) [r]× + ((1 − cos θ)/θ²) [r]×²``, θ = |r|.

Pure NumPy; attitudes as heading/pitch/roll follow :func:`mitsar.model.geometry.attitude.
body_to_world` (docs/conventions.md), relative to the body's state at load.
"""

from __future__ import annotations

from dataclasses import dataclass, field
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.checks import vector
from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import body_to_world

__all__ = ["MAX_ATTITUDE_STEP_DEG", "BodyPath", "RigidMotion", "cross_matrices",
           "rotation_matrices", "rotation_vectors"]

MAX_ATTITUDE_STEP_DEG = 170.0
"""Largest rotation between successive attitude samples of a path [deg]."""


def cross_matrices(r: ArrayLike) -> NDArray[np.float64]:
    """Cross-product matrices ``[r]×`` (``[r]× x = r × x``); shape ``r.shape[:-1] + (3, 3)``."""
    r = np.asarray(r, dtype=float)
    z = np.zeros(r.shape[:-1])
    x, y, w = r[..., 0], r[..., 1], r[..., 2]
    return np.stack([np.stack([z, -w, y], -1), np.stack([w, z, -x], -1),
                     np.stack([-y, x, z], -1)], -2)


def rotation_matrices(rotation_vector: ArrayLike) -> NDArray[np.float64]:
    """Rotations by rotation vectors ``r`` [rad] (axis r/|r|, angle |r|), Rodrigues' formula
    (module docstring, eq. 3); shape ``r.shape[:-1] + (3, 3)``. Series below 1e-4 rad."""
    r = np.asarray(rotation_vector, dtype=float)
    theta = np.linalg.norm(r, axis=-1)
    small = theta < 1e-4
    safe = np.where(small, 1.0, theta)
    a = np.where(small, 1.0 - theta ** 2 / 6.0, np.sin(safe) / safe)
    b = np.where(small, 0.5 - theta ** 2 / 24.0, (1.0 - np.cos(safe)) / safe ** 2)
    k = cross_matrices(r)
    return np.eye(3) + a[..., None, None] * k + b[..., None, None] * (k @ k)


def rotation_vectors(rotation: ArrayLike) -> NDArray[np.float64]:
    """Rotation vectors [rad] of rotation matrices (the inverse of :func:`rotation_matrices`
    for angles below π); shape ``rotation.shape[:-2] + (3,)``."""
    m = np.asarray(rotation, dtype=float)
    cos = np.clip((np.trace(m, axis1=-2, axis2=-1) - 1.0) / 2.0, -1.0, 1.0)
    theta = np.arccos(cos)
    vee = 0.5 * np.stack([m[..., 2, 1] - m[..., 1, 2], m[..., 0, 2] - m[..., 2, 0],
                          m[..., 1, 0] - m[..., 0, 1]], -1)       # sin θ · axis
    small = theta < 1e-4
    factor = np.where(small, 1.0 + theta ** 2 / 6.0,
                      theta / np.sin(np.where(small, 1.0, theta)))
    return factor[..., None] * vee


@dataclass(frozen=True, eq=False)
class BodyPath:
    """A sampled path of a body's centre, optionally with attitudes (module docstring).

    Parameters
    ----------
    times : numpy.ndarray, shape (K,)
        Slow times [s], strictly increasing, K >= 2.
    positions : numpy.ndarray, shape (K, 3)
        Positions of the body's centre [m] (world frame).
    rotations : numpy.ndarray, shape (K, 3, 3), optional
        Rotations from the state at load (default: none, the body only translates).
    """

    times: NDArray[np.float64]
    positions: NDArray[np.float64]
    rotations: NDArray[np.float64] | None = None
    _tangents: NDArray[np.float64] = field(init=False, repr=False)
    _steps: NDArray[np.float64] | None = field(init=False, repr=False)

    def __post_init__(self) -> None:
        tangents = np.gradient(self.positions, self.times, axis=0,
                               edge_order=2 if len(self.times) > 2 else 1)
        object.__setattr__(self, "_tangents", tangents)
        steps = None if self.rotations is None else rotation_vectors(
            np.swapaxes(self.rotations[:-1], -1, -2) @ self.rotations[1:])
        object.__setattr__(self, "_steps", steps)

    @classmethod
    def from_samples(cls, where: str, name: str, times: Any, positions: Any,
                     attitude_deg: Any = None, rotation_vector: Any = None) -> BodyPath:
        """Validate samples; ``attitude_deg`` (K, 3) heading, pitch, roll [deg] or
        ``rotation_vector`` (K, 3) [rad], relative to the body's state at load. Errors name
        ``<name>.times`` etc."""
        t = _array(where, f"{name}.times", times, (-1,), "slow times [s], at least 2")
        if len(t) < 2 or np.any(np.diff(t) <= 0):
            raise ParameterError(where, f"{name}.times", "at least 2 strictly increasing slow "
                                 "times [s]", times)
        p = _array(where, f"{name}.positions", positions, (len(t), 3),
                   f"{len(t)} positions [x, y, z] m (one per time)")
        if attitude_deg is not None and rotation_vector is not None:
            raise ParameterError(where, f"{name}.attitude_deg", "either attitude_deg or "
                                 "rotation_vector, not both", "both")
        rotations = None
        if attitude_deg is not None:
            a = np.radians(_array(where, f"{name}.attitude_deg", attitude_deg, (len(t), 3),
                                  f"{len(t)} attitudes [heading, pitch, roll] deg"))
            rotations = body_to_world(a[:, 0], a[:, 1], a[:, 2])
            key = f"{name}.attitude_deg"
        elif rotation_vector is not None:
            rotations = rotation_matrices(_array(
                where, f"{name}.rotation_vector", rotation_vector, (len(t), 3),
                f"{len(t)} rotation vectors [rx, ry, rz] rad"))
            key = f"{name}.rotation_vector"
        if rotations is not None:
            relative = np.swapaxes(rotations[:-1], -1, -2) @ rotations[1:]
            step = np.degrees(np.arccos(np.clip(
                (np.trace(relative, axis1=-2, axis2=-1) - 1) / 2, -1.0, 1.0)))
            if np.any(step >= MAX_ATTITUDE_STEP_DEG):
                raise ParameterError(where, key, f"successive attitudes less than "
                                     f"{MAX_ATTITUDE_STEP_DEG:g} deg apart (sample more "
                                     "densely)", f"steps up to {float(step.max()):.1f} deg")
        return cls(t, p, rotations)

    def state(self, t: NDArray) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """(p(t), R(t), ṗ(t), ω(t)) at slow times ``t`` (any shape): cubic Hermite positions,
        slerp attitudes (module docstring). Beyond the samples the end pieces extrapolate."""
        k = np.clip(np.searchsorted(self.times, t, side="right") - 1, 0, len(self.times) - 2)
        h = self.times[k + 1] - self.times[k]
        s = ((t - self.times[k]) / h)[..., None]
        p0, p1 = self.positions[k], self.positions[k + 1]
        m0, m1 = self._tangents[k] * h[..., None], self._tangents[k + 1] * h[..., None]
        s2, s3 = s * s, s * s * s
        position = ((2 * s3 - 3 * s2 + 1) * p0 + (s3 - 2 * s2 + s) * m0
                    + (-2 * s3 + 3 * s2) * p1 + (s3 - s2) * m1)
        velocity = ((6 * s2 - 6 * s) * p0 + (3 * s2 - 4 * s + 1) * m0
                    + (-6 * s2 + 6 * s) * p1 + (3 * s2 - 2 * s) * m1) / h[..., None]
        if self.rotations is None:
            shape = np.shape(t)
            return position, np.broadcast_to(np.eye(3), shape + (3, 3)), velocity, \
                np.zeros(shape + (3,))
        step = self._steps[k]
        rotation = self.rotations[k] @ rotation_matrices(s * step)
        omega = np.einsum("...ij,...j->...i", self.rotations[k], step) / h[..., None]
        return position, rotation, velocity, omega


@dataclass(frozen=True, eq=False)
class RigidMotion:
    """The motion of one body (module docstring): constant ``velocity`` [m/s] and
    ``angular_velocity`` [rad/s] about ``centre`` [m], or a :class:`BodyPath` of the centre.

    Points are broadcast with the times: ``points`` has shape ``t.shape + extra + (3,)`` (any
    ``extra``, size-1 axes broadcast), e.g. ``points (N, 3, 3)`` triangles with ``t (N,)``.
    """

    centre: NDArray[np.float64]
    velocity: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    angular_velocity: NDArray[np.float64] = field(default_factory=lambda: np.zeros(3))
    path: BodyPath | None = None

    @property
    def rotates(self) -> bool:
        """Whether the body rotates or follows a path (more than a constant translation)."""
        return self.path is not None or bool(np.any(self.angular_velocity != 0.0))

    def state(self, t: ArrayLike) -> tuple[NDArray, NDArray, NDArray, NDArray]:
        """(p(t) [m], R(t), ṗ(t) [m/s], ω(t) [rad/s]) at slow times ``t`` [s], eq. (1)-(3)."""
        t = np.asarray(t, dtype=float)
        if self.path is not None:
            return self.path.state(t)
        shape = t.shape + (3,)
        return (self.centre + t[..., None] * self.velocity,
                rotation_matrices(t[..., None] * self.angular_velocity),
                np.broadcast_to(self.velocity, shape), np.broadcast_to(self.angular_velocity,
                                                                       shape))

    def move(self, points: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Positions at ``t`` of body points given at load, eq. (1) [m]."""
        x = np.asarray(points, dtype=float)
        position, rotation, _, _ = self._expanded(x, t)
        return position + np.einsum("...ij,...j->...i", rotation, x - self.centre)

    def rotate(self, vectors: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Directions at ``t`` of body directions given at load (normals): ``R(t) n``."""
        n = np.asarray(vectors, dtype=float)
        return np.einsum("...ij,...j->...i", self._expanded(n, t)[1], n)

    def point_velocity(self, points_now: ArrayLike, t: ArrayLike) -> NDArray[np.float64]:
        """Velocity [m/s] of the body points that are at ``points_now`` at time ``t``,
        eq. (2)."""
        x = np.asarray(points_now, dtype=float)
        position, _, velocity, omega = self._expanded(x, t)
        return velocity + np.cross(omega, x - position)

    def max_speed(self, radius: float, start: float, end: float) -> float:
        """Largest speed [m/s] of a body point within ``radius`` of the centre over
        ``[start, end]`` (sampled 32 times per path interval and at 257 times otherwise)."""
        if self.path is None:
            return float(np.linalg.norm(self.velocity)
                         + np.linalg.norm(self.angular_velocity) * radius)
        count = 32 * len(self.path.times) + 257
        _, _, velocity, omega = self.state(np.linspace(start, end, count))
        return float(np.max(np.linalg.norm(velocity, axis=-1)
                            + np.linalg.norm(omega, axis=-1) * radius))

    def _expanded(self, x: NDArray, t: ArrayLike) -> tuple[NDArray, ...]:
        t = np.asarray(t, dtype=float)
        extra = x.ndim - 1 - t.ndim
        if extra < 0:
            raise ParameterError("RigidMotion", "points", f"an array of shape t.shape + (..., 3) "
                                 f"(t.shape = {t.shape})", x.shape)
        position, rotation, velocity, omega = self.state(t)
        pad = (1,) * extra
        return (position.reshape(t.shape + pad + (3,)),
                rotation.reshape(t.shape + pad + (3, 3)),
                np.reshape(velocity, t.shape + pad + (3,)),
                np.reshape(omega, t.shape + pad + (3,)))


def _array(where: str, name: str, value: Any, shape: tuple[int, ...], expected: str
           ) -> NDArray[np.float64]:
    """``value`` as a finite float array of ``shape`` (-1: any length)."""
    if len(shape) == 1 and shape[0] == -1:
        try:
            length = len(value)
        except TypeError:
            length = -1
        if length < 1:
            raise ParameterError(where, name, expected, value)
        return vector(where, name, value, length, expected)
    try:
        array = np.asarray(value, dtype=float)
    except (TypeError, ValueError):
        array = np.full(0, np.nan)
    if array.shape != shape or not np.all(np.isfinite(array)):
        raise ParameterError(where, name, expected, value)
    return array
