"""Multipath by shooting and bouncing rays: the pure formulas (docs/design.md §5.4 mechanism 2).

The ``radar`` integrator (``plugins/integrators/radar/``) traces a fixed set of rays per sweep and
evaluates, in Dr.Jit, the formulas written here in NumPy; the tests call these functions directly
and compare the tracer against the image-method closed forms at the end of this module.
``docs/multipath.md`` explains the model; in short:

Ray set
    A regular, cell-centred (stratified, one sample per stratum) grid of launch directions in
    the *ray frame* of the antenna, ``d = p e_0 + q e_1 + sqrt(1 - p² - q²) e_2``, with direction
    sines ``p, q`` covering ``|p| <= cover β_0``, ``|q| <= cover β_1``. In 3D the ray frame is the
    antenna frame (azimuth axis, elevation axis, boresight; ``β`` = the beamwidths); in 2D mode
    (:func:`ray_frame_2d`) it is (plane normal, in-plane axis, boresight) and the rays form one
    fan ``p = 0`` in the plane. The set is fixed in the antenna frame, so it moves rigidly with
    the platform. Each ray carries its ray-tube solid angle ``dΩ = dp dq / sqrt(1 - p² - q²)``.

Ray tubes and capture
    After specular reflections by planes, a ray tube spreads as if it came from the image of the
    transmitter (:func:`mirror_point`), ``img_k = H_k ... H_1 (tx)``, and the reflected ray frame
    ``e'_j = M e_j`` (``M`` the product of the reflections) maps launch directions to directions
    from the image. The receiver at ``rx`` then sits at the launch coordinates
    ``(p*, q*) = ((rx - img)·e'_0, (rx - img)·e'_1) / |rx - img|`` of the tube it lies in. A ray
    whose tube footprint contains the receiver contributes with the weight
    :func:`capture_weight` (a tent over one ray spacing by default: the ray-tube footprint with
    linear taper). The weights of a regular grid are a partition of unity, so the rays around the
    receiver sum to exactly the image-method field (:func:`image_amplitude`), whatever the ray
    density; the density only sets how sharply shadow boundaries and small facets are resolved.
    This ray-tube bookkeeping plays the role of the paper's ``L_RX = N_reflected / N_rays``
    (eq. 12).

Everything here accepts NumPy arrays; the ops-agnostic helpers (``*_components``) are written
with plain arithmetic so the Dr.Jit kernel evaluates the same expressions.
"""

from __future__ import annotations

import math
from collections.abc import Sequence
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.ops import NUMPY_OPS
from mitsar.model.radar import SPEED_OF_LIGHT, Radar

__all__ = [
    "CAPTURE_KINDS",
    "RaySet",
    "capture_weight",
    "image_amplitude",
    "image_frame",
    "image_path",
    "image_power",
    "launch_coordinates",
    "mirror_point",
    "mirror_power",
    "multipath_amplitude_constant",
    "path_delay",
    "path_range_rate",
    "ray_frame_2d",
    "ray_set",
    "reflect",
    "tube_scatter_power",
]

CAPTURE_KINDS = ("tent", "box")
"""Capture kernels: ``tent`` (linear over one ray spacing per axis), ``box`` (the ray whose
tube cell contains the receiver)."""


# --------------------------------------------------------------------------------------------
# The ray set
# --------------------------------------------------------------------------------------------

