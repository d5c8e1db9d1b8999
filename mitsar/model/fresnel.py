"""Specular reflection of a dielectric half-space or slab: Fresnel coefficients (ITU-R P.2040-3).

For a plane wave from air (vacuum) onto a non-magnetic medium of complex relative permittivity
η at incidence θ, with ``c = cos θ`` and ``w = sqrt(η − sin² θ)`` (the branch with Re w >= 0,
so Im w <= 0 for a lossy medium in the ``exp(+jωt)`` convention), ITU-R P.2040-3 (reflection
at a plane interface) gives the interface reflection coefficients

    r_TE = (c − w) / (c + w)            (E perpendicular to the plane of incidence),
    r_TM = (η c − w) / (η c + w)        (E in the plane of incidence).

A slab of thickness d (ITU-R P.2040-3, single-layer slab; the model of Sionna RT's
``RadioMaterial`` with its ``thickness``, Sionna RT documentation "Primer on Electromagnetics")
adds the internal multiple reflections:

    R = r (1 − e^{−j2q}) / (1 − r² e^{−j2q}),      q = (2π d / λ) w,

which tends to r when the slab is thick or lossy enough (e^{−j2q} → 0).

mitsar's ray tracer is scalar: it carries no polarisation state, so a material reflects a
power fraction ``Γ² = |R_TE|²`` (``"te"``), ``|R_TM|²`` (``"tm"``) or their mean
(``"average"``, an unpolarised wave). These are NumPy functions (complex arithmetic); the radar
kernel reads them through θ-tables (:func:`mitsar.model.doublelobe.specular_field_table`)
interpolated by the ``ops``-generic :func:`mitsar.model.doublelobe.interp_theta_table`.
"""

from __future__ import annotations

import math
from typing import Any

import numpy as np

from mitsar.errors import ParameterError
from mitsar.model.radar import SPEED_OF_LIGHT

__all__ = ["POLARIZATIONS", "fresnel_coefficients", "reflectance", "slab_reflection_coefficients"]

POLARIZATIONS = ("average", "te", "tm")
"""Polarisations of the scalar reflectance: the TE/TM power mean, TE only, TM only."""

def _branch_sqrt(z: np.ndarray) -> np.ndarray:
    """Square root with Re >= 0 (NumPy's principal branch; Im has the sign of Im z)."""
    return np.sqrt(z)


def fresnel_coefficients(cos_theta_i: Any, eta: complex) -> tuple[np.ndarray, np.ndarray]:
    """Interface reflection coefficients ``(r_TE, r_TM)`` from air (ITU-R P.2040-3).

    Parameters
    ----------
    cos_theta_i : array_like
        Cosine of the incidence angle, clipped to [0, 1] [-].
    eta : complex
        Complex relative permittivity of the medium (imaginary part <= 0) [-].

    Returns
    -------
    r_te, r_tm : numpy.ndarray of complex
        Field reflection coefficients [-]; both are -1 at grazing incidence.
    """
    c, w = _normal_components(cos_theta_i, eta)
    r_te = (c - w) / (c + w)
    r_tm = (eta * c - w) / (eta * c + w)
    return r_te, r_tm


def _normal_components(cos_theta_i: Any, eta: complex) -> tuple[np.ndarray, np.ndarray]:
    """``cos θ_i`` clipped to [0, 1] and ``sqrt(eta - sin² θ_i)`` (the normal wavenumber in the
    medium over k_0, on the decaying branch) [-]."""
    c = np.clip(np.asarray(cos_theta_i, dtype=np.float64), 0.0, 1.0)
    return c, _branch_sqrt(complex(eta) - (1.0 - c * c) + 0j)


def slab_reflection_coefficients(cos_theta_i: Any, eta: complex, thickness: float,
                                 frequency: float) -> tuple[np.ndarray, np.ndarray]:
    """Reflection coefficients ``(R_TE, R_TM)`` of a slab in air (ITU-R P.2040-3, one layer).

    Parameters
    ----------
    cos_theta_i : array_like
        Cosine of the incidence angle [-].
    eta : complex
        Complex relative permittivity [-].
    thickness : float
        Slab thickness d > 0 [m]; ``inf`` gives the half-space (:func:`fresnel_coefficients`).
    frequency : float
        Frequency [Hz].

    Returns
    -------
    R_te, R_tm : numpy.ndarray of complex
        Field reflection coefficients [-].
    """
    r_te, r_tm = fresnel_coefficients(cos_theta_i, eta)
    if math.isinf(thickness):
        return r_te, r_tm
    _, w = _normal_components(cos_theta_i, eta)
    q = (2.0 * math.pi * frequency * thickness / SPEED_OF_LIGHT) * w
    with np.errstate(over="ignore", under="ignore"):
        phase = np.exp(-2j * q)   # |phase| = exp(2 Im q) <= 1
    return tuple(r * (1.0 - phase) / (1.0 - r * r * phase)  # type: ignore[return-value]
                 for r in (r_te, r_tm))


def reflectance(cos_theta_i: Any, eta: complex, thickness: float = math.inf,
                frequency: float = 94e9, polarization: str = "average") -> np.ndarray:
    """Specularly reflected power fraction ``Γ²(θ_i)`` of a slab (or half-space) [-].

    Parameters
    ----------
    cos_theta_i : array_like
        Cosine of the incidence angle [-].
    eta : complex
        Complex relative permittivity [-].
    thickness : float
        Slab thickness [m] (``inf``: half-space).
    frequency : float
        Frequency [Hz] (used by the slab only).
    polarization : {"average", "te", "tm"}
        ``|R_TE|²``, ``|R_TM|²`` or their mean (unpolarised incidence).

    Returns
    -------
    numpy.ndarray
        Γ² in [0, 1], shape of ``cos_theta_i``.
    """
    if polarization not in POLARIZATIONS:
        raise ParameterError("reflectance", "polarization", f"one of {list(POLARIZATIONS)}",
                             polarization)
    r_te, r_tm = slab_reflection_coefficients(cos_theta_i, eta, thickness, frequency)
    te, tm = np.abs(r_te) ** 2, np.abs(r_tm) ** 2
    out = {"te": te, "tm": tm, "average": 0.5 * (te + tm)}[polarization]
    return np.clip(out, 0.0, 1.0)
