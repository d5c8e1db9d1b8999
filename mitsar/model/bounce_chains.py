"""Bounce chains of planar facets at finite range: which chains a scene has, and the
physical-optics echo of one chain through a small sub-facet of its last facet
(docs/physical_optics.md §3, §5).

A chain ``f_1 … f_n`` is a sequence of facets a wave reflects on in turn before it leaves the
last one toward the receiver (n = 1: a single facet; 2: a dihedral's orders; 3: a trihedral's).
At finite range the incident wave after the reflections is the spherical wave of the
transmitter's *image* ``I`` mirrored through the planes of ``f_1 … f_(n−1)`` (the image
method, docs/multipath.md); over a sub-facet ``j`` of ``f_n`` small enough to be in its own far
field (:func:`mitsar.model.physical_optics.subfacet_size`) it is a plane wave along
``d = (c_j − I)/|c_j − I|``. The lit part of the sub-facet is the unfolded aperture of the chain
for that plane wave (:func:`mitsar.model.physical_optics.bounce_aperture`, with the sub-facet
as the last link), and the echo is PO on it (docs/physical_optics.md §2–§4):

    S_j = (k/√π) Π_m Γ_m (|n·d| + |n·k_s|)/2 ∫_{A_j} exp(j k (d − k_s)·(r − c_j)) dA     [m],
    E_j = S_j exp(j k (R_t + R_r)) / (√(4π) R_t R_r)                                     [1/m],

``R_t = |c_j − I|`` (the unfolded transmit path), ``R_r = |rx − c_j|``, ``k_s`` toward the
receiver. n = 1 is :func:`mitsar.model.physical_optics.field_factor`'s term. For a large chain
near the radar the sum over sub-facets tends to the image method's ``Γ…/L``; in the far field it
is :func:`mitsar.model.physical_optics.chain_amplitude` (dihedral ``8πa²b²/λ²``, trihedral
``4πa⁴/(3λ²)``).
"""

from __future__ import annotations

import math
from collections.abc import Callable, Sequence
from typing import NamedTuple

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.geometry.antenna import direction_sines
from mitsar.model.physical_optics import bounce_aperture, facet_integral, facet_plane

__all__ = ["ChainEcho", "chain_echo", "facet_chains", "facets_in_beam", "mirror_points"]

_SIDE_TOLERANCE = 1e-9
"""Relative distance below which a vertex counts as in a plane (coplanar facets)."""


def mirror_points(points: ArrayLike, plane_point: ArrayLike, plane_normal: ArrayLike
                  ) -> NDArray[np.float64]:
    """Mirror images of points in planes, ``x − 2((x − q)·n) n`` (paper eq. 5) [m].

    Affine in ``(x, q)``, so the same call mirrors velocities: the image of a point moving at
    ``ẋ`` in a plane translating at ``q̇`` moves at ``mirror_points(ẋ, q̇, n)``.

    Parameters
    ----------
    points, plane_point : array_like, shape (..., 3)
        Points and a point of each plane [m] (or velocities [m/s]).
    plane_normal : array_like, shape (..., 3)
        Unit normals [-].
    """
    x = np.asarray(points, dtype=np.float64)
    n = np.asarray(plane_normal, dtype=np.float64)
    return x - 2.0 * np.sum((x - np.asarray(plane_point)) * n, axis=-1, keepdims=True) * n


class ChainEcho(NamedTuple):
    """Echo of one chain through one sub-facet per lane (:func:`chain_echo`)."""

    amplitude: NDArray[np.complex128]
    """``S_j`` [m], referenced to the sub-facet's centroid (0: not lit through the chain)."""
    transmit_range: NDArray[np.float64]
    """``R_t = |c_j − I|``, the unfolded path from the transmitter [m]."""
    receive_range: NDArray[np.float64]
    """``R_r = |rx − c_j|`` [m]."""
    entry: NDArray[np.float64]
    """First reflection point ``x_1`` of the path through :attr:`exit`, shape (B, 3) [m]."""
    exit: NDArray[np.float64]
    """Last reflection point: a point of the sub-facet's lit part (the vertex mean of the lit
    polygon, inside it as it is convex; the centroid ``c_j`` when nothing is lit), so that the
    path through it is a true path of the chain, for shadow rays and the antenna pattern,
    shape (B, 3) [m]."""
    image: NDArray[np.float64]
    """The transmitter's image ``I``, shape (B, 3) [m]."""