@dataclass(frozen=True)
class RaySet:
    """A fixed grid of launch directions in the ray frame (module docstring).

    Attributes
    ----------
    p, q : ndarray, shape (n,)
        Direction sines along the ray frame's axes 0 and 1 (cell centres).
    dp, dq : float
        Grid spacings. In 2D mode ``dq`` is the in-plane spacing and ``dp = dq`` is a notional
        out-of-plane width (the tent along ``p`` is 1 for a receiver in the plane).
    counts : (int, int)
        Grid size ``(n_p, n_q)``; ray ``i`` is ``(i // n_q, i % n_q)``.
    planar : bool
        2D mode: one fan ``p = 0``.
    cover : float
        Half-width of the grid in beamwidths.
    """

    p: NDArray[np.float64]
    q: NDArray[np.float64]
    dp: float
    dq: float
    counts: tuple[int, int]
    planar: bool
    cover: float

    def __len__(self) -> int:
        return len(self.p)

    @property
    def z(self) -> NDArray[np.float64]:
        """Component along the boresight, ``sqrt(1 - p² - q²)``."""
        return np.sqrt(np.maximum(1.0 - self.p**2 - self.q**2, 0.0))

    @property
    def solid_angle(self) -> NDArray[np.float64]:
        """Ray-tube solid angle ``dp dq / z`` [sr] (2D mode: with the notional ``dp``)."""
        return self.dp * self.dq / self.z

    def directions(self, frame: ArrayLike | None = None) -> NDArray[np.float64]:
        """Unit launch directions, shape (n, 3): in the ray frame, or in the world frame when
        ``frame`` (ray-to-world rotation, columns = axes) is given."""
        local = np.stack([self.p, self.q, self.z], axis=-1)
        return local if frame is None else local @ np.asarray(frame, dtype=float).T


def ray_set(radar: Radar, rays: int, cover: float = 1.0, planar: bool = False,
            beamwidths: tuple[float, float] | None = None) -> RaySet:
    """The fixed launch grid of the multipath mechanism.

    Parameters
    ----------
    radar : Radar
    rays : int
        Number of rays (3D: about that many, on a grid with equal spacing in both direction
        sines and an even count along each axis; 2D: exactly that many in the fan).
    cover : float
        Half-width of the grid in beamwidths: ``|p| <= cover β_0``, ``|q| <= cover β_1``
        (1: to the first nulls of the sinc² pattern, i.e. the whole main lobe).
    planar : bool
        2D mode: one fan along axis 1 of the ray frame.
    beamwidths : (float, float), optional
        ``(β_0, β_1)`` along the ray frame's axes; default the radar's (azimuth, elevation).
        In 2D mode only ``β_1`` is used (the beamwidth along the fan).

    Returns
    -------
    RaySet
    """
    if isinstance(rays, bool) or not isinstance(rays, int | np.integer) or rays < 1:
        raise ParameterError("ray_set", "rays", "an integer >= 1", rays)
    if not (isinstance(cover, int | float) and math.isfinite(cover) and cover > 0):
        raise ParameterError("ray_set", "cover", "a number of beamwidths > 0", cover)
    b0, b1 = beamwidths if beamwidths is not None else (radar.azimuth_beamwidth,
                                                        radar.elevation_beamwidth)
    if planar and cover * b1 > 0.999:
        raise ParameterError("ray_set", "cover", f"<= {0.999 / b1:.3g} beamwidths (ray_cover: the "
                             "fan's direction sines must stay below 1, in front of the antenna)",
                             cover)
    half0, half1 = min(cover * b0, 0.999), min(cover * b1, 0.999)
    if planar:
        n0, n1 = 1, int(rays)
        dq = 2 * half1 / n1
        dp = dq
        p = np.zeros(n1)
        q = -half1 + (np.arange(n1) + 0.5) * dq
        return RaySet(p, q, float(dp), float(dq), (1, n1), True, float(cover))
    if half0**2 + half1**2 >= 1.0:
        raise ParameterError("ray_set", "cover", f"<= {1 / math.hypot(b0, b1):.3g} beamwidths "
                             "(the grid corners must stay in front of the antenna)", cover)
    spacing = math.sqrt(4.0 * half0 * half1 / rays)
    # Even counts: no ray on the boresight itself, so a corner aimed at exactly is seen between
    # rays (a ray through an edge or a vertex would split there, at the shadow boundary).
    n0 = max(2, 2 * round(half0 / spacing))
    n1 = max(2, 2 * round(half1 / spacing))
    dp, dq = 2 * half0 / n0, 2 * half1 / n1
    i0, i1 = np.meshgrid(np.arange(n0), np.arange(n1), indexing="ij")
    p = -half0 + (i0.ravel() + 0.5) * dp
    q = -half1 + (i1.ravel() + 0.5) * dq
    return RaySet(p, q, float(dp), float(dq), (int(n0), int(n1)), False, float(cover))


