"""The two-lobe pattern and the scattering coefficient σ⁰ (paper eqs. 8-11, Degli-Esposti 2007).

At a hit the incident power splits into

- ``P_L/P_i``            lost (absorbed or transmitted), ``transmission_loss_db``;
- ``Γ² R²``              reflected specularly, ``R = 10^(reflection_reduction_db/20)``;
- ``Γ² S² share_B``      scattered into the lobe around the backscatter direction ``-k_i``;
- ``Γ² S² share_F``      scattered into the lobe around the specular direction;

with ``Γ² = 1 - P_L/P_i`` (paper eq. 8) and ``S = sqrt(1 - R²)`` (paper eq. 10). The scattering
pattern (paper eq. 11, normalised) is::

    f(k_i, k_s) = w_B ((1 + cos ψ_B)/2)^α_B + w_F ((1 + cos ψ_F)/2)^α_F      [1/sr]

with ∫_hemisphere f dΩ = 1. With the default ``"joint"`` normalisation (Degli-Esposti 2007,
docs/design.md §5.3) ``w_B = Λ/N``, ``w_F = (1-Λ)/N``, ``N(θ_i) = Λ F_αB(θ_i) + (1-Λ) F_αF(θ_i)``,
so Λ
sets the relative *amplitude* of the lobes and the back lobe carries ``share_B = Λ F_αB / N`` of the
scattered power; with ``"separate"`` normalisation ``w_B = Λ/F_αB`` and ``w_F = (1-Λ)/F_αF``, so
the back lobe carries exactly Λ of it (the wording of paper §3.2). ``F_α`` is the lobe integral of
:mod:`mitsar.model.doublelobe.lobes`.

The bistatic scattering coefficient per unit area is ``σ⁰ = 4π Γ² S² cos θ_i f`` (docs/design.md
§5.3);
monostatic ``k_s = -k_i``. Sionna RT's ``BackscatteringPattern`` weighs the lobes the other way
round (``λ = 1 - Λ``).

Conventions: ``k_i`` is the propagation direction of the incident wave (pointing *into* the
surface), ``k_s`` the scattered direction; Mitsuba's local ``wi = -k_i`` (pointing away from the
surface). The material is two-sided: the normal is flipped to the side the wave comes from.
"""

from __future__ import annotations

from typing import Any

import numpy as np

from mitsar.model.doublelobe.lobes import _FOUR_PI, NUMPY_OPS, _clip01, lobe_shape

__all__ = [
    "backscatter_fraction_from_sionna",
    "double_lobe_pattern",
    "lobe_weights",
    "scattering_cosines",
    "sigma0_from_law",
    "sigma0_from_pattern",
    "sionna_lambda_from_backscatter_fraction",
]


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
    """Bistatic scattering coefficient ``σ⁰ = 4π Γ² S² cos θ_i f`` (docs/design.md §5.3) [m²/m²].

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
