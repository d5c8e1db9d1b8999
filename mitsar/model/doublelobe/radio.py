"""Sionna RT's radio material as a mitsar radar material: Fresnel reflection + double lobe.

Sionna RT's ``RadioMaterial`` (Sionna RT documentation, "Radio Materials" and "Primer on
Electromagnetics") reflects the field of a slab of complex permittivity η and thickness d
(:mod:`mitsar.model.fresnel`), then splits the reflected power ``Γ²(θ_i) = |R(θ_i)|²`` into a
specular part ``(1 − S²) Γ²`` and a diffuse part ``S² Γ²`` with the scattering coefficient S;
the rest, ``1 − Γ²``, is transmitted or absorbed. That is the paper's power balance (eqs. 8, 10)
with an incidence-dependent Γ:

    P_L/P_i = 1 − Γ²(θ_i),    R = sqrt(1 − S²),    specular field factor Γ(θ_i) R.

:class:`RadioMaterial` is a :class:`~mitsar.model.doublelobe.DoubleLobe` whose :meth:`gamma2_at`
is the slab reflectance at ``frequency`` for the chosen ``polarization``; every σ⁰ and power
split of the double-lobe model then uses Γ²(θ_i). :attr:`gamma2` (and the derived
``transmission_loss_db``, ``specular_fraction``, ``scattered_fraction``) are the values at
normal incidence. Sionna's scattering patterns map onto the lobes: ``directive`` (α_R) is the
forward lobe alone (Λ = 0), ``backscattering`` (α_R, α_I, λ) gives Λ = 1 − λ, α_F = α_R,
α_B = α_I (:func:`~mitsar.model.doublelobe.backscatter_fraction_from_sionna`), and
``lambertian`` (Sionna's default), which the double-lobe model cannot express, is approximated
by α_B = α_F = 1, Λ = 1/2 (monostatic σ⁰ within 2 dB of Lambert's for θ_i <= 60°; the loader
warns).
"""

from __future__ import annotations

import math
import warnings
from dataclasses import dataclass
from typing import Any

import numpy as np

from mitsar.errors import ParameterError
from mitsar.model.doublelobe.material import DoubleLobe, _as_real
from mitsar.model.doublelobe.pattern import backscatter_fraction_from_sionna
from mitsar.model.fresnel import POLARIZATIONS, reflectance
from mitsar.model.itu import complex_permittivity, itu_properties

__all__ = ["DEFAULT_FREQUENCY", "DEFAULT_THICKNESS", "RadioMaterial", "SCATTERING_PATTERNS",
           "radio_material_from_sionna"]

DEFAULT_FREQUENCY = 94e9
"""Frequency at which the permittivity is evaluated unless given [Hz] (the paper's carrier)."""

DEFAULT_THICKNESS = 0.1
"""Slab thickness when none is given [m] (Sionna RT's default)."""

SCATTERING_PATTERNS = ("lambertian", "directive", "backscattering")
"""Sionna RT's scattering patterns that :func:`radio_material_from_sionna` maps."""


