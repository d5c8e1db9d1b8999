"""The double-lobe radar material: parameters, presets, power split and σ⁰ (paper eqs. 8-11).

:class:`DoubleLobe` holds the parameters of :mod:`mitsar.model.doublelobe.pattern` and evaluates
the pattern and σ⁰ with NumPy. A material may instead carry a given ``sigma0_db`` for the direct
(monostatic) backscatter, as the paper does (σ⁰ = -20 dB, §4.2).
:func:`monostatic_sigma0_table` tabulates that σ⁰ for the radar integrator's kernel.
"""

from __future__ import annotations

import dataclasses
import functools
import math
from collections.abc import Mapping, Sequence
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np

from mitsar.checks import MAX_LEVEL_DB
from mitsar.errors import ParameterError
from mitsar.model.doublelobe.lobes import (
    _FOUR_PI,
    ALPHA_MAX,
    TABLE_SIZE,
    lobe_integral,
    theta_table_cosines,
)
from mitsar.model.doublelobe.pattern import (
    backscatter_fraction_from_sionna,
    double_lobe_pattern,
    lobe_weights,
    scattering_cosines,
    sigma0_from_law,
    sigma0_from_pattern,
    sionna_lambda_from_backscatter_fraction,
)

__all__ = [
    "DoubleLobe",
    "LOBE_NORMALISATIONS",
    "PRESETS",
    "PowerSplit",
    "SIGMA0_LAWS",
    "bistatic_lobe_tables",
    "monostatic_sigma0_table",
    "preset_names",
    "specular_field_table",
]

SIGMA0_LAWS = ("constant", "lambert")
"""Angular laws of a given ``sigma0_db``: constant, or ``σ⁰(0) cos² θ_i`` (Lambert)."""

LOBE_NORMALISATIONS = ("joint", "separate")
"""``"joint"``: Degli-Esposti 2007 / docs/design.md §5.3; ``"separate"``: Λ is the back-lobe
power."""


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
  gives no lobe widths, α_B = 6 and α_F = 3 are docs/design.md §5.3's choice. σ⁰ from the model
  (monostatic ≈ -0.2 dB at 35°).
- ``concrete_94ghz_paper``: the same with the paper's σ⁰ = -20 dB (constant) for the direct
  backscatter (§4.2); reflections and bistatic scattering still follow the lobes.
- ``absorber``: everything is lost (Γ = 0).
- ``mirror``: lossless perfect specular reflector (Γ = R = 1).
"""


def preset_names() -> list[str]:
    """Names of the material presets, sorted."""
    return sorted(PRESETS)


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
    """Double-lobe radar material (paper eqs. 8-11, Degli-Esposti 2007, docs/design.md §5.3).

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
            expected = f"None or a level in dB <= {MAX_LEVEL_DB:g} (finite or -inf)"
            value = _as_real(where, "sigma0_db", self.sigma0_db, expected)
            if math.isnan(value) or value > MAX_LEVEL_DB:
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

    def gamma2_at(self, cos_theta_i: Any) -> Any:
        """``Γ²`` at incidence cosine ``cos_theta_i`` [-].

        The double-lobe material's Γ does not depend on the incidence: this returns the float
        :attr:`gamma2` (it broadcasts). Materials with a Fresnel reflection
        (:class:`~mitsar.model.doublelobe.radio.RadioMaterial`) return an array.
        """
        return self.gamma2

    def scattered_fraction_at(self, cos_theta_i: Any) -> Any:
        """``Γ²(θ_i) S²``, the fraction scattered into the two lobes at ``cos_theta_i`` [-]."""
        return self.gamma2_at(cos_theta_i) * self.scattering**2

    def specular_field(self, cos_theta_i: Any) -> Any:
        """Specular field factor ``Γ(θ_i) R`` of a reflection at ``cos_theta_i`` [-].

        What the ray tracer multiplies a ray's field by at each specular reflection
        (docs/design.md §5.4), through :func:`specular_field_table`.
        """
        return np.sqrt(self.gamma2_at(cos_theta_i)) * self.reflection

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
        gamma2 = self.gamma2_at(cos_theta_i)
        scattered = gamma2 * self.scattering**2
        return PowerSplit(specular=gamma2 * self.reflection**2, back=scattered * share_b,
                          forward=scattered * share_f, loss=1.0 - gamma2)

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
        return sigma0_from_pattern(self.scattered_fraction_at(cos_i), cos_i,
                                   self.pattern(k_i, k_s, normal))

    def sigma0_monostatic_model(self, cos_theta_i: Any) -> np.ndarray:
        """Monostatic σ⁰ of the lobe model (``k_s = -k_i``) [m²/m²].

        ``cos ψ_B = 1`` and ``cos ψ_F = cos 2θ_i``, so ``f = w_B + w_F cos^(2α_F) θ_i``.
        """
        c = np.clip(np.abs(np.asarray(cos_theta_i, dtype=np.float64)), 0.0, 1.0)
        w_b, w_f = self.weights(c)
        f = double_lobe_pattern(1.0, 2.0 * c * c - 1.0, w_b, w_f, self.alpha_b, self.alpha_f)
        return np.where(c > 0.0, sigma0_from_pattern(self.scattered_fraction_at(c), c, f), 0.0)

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
        return self.scattered_fraction_at(np.abs(wi[..., 2])) * self.pattern(-wi, wo, normal)


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
    cos_theta = theta_table_cosines(n)
    out = np.zeros((len(materials), n))
    for row, material in enumerate(materials):
        if material is not None:
            out[row] = material.sigma0_monostatic(cos_theta)
    return out


