"""One lobe of the double-lobe pattern: shape, hemisphere integral, tables, sampling (paper eq. 11).

A lobe about an axis ``d`` is ``((1 + cos ψ)/2)^α`` (Degli-Esposti et al. 2007). Its integral over
the upper hemisphere, ``F_α(θ_i)``, normalises the pattern; it is the same for the backscatter and
the specular lobe (mirror symmetry) and is computed in closed form for integer α and from an
accurate table in θ_i otherwise (derivation: ``docs/materials.md``).

Every formula below that a Dr.Jit kernel needs is written once, generic over an ``ops`` namespace
(:data:`mitsar.model.ops.NUMPY_OPS`, ``mitsar.plugins.ops.DRJIT_OPS``), so that the NumPy
reference and the Mitsuba plugin evaluate the same expressions.
"""

from __future__ import annotations

import functools
import math
from typing import Any

import numpy as np

from mitsar.errors import ParameterError
from mitsar.model.ops import NUMPY_OPS, ArrayOps

__all__ = [
    "ALPHA_MAX",
    "ArrayOps",
    "CLOSED_FORM_ALPHA_MAX",
    "NUMPY_OPS",
    "TABLE_SIZE",
    "closed_form_coefficients",
    "interp_theta_table",
    "is_closed_form",
    "lobe_integral",
    "lobe_integral_closed_form",
    "lobe_integral_quadrature",
    "lobe_integral_table",
    "lobe_sample_cos_psi",
    "lobe_sampling_pdf",
    "lobe_shape",
    "theta_table_cosines",
]

ALPHA_MAX = 200.0
"""Largest accepted lobe exponent α (beyond it the lobe is narrower than ~6°)."""

CLOSED_FORM_ALPHA_MAX = 64
"""Integer exponents up to this use the closed-form normalisation; larger ones the table."""

TABLE_SIZE = 1025
"""Nodes of the normalisation tables, uniform in θ_i over [0, 90°] (step 0.088°)."""

_HALF_PI = 0.5 * math.pi
_FOUR_PI = 4.0 * math.pi


def _clip01(x: Any, ops: Any) -> Any:
    return ops.minimum(ops.maximum(x, 0.0), 1.0)


# --------------------------------------------------------------------------------------------
# One lobe: shape, hemisphere integral (closed form, quadrature, table), sampling
# --------------------------------------------------------------------------------------------


def lobe_shape(cos_psi: Any, alpha: Any, ops: Any = NUMPY_OPS) -> Any:
    """One lobe of the pattern, ``((1 + cos ψ)/2)^α`` (paper eq. 11).

    Parameters
    ----------
    cos_psi : array_like
        Cosine of the angle between the scattered direction and the lobe axis [-].
    alpha : float or array_like
        Lobe exponent α > 0 (non-integer allowed).
    ops : namespace
        Array operations (:data:`NUMPY_OPS` or the plugin's ``DRJIT_OPS``).

    Returns
    -------
    array_like
        Lobe value in [0, 1] [-].
    """
    base = _clip01(0.5 * (1.0 + cos_psi), ops)
    return base**alpha


@functools.lru_cache(maxsize=256)
def closed_form_coefficients(alpha: int) -> tuple[float, tuple[float, ...]]:
    """Coefficients of the closed-form lobe integral ``F_α(θ_i) = A + cos θ_i · Q(sin² θ_i)``.

    Binomial expansion of ``((1 + d·ω)/2)^α`` and term-wise integration over the upper hemisphere
    (derivation in ``docs/materials.md``)::

        F_α = 2^-α Σ_k C(α,k) I_k,   I_k = ∫_H (d·ω)^k dΩ,
        I_k = 2π/(k+1)                                            (k even)
        I_k = 2π/(k+1) cos θ_i Σ_{w=0}^{(k-1)/2} C(2w,w) (sin² θ_i / 4)^w   (k odd)

    Parameters
    ----------
    alpha : int
        Integer lobe exponent, 1 <= α <= :data:`CLOSED_FORM_ALPHA_MAX`.

    Returns
    -------
    A : float
        The θ_i-independent part (even k) [sr].
    q : tuple of float
        Coefficients ``q_w`` of ``Q(x) = Σ_w q_w x^w``, all positive [sr].
    """
    alpha = int(alpha)
    if not 1 <= alpha <= CLOSED_FORM_ALPHA_MAX:
        raise ParameterError("closed_form_coefficients", "alpha",
                             f"an integer in [1, {CLOSED_FORM_ALPHA_MAX}]", alpha)
    scale = 2.0**-alpha
    even = scale * sum(math.comb(alpha, k) * 2.0 * math.pi / (k + 1)
                       for k in range(0, alpha + 1, 2))
    n_w = (alpha + 1) // 2
    q = []
    for w in range(n_w):
        tail = sum(math.comb(alpha, k) * 2.0 * math.pi / (k + 1)
                   for k in range(2 * w + 1, alpha + 1, 2))
        q.append(scale * math.comb(2 * w, w) / 4.0**w * tail)
    return even, tuple(q)