@dataclass(frozen=True)
class RadioMaterial(DoubleLobe):
    """A double-lobe material whose specular reflection is a Fresnel (slab) reflection.

    Parameters
    ----------
    relative_permittivity : float
        Real part ε_r' >= 1 [-].
    conductivity : float
        σ >= 0 [S/m].
    frequency : float
        Frequency at which η = ε_r' − jσ/(2π f ε₀) is formed [Hz] (default 94 GHz).
    thickness : float
        Slab thickness d > 0 [m] (``inf``: half-space).
    polarization : {"average", "te", "tm"}
        Which reflectance the scalar tracer uses (:func:`mitsar.model.fresnel.reflectance`).
    xpd_coefficient : float
        Sionna's cross-polarisation discrimination K_x ∈ [0, 1]; recorded only (the tracer is
        scalar and counts the scattered power whatever its polarisation).
    itu_type : str or None
        ITU-R P.2040-3 material name the permittivity came from, for provenance.
    **double-lobe parameters
        As :class:`DoubleLobe`; ``transmission_loss_db`` is derived (the normal-incidence
        ``10 log10(1 − Γ²(0))``) and any given value is replaced.
    """

    relative_permittivity: float = 1.0
    conductivity: float = 0.0
    frequency: float = DEFAULT_FREQUENCY
    thickness: float = DEFAULT_THICKNESS
    polarization: str = "average"
    xpd_coefficient: float = 0.0
    itu_type: str | None = None

    def _validate(self, where: str) -> None:
        checks = (("relative_permittivity", "a real permittivity >= 1", lambda v: v >= 1.0),
                  ("conductivity", "a conductivity >= 0 S/m", lambda v: v >= 0.0),
                  ("frequency", "a frequency > 0 Hz", lambda v: 0.0 < v < math.inf),
                  ("thickness", "a thickness > 0 m (inf: half-space)", lambda v: v > 0.0),
                  ("xpd_coefficient", "a value in [0, 1]", lambda v: 0.0 <= v <= 1.0))
        for name, expected, ok in checks:
            value = _as_real(where, name, getattr(self, name), expected)
            if math.isnan(value) or not ok(value):
                raise ParameterError(where, name, expected, getattr(self, name))
            object.__setattr__(self, name, value)
        if self.polarization not in POLARIZATIONS:
            raise ParameterError(where, "polarization", f"one of {list(POLARIZATIONS)}",
                                 self.polarization)
        gamma2 = float(self.gamma2_at(1.0))
        loss = 1.0 - gamma2
        object.__setattr__(self, "transmission_loss_db",
                           10.0 * math.log10(loss) if loss > 0.0 else -math.inf)
        super()._validate(where)

    @property
    def eta(self) -> complex:
        """Complex relative permittivity η at :attr:`frequency` [-]."""
        return complex_permittivity(self.relative_permittivity, self.conductivity,
                                    self.frequency)

    @property
    def gamma2(self) -> float:
        """``Γ²`` at normal incidence [-]."""
        return float(self.gamma2_at(1.0))

    def gamma2_at(self, cos_theta_i: Any) -> np.ndarray:
        """Slab reflectance ``Γ²(θ_i)`` for :attr:`polarization` (ITU-R P.2040-3) [-]."""
        c = np.abs(np.asarray(cos_theta_i, dtype=np.float64))
        return reflectance(c, self.eta, self.thickness, self.frequency, self.polarization)


def _sionna_lobes(pattern: str, alpha_r: float, alpha_i: float, lambda_: float,
                  where: str) -> dict[str, Any]:
    """Double-lobe parameters of a Sionna RT scattering pattern (module docstring)."""
    if pattern == "lambertian":
        return {"backscatter_fraction": 0.5, "alpha_b": 1.0, "alpha_f": 1.0}
    if pattern == "directive":
        return {"backscatter_fraction": 0.0, "alpha_b": 1.0, "alpha_f": alpha_r}
    if pattern == "backscattering":
        lam = _as_real(where, "lambda_", lambda_, "a weight in [0, 1]")
        if not 0.0 <= lam <= 1.0:
            raise ParameterError(where, "lambda_", "a weight in [0, 1]", lambda_)
        return {"backscatter_fraction": backscatter_fraction_from_sionna(lam),
                "alpha_b": alpha_i, "alpha_f": alpha_r}
    raise ParameterError(where, "scattering_pattern", f"one of {list(SCATTERING_PATTERNS)}",
                         pattern)