def chain_echo(facets: Sequence[ArrayLike], transmitter: ArrayLike, receiver: ArrayLike,
               wavelength: float,
               reflection: ArrayLike | Callable[[int, NDArray], NDArray] = 1.0) -> ChainEcho:
    """PO echo of a bounce chain through small sub-facets of its last facet (module docstring).

    Parameters
    ----------
    facets : sequence of array_like, each (M, 3) or (B, M, 3)
        The chain; the last link holds the sub-facets (triangles, one per lane), the others
        whole convex facets [m].
    transmitter, receiver : array_like, shape (B, 3) or (3,)
        Antenna positions [m].
    wavelength : float
        λ [m].
    reflection : array_like or callable
        Product of the field reflection coefficients ``Π Γ_m`` [-], or ``f(m, cos θ_m)``
        giving ``Γ`` of link ``m`` (0-based) at the incidence cosines ``|n_m·d_m|`` (B,).

    Returns
    -------
    ChainEcho
    """
    if len(facets) == 0:
        raise ParameterError("chain_echo", "facets", "at least one facet", 0)
    last = np.asarray(facets[-1], dtype=np.float64)
    tx = np.asarray(transmitter, dtype=np.float64)
    batch = np.broadcast_shapes(last.shape[:-2], tx.shape[:-1],
                                np.shape(receiver)[:-1]) or (1,)
    lanes = (batch[0], 3)
    tx = np.broadcast_to(tx, lanes)
    rx = np.broadcast_to(np.asarray(receiver, dtype=np.float64), lanes)
    planes = [facet_plane(f) for f in facets]
    points = [np.broadcast_to(q, lanes) for q, _ in planes]
    normals = [np.broadcast_to(n, lanes) for _, n in planes]
    images = [tx]
    for q, n in zip(points[:-1], normals[:-1], strict=True):   # the chain's links (a few)
        images.append(mirror_points(images[-1], q, n))
    centre = np.broadcast_to(last.mean(axis=-2), lanes)
    to_t = centre - images[-1]
    r_t = np.linalg.norm(to_t, axis=-1)
    d_last = to_t / r_t[:, None]
    d_first = d_last
    for n in normals[-2::-1]:                                   # unfold back to f_1
        d_first = d_first - 2.0 * np.einsum("bi,bi->b", d_first, n)[:, None] * n
    aperture, count, d, _ = bounce_aperture(facets, d_first)
    to_r = rx - centre
    r_r = np.linalg.norm(to_r, axis=-1)
    k_s = to_r / r_r[:, None]
    if callable(reflection):
        gamma = np.ones(lanes[0])
        incoming = d_first
        for m, n in enumerate(normals):                         # Γ of each link
            dn = np.einsum("bi,bi->b", incoming, n)
            gamma = gamma * reflection(m, np.abs(dn))
            incoming = incoming - 2.0 * dn[:, None] * n
    else:
        gamma = np.asarray(reflection, dtype=np.float64)
    nd = np.einsum("bi,bi->b", d, normals[-1])
    ns = np.einsum("bi,bi->b", k_s, normals[-1])
    lit = (nd * ns < 0) & (count > 0)
    k = 2.0 * math.pi / wavelength
    integral = facet_integral(aperture, d - k_s, k, centre)
    amplitude = np.where(lit, k / math.sqrt(math.pi) * gamma * 0.5 * (np.abs(nd) + np.abs(ns))
                         * integral, 0.0 + 0.0j)
    # a true path: through a lit point, back from the last link: x_m on plane m on the line
    # from the image I_m (through planes 1..m) to x_(m+1)
    real = np.arange(aperture.shape[1])[None, :] < count[:, None]
    lit_point = (np.where(real[..., None], aperture, 0.0).sum(axis=1)
                 / np.maximum(count, 1)[:, None])
    x = np.where((count > 0)[:, None], lit_point, centre)
    exit_point = x
    for m in range(len(facets) - 2, -1, -1):
        ray = x - images[m + 1]
        t = (np.einsum("bi,bi->b", points[m] - images[m + 1], normals[m])
             / _nonzero(np.einsum("bi,bi->b", ray, normals[m])))
        x = images[m + 1] + t[:, None] * ray
    return ChainEcho(amplitude, r_t, r_r, x, exit_point, images[-1])


def _nonzero(values: NDArray) -> NDArray:
    return np.where(values == 0, 1e-300, values)


