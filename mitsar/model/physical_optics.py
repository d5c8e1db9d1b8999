"""Physical optics (PO) of finite planar facets in closed form (Gordon 1975), single and multiple
bounce (docs/physical_optics.md).

Sign convention (docs/conventions.md, docs/design.md §4): mitsar's dechirped echo has the phase
``+2 pi f_c tau``, so a longer path adds ``+k L``. A facet point ``r`` lit by a plane wave
travelling along ``k_i`` and seen from the direction the scattered wave travels, ``k_s``, adds
the path ``(k_i - k_s)·r`` (far field), and the PO surface integral is

    I(w) = ∫_A exp(+j k w·(r − o)) dA,    w = k_i − k_s,                (docs/physical_optics.md §1)

referenced to a phase centre ``o``. Gordon's closed form (Gordon 1975, eq. 22 in our sign) turns
it into a sum over the edges of the polygon (the divergence theorem in the facet plane):

    I = −j / (k |w_t|²) Σ_m (w·(e_m × n)) exp(j k w·(c_m − o)) sinc(k w·e_m / 2),

``e_m`` the edge vector, ``c_m`` its midpoint, ``n`` the unit normal about which the vertices run
counter-clockwise, ``w_t`` the part of ``w`` in the plane and ``sinc x = sin x / x``. Near the
specular direction (``w_t → 0``) the sum cancels to ``A exp(...)``; there a power series of the
fan triangles' exponential moments is used instead (§1 of the docs page), so the integral is
smooth and accurate through the specular direction.

The scattering amplitude (``sqrt(σ)`` with its phase, in metres; Knott, Shaeffer & Tuley,
*Radar Cross Section*, 2nd ed., §6.2, scalar form) of a facet with field reflection coefficient
``Γ`` is

    S = (k / sqrt(π)) Γ (|n·k_i| + |n·k_s|)/2 I(k_i − k_s),                (§2)

zero unless the incident and scattered waves are on the same side of the facet. Monostatic
(``k_s = −k_i``) a flat plate gives ``σ = 4π A² cos²θ / λ² · (pattern)``, peak ``4πA²/λ²``.
"""

from __future__ import annotations

import math
from collections.abc import Sequence

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.polygons import (
    area_vector,
    clip_convex,
    clip_halfspace,
    project_to_plane,
    subdivide_triangles,
    triangulate,
)

__all__ = ["SERIES_TERMS", "SERIES_THRESHOLD", "bounce_aperture", "chain_amplitude",
           "facet_integral", "facet_plane", "field_factor", "monostatic_amplitude",
           "scattering_amplitude", "subdivide_facets", "subfacet_size"]

SERIES_THRESHOLD = 1.0
"""Below ``k |w_t| D = 1`` (``D`` the largest vertex distance from vertex 0) the integral uses
the power series: Gordon's edge sum loses ``~eps D²/(A x)`` to cancellation, the series with
:data:`SERIES_TERMS` terms truncates at ``(N+1) x^N/(N+2)! < 1e-15``."""

SERIES_TERMS = 18
"""Terms of the power series of the specular neighbourhood (see :data:`SERIES_THRESHOLD`)."""


def _unit(v: NDArray, where: str, name: str) -> NDArray[np.float64]:
    v = np.asarray(v, dtype=np.float64)
    if v.shape[-1:] != (3,) or not np.all(np.isfinite(v)):
        raise ParameterError(where, name, "finite 3-vectors, shape (..., 3)", f"shape {v.shape}")
    norm = np.linalg.norm(v, axis=-1, keepdims=True)
    if np.any(norm == 0):
        raise ParameterError(where, name, "non-zero direction vectors", "a zero vector")
    return v / norm