def ray_frame_2d(frames: ArrayLike, plane_normal: ArrayLike) -> NDArray[np.float64]:
    """Ray frames of the 2D mode: (plane normal, in-plane axis, boresight) per sweep.

    The plane passes through the antenna and contains the boresight ``l``; ``plane_normal`` is
    its normal (world frame; the paper's y-z analyses: ``[1, 0, 0]``). When the given normal is
    not perpendicular to the boresight, its component along ``l`` is removed (the plane through
    ``l`` closest to the given orientation).

    Parameters
    ----------
    frames : array_like, shape (..., 3, 3)
        Antenna-to-world rotations (columns: azimuth axis, elevation axis, boresight).
    plane_normal : array_like, shape (3,)

    Returns
    -------
    ndarray, shape (..., 3, 3)
        Columns ``n'``, ``t = l x n'``, ``l``. With ``plane_normal`` = the azimuth axis this is
        the antenna frame itself.
    """
    frames = np.asarray(frames, dtype=float)
    normal = np.asarray(plane_normal, dtype=float)
    if normal.shape != (3,) or not np.all(np.isfinite(normal)) or np.linalg.norm(normal) == 0:
        raise ParameterError("ray_frame_2d", "plane_normal", "a non-zero 3-vector", plane_normal)
    look = frames[..., :, 2]
    n = normal / np.linalg.norm(normal) - np.einsum("...i,i->...", look, normal
                                                    / np.linalg.norm(normal))[..., None] * look
    size = np.linalg.norm(n, axis=-1, keepdims=True)
    if np.any(size < 1e-6):
        raise ParameterError("ray_frame_2d", "plane_normal", "a direction not parallel to the "
                             "boresight", plane_normal)
    n = n / size
    t = np.cross(look, n)
    return np.stack([n, t, look], axis=-1)


# --------------------------------------------------------------------------------------------
# Reflections and images (ops-agnostic component forms + NumPy vector forms)
# --------------------------------------------------------------------------------------------

def reflect(direction: ArrayLike, normal: ArrayLike) -> NDArray[np.float64]:
    """Specular reflection ``d - 2 (d·n) n`` (paper eq. 5, unit vectors), shape (..., 3)."""
    d = np.asarray(direction, dtype=float)
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    return d - 2.0 * np.sum(d * n, axis=-1, keepdims=True) * n


def mirror_point(point: ArrayLike, plane_point: ArrayLike, normal: ArrayLike
                 ) -> NDArray[np.float64]:
    """Mirror image of ``point`` in the plane through ``plane_point`` with ``normal``."""
    x = np.asarray(point, dtype=float)
    n = np.asarray(normal, dtype=float)
    n = n / np.linalg.norm(n, axis=-1, keepdims=True)
    offset = np.sum((x - np.asarray(plane_point, dtype=float)) * n, axis=-1, keepdims=True)
    return x - 2.0 * offset * n


def image_frame(frame: ArrayLike, normals: Sequence[ArrayLike]) -> NDArray[np.float64]:
    """Ray frame reflected by a sequence of planes, ``M e_j`` (columns), shape (3, 3)."""
    out = np.asarray(frame, dtype=float).copy()
    for normal in normals:
        out = reflect(out.T, normal).T
    return out