def radio_material_from_sionna(*, itu_type: str | None = None,
                               relative_permittivity: float | None = None,
                               conductivity: float | None = None,
                               frequency: float = DEFAULT_FREQUENCY,
                               thickness: float = DEFAULT_THICKNESS,
                               scattering_coefficient: float = 0.0,
                               xpd_coefficient: float = 0.0,
                               scattering_pattern: str = "lambertian",
                               alpha_r: float = 4.0, alpha_i: float = 4.0,
                               lambda_: float = 0.75, polarization: str = "average",
                               sigma0_db: float | None = None, name: str | None = None,
                               where: str = "radio_material_from_sionna") -> RadioMaterial:
    """A :class:`RadioMaterial` from the parameters of Sionna RT's (ITU) radio material.

    Parameters
    ----------
    itu_type : str, optional
        ITU-R P.2040-3 material (:func:`mitsar.model.itu.itu_properties`); excludes
        ``relative_permittivity`` and ``conductivity``.
    relative_permittivity, conductivity : float, optional
        ε_r' [-] and σ [S/m] (Sionna's ``radio-material``); defaults 1 and 0 (vacuum).
    frequency : float
        Frequency of evaluation [Hz] (default 94 GHz).
    thickness : float
        Slab thickness [m] (Sionna's default 0.1 m).
    scattering_coefficient : float
        Sionna's S ∈ [0, 1]: ``R = sqrt(1 − S²)``.
    xpd_coefficient : float
        Sionna's K_x ∈ [0, 1] (recorded only).
    scattering_pattern : {"lambertian", "directive", "backscattering"}
        Sionna's pattern (module docstring for the mapping); ``lambertian`` with S > 0 warns.
    alpha_r, alpha_i, lambda_ : float
        Sionna's pattern parameters (α_R, α_I, λ; λ weighs the specular lobe).
    polarization : {"average", "te", "tm"}
        Reflectance of the scalar tracer.
    sigma0_db : float, optional
        Given σ⁰ of the direct backscatter, as :class:`DoubleLobe` (mitsar extension).
    name : str, optional
        Label for provenance.
    where : str
        Caller named in errors.

    Raises
    ------
    ParameterError
        Naming ``where`` and the parameter.
    """
    if itu_type is not None:
        if relative_permittivity is not None or conductivity is not None:
            raise ParameterError(where, "relative_permittivity",
                                 "no explicit permittivity or conductivity with an ITU 'type'",
                                 relative_permittivity if relative_permittivity is not None
                                 else conductivity)
        f = _as_real(where, "frequency", frequency, "a frequency > 0 Hz")
        relative_permittivity, conductivity = itu_properties(itu_type, f, where)
    s = _as_real(where, "scattering_coefficient", scattering_coefficient, "a value in [0, 1]")
    if not 0.0 <= s <= 1.0:
        raise ParameterError(where, "scattering_coefficient", "a value in [0, 1]",
                             scattering_coefficient)
    r2 = 1.0 - s * s
    lobes = _sionna_lobes(scattering_pattern, alpha_r, alpha_i, lambda_, where)
    if scattering_pattern == "lambertian" and s > 0.0:
        warnings.warn(f"{where}: Sionna's 'lambertian' scattering pattern is approximated by "
                      "the double lobe alpha_b = alpha_f = 1, backscatter_fraction = 0.5 "
                      "(docs/scenes.md); give scattering_pattern 'backscattering' or "
                      "'directive' for an exact mapping", stacklevel=2)
    params: dict[str, Any] = {
        **lobes,
        "reflection_reduction_db": 10.0 * math.log10(r2) if r2 > 0.0 else -math.inf,
        "lobe_normalisation": "joint",
        "relative_permittivity": 1.0 if relative_permittivity is None
        else relative_permittivity,
        "conductivity": 0.0 if conductivity is None else conductivity,
        "frequency": frequency, "thickness": thickness, "polarization": polarization,
        "xpd_coefficient": xpd_coefficient, "itu_type": itu_type, "sigma0_db": sigma0_db,
        "name": name if name is not None else (f"itu_{itu_type}" if itu_type else None),
    }
    return RadioMaterial.from_parameters(params, where=where)