def bistatic_lobe_tables(materials: Sequence[DoubleLobe], n: int = TABLE_SIZE
                         ) -> tuple[np.ndarray, np.ndarray, np.ndarray, np.ndarray]:
    """Stacked tables of the scaled lobe weights for a kernel's bistatic σ⁰ (paper eq. 11).

    With these, ``σ⁰ = cos θ_i [W_B lobe(ψ_B)^α_B + W_F lobe(ψ_F)^α_F]`` is
    :func:`~mitsar.model.doublelobe.pattern.double_lobe_pattern` with weights ``W = 4π Γ² S² w``
    (:func:`~mitsar.model.doublelobe.pattern.sigma0_from_pattern` with the constant folded in).

    Parameters
    ----------
    materials : sequence of DoubleLobe
        One row per material (at least one row is returned: zeros when the sequence is empty).
    n : int
        Nodes per table, uniform in θ_i (:func:`theta_table_cosines`).

    Returns
    -------
    w_b, w_f : numpy.ndarray, shape (rows, n)
        ``4π Γ² S² w_B,F(θ_i)`` [1/sr].
    alpha_b, alpha_f : numpy.ndarray, shape (rows,)
        Lobe exponents (1 for the empty row).
    """
    rows = max(1, len(materials))
    cos_theta = np.maximum(theta_table_cosines(n), 1e-6)
    w_b, w_f = np.zeros((rows, n)), np.zeros((rows, n))
    alpha_b, alpha_f = np.ones(rows), np.ones(rows)
    for row, material in enumerate(materials):
        weight_b, weight_f = material.weights(cos_theta)
        scattered = material.scattered_fraction_at(cos_theta)
        w_b[row] = _FOUR_PI * scattered * weight_b
        w_f[row] = _FOUR_PI * scattered * weight_f
        alpha_b[row], alpha_f[row] = material.alpha_b, material.alpha_f
    return w_b, w_f, alpha_b, alpha_f


def specular_field_table(materials: Sequence[DoubleLobe | None], n: int = TABLE_SIZE
                         ) -> np.ndarray:
    """Stacked tables of the specular field factor ``Γ(θ_i) R``, uniform in θ_i ∈ [0, π/2].

    The ray tracer's reflection step gathers from these with :func:`interp_theta_table`
    (``offset = row * n``), so a material whose Γ depends on the incidence (a Fresnel
    reflection, :class:`~mitsar.model.doublelobe.radio.RadioMaterial`) and one whose Γ does not
    take the same path; a constant row interpolates exactly. ``None`` rows are 0 (the ray
    stops).

    Parameters
    ----------
    materials : sequence of DoubleLobe or None
        One entry per table.
    n : int
        Nodes per table.

    Returns
    -------
    numpy.ndarray
        Shape ``(len(materials), n)`` [-].
    """
    cos_theta = theta_table_cosines(n)
    out = np.zeros((len(materials), n))
    for row, material in enumerate(materials):
        if material is not None:
            out[row] = material.specular_field(cos_theta)
    return out
