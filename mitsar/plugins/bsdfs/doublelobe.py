"""Mitsuba BSDF ``doublelobe``: the double-lobe radar material (paper eqs. 8-11, docs/design.md
§5.3).

XML parameters (all optional; a ``preset`` gives the base values, explicit ones override it)::

    <bsdf type="doublelobe" id="concrete">
        <string name="preset" value="concrete_94ghz_paper"/>
        <float  name="transmission_loss_db"    value="-7.0"/>   <!-- P_L/P_i [dB] <= 0 -->
        <float  name="reflection_reduction_db" value="-7.5"/>   <!-- 20 log10 R [dB] <= 0 -->
        <float  name="backscatter_fraction"    value="0.1"/>    <!-- Λ in [0, 1] -->
        <float  name="alpha_b" value="6"/>   <float name="alpha_f" value="3"/>
        <float  name="sigma0_db" value="-20"/>  <!-- or <string ... value="none"/> -->
        <string name="sigma0_law" value="constant"/>            <!-- or "lambert" -->
        <string name="lobe_normalisation" value="joint"/>       <!-- or "separate" -->
    </bsdf>

Unknown parameters and out-of-range values raise :class:`~mitsar.errors.ParameterError` naming
``doublelobe '<id>'`` and the parameter.

Mitsuba semantics (two-sided; local frame, normal +z, ``wi`` towards the source):

- component 0, ``DeltaReflection``: specular reflection, power ``Γ² R²``;
- component 1, ``GlossyReflection``: backscatter lobe around ``wi``;
- component 2, ``GlossyReflection``: forward lobe around the mirror direction of ``wi``.

``eval`` returns ``Γ² S² f(wi, wo)`` (BSDF × cos θ_o), so that ∫ eval dω_o = Γ² S²; the
bistatic scattering coefficient is ``σ⁰ = 4π cos θ_i · eval`` (docs/design.md §5.3). ``sample``
picks a
component with probability proportional to its power (``R²``, ``S² share_B``, ``S² share_F``),
draws a glossy direction from ``((1+cos ψ)/2)^α`` about the lobe axis (full sphere; directions
below the surface are rejected with weight 0), and weights glossy samples with the one-sample MIS
estimate ``eval / pdf`` where ``pdf`` is the mixture density of both lobes; the specular sample
has weight ``Γ² R² / P_spec``. The expected weight is Γ² (checked in the tests).

The integrator reads the material through the Python attributes of the plugin instance that
``shape.bsdf()`` returns: ``material`` (a :class:`mitsar.model.doublelobe.DoubleLobe`) and the
Dr.Jit methods :meth:`sigma0_monostatic`, :meth:`sigma0_monostatic_model` and
:meth:`sigma0_bistatic`, which call the same generic formulas as the NumPy module.
"""

from __future__ import annotations

import math
from typing import Any

import drjit as dr
import mitsuba as mi

from mitsar.model import doublelobe as dl
from mitsar.model.doublelobe import DoubleLobe
from mitsar.plugins import PerVariant, plugin_where, read_properties
from mitsar.plugins.kind import PluginKind
from mitsar.plugins.ops import DRJIT_OPS

PLUGIN_NAME = "doublelobe"
"""XML type name."""

PARAMETERS: tuple[str, ...] = ("preset", "transmission_loss_db", "reflection_reduction_db",
                               "backscatter_fraction", "alpha_b", "alpha_f", "sigma0_db",
                               "sigma0_law", "lobe_normalisation")
"""Accepted XML parameters."""

_TRAVERSED = ("transmission_loss_db", "reflection_reduction_db", "backscatter_fraction",
              "alpha_b", "alpha_f")




def _flip_to_front(wi: Any, wo: Any) -> tuple[Any, Any]:
    """Two-sided: mirror both directions so that ``wi`` is on the +z side."""
    sign = dr.select(wi.z < 0.0, -1.0, 1.0)
    return (mi.Vector3f(wi.x, wi.y, wi.z * sign), mi.Vector3f(wo.x, wo.y, wo.z * sign))