def facets_in_beam(centres: ArrayLike, radii: ArrayLike, positions: ArrayLike, frames: ArrayLike,
                   beamwidth_az: float, beamwidth_el: float, cull: float) -> NDArray[np.bool_]:
    """Facets some part of which comes within ``cull`` beamwidths of the boresight at some
    antenna state (the beam cull of the surface scatterers, docs/integrator.md, widened by the
    facet's angular radius).

    Parameters
    ----------
    centres : array_like, shape (S, F, 3) or (F, 3)
        Facet centres at each state (or fixed) [m].
    radii : array_like, shape (F,)
        Largest vertex distance from the centre [m].
    positions : array_like, shape (S, 3)
        Antenna positions [m].
    frames : array_like, shape (S, 3, 3)
        Antenna-to-world rotations.
    beamwidth_az, beamwidth_el : float
        [rad]
    cull : float
        Beamwidths of direction sine kept on each side.

    Returns
    -------
    numpy.ndarray of bool, shape (F,)
    """
    centres = np.asarray(centres, dtype=np.float64)
    positions = np.asarray(positions, dtype=np.float64)
    offset = np.broadcast_to(centres, (len(positions),) + centres.shape[-2:]) \
        - positions[:, None, :]
    distance = np.linalg.norm(offset, axis=-1)
    spread = np.asarray(radii, dtype=np.float64)[None] / np.maximum(distance, 1e-300)
    u_az, u_el, cos_b = direction_sines(offset / np.maximum(distance, 1e-300)[..., None],
                                        np.asarray(frames)[:, None])
    seen = ((np.abs(u_az) <= cull * beamwidth_az + spread)
            & (np.abs(u_el) <= cull * beamwidth_el + spread) & (cos_b > -spread))
    return np.any(seen | (spread >= 1.0), axis=0)


def facet_chains(triangles: ArrayLike, positions: ArrayLike, max_length: int,
                 in_beam: ArrayLike | None = None) -> list[NDArray[np.int64]]:
    """Chains of facets a wave from the antenna can reflect along, by length.

    A link ``i → j`` needs (two-sided facets, docs/physical_optics.md §2): ``j`` partly on a
    side of ``i``'s plane where the antenna is at some position (the wave reflects back to the
    side it came from), and ``i`` partly on a side of ``j``'s plane where the antenna is at
    some position (the last facet scatters toward it); coplanar facets never link. The first
    and the last facet must be in the beam (``in_beam``). This prunes; the apertures of
    :func:`chain_echo` decide what is actually lit.

    Parameters
    ----------
    triangles : array_like, shape (F, M, 3)
        Facets [m].
    positions : array_like, shape (S, 3)
        Antenna positions of the acquisition (relative to the facets) [m].
    max_length : int
        Longest chain (number of reflections).
    in_beam : array_like of bool, shape (F,), optional
        Facets in the beam (default all).

    Returns
    -------
    list of numpy.ndarray of int
        Entry ``n − 1``: the chains of length ``n``, shape (C_n, n) (facet indices).
    """
    tri = np.asarray(triangles, dtype=np.float64)
    count = len(tri)
    beam = np.ones(count, bool) if in_beam is None else np.asarray(in_beam, bool)
    if int(max_length) <= 1:
        return [np.flatnonzero(beam)[:, None]]
    point, normal = facet_plane(tri)
    scale = 1.0 + np.abs(tri).max(initial=0.0)
    tol = _SIDE_TOLERANCE * scale
    # side[i, j, v]: vertex v of facet j against the plane of facet i
    side = np.einsum("jvk,ik->ijv", tri, normal) - np.einsum("ik,ik->i", point, normal)[:, None,
                                                                                         None]
    front, back = np.any(side > tol, axis=2), np.any(side < -tol, axis=2)
    antenna = np.asarray(positions, dtype=np.float64) @ normal.T \
        - np.einsum("ik,ik->i", point, normal)
    a_front, a_back = np.any(antenna > tol, axis=0), np.any(antenna < -tol, axis=0)
    reach = (front & a_front[:, None]) | (back & a_back[:, None])   # i reflects toward j
    link = reach & reach.T
    np.fill_diagonal(link, False)
    out = [np.flatnonzero(beam)[:, None]]
    chains = out[0]
    for _ in range(1, int(max_length)):                         # chain lengths (a few)
        row, nxt = np.nonzero(link[chains[:, -1]])
        chains = np.concatenate([chains[row], nxt[:, None]], axis=1)
        out.append(chains[beam[chains[:, -1]]])
    return out