def facet_integral(vertices: ArrayLike, w: ArrayLike, wavenumber: float,
                   origin: ArrayLike | None = None) -> NDArray[np.complex128]:
    """``I = ∫_A exp(+j k w·(r − o)) dA`` over planar polygons (Gordon 1975) [m²].

    Parameters
    ----------
    vertices : array_like, shape (..., M, 3)
        Polygon vertices in order (convex or not, planar; padded slots repeat vertex 0) [m].
    w : array_like, shape (..., 3)
        Phase-gradient vector, ``k_i − k_s`` for PO [-]; broadcast against the polygons.
    wavenumber : float
        ``k = 2π/λ`` [rad/m].
    origin : array_like, shape (..., 3), optional
        Phase centre ``o`` [m]; default the coordinate origin.

    Returns
    -------
    numpy.ndarray of complex, shape broadcast of (...)
        The integral [m²]; ``A exp(j k w·(r_0 − o))`` when ``w`` is normal to the facet.
        Degenerate (zero-area) polygons give 0.
    """
    v = np.asarray(vertices, dtype=np.float64)
    w = np.asarray(w, dtype=np.float64)
    o = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    k = float(wavenumber)
    shape = np.broadcast_shapes(v.shape[:-2], w.shape[:-1], o.shape[:-1])
    batch = shape or (1,)                                    # one lane for a single facet
    v = np.broadcast_to(v, batch + v.shape[-2:])
    w = np.broadcast_to(w, batch + (3,))
    o = np.broadcast_to(o, batch + (3,))
    v0 = v[..., 0, :]
    rho = v - v0[..., None, :]                               # in-plane offsets from vertex 0
    avec = area_vector(v)
    area = np.linalg.norm(avec, axis=-1)
    safe = np.where(area > 0, area, 1.0)
    n = avec / safe[..., None]
    w_t = w - np.einsum("...i,...i->...", w, n)[..., None] * n
    wt2 = np.einsum("...i,...i->...", w_t, w_t)
    base = np.exp(1j * k * np.einsum("...i,...i->...", w, v0 - o))
    x = k * np.sqrt(wt2) * np.linalg.norm(rho, axis=-1).max(axis=-1)

    # Gordon's edge sum, relative to vertex 0.
    e = np.roll(rho, -1, axis=-2) - rho
    c = rho + 0.5 * e
    weight = np.einsum("...i,...mi->...m", w, np.cross(e, n[..., None, :]))
    phase = np.exp(1j * k * np.einsum("...i,...mi->...m", w, c))
    sinc = np.sinc(k * np.einsum("...i,...mi->...m", w, e) / (2 * np.pi))
    gordon = -1j * (weight * phase * sinc).sum(axis=-1) / (k * np.where(wt2 > 0, wt2, 1.0))

    # Series near the specular direction, only where it is used: fan triangles (0, m, m+1),
    # ∫_T exp(z·rho) dA = 2 A_T Σ_n h_n(b, c) / (n + 2)!, h_n the complete homogeneous polynomial.
    near = x < SERIES_THRESHOLD
    result = gordon.copy()
    if np.any(near):
        b = 1j * k * np.einsum("...i,...mi->...m", w[near], rho[near])
        bm, cm = b[..., :-1], b[..., 1:]
        rn = rho[near]
        tri_area = 0.5 * np.einsum("...mi,...i->...m", np.cross(rn[..., :-1, :], rn[..., 1:, :]),
                                   n[near])
        h = np.ones_like(bm)
        bpow = np.ones_like(bm)
        total = h / 2.0
        for order in range(1, SERIES_TERMS):       # polynomial order, not a loop over data
            bpow = bpow * bm
            h = bpow + cm * h
            total = total + h / math.factorial(order + 2)
        result[near] = (2.0 * tri_area * total).sum(axis=-1)
    return np.where(area > 0, base * result, 0.0 + 0.0j).reshape(shape)


def scattering_amplitude(vertices: ArrayLike, incident: ArrayLike, scattered: ArrayLike,
                         wavelength: float, reflection: ArrayLike = 1.0,
                         origin: ArrayLike | None = None,
                         two_sided: bool = True) -> NDArray[np.complex128]:
    """Bistatic PO scattering amplitude ``S`` of flat facets (``|S|² = σ``) [m].

    ``S = (k/√π) Γ (|n·k_i| + |n·k_s|)/2 · ∫_A exp(j k (k_i − k_s)·(r − o)) dA``
    (docs/physical_optics.md §2; Gordon 1975; Knott et al., *Radar Cross Section*, §6.2), zero
    unless ``k_i`` arrives on the side ``k_s`` leaves from (a reflection, not a transmission).
    Reciprocal: swapping ``(k_i, k_s) → (−k_s, −k_i)`` leaves ``S`` unchanged.

    Parameters
    ----------
    vertices : array_like, shape (..., M, 3)
        Facet polygons [m].
    incident : array_like, shape (..., 3)
        Propagation direction of the incident wave ``k_i`` (transmitter → facet) [-].
    scattered : array_like, shape (..., 3)
        Propagation direction of the scattered wave ``k_s`` (facet → receiver) [-].
    wavelength : float
        λ [m].
    reflection : array_like
        Field reflection coefficient Γ of each facet [-] (1 for a perfect mirror in mitsar's
        convention of real positive field factors, docs/multipath.md).
    origin : array_like, shape (..., 3), optional
        Phase centre [m]; default the coordinate origin.
    two_sided : bool
        A facet reflects on both sides (mitsar's materials are two-sided, docs/integrator.md);
        ``False``: only from the side its counter-clockwise normal points to.
    """
    k_i = _unit(incident, "scattering_amplitude", "incident")
    k_s = _unit(scattered, "scattering_amplitude", "scattered")
    if not (wavelength > 0 and math.isfinite(wavelength)):
        raise ParameterError("scattering_amplitude", "wavelength", "a finite wavelength > 0 m",
                             wavelength)
    k = 2.0 * math.pi / wavelength
    v = np.asarray(vertices, dtype=np.float64)
    avec = area_vector(v)
    n = avec / np.maximum(np.linalg.norm(avec, axis=-1, keepdims=True), 1e-300)
    ni = np.einsum("...i,...i->...", n, k_i)
    ns = np.einsum("...i,...i->...", n, k_s)
    lit = ni * ns < 0
    if not two_sided:
        lit = lit & (ni < 0)
    obliquity = 0.5 * (np.abs(ni) + np.abs(ns))
    integral = facet_integral(v, k_i - k_s, k, origin)
    return np.where(lit, k / math.sqrt(math.pi) * np.asarray(reflection) * obliquity * integral,
                    0.0 + 0.0j)