def image_path(source: ArrayLike, receiver: ArrayLike,
               planes: Sequence[tuple[ArrayLike, ArrayLike]]) -> dict[str, Any]:
    """The specular path from ``source`` to ``receiver`` over a sequence of planes (image method).

    Parameters
    ----------
    source, receiver : array_like, shape (3,)
    planes : sequence of (point, normal)
        The reflecting planes in the order the wave meets them.

    Returns
    -------
    dict
        ``image`` (the image of the source in the planes, in order), ``length`` (``|rx - img|``,
        the unfolded path length), ``points`` (the reflection points, in order; found by
        unfolding backwards from the receiver), ``valid`` (every segment leaves and reaches its
        planes on the same side, i.e. the points are genuine reflections; the planes' extents
        are not checked).
    """
    images = [np.asarray(source, dtype=float)]
    for point, normal in planes:
        images.append(mirror_point(images[-1], point, normal))
    rx = np.asarray(receiver, dtype=float)
    length = float(np.linalg.norm(rx - images[-1]))
    points: list[NDArray] = []
    target = rx
    valid = True
    for j in range(len(planes) - 1, -1, -1):
        point, normal = (np.asarray(v, dtype=float) for v in planes[j])
        img = images[j + 1]
        direction = target - img
        denominator = float(direction @ normal)
        if abs(denominator) < 1e-15:
            valid = False
            break
        t = float((point - img) @ normal) / denominator
        if not 0.0 < t < 1.0:
            valid = False
        hit = img + t * direction
        points.append(hit)
        target = hit
    return {"image": images[-1], "length": length, "points": points[::-1], "valid": valid}


def launch_coordinates(receiver: ArrayLike, image: ArrayLike, frame: ArrayLike
                       ) -> NDArray[np.float64]:
    """Launch direction sines ``(p*, q*, z*)`` of the tube that reaches ``receiver``.

    Parameters
    ----------
    receiver, image : array_like, shape (..., 3)
        Receiver position and the transmitter's image for the ray's plane sequence.
    frame : array_like, shape (..., 3, 3)
        The reflected ray frame ``M e_j`` (columns; :func:`image_frame`).
    """
    w = np.asarray(receiver, dtype=float) - np.asarray(image, dtype=float)
    w = w / np.linalg.norm(w, axis=-1, keepdims=True)
    return np.einsum("...ji,...j->...i", np.asarray(frame, dtype=float), w)


def capture_weight(offset: Any, spacing: Any, kind: str = "tent", ops: Any = NUMPY_OPS) -> Any:
    """Weight of a ray whose launch coordinate is ``offset`` away from the receiver's.

    ``tent``: ``max(0, 1 - |offset| / spacing)``; ``box``: 1 for ``-spacing/2 <= offset <
    spacing/2``. Both are partitions of unity on a regular grid. Apply per axis and multiply.
    Generic over ``ops`` (:mod:`mitsar.model.ops`): the multipath kernel calls it on Dr.Jit arrays.
    """
    x = (np.asarray(offset, dtype=float) if ops is NUMPY_OPS else offset) / spacing
    if kind == "tent":
        return ops.maximum(0.0, 1.0 - abs(x))
    if kind == "box":
        return ops.where((x >= -0.5) & (x < 0.5), 1.0, 0.0)
    raise ParameterError("capture_weight", "kind", f"one of {list(CAPTURE_KINDS)}", kind)


# --------------------------------------------------------------------------------------------
# Powers and amplitudes
# --------------------------------------------------------------------------------------------

def multipath_amplitude_constant(radar: Radar) -> float:
    """``sqrt(P_T G_T G_R λ²) / (4π)``: the amplitude of an image path is this times
    ``ρ sqrt(P_tx P_rx) / L`` (``ρ`` the product of the field factors ``Γ R``)."""
    return math.sqrt(radar.transmit_power * radar.antenna_gain**2
                     * radar.wavelength**2) / (4.0 * math.pi)