def _make_class() -> type:
    """Create the BSDF class for the active variant (classes are tied to a variant)."""

    class DoubleLobeBSDF(mi.BSDF):
        """Double-lobe radar material (see the module docstring)."""

        PLUGIN_KIND = PluginKind.DOUBLELOBE

        def __init__(self, props: Any) -> None:
            mi.BSDF.__init__(self, props)
            self._where = plugin_where(PLUGIN_NAME, props)
            values = read_properties(props, self._where, PARAMETERS)
            self.material: DoubleLobe = DoubleLobe.from_parameters(values, where=self._where)
            self._init_components()

        def _init_components(self) -> None:
            """Flags of the three components and the derived state (after ``self.material``)."""
            glossy = mi.BSDFFlags.GlossyReflection | mi.BSDFFlags.FrontSide \
                | mi.BSDFFlags.BackSide
            delta = mi.BSDFFlags.DeltaReflection | mi.BSDFFlags.FrontSide | mi.BSDFFlags.BackSide
            self.m_components = [delta, glossy, glossy]
            self.m_flags = delta | glossy
            self._setup()

        # ---- state ---------------------------------------------------------------------

        def _setup(self) -> None:
            """Derived constants and Dr.Jit tables from ``self.material``."""
            m = self.material
            for name in _TRAVERSED:
                setattr(self, name, mi.Float(getattr(m, name)))
            self._gamma2 = m.gamma2
            self._r2 = m.reflection**2
            self._s2 = m.scattering**2
            self._tables = {}
            for alpha in {m.alpha_b, m.alpha_f}:
                if not dl.is_closed_form(alpha):
                    self._tables[alpha] = mi.Float(dl.lobe_integral_table(alpha))

        def _gamma2_at(self, cos_theta_i: Any) -> Any:
            """``Γ²`` at ``cos_theta_i``: a constant here; Fresnel materials override it."""
            return self._gamma2

        def _lobe_integral(self, alpha: float, cos_theta_i: Any) -> Any:
            return dl.lobe_integral(alpha, cos_theta_i, DRJIT_OPS,
                                    table=self._tables.get(alpha), table_size=dl.TABLE_SIZE)

        def _weights(self, cos_theta_i: Any) -> tuple[Any, Any, Any, Any]:
            """``(w_B, w_F, share_B, share_F)`` at ``cos_theta_i``."""
            m = self.material
            f_b = self._lobe_integral(m.alpha_b, cos_theta_i)
            f_f = self._lobe_integral(m.alpha_f, cos_theta_i)
            w_b, w_f = dl.lobe_weights(m.backscatter_fraction, f_b, f_f, m.lobe_normalisation)
            return w_b, w_f, w_b * f_b, w_f * f_f

        def _selection(self, ctx: Any, share_b: Any, share_f: Any) -> tuple[Any, Any, Any]:
            """Probabilities of picking (specular, back lobe, forward lobe)."""
            p_s = self._r2 if ctx.is_enabled(mi.BSDFFlags.DeltaReflection, 0) else 0.0
            p_b = self._s2 * share_b if ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1) \
                else 0.0 * share_b
            p_f = self._s2 * share_f if ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 2) \
                else 0.0 * share_f
            total = p_s + p_b + p_f
            inv = dr.select(total > 0.0, dr.rcp(total), 0.0)
            return p_s * inv, p_b * inv, p_f * inv

        def _glossy(self, ctx: Any, wi: Any, wo: Any) -> tuple[Any, Any]:
            """``(eval, pdf)`` of the enabled glossy lobes for front-side ``wi``, ``wo``."""
            m = self.material
            w_b, w_f, share_b, share_f = self._weights(wi.z)
            _, p_b, p_f = self._selection(ctx, share_b, share_f)
            if not ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 1):
                w_b = 0.0 * w_b
            if not ctx.is_enabled(mi.BSDFFlags.GlossyReflection, 2):
                w_f = 0.0 * w_f
            cos_b = dr.dot(wo, wi)
            cos_f = dr.dot(wo, mi.reflect(wi))
            f = dl.double_lobe_pattern(cos_b, cos_f, w_b, w_f, m.alpha_b, m.alpha_f, DRJIT_OPS)
            value = self._gamma2_at(wi.z) * self._s2 * f
            pdf = (p_b * dl.lobe_sampling_pdf(cos_b, m.alpha_b, DRJIT_OPS)
                   + p_f * dl.lobe_sampling_pdf(cos_f, m.alpha_f, DRJIT_OPS))
            valid = (wi.z > 0.0) & (wo.z > 0.0)
            return dr.select(valid, value, 0.0), dr.select(valid, pdf, 0.0)

        # ---- mi.BSDF interface ----------------------------------------------------------

        def eval(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            wi, wo_f = _flip_to_front(si.wi, wo)
            value, _ = self._glossy(ctx, wi, wo_f)
            return mi.Spectrum(dr.select(active, value, 0.0))

        def pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            wi, wo_f = _flip_to_front(si.wi, wo)
            _, pdf = self._glossy(ctx, wi, wo_f)
            return dr.select(active, pdf, 0.0)

        def eval_pdf(self, ctx: Any, si: Any, wo: Any, active: Any = True) -> Any:
            wi, wo_f = _flip_to_front(si.wi, wo)
            value, pdf = self._glossy(ctx, wi, wo_f)
            return mi.Spectrum(dr.select(active, value, 0.0)), dr.select(active, pdf, 0.0)

        def sample(self, ctx: Any, si: Any, sample1: Any, sample2: Any,
                   active: Any = True) -> Any:
            m = self.material
            sign = dr.select(si.wi.z < 0.0, -1.0, 1.0)
            wi = mi.Vector3f(si.wi.x, si.wi.y, si.wi.z * sign)
            _, _, share_b, share_f = self._weights(wi.z)
            p_s, p_b, _ = self._selection(ctx, share_b, share_f)

            pick_s = sample1 < p_s
            pick_b = ~pick_s & (sample1 < p_s + p_b)
            mirror = mi.reflect(wi)
            axis = dr.select(pick_b, wi, mirror)
            alpha = dr.select(pick_b, mi.Float(m.alpha_b), mi.Float(m.alpha_f))
            cos_psi = dl.lobe_sample_cos_psi(sample2.x, alpha, DRJIT_OPS)
            sin_psi = dr.sqrt(dr.maximum(1.0 - cos_psi * cos_psi, 0.0))
            sin_phi, cos_phi = dr.sincos(2.0 * math.pi * sample2.y)
            local = mi.Vector3f(sin_psi * cos_phi, sin_psi * sin_phi, cos_psi)
            wo_glossy = mi.Frame3f(axis).to_world(local)
            value, pdf_glossy = self._glossy(ctx, wi, wo_glossy)

            wo = dr.select(pick_s, mirror, wo_glossy)
            pdf = dr.select(pick_s, p_s, pdf_glossy)
            weight = dr.select(pick_s, self._gamma2_at(wi.z) * self._r2 * dr.rcp(p_s),
                               value * dr.rcp(pdf_glossy))
            valid = active & (wi.z > 0.0) & (wo.z > 0.0) & (pdf > 0.0)

            bs = dr.zeros(mi.BSDFSample3f)
            bs.wo = mi.Vector3f(wo.x, wo.y, wo.z * sign)
            bs.pdf = dr.select(valid, pdf, 0.0)
            bs.eta = 1.0
            bs.sampled_type = dr.select(pick_s, mi.UInt32(+mi.BSDFFlags.DeltaReflection),
                                        mi.UInt32(+mi.BSDFFlags.GlossyReflection))
            bs.sampled_component = dr.select(pick_s, mi.UInt32(0),
                                             dr.select(pick_b, mi.UInt32(1), mi.UInt32(2)))
            return bs, mi.Spectrum(dr.select(valid, weight, 0.0))

        def traverse(self, callback: Any) -> None:
            for name in _TRAVERSED:
                callback.put(name, getattr(self, name), mi.ParamFlags.NonDifferentiable)

        def parameters_changed(self, keys: Any = None) -> None:
            values = {name: float(getattr(self, name)[0]) for name in _TRAVERSED}
            self.material = DoubleLobe.from_parameters({**self.material.to_dict(), **values},
                                                       where=self._where)
            self._setup()

        def to_string(self) -> str:
            m = self.material
            return (f"DoubleLobeBSDF[name={m.name!r}, "
                    f"transmission_loss_db={m.transmission_loss_db:g}, "
                    f"reflection_reduction_db={m.reflection_reduction_db:g}, "
                    f"backscatter_fraction={m.backscatter_fraction:g}, "
                    f"alpha_b={m.alpha_b:g}, alpha_f={m.alpha_f:g}, sigma0_db={m.sigma0_db}, "
                    f"sigma0_law={m.sigma0_law!r}, "
                    f"lobe_normalisation={m.lobe_normalisation!r}]")

        # ---- radar queries (Dr.Jit, same formulas as mitsar.model.doublelobe) -----------------

        def sigma0_monostatic_model(self, cos_theta_i: Any) -> Any:
            """Monostatic σ⁰ of the lobe model, ``4π Γ² S² cos θ_i (w_B + w_F cos^2α_F θ_i)``.

            Parameters
            ----------
            cos_theta_i : mi.Float
                Incidence cosine (either side) [-].

            Returns
            -------
            mi.Float
                σ⁰ [m²/m²].
            """
            m = self.material
            c = dr.minimum(dr.abs(mi.Float(cos_theta_i)), 1.0)
            w_b, w_f, _, _ = self._weights(c)
            f = dl.double_lobe_pattern(1.0, 2.0 * c * c - 1.0, w_b, w_f, m.alpha_b, m.alpha_f,
                                       DRJIT_OPS)
            sigma0 = dl.sigma0_from_pattern(self._gamma2_at(c) * self._s2, c, f)
            return dr.select(c > 0.0, sigma0, 0.0)

        def sigma0_monostatic(self, cos_theta_i: Any) -> Any:
            """σ⁰ [m²/m²] of the direct backscatter at incidence cosine ``cos_theta_i`` (either
            side): the given ``sigma0_db`` with its law, or :meth:`sigma0_monostatic_model`."""
            m = self.material
            if m.sigma0_db is None:
                return self.sigma0_monostatic_model(cos_theta_i)
            c = dr.abs(mi.Float(cos_theta_i))
            return dl.sigma0_from_law(m.sigma0_linear, m.sigma0_law, c, DRJIT_OPS)

        def sigma0_bistatic(self, wi: Any, wo: Any) -> Any:
            """Bistatic σ⁰ of the lobe model, ``4π cos θ_i Γ² S² f(wi, wo)`` [m²/m²].

            Parameters
            ----------
            wi, wo : mi.Vector3f
                Local-frame directions (normal +z), both pointing away from the surface.
            """
            wi_f, wo_f = _flip_to_front(wi, wo)
            value, _ = self._glossy(mi.BSDFContext(), wi_f, wo_f)
            return 4.0 * math.pi * wi_f.z * value

    return DoubleLobeBSDF


bsdf_class = PerVariant(_make_class)
"""The BSDF class for the active variant (created once per variant)."""


def register() -> None:
    """Register ``doublelobe`` for the active Mitsuba variant."""
    cls = bsdf_class()
    mi.register_bsdf(PLUGIN_NAME, lambda props: cls(props))