def is_closed_form(alpha: float) -> bool:
    """Whether a lobe of exponent ``alpha`` has the closed-form integral (an integer from 1 to
    :data:`CLOSED_FORM_ALPHA_MAX`); otherwise :func:`lobe_integral_table` interpolates it."""
    return float(alpha).is_integer() and 1 <= alpha <= CLOSED_FORM_ALPHA_MAX


def lobe_integral_closed_form(alpha: int, cos_theta_i: Any, ops: Any = NUMPY_OPS) -> Any:
    """Hemisphere integral of one lobe for integer α, ``F_α(θ_i) = ∫_H ((1+d·ω)/2)^α dΩ``.

    ``d`` is the lobe axis (backscatter or specular direction) at incidence angle θ_i; both axes
    give the same integral. Horner evaluation of the positive polynomial of
    :func:`closed_form_coefficients` (Degli-Esposti 2007 normalisation; docs/materials.md).

    Parameters
    ----------
    alpha : int
        Integer exponent, 1 <= α <= :data:`CLOSED_FORM_ALPHA_MAX`.
    cos_theta_i : array_like
        Cosine of the incidence angle, clipped to [0, 1] [-].
    ops : namespace
        Array operations.

    Returns
    -------
    array_like
        ``F_α(θ_i)`` [sr].
    """
    even, q = closed_form_coefficients(int(alpha))
    c = _clip01(cos_theta_i, ops)
    x = 1.0 - c * c
    poly = q[-1] + 0.0 * x
    for coef in reversed(q[:-1]):
        poly = poly * x + coef
    return even + c * poly


def lobe_integral_quadrature(alpha: float, theta_i: Any, n_nodes: int = 256) -> np.ndarray:
    """Hemisphere integral of one lobe by an accurate 1-D quadrature, any α > 0.

    With ``s = sin θ_i``, ``c = cos θ_i`` the integral reduces to (docs/materials.md)::

        F_α = 4π/(α+1) [1 - ((1+s)/2)^(α+1)]
              + ∫_{-π/2}^{π/2} ((1 + s sin t)/2)^α · 2 (π/2 + atan(c tan t)) · s cos t dt,

    whose integrand is smooth; Gauss-Legendre with 256 nodes is exact to ~1e-13 (checked against
    the closed form for integer α up to grazing incidence).

    Parameters
    ----------
    alpha : float
        Lobe exponent α > 0.
    theta_i : array_like
        Incidence angles in [0, π/2] [rad].
    n_nodes : int
        Gauss-Legendre nodes.

    Returns
    -------
    numpy.ndarray
        ``F_α(θ_i)`` [sr], same shape as ``theta_i``.
    """
    theta = np.asarray(theta_i, dtype=np.float64)
    s = np.sin(theta)[..., None]
    c = np.cos(theta)[..., None]
    nodes, weights = np.polynomial.legendre.leggauss(n_nodes)
    t = nodes * _HALF_PI
    w = weights * _HALF_PI
    cap = 4.0 * math.pi / (alpha + 1.0) * (1.0 - ((1.0 + s[..., 0]) / 2.0) ** (alpha + 1.0))
    with np.errstate(over="ignore"):
        band = (((1.0 + s * np.sin(t)) / 2.0) ** alpha
                * 2.0 * (_HALF_PI + np.arctan(c * np.tan(t))) * s * np.cos(t))
    return cap + np.sum(w * band, axis=-1)


@functools.lru_cache(maxsize=256)
def _table_cached(alpha: float, n: int) -> np.ndarray:
    theta = np.linspace(0.0, _HALF_PI, n)
    table = lobe_integral_quadrature(alpha, theta)
    table.setflags(write=False)
    return table