def monostatic_amplitude(vertices: ArrayLike, direction: ArrayLike, wavelength: float,
                         reflection: ArrayLike = 1.0, origin: ArrayLike | None = None,
                         two_sided: bool = True) -> NDArray[np.complex128]:
    """Monostatic PO amplitude, :func:`scattering_amplitude` with ``k_s = −k_i`` [m].

    ``direction`` is the propagation direction antenna → facet.
    """
    d = np.asarray(direction, dtype=np.float64)
    return scattering_amplitude(vertices, d, -d, wavelength, reflection, origin, two_sided)


# --------------------------------------------------------------------------------------------
# Finite range: sub-facets that are each in their own far field
# --------------------------------------------------------------------------------------------

def subfacet_size(distance: ArrayLike, wavelength: float) -> NDArray[np.float64]:
    """Largest sub-facet edge for which PO in each sub-facet's own far field is accurate [m].

    Rule (docs/physical_optics.md §4): a sub-facet of size ``D`` at range ``R`` from a
    co-located antenna has a two-way quadratic phase error ``k D²/(4R)`` at its rim. The usual
    one-way far-field rule ``R > 2D²/λ`` (π/8) carried over to two ways (``R ≥ 4D²/λ``) left
    0.7 dB errors on a 0.3 m plate at 2 m (the outer Fresnel zones, whose contributions
    cancel, amplify each sub-facet's error), so we ask four times finer, π/32:
    ``R ≥ 16 D²/λ``, ``D ≤ sqrt(λ R / 16)`` (0.01 dB against direct quadrature there).

    Parameters
    ----------
    distance : array_like
        Smallest range from the antenna to the facet [m].
    wavelength : float
        λ [m].
    """
    return np.sqrt(wavelength * np.asarray(distance, dtype=np.float64) / 16.0)