def image_power(radar: Radar, length: ArrayLike, field_factor: ArrayLike = 1.0,
                pattern_tx: ArrayLike = 1.0, pattern_rx: ArrayLike = 1.0) -> NDArray:
    """Received power of an image path [W]: ``P_T G_T G_R λ² ρ² P_tx P_rx / (4π L)²``.

    Parameters
    ----------
    length : array_like
        Unfolded path length ``L = |rx - img|`` [m].
    field_factor : array_like
        Product of the field factors ``Γ R`` of the reflections (``ρ``).
    pattern_tx, pattern_rx : array_like
        One-way power patterns of the antennas toward the launch / from the arrival direction.
    """
    return (radar.transmit_power * radar.antenna_gain**2 * radar.wavelength**2
            * np.asarray(field_factor, dtype=float) ** 2 * np.asarray(pattern_tx)
            * np.asarray(pattern_rx) / (4.0 * math.pi * np.asarray(length, dtype=float)) ** 2)


def image_amplitude(radar: Radar, length: ArrayLike, field_factor: ArrayLike = 1.0,
                    pattern_tx: ArrayLike = 1.0, pattern_rx: ArrayLike = 1.0) -> NDArray:
    """``sqrt(image_power)`` [sqrt(W)]."""
    return np.sqrt(image_power(radar, length, field_factor, pattern_tx, pattern_rx))


def mirror_power(radar: Radar, distance: ArrayLike, field_factor: ArrayLike = 1.0) -> NDArray:
    """A monostatic antenna facing a plane mirror at ``distance`` D on boresight:
    ``P_T G² λ² |Γ R|² / ((4π)² (2D)²)`` [W]."""
    return image_power(radar, 2.0 * np.asarray(distance, dtype=float), field_factor)


def path_range_rate(direction: ArrayLike, image_velocity: ArrayLike,
                    receiver_velocity: ArrayLike) -> NDArray:
    """Rate of the unfolded path length ``dL/dt = ŵ·(v_rx - M v_tx)`` [m/s].

    ``ŵ`` is the unit vector from the image to the receiver and ``M v_tx`` the transmitter's
    velocity reflected like the ray frame (the image's velocity). The histogram deposit uses
    half of it with half the path length (:func:`mitsar.model.histogram.apparent_range`).
    """
    return np.sum(np.asarray(direction) * (np.asarray(receiver_velocity)
                                           - np.asarray(image_velocity)), axis=-1)


def tube_scatter_power(radar: Radar, field_factor: ArrayLike, pattern_tx: ArrayLike,
                       solid_angle: ArrayLike, sigma0: ArrayLike, cos_incidence: ArrayLike,
                       receive_range: ArrayLike, pattern_rx: ArrayLike = 1.0) -> NDArray:
    """Power a ray tube scatters back to the receiver from its hit (the optional ghosts) [W].

    The tube brings ``P_T G_T P_tx ρ² / (4π s²)`` per m² onto the area ``dΩ s² / cos θ_i`` (``s``
    cancels); that area scatters with ``σ⁰`` (bistatic, per unit area) toward the receiver at
    ``R_r``: ``P = P_T G_T P_tx ρ² dΩ σ⁰ / (4π cos θ_i) · G_R λ² P_rx / ((4π)² R_r²)``.
    """
    return (radar.transmit_power * radar.antenna_gain**2 * radar.wavelength**2
            * np.asarray(pattern_tx) * np.asarray(field_factor, dtype=float) ** 2
            * np.asarray(solid_angle) * np.asarray(sigma0) * np.asarray(pattern_rx)
            / (4.0 * math.pi * np.asarray(cos_incidence) * (4.0 * math.pi) ** 2
               * np.asarray(receive_range, dtype=float) ** 2))


def path_delay(length: ArrayLike) -> NDArray:
    """Delay of a path of (unfolded) length ``L``: ``L / c`` [s]."""
    return np.asarray(length, dtype=float) / SPEED_OF_LIGHT
