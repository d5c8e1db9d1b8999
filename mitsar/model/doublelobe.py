"""Double-lobe radar material: the physics, in small pure functions (paper eqs. 8-11).

The model is the double-lobe ("ER") scattering model of Degli-Esposti et al. 2007 as adapted by the
paper (eqs. 8-11) and DESIGN §5.3. At a hit the incident power splits into

- ``P_L/P_i``            lost (absorbed or transmitted), ``transmission_loss_db``;
- ``Γ² R²``              reflected specularly, ``R = 10^(reflection_reduction_db/20)``;
- ``Γ² S² share_B``      scattered into the lobe around the backscatter direction ``-k_i``;
- ``Γ² S² share_F``      scattered into the lobe around the specular direction;

with ``Γ² = 1 - P_L/P_i`` (paper eq. 8) and ``S = sqrt(1 - R²)`` (paper eq. 10). The scattering
pattern (paper eq. 11, normalised) is::

    f(k_i, k_s) = w_B ((1 + cos ψ_B)/2)^α_B + w_F ((1 + cos ψ_F)/2)^α_F      [1/sr]

with ∫_hemisphere f dΩ = 1. With the default ``"joint"`` normalisation (Degli-Esposti 2007,
DESIGN §5.3) ``w_B = Λ/N``, ``w_F = (1-Λ)/N``, ``N(θ_i) = Λ F_αB(θ_i) + (1-Λ) F_αF(θ_i)``, so Λ
sets the relative *amplitude* of the lobes and the back lobe carries ``share_B = Λ F_αB / N`` of the
scattered power; with ``"separate"`` normalisation ``w_B = Λ/F_αB`` and ``w_F = (1-Λ)/F_αF``, so
the back lobe carries exactly Λ of it (the wording of paper §3.2). ``F_α(θ_i)`` is the hemisphere
integral of one lobe; it is the same for both lobes (mirror symmetry) and is computed in closed
form for integer α and from an accurate table in θ_i otherwise (derivation: ``docs/materials.md``).

The bistatic scattering coefficient per unit area is ``σ⁰ = 4π Γ² S² cos θ_i f`` (DESIGN §5.3);
monostatic ``k_s = -k_i``. A material may instead carry a given ``sigma0_db`` for the direct
(monostatic) backscatter, as the paper does (σ⁰ = -20 dB, §4.2).

Conventions: ``k_i`` is the propagation direction of the incident wave (pointing *into* the
surface), ``k_s`` the scattered direction; Mitsuba's local ``wi = -k_i`` (pointing away from the
surface). The material is two-sided: the normal is flipped to the side the wave comes from.

Every formula below that a Dr.Jit kernel needs is written once, generic over an ``ops`` namespace
(:data:`NUMPY_OPS` here, ``DRJIT_OPS`` in ``mitsar.plugins.bsdfs.doublelobe``), so that the NumPy
reference and the Mitsuba plugin evaluate the same expressions.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mitsar.errors import ParameterError

__all__ = [
    "ALPHA_MAX",
    "CLOSED_FORM_ALPHA_MAX",
    "DoubleLobe",
    "NUMPY_OPS",
    "PowerSplit",
    "PRESETS",
    "TABLE_SIZE",
    "backscatter_fraction_from_sionna",
    "closed_form_coefficients",
    "double_lobe_pattern",
    "interp_theta_table",
    "lobe_integral",
    "lobe_integral_closed_form",
    "lobe_integral_quadrature",
    "lobe_integral_table",
    "lobe_sample_cos_psi",
    "lobe_sampling_pdf",
    "lobe_shape",
    "lobe_weights",
    "monostatic_sigma0_table",
    "preset_names",
    "scattering_cosines",
    "sigma0_from_law",
    "sigma0_from_pattern",
    "sionna_lambda_from_backscatter_fraction",
]

ALPHA_MAX = 200.0
"""Largest accepted lobe exponent α (beyond it the lobe is narrower than ~6°)."""

CLOSED_FORM_ALPHA_MAX = 64
"""Integer exponents up to this use the closed-form normalisation; larger ones the table."""

TABLE_SIZE = 1025
"""Nodes of the normalisation tables, uniform in θ_i over [0, 90°] (step 0.088°)."""

SIGMA0_LAWS = ("constant", "lambert")
"""Angular laws of a given ``sigma0_db``: constant, or ``σ⁰(0) cos² θ_i`` (Lambert)."""

LOBE_NORMALISATIONS = ("joint", "separate")
"""``"joint"``: Degli-Esposti 2007 / DESIGN §5.3; ``"separate"``: Λ is the back-lobe power."""

_HALF_PI = 0.5 * math.pi
_FOUR_PI = 4.0 * math.pi


# --------------------------------------------------------------------------------------------
# Array namespace shared by the NumPy reference and the Dr.Jit kernels
# --------------------------------------------------------------------------------------------


class _NumpyOps:
    """The few array operations the generic formulas need, for NumPy inputs.

    ``mitsar.plugins.bsdfs.doublelobe.DRJIT_OPS`` provides the same names for Dr.Jit arrays.
    """

    sqrt = staticmethod(np.sqrt)
    maximum = staticmethod(np.maximum)
    minimum = staticmethod(np.minimum)
    arccos = staticmethod(np.arccos)
    floor = staticmethod(np.floor)
    where = staticmethod(np.where)

    @staticmethod
    def gather(table: np.ndarray, index: np.ndarray) -> np.ndarray:
        """``table[index]`` for a float array of integral values."""
        return np.asarray(table)[np.asarray(index).astype(np.intp)]


NUMPY_OPS = _NumpyOps()
"""Array operations for NumPy inputs (the default ``ops`` of every generic formula)."""


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


def _is_closed_form(alpha: float) -> bool:
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
    if _is_closed_form(alpha):
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


# --------------------------------------------------------------------------------------------
# Two lobes: weights, pattern, σ⁰
# --------------------------------------------------------------------------------------------


def lobe_weights(backscatter_fraction: float, f_b: Any, f_f: Any,
                 normalisation: str = "joint") -> tuple[Any, Any]:
    """Weights ``(w_B, w_F)`` of the two lobes so that ∫_H f dΩ = 1.

    Parameters
    ----------
    backscatter_fraction : float
        Λ ∈ [0, 1] (paper convention: weight of the backscatter lobe).
    f_b, f_f : array_like
        Lobe integrals ``F_αB(θ_i)``, ``F_αF(θ_i)`` [sr].
    normalisation : {"joint", "separate"}
        ``"joint"``: ``w = (Λ, 1-Λ) / (Λ F_B + (1-Λ) F_F)`` (Degli-Esposti 2007); ``"separate"``:
        ``w = (Λ/F_B, (1-Λ)/F_F)``.

    Returns
    -------
    tuple
        ``(w_B, w_F)`` [1/sr]. The back lobe carries ``w_B F_B`` of the scattered power.
    """
    lam = float(backscatter_fraction)
    if normalisation == "separate":
        return lam / f_b, (1.0 - lam) / f_f
    inv = 1.0 / (lam * f_b + (1.0 - lam) * f_f)
    return lam * inv, (1.0 - lam) * inv


def double_lobe_pattern(cos_psi_b: Any, cos_psi_f: Any, w_b: Any, w_f: Any,
                        alpha_b: float, alpha_f: float, ops: Any = NUMPY_OPS) -> Any:
    """Normalised double-lobe pattern ``f = w_B lobe(ψ_B)^α_B + w_F lobe(ψ_F)^α_F`` (paper eq. 11).

    Parameters
    ----------
    cos_psi_b : array_like
        Cosine of the angle between ``k_s`` and the backscatter direction ``-k_i`` [-].
    cos_psi_f : array_like
        Cosine of the angle between ``k_s`` and the specular direction [-].
    w_b, w_f : array_like
        Lobe weights from :func:`lobe_weights` [1/sr].
    alpha_b, alpha_f : float
        Lobe exponents.
    ops : namespace
        Array operations.

    Returns
    -------
    array_like
        ``f(k_i, k_s)`` [1/sr].
    """
    return (w_b * lobe_shape(cos_psi_b, alpha_b, ops)
            + w_f * lobe_shape(cos_psi_f, alpha_f, ops))


def sigma0_from_pattern(gamma2_s2: float, cos_theta_i: Any, pattern: Any) -> Any:
    """Bistatic scattering coefficient ``σ⁰ = 4π Γ² S² cos θ_i f`` (DESIGN §5.3) [m²/m²].

    Parameters
    ----------
    gamma2_s2 : float
        ``Γ² S²``, the scattered fraction of the incident power [-].
    cos_theta_i : array_like
        Cosine of the incidence angle (>= 0) [-].
    pattern : array_like
        ``f(k_i, k_s)`` [1/sr].
    """
    return _FOUR_PI * gamma2_s2 * cos_theta_i * pattern


def sigma0_from_law(sigma0_linear: float, law: str, cos_theta_i: Any,
                    ops: Any = NUMPY_OPS) -> Any:
    """Monostatic σ⁰ from a given value and angular law [m²/m²].

    Parameters
    ----------
    sigma0_linear : float
        ``10^(sigma0_db/10)``: the constant value, or the value at normal incidence (Lambert).
    law : {"constant", "lambert"}
        ``"constant"``: σ⁰ for every θ_i < 90°; ``"lambert"``: ``σ⁰(0) cos² θ_i``.
    cos_theta_i : array_like
        Cosine of the incidence angle [-]; 0 at and beyond grazing.
    ops : namespace
        Array operations.
    """
    c = _clip01(cos_theta_i, ops)
    if law == "lambert":
        return sigma0_linear * c * c
    return ops.where(c > 0.0, sigma0_linear, 0.0 * c)


def scattering_cosines(k_i: Any, k_s: Any, normal: Any) -> tuple[np.ndarray, ...]:
    """Cosines that the pattern needs, from world-frame directions (NumPy, two-sided).

    Parameters
    ----------
    k_i : array_like, shape (..., 3)
        Propagation direction of the incident wave (towards the surface), unit.
    k_s : array_like, shape (..., 3)
        Scattered direction (away from the surface), unit.
    normal : array_like, shape (..., 3)
        Surface normal, either orientation; it is flipped towards the incident side.

    Returns
    -------
    cos_theta_i, cos_theta_s, cos_psi_b, cos_psi_f : numpy.ndarray
        Incidence cosine (>= 0), scattering cosine (> 0 on the incident side), and the cosines of
        the angles to the backscatter direction ``-k_i`` and to the specular direction.
    """
    k_i = np.asarray(k_i, dtype=np.float64)
    k_s = np.asarray(k_s, dtype=np.float64)
    n = np.asarray(normal, dtype=np.float64)
    side = np.where(np.sum(k_i * n, axis=-1) > 0.0, -1.0, 1.0)[..., None]
    n = n * side
    cos_i = -np.sum(k_i * n, axis=-1)
    cos_s = np.sum(k_s * n, axis=-1)
    cos_b = -np.sum(k_i * k_s, axis=-1)
    specular = k_i + 2.0 * cos_i[..., None] * n
    cos_f = np.sum(specular * k_s, axis=-1)
    return cos_i, cos_s, cos_b, cos_f


# --------------------------------------------------------------------------------------------
# Sionna RT convention
# --------------------------------------------------------------------------------------------


def backscatter_fraction_from_sionna(lambda_: float) -> float:
    """Paper's Λ from Sionna RT's ``BackscatteringPattern(lambda_)``: ``Λ = 1 - λ``.

    Sionna weighs the *specular* lobe with λ (``alpha_r`` is its exponent, ``alpha_i`` the
    backscatter lobe's); the paper's Λ weighs the *backscatter* lobe.
    """
    return 1.0 - float(lambda_)


def sionna_lambda_from_backscatter_fraction(backscatter_fraction: float) -> float:
    """Sionna RT's ``lambda_`` from the paper's Λ: ``λ = 1 - Λ``."""
    return 1.0 - float(backscatter_fraction)


# --------------------------------------------------------------------------------------------
# The material
# --------------------------------------------------------------------------------------------


class PowerSplit(NamedTuple):
    """Fractions of the incident power at a hit (paper eq. 8); they sum to 1."""

    specular: Any
    """Reflected specularly, ``Γ² R²``."""
    back: Any
    """Scattered into the backscatter lobe, ``Γ² S² share_B``."""
    forward: Any
    """Scattered into the forward (specular) lobe, ``Γ² S² share_F``."""
    loss: Any
    """Lost by absorption/transmission, ``P_L/P_i``."""


PRESETS: dict[str, dict[str, Any]] = {
    "concrete_94ghz": {
        "transmission_loss_db": -7.0,
        "reflection_reduction_db": -7.5,
        "backscatter_fraction": 0.1,
        "alpha_b": 6.0,
        "alpha_f": 3.0,
    },
    "concrete_94ghz_paper": {
        "transmission_loss_db": -7.0,
        "reflection_reduction_db": -7.5,
        "backscatter_fraction": 0.1,
        "alpha_b": 6.0,
        "alpha_f": 3.0,
        "sigma0_db": -20.0,
        "sigma0_law": "constant",
    },
    "absorber": {
        "transmission_loss_db": 0.0,
        "reflection_reduction_db": 0.0,
        "backscatter_fraction": 0.0,
        "alpha_b": 1.0,
        "alpha_f": 1.0,
    },
    "mirror": {
        "transmission_loss_db": -math.inf,
        "reflection_reduction_db": 0.0,
        "backscatter_fraction": 0.0,
        "alpha_b": 1.0,
        "alpha_f": 1.0,
    },
}
"""Named parameter sets.

- ``concrete_94ghz``: concrete walls at 94 GHz, paper §4.2 (-7.0 dB, -7.5 dB, Λ = 0.1); the paper
  gives no lobe widths, α_B = 6 and α_F = 3 are DESIGN §5.3's choice. σ⁰ from the model
  (monostatic ≈ -0.2 dB at 35°).
- ``concrete_94ghz_paper``: the same with the paper's σ⁰ = -20 dB (constant) for the direct
  backscatter (§4.2); reflections and bistatic scattering still follow the lobes.
- ``absorber``: everything is lost (Γ = 0).
- ``mirror``: lossless perfect specular reflector (Γ = R = 1).
"""


def preset_names() -> list[str]:
    """Names of the material presets, sorted."""
    return sorted(PRESETS)


_NUMERIC_FIELDS = ("transmission_loss_db", "reflection_reduction_db", "backscatter_fraction",
                   "alpha_b", "alpha_f")


def _as_real(where: str, name: str, value: Any, expected: str) -> float:
    if isinstance(value, bool) or value is None:
        raise ParameterError(where, name, expected, value)
    if isinstance(value, str):
        try:
            return float(value.strip())
        except ValueError:
            raise ParameterError(where, name, expected, value) from None
    try:
        out = float(value)
    except (TypeError, ValueError):
        raise ParameterError(where, name, expected, value) from None
    return out


@dataclass(frozen=True)
class DoubleLobe:
    """Double-lobe radar material (paper eqs. 8-11, Degli-Esposti 2007, DESIGN §5.3).

    Parameters
    ----------
    transmission_loss_db : float
        ``10 log10(P_L/P_i)`` <= 0 [dB]: power lost by absorption/transmission; 0 dB loses
        everything (absorber), ``-inf`` nothing.
    reflection_reduction_db : float
        ``20 log10 R`` <= 0 [dB]: reflection reduction factor R; the scattering coefficient is
        ``S = sqrt(1 - R²)`` (paper eq. 10).
    backscatter_fraction : float
        Λ ∈ [0, 1], weight of the backscatter lobe (paper convention; Sionna's λ = 1 - Λ).
    alpha_b : float
        Exponent α_B > 0 of the backscatter lobe (non-integer allowed).
    alpha_f : float
        Exponent α_F > 0 of the forward (specular) lobe.
    sigma0_db : float or None
        If given, the direct (monostatic) backscatter uses this σ⁰ [dB] with ``sigma0_law``
        instead of the lobe model (paper §4.2: -20 dB); ``None`` uses the model.
    sigma0_law : {"constant", "lambert"}
        Angular law of ``sigma0_db``: constant, or ``σ⁰(0) cos² θ_i`` with ``sigma0_db`` at normal
        incidence.
    lobe_normalisation : {"joint", "separate"}
        How Λ enters the normalisation; see the module docstring.
    name : str or None
        Preset name or label, for provenance only.

    Raises
    ------
    ParameterError
        Naming the parameter that is out of range.
    """

    transmission_loss_db: float = -7.0
    reflection_reduction_db: float = -7.5
    backscatter_fraction: float = 0.1
    alpha_b: float = 6.0
    alpha_f: float = 3.0
    sigma0_db: float | None = None
    sigma0_law: str = "constant"
    lobe_normalisation: str = "joint"
    name: str | None = None

    def __post_init__(self) -> None:
        self._validate("DoubleLobe")

    def _validate(self, where: str) -> None:
        set_ = functools.partial(object.__setattr__, self)
        for field_name, expected in (
                ("transmission_loss_db", "a level <= 0 dB (0 = all lost, -inf = lossless)"),
                ("reflection_reduction_db", "a level <= 0 dB (20 log10 R, -inf = no reflection)")):
            value = _as_real(where, field_name, getattr(self, field_name), expected)
            if math.isnan(value) or value > 0.0:
                raise ParameterError(where, field_name, expected, getattr(self, field_name))
            set_(field_name, value)
        lam = _as_real(where, "backscatter_fraction", self.backscatter_fraction,
                       "a fraction in [0, 1]")
        if not 0.0 <= lam <= 1.0:
            raise ParameterError(where, "backscatter_fraction", "a fraction in [0, 1]",
                                 self.backscatter_fraction)
        set_("backscatter_fraction", lam)
        for field_name in ("alpha_b", "alpha_f"):
            expected = f"a lobe exponent in (0, {ALPHA_MAX:g}]"
            value = _as_real(where, field_name, getattr(self, field_name), expected)
            if not 0.0 < value <= ALPHA_MAX:
                raise ParameterError(where, field_name, expected, getattr(self, field_name))
            set_(field_name, value)
        if self.sigma0_db is not None:
            expected = "None or a level in dB (finite or -inf)"
            value = _as_real(where, "sigma0_db", self.sigma0_db, expected)
            if math.isnan(value) or value == math.inf:
                raise ParameterError(where, "sigma0_db", expected, self.sigma0_db)
            set_("sigma0_db", value)
        if self.sigma0_law not in SIGMA0_LAWS:
            raise ParameterError(where, "sigma0_law", f"one of {list(SIGMA0_LAWS)}",
                                 self.sigma0_law)
        if self.lobe_normalisation not in LOBE_NORMALISATIONS:
            raise ParameterError(where, "lobe_normalisation",
                                 f"one of {list(LOBE_NORMALISATIONS)}", self.lobe_normalisation)
        if self.name is not None and not isinstance(self.name, str):
            raise ParameterError(where, "name", "None or a string", self.name)

    # ---- construction helpers -----------------------------------------------------------

    @classmethod
    def preset(cls, name: str, **overrides: Any) -> DoubleLobe:
        """A named preset (:data:`PRESETS`), optionally with some parameters overridden.

        Raises
        ------
        ParameterError
            For an unknown preset name or parameter.
        """
        if name not in PRESETS:
            raise ParameterError("DoubleLobe.preset", "name", f"one of {preset_names()}", name)
        params = dict(PRESETS[name])
        params.update(overrides)
        params.setdefault("name", name)
        return cls.from_parameters(params, where=f"DoubleLobe.preset({name!r})")

    @classmethod
    def from_parameters(cls, params: Mapping[str, Any], where: str = "DoubleLobe"
                        ) -> DoubleLobe:
        """Build from a mapping of parameters, with an optional ``preset`` entry as the base.

        ``sigma0_db`` may be ``None`` or the string ``"none"`` (use the model). Errors name
        ``where`` (e.g. the XML element) and the parameter.
        """
        params = dict(params)
        base: dict[str, Any] = {}
        preset = params.pop("preset", None)
        if preset is not None:
            if preset not in PRESETS:
                raise ParameterError(where, "preset", f"one of {preset_names()}", preset)
            base = dict(PRESETS[preset])
            base["name"] = preset
        known = {f.name for f in dataclasses.fields(cls)}
        for key in params:
            if key not in known:
                raise ParameterError(where, key, f"one of the parameters {sorted(known)}",
                                     params[key])
        base.update(params)
        if isinstance(base.get("sigma0_db"), str) and base["sigma0_db"].strip().lower() in (
                "none", ""):
            base["sigma0_db"] = None
        obj = cls.__new__(cls)
        for f in dataclasses.fields(cls):
            value = base.get(f.name, f.default)
            object.__setattr__(obj, f.name, value)
        obj._validate(where)
        return obj

    @classmethod
    def from_sionna(cls, lambda_: float = 1.0, alpha_r: float = 1.0, alpha_i: float = 1.0,
                    scattering_coefficient: float | None = None, **kwargs: Any) -> DoubleLobe:
        """From Sionna RT's ``BackscatteringPattern(alpha_r, alpha_i, lambda_)`` parameters.

        Sionna's ``lambda_`` weighs the specular lobe (exponent ``alpha_r``); so Λ = 1 - λ,
        α_F = α_R, α_B = α_I, with the joint normalisation Sionna uses. A Sionna
        ``scattering_coefficient`` S gives ``reflection_reduction_db = 20 log10 sqrt(1 - S²)``.
        """
        params: dict[str, Any] = {
            "backscatter_fraction": backscatter_fraction_from_sionna(lambda_),
            "alpha_f": alpha_r,
            "alpha_b": alpha_i,
            "lobe_normalisation": "joint",
        }
        if scattering_coefficient is not None:
            s = float(scattering_coefficient)
            if not 0.0 <= s <= 1.0:
                raise ParameterError("DoubleLobe.from_sionna", "scattering_coefficient",
                                     "a value in [0, 1]", scattering_coefficient)
            r2 = 1.0 - s * s
            params["reflection_reduction_db"] = 10.0 * math.log10(r2) if r2 > 0 else -math.inf
        params.update(kwargs)
        return cls.from_parameters(params, where="DoubleLobe.from_sionna")

    def sionna_parameters(self) -> dict[str, float]:
        """Sionna RT ``BackscatteringPattern`` keywords equivalent to this pattern.

        Exact for ``lobe_normalisation="joint"`` (Sionna needs integer α).
        """
        return {"lambda_": sionna_lambda_from_backscatter_fraction(self.backscatter_fraction),
                "alpha_r": self.alpha_f, "alpha_i": self.alpha_b,
                "scattering_coefficient": self.scattering}

    def replace(self, **changes: Any) -> DoubleLobe:
        """A copy with some parameters changed (validated)."""
        return dataclasses.replace(self, **changes)

    def to_dict(self) -> dict[str, Any]:
        """The parameters as a plain dict (for provenance and XML)."""
        return dataclasses.asdict(self)

    # ---- derived quantities (paper eqs. 8, 10) ------------------------------------------

    @property
    def loss_fraction(self) -> float:
        """``P_L/P_i`` [-]."""
        return 10.0 ** (self.transmission_loss_db / 10.0)

    @property
    def gamma2(self) -> float:
        """``Γ² = 1 - P_L/P_i`` (paper eq. 8) [-]."""
        return max(0.0, 1.0 - self.loss_fraction)

    @property
    def reflection(self) -> float:
        """Reflection reduction factor ``R = 10^(dB/20)`` [-]."""
        return 10.0 ** (self.reflection_reduction_db / 20.0)

    @property
    def scattering(self) -> float:
        """Scattering coefficient ``S = sqrt(1 - R²)`` (paper eq. 10) [-]."""
        return math.sqrt(max(0.0, 1.0 - self.reflection**2))

    @property
    def specular_fraction(self) -> float:
        """``Γ² R²``, the specularly reflected fraction of the incident power [-]."""
        return self.gamma2 * self.reflection**2

    @property
    def scattered_fraction(self) -> float:
        """``Γ² S²``, the fraction scattered into the two lobes [-]."""
        return self.gamma2 * self.scattering**2

    @property
    def sigma0_linear(self) -> float | None:
        """``10^(sigma0_db/10)`` or None [m²/m²]."""
        return None if self.sigma0_db is None else 10.0 ** (self.sigma0_db / 10.0)

    @property
    def is_absorber(self) -> bool:
        """True when nothing comes back: Γ = 0 and no given σ⁰ (or σ⁰ = 0)."""
        if self.sigma0_db is not None:
            return self.sigma0_db == -math.inf
        return self.gamma2 == 0.0

    # ---- pattern and σ⁰ ------------------------------------------------------------------

    def normalisers(self, cos_theta_i: Any) -> tuple[np.ndarray, np.ndarray]:
        """Lobe integrals ``(F_αB(θ_i), F_αF(θ_i))`` [sr]."""
        c = np.asarray(cos_theta_i, dtype=np.float64)
        return lobe_integral(self.alpha_b, c), lobe_integral(self.alpha_f, c)

    def weights(self, cos_theta_i: Any) -> tuple[np.ndarray, np.ndarray]:
        """Lobe weights ``(w_B, w_F)`` at incidence cosine ``cos_theta_i`` [1/sr]."""
        f_b, f_f = self.normalisers(cos_theta_i)
        return lobe_weights(self.backscatter_fraction, f_b, f_f, self.lobe_normalisation)

    def lobe_shares(self, cos_theta_i: Any) -> tuple[np.ndarray, np.ndarray]:
        """Shares of the scattered power in the back and forward lobes; they sum to 1."""
        f_b, f_f = self.normalisers(cos_theta_i)
        w_b, w_f = lobe_weights(self.backscatter_fraction, f_b, f_f, self.lobe_normalisation)
        return w_b * f_b, w_f * f_f

    def power_split(self, cos_theta_i: Any = 1.0) -> PowerSplit:
        """Fractions of the incident power at a hit (paper eq. 8): they sum to 1.

        Parameters
        ----------
        cos_theta_i : array_like
            Incidence cosine; the lobe shares depend on it for the joint normalisation.
        """
        share_b, share_f = self.lobe_shares(cos_theta_i)
        scattered = self.scattered_fraction
        return PowerSplit(specular=self.specular_fraction, back=scattered * share_b,
                          forward=scattered * share_f, loss=1.0 - self.gamma2)

    def pattern(self, k_i: Any, k_s: Any, normal: Any) -> np.ndarray:
        """Normalised pattern ``f(k_i, k_s)`` [1/sr]; 0 for ``k_s`` behind the surface.

        Parameters
        ----------
        k_i, k_s, normal : array_like, shape (..., 3)
            See :func:`scattering_cosines`.
        """
        cos_i, cos_s, cos_b, cos_f = scattering_cosines(k_i, k_s, normal)
        w_b, w_f = self.weights(cos_i)
        f = double_lobe_pattern(cos_b, cos_f, w_b, w_f, self.alpha_b, self.alpha_f)
        return np.where((cos_s > 0.0) & (cos_i > 0.0), f, 0.0)

    def sigma0(self, k_i: Any, k_s: Any, normal: Any) -> np.ndarray:
        """Bistatic scattering coefficient of the lobe model, ``4π Γ² S² cos θ_i f`` [m²/m²]."""
        cos_i = scattering_cosines(k_i, k_s, normal)[0]
        return sigma0_from_pattern(self.scattered_fraction, cos_i,
                                   self.pattern(k_i, k_s, normal))

    def sigma0_monostatic_model(self, cos_theta_i: Any) -> np.ndarray:
        """Monostatic σ⁰ of the lobe model (``k_s = -k_i``) [m²/m²].

        ``cos ψ_B = 1`` and ``cos ψ_F = cos 2θ_i``, so ``f = w_B + w_F cos^(2α_F) θ_i``.
        """
        c = np.clip(np.abs(np.asarray(cos_theta_i, dtype=np.float64)), 0.0, 1.0)
        w_b, w_f = self.weights(c)
        f = double_lobe_pattern(1.0, 2.0 * c * c - 1.0, w_b, w_f, self.alpha_b, self.alpha_f)
        return np.where(c > 0.0, sigma0_from_pattern(self.scattered_fraction, c, f), 0.0)

    def sigma0_monostatic(self, cos_theta_i: Any) -> np.ndarray:
        """σ⁰ of the direct backscatter [m²/m²]: the given ``sigma0_db`` if any, else the model.

        Parameters
        ----------
        cos_theta_i : array_like
            Cosine of the incidence angle (either side) [-].
        """
        if self.sigma0_db is None:
            return self.sigma0_monostatic_model(cos_theta_i)
        c = np.abs(np.asarray(cos_theta_i, dtype=np.float64))
        return np.asarray(sigma0_from_law(self.sigma0_linear, self.sigma0_law, c))

    def bsdf_value_local(self, wi: Any, wo: Any) -> np.ndarray:
        """What the Mitsuba plugin's ``eval`` returns: ``Γ² S² f`` (BSDF × cos θ_o) [1/sr].

        Parameters
        ----------
        wi, wo : array_like, shape (..., 3)
            Mitsuba local-frame directions (normal = +z), both pointing away from the surface.
        """
        wi = np.asarray(wi, dtype=np.float64)
        wo = np.asarray(wo, dtype=np.float64)
        normal = np.broadcast_to(np.array([0.0, 0.0, 1.0]), wi.shape)
        return self.scattered_fraction * self.pattern(-wi, wo, normal)


def monostatic_sigma0_table(materials: Sequence[DoubleLobe | None],
                            n: int = TABLE_SIZE) -> np.ndarray:
    """Stacked tables of the direct-backscatter σ⁰, uniform in θ_i ∈ [0, π/2].

    For a kernel that needs σ⁰ for scatterers of many materials: gather with
    :func:`interp_theta_table` and ``offset = material_index * n``. ``None`` rows are 0.

    Parameters
    ----------
    materials : sequence of DoubleLobe or None
        One entry per table (e.g. per shape).
    n : int
        Nodes per table.

    Returns
    -------
    numpy.ndarray
        Shape ``(len(materials), n)`` [m²/m²].
    """
    cos_theta = np.cos(np.linspace(0.0, _HALF_PI, n))
    cos_theta[-1] = 0.0
    out = np.zeros((len(materials), n))
    for row, material in enumerate(materials):
        if material is not None:
            out[row] = material.sigma0_monostatic(cos_theta)
    return out