def subdivide_facets(vertices: ArrayLike, count: ArrayLike, max_size: ArrayLike
                     ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Convex facets as triangles no longer than ``max_size`` (fan, then a barycentric grid).

    Parameters
    ----------
    vertices : array_like, shape (F, M, 3)
        Convex polygons (padded convention of :mod:`mitsar.model.polygons`) [m].
    count : array_like of int, shape (F,)
        Vertex counts.
    max_size : array_like, shape (F,) or scalar
        Largest sub-triangle edge for each facet [m].

    Returns
    -------
    triangles : numpy.ndarray, shape (T, 3, 3)
        Sub-triangles, oriented as their facet [m].
    parent : numpy.ndarray of int, shape (T,)
        Facet index of each.
    """
    tri, parent = triangulate(np.asarray(vertices, dtype=np.float64), np.asarray(count))
    longest = np.linalg.norm(tri - np.roll(tri, -1, axis=1), axis=-1).max(axis=-1)
    limit = np.broadcast_to(np.asarray(max_size, dtype=np.float64), (len(count),))[parent]
    pieces = np.maximum(np.ceil(longest / limit - 1e-9), 1).astype(np.int64)
    out_tri, out_parent = [np.zeros((0, 3, 3))], [np.zeros(0, dtype=np.int64)]
    for p in np.unique(pieces):              # one group per division count (a few)
        sel = pieces == p
        out_tri.append(subdivide_triangles(tri[sel], int(p)))
        out_parent.append(np.repeat(parent[sel], int(p) ** 2))
    return np.concatenate(out_tri), np.concatenate(out_parent)


def field_factor(triangles: ArrayLike, transmitter: ArrayLike, receiver: ArrayLike,
                 wavelength: float, reflection: ArrayLike = 1.0,
                 two_sided: bool = True) -> NDArray[np.complex128]:
    """Received field of small facets at finite range, relative to the radar equation's
    ``sqrt(P_T G_T G_R λ² / (4π)²)`` [1/m] (docs/physical_optics.md §4).

    ``E = Σ_j S_j exp(j k (R_tj + R_rj)) / (sqrt(4π) R_tj R_rj)``, each sub-facet ``j`` in
    its own far field (directions and ranges to its centroid, :func:`subdivide_facets`). A
    point scatterer of RCS σ gives ``|E| = sqrt(σ/(4π)) / (R_t R_r)``; a mirror, the image
    method's ``Γ / L`` (L the image distance, docs/multipath.md).

    Parameters
    ----------
    triangles : array_like, shape (T, 3, 3) or (T, M, 3)
        Sub-facets [m].
    transmitter, receiver : array_like, shape (..., 3)
        Antenna positions (broadcast against the leading axes of the result) [m].
    wavelength : float
        λ [m].
    reflection : array_like, shape (T,) or scalar
        Field reflection coefficients [-].
    two_sided : bool
        As :func:`scattering_amplitude`.

    Returns
    -------
    numpy.ndarray of complex, shape (..., T)
        Each sub-facet's term (sum over the last axis for the facet set) [1/m].
    """
    tri = np.asarray(triangles, dtype=np.float64)
    centre = tri.mean(axis=-2)
    tx = np.asarray(transmitter, dtype=np.float64)[..., None, :]
    rx = np.asarray(receiver, dtype=np.float64)[..., None, :]
    to_t = centre - tx
    to_r = rx - centre
    r_t = np.linalg.norm(to_t, axis=-1)
    r_r = np.linalg.norm(to_r, axis=-1)
    s = scattering_amplitude(tri, to_t, to_r, wavelength, reflection, centre, two_sided)
    k = 2.0 * math.pi / wavelength
    return s * np.exp(1j * k * (r_t + r_r)) / (math.sqrt(4.0 * math.pi) * r_t * r_r)


# --------------------------------------------------------------------------------------------
# Multiple bounces: the unfolded aperture
# --------------------------------------------------------------------------------------------

def _reflect(d: NDArray, n: NDArray) -> NDArray:
    """Mirror directions ``d`` (B, 3) in planes of unit normals ``n`` ((3,) or (B, 3))."""
    return d - 2.0 * np.einsum("bi,bi->b", d, np.broadcast_to(n, d.shape))[:, None] * n


def facet_plane(polygons: ArrayLike) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """A point (vertex 0) and the unit counter-clockwise normal of planar polygons.

    Parameters
    ----------
    polygons : array_like, shape (..., M, 3)
        Polygons [m] (padded convention of :mod:`mitsar.model.polygons`).

    Returns
    -------
    point : numpy.ndarray, shape (..., 3)
        [m]
    normal : numpy.ndarray, shape (..., 3)
        [-]
    """
    v = np.asarray(polygons, dtype=np.float64)
    n = area_vector(v)
    return v[..., 0, :], n / np.maximum(np.linalg.norm(n, axis=-1, keepdims=True), 1e-300)


def bounce_aperture(facets: Sequence[ArrayLike], incident: ArrayLike
                    ) -> tuple[NDArray[np.float64], NDArray[np.int64], NDArray[np.float64],
                               NDArray[np.float64]]:
    """The part of the last facet of a bounce chain lit through it (docs/physical_optics.md §3).

    Starting from the whole first facet, each step keeps the lit region's part in front of the
    next facet's plane (along the reflected direction), projects it along that direction onto
    the plane and clips it by the next facet (convex). The incident plane wave after the
    reflections is ``exp(j k (d·r + c))``; ``d`` and ``c`` follow the mirror images
    (``d_m = d − 2(d·n_m)n_m``, ``c_m = c + 2(p_m·n_m)(d·n_m)``, ``p_m`` on plane m).

    Parameters
    ----------
    facets : sequence of array_like, each of shape (M_i, 3) or (B, M_i, 3)
        The chain ``f_1 … f_n``, convex planar polygons [m]: one chain for all directions, or
        one facet per direction at any link (e.g. the sub-facets of the last facet).
    incident : array_like, shape (B, 3)
        Propagation directions of the incident plane waves [-].

    Returns
    -------
    aperture : numpy.ndarray, shape (B, K, 3)
        Lit part of ``f_n`` per direction (padded polygons, :mod:`mitsar.model.polygons`) [m].
    count : numpy.ndarray of int, shape (B,)
        Its vertex counts (0: nothing lit).
    direction : numpy.ndarray, shape (B, 3)
        Propagation direction of the wave arriving at ``f_n`` [-].
    offset : numpy.ndarray, shape (B,)
        Phase constant ``c`` of that wave (path of the incident wave = ``d·r + c``) [m].
    """
    d = _unit(np.atleast_2d(incident), "bounce_aperture", "incident")
    if len(facets) == 0:
        raise ParameterError("bounce_aperture", "facets", "at least one facet", 0)
    batch = d.shape[0]
    chain = [np.asarray(f, dtype=np.float64) for f in facets]
    chain = [np.broadcast_to(f, (batch,) + f.shape[-2:]) for f in chain]
    points = chain[0].copy()
    count = np.full(batch, chain[0].shape[1], dtype=np.int64)
    offset = np.zeros(batch)
    anchor_prev, n_prev = facet_plane(chain[0])
    for face in chain[1:]:                      # the chain's bounces (a few)
        offset = offset + 2.0 * np.einsum("bi,bi->b", anchor_prev, n_prev) \
            * np.einsum("bi,bi->b", d, n_prev)
        d = _reflect(d, n_prev)
        anchor, normal = facet_plane(face)
        dn = np.einsum("bi,bi->b", d, normal)
        dn_safe = np.where(dn == 0, 1.0, dn)
        # keep what lies before the next plane along d: (q - p)·n has the sign of -(d·n)
        values = -np.einsum("bmi,bi->bm", points - anchor[:, None, :], normal) \
            * np.sign(dn_safe)[:, None]
        points, count = clip_halfspace(points, count, values)
        count = np.where(dn == 0, 0, count)
        points, _ = project_to_plane(points, np.where(dn[:, None] == 0, normal, d), anchor,
                                     normal)
        points, count = clip_convex(points, count, face)
        anchor_prev, n_prev = anchor, normal
    return points, count, d, offset


def chain_amplitude(facets: Sequence[ArrayLike], incident: ArrayLike, scattered: ArrayLike,
                    wavelength: float, reflection: ArrayLike = 1.0,
                    origin: ArrayLike | None = None) -> NDArray[np.complex128]:
    """PO amplitude of a bounce chain by the unfolded aperture (docs/physical_optics.md §3) [m].

    ``S = (k/√π) Π Γ_m (|n_n·d| + |n_n·k_s|)/2 ∫_{A_eff} exp(j k ((d − k_s)·r + c)) dA``, the
    effective aperture ``A_eff`` and ``(d, c)`` from :func:`bounce_aperture`, referenced to the
    phase centre ``o`` by ``exp(−j k (k_i − k_s)·o)``. One facet is :func:`scattering_amplitude`
    (two-sided). The sum over all chains of a corner gives its RCS (90° dihedral ``8πa²b²/λ²``,
    triangular trihedral ``4πa⁴/(3λ²)`` on its axis).

    Parameters
    ----------
    facets : sequence of array_like
        The chain, convex polygons [m].
    incident, scattered : array_like, shape (B, 3)
        Propagation directions ``k_i`` and ``k_s`` [-].
    wavelength : float
        λ [m].
    reflection : array_like
        Product of the chain's field reflection coefficients (or one per direction) [-].
    origin : array_like, shape (3,), optional
        Phase centre [m]; default the coordinate origin.
    """
    k_i = _unit(np.atleast_2d(incident), "chain_amplitude", "incident")
    k_s = _unit(np.atleast_2d(scattered), "chain_amplitude", "scattered")
    k_i, k_s = np.broadcast_arrays(k_i, k_s)
    o = np.zeros(3) if origin is None else np.asarray(origin, dtype=np.float64)
    shifted = [np.asarray(f, dtype=np.float64) - o for f in facets]
    aperture, count, d, offset = bounce_aperture(shifted, k_i)
    k = 2.0 * math.pi / wavelength
    n = np.broadcast_to(facet_plane(shifted[-1])[1], d.shape)
    nd, ns = np.einsum("bi,bi->b", d, n), np.einsum("bi,bi->b", k_s, n)
    lit = (nd * ns < 0) & (count > 0)
    integral = facet_integral(aperture, d - k_s, k) * np.exp(1j * k * offset)
    obliquity = 0.5 * (np.abs(nd) + np.abs(ns))
    return np.where(lit, k / math.sqrt(math.pi) * np.asarray(reflection) * obliquity * integral,
                    0.0 + 0.0j)