def lobe_integral_table(alpha: float, n: int = TABLE_SIZE) -> np.ndarray:
    """Table of ``F_α(θ_i)`` on ``n`` nodes uniform in θ_i ∈ [0, π/2], by quadrature (cached).

    Parameters
    ----------
    alpha : float
        Lobe exponent α > 0.
    n : int
        Number of nodes (>= 2).

    Returns
    -------
    numpy.ndarray
        Read-only array of shape ``(n,)`` [sr].
    """
    return _table_cached(float(alpha), int(n))


def theta_table_cosines(n: int = TABLE_SIZE) -> np.ndarray:
    """Incidence cosines of the nodes of a table uniform in θ_i ∈ [0, π/2] (last node exactly 0).

    Every θ-table that :func:`interp_theta_table` reads is built on these nodes.
    """
    cos_theta = np.cos(np.linspace(0.0, _HALF_PI, int(n)))
    cos_theta[-1] = 0.0
    return cos_theta


def interp_theta_table(values: Any, n: int, cos_theta_i: Any, ops: Any = NUMPY_OPS,
                       offset: Any = 0) -> Any:
    """Linear interpolation in a table uniform in θ_i ∈ [0, π/2].

    Parameters
    ----------
    values : array_like
        Table values (NumPy array, or ``mi.Float`` for Dr.Jit); several tables of ``n`` nodes may
        be stacked, selected by ``offset``.
    n : int
        Nodes per table.
    cos_theta_i : array_like
        Cosine of the incidence angle, clipped to [0, 1] [-].
    ops : namespace
        Array operations.
    offset : int or array_like
        Index of the first node of the table to use (``table_index * n``).

    Returns
    -------
    array_like
        Interpolated value.
    """
    theta = ops.arccos(_clip01(cos_theta_i, ops))
    pos = theta * ((n - 1) / _HALF_PI)
    index = ops.minimum(ops.floor(pos), float(n - 2))
    frac = pos - index
    v0 = ops.gather(values, index + offset)
    v1 = ops.gather(values, index + (offset + 1))
    return v0 + frac * (v1 - v0)


def lobe_integral(alpha: float, cos_theta_i: Any, ops: Any = NUMPY_OPS,
                  table: Any = None, table_size: int = TABLE_SIZE) -> Any:
    """``F_α(θ_i)``: closed form for integer α <= 64, else interpolated table.

    Parameters
    ----------
    alpha : float
        Lobe exponent α > 0.
    cos_theta_i : array_like
        Cosine of the incidence angle [-].
    ops : namespace
        Array operations.
    table : array_like, optional
        The :func:`lobe_integral_table` of α in the representation ``ops`` gathers from (needed
        for Dr.Jit; NumPy builds it on demand).
    table_size : int
        Number of nodes of ``table``.

    Returns
    -------
    array_like
        ``F_α(θ_i)`` [sr].
    """
    if is_closed_form(alpha):
        return lobe_integral_closed_form(int(alpha), cos_theta_i, ops)
    if table is None:
        table = lobe_integral_table(alpha, table_size)
    return interp_theta_table(table, table_size, cos_theta_i, ops)


def lobe_sampling_pdf(cos_psi: Any, alpha: Any, ops: Any = NUMPY_OPS) -> Any:
    """Density of the lobe sampler over the full sphere, ``(α+1)/(4π) ((1+cos ψ)/2)^α`` [1/sr].

    Parameters
    ----------
    cos_psi : array_like
        Cosine of the angle to the lobe axis [-].
    alpha : float or array_like
        Lobe exponent α > 0.
    ops : namespace
        Array operations.
    """
    return (alpha + 1.0) * (1.0 / _FOUR_PI) * lobe_shape(cos_psi, alpha, ops)


def lobe_sample_cos_psi(xi: Any, alpha: Any, ops: Any = NUMPY_OPS) -> Any:
    """Invert the lobe's CDF: ``cos ψ = 2 ξ^(1/(α+1)) - 1`` for ξ uniform in [0, 1).

    With ``u = (1 + cos ψ)/2`` the solid angle is ``dΩ = 2 du dφ`` and the density ∝ u^α, so
    ``u = ξ^(1/(α+1))``; the azimuth about the axis is uniform.

    Parameters
    ----------
    xi : array_like
        Uniform random numbers in [0, 1).
    alpha : float or array_like
        Lobe exponent α > 0.
    ops : namespace
        Array operations.
    """
    u = ops.maximum(xi, 0.0) ** (1.0 / (alpha + 1.0))
    return ops.minimum(2.0 * u - 1.0, 1.0)
