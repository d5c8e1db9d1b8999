"""The block kernel's receivers away from the transmitter: their bin and phase as the
transmitter's plus a polynomial in the sweep index (docs/interferometry.md §"Cost").

On a uniform chunk the antenna moves by one step ``s`` per sweep and a receiver at the body
offset ``b`` moves with it, so for a scatterer ``q`` the transmitter's range ``R(t) = |o(t)|``
and the receiver's ``R'(t) = |o(t) - b|``, ``o(t) = c + t h`` (``t`` in [-1, 1] over the
chunk's sweeps, ``h`` half the chunk's displacement), are analytic in ``t``. So are the
receiver's offsets from the transmitter's deposit: its phase
``Φ(t) = deposit_cycles(2P/c) - deposit_cycles(2R/c)``, ``P = (R + R')/2``
(:func:`mitsar.model.histogram.deposit_cycles`, :func:`mitsar.model.signal.half_path`), and its
bin position ``Δx(t) = (P - R + (f_c/K)(dP/dt - dR/dt)) / dr``
(:func:`mitsar.model.histogram.apparent_range`). :func:`receiver_offsets` interpolates both per
lane through their exact float64 values at the Chebyshev nodes of the chunk
(:data:`~.blocks.AMPLITUDE_NODES`, degree :data:`RECEIVER_DEGREE`); the kernel then adds two
Horner evaluations to the transmitter's bin and phase in place of the receiver's square root,
division and own phase chain. :func:`receiver_polynomial_bound` bounds the interpolation error
of a chunk rigorously; :func:`receiver_polynomial_holds` admits the chunk when the bound is
below :data:`RECEIVER_PHASE_TOLERANCE` and :data:`RECEIVER_BIN_TOLERANCE`, and the kernel
evaluates the exact half path per sweep otherwise.

**The bound.** Interpolation of degree ``n`` at the Chebyshev zeros errs by at most
``max|F^(n+1)| / (2^n (n+1)!)`` on [-1, 1] (the interpolation remainder with the node
polynomial ``T_{n+1}/2^n``: Mason & Handscomb, *Chebyshev Polynomials*, Chapman & Hall/CRC
2003, ch. 6), and Cauchy's estimate on a disc of radius ``r`` around each real ``t``, where
``|F| <= M``, gives ``|F^(n+1)(t)| <= (n+1)! M / r^(n+1)`` (Ahlfors, *Complex Analysis*, 3rd
ed., McGraw-Hill 1979, ch. 4 §2.3): together ``M / (2^n r^(n+1))``. With
``R_c`` the closest range of a candidate to the transmitter over the chunk, ``R_c' = R_c - |b|``,
``η = |h|`` and ``κ = r η / R_c' < √2 - 1``: ``|Q(t + w) / Q(t) - 1| <= ρ = 2κ + κ²`` for
``Q = |o|²`` (and for the receiver's), so both square roots are analytic on the disc with
``Re sqrt(Q) >= R(t) sqrt(1 - ρ)`` and ``|sqrt(Q)| <= R(t) + r η``. Then
``R' - R = (|b|² - 2 b.o) / (R' + R)`` is bounded by
``M_u = (|b|² + 2|b|(R_c + r η)) / ((2 R_c - |b|) sqrt(1 - ρ))``, the range rate's change
``v.o/R - v.o'/R'`` by ``2|v|(1 + κ)/sqrt(1 - ρ)``, and ``Φ = (R' - R)(f_c/c) -
rvp (2K/c²)(R (R' - R) + (R' - R)²/4)`` by ``(f_c/c) M_u + rvp (2K/c²)((R_f + r η) M_u +
M_u²/4)`` (``R_f`` the farthest range); ``κ`` is chosen on a grid to minimise the bound.
"""

from __future__ import annotations

import math
from types import SimpleNamespace
from typing import Any

import drjit as dr
import mitsuba as mi

from mitsar.model import histogram as hg
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.plugins.integrators.radar.constants import Constants

RECEIVER_DEGREE = 6
"""Degree of a receiver's bin and phase offsets in the sweep index over a chunk: the nodes are
the amplitude's (:data:`~.blocks.AMPLITUDE_NODES`). At the paper's geometry (5 cm baseline,
128 sweeps of 2 mm, candidates beyond 4 m) the bound is 3e-8 cycles and 1e-8 bins."""

RECEIVER_PHASE_TOLERANCE = 1e-6
"""Largest bound on a receiver's phase offset error [cycles] (6e-6 rad, against the 1 mrad of
issue 22's channel phases and the ~1e-5 rad of the block kernel's float32 advance) for which a
chunk takes the polynomial."""

RECEIVER_BIN_TOLERANCE = 1e-6
"""Largest bound on a receiver's bin offset error [bins] (the deposit's linear split moves by
as much of its amplitude) for which a chunk takes the polynomial."""

_KAPPAS = tuple(0.01 * i for i in range(1, 42))
"""Disc radii ``κ = r η / R_c'`` tried by :func:`receiver_polynomial_bound` (below √2 - 1)."""


def receiver_polynomial_bound(eta: float, closest: float, farthest: float, baseline: float,
                              speed: float, constants: Constants,
                              degree: int = RECEIVER_DEGREE) -> tuple[float, float]:
    """Rigorous bounds on the interpolation errors of a receiver's phase and bin offsets over a
    uniform chunk (the module's docstring derives them).

    Parameters
    ----------
    eta : float
        Half the antenna's displacement over the chunk, ``(sweeps - 1)/2 |s|`` [m].
    closest, farthest : float
        Smallest and largest range of a candidate from the transmitter over the chunk [m].
    baseline : float
        Largest distance of a receiver from the transmitter [m].
    speed : float
        The antenna's speed [m/s].
    constants : Constants
        The chunk's constants (``fc``, ``chirp_rate``, ``rvp``, ``inv_step``).
    degree : int
        The polynomials' degree.

    Returns
    -------
    phase, bins : float
        The bounds [cycles] and [bins]; infinite where no disc fits (``closest <= baseline``).
    """
    inner = closest - baseline
    if not inner > 0.0 or not closest > 0.0:
        return math.inf, math.inf
    if eta <= 0.0:  # a still antenna: the offsets are constant, the interpolation exact
        return 0.0, 0.0
    fc, rate = float(constants.value("fc")), float(constants.value("chirp_rate"))
    carrier = fc / SPEED_OF_LIGHT  # cycles per metre of R' - R (half of 2 f_c/c)
    quadratic = abs(float(constants.value("rvp"))) * 2.0 * rate / SPEED_OF_LIGHT**2
    doppler, inv_step = fc / rate, float(constants.value("inv_step"))
    best = (math.inf, math.inf)
    for kappa in _KAPPAS:
        radius = kappa * inner / eta
        rho = 2.0 * kappa + kappa * kappa
        root = math.sqrt(1.0 - rho)
        m_u = ((baseline * baseline + 2.0 * baseline * (closest + radius * eta))
               / ((2.0 * closest - baseline) * root))
        m_phase = carrier * m_u + quadratic * ((farthest + radius * eta) * m_u + 0.25 * m_u**2)
        m_rate = 2.0 * speed * (1.0 + kappa) / root
        m_bins = 0.5 * (m_u + doppler * m_rate) * inv_step
        factor = 1.0 / (2.0**degree * radius ** (degree + 1))
        if m_phase * factor < best[0]:
            best = (m_phase * factor, m_bins * factor)
    return best


def receiver_polynomial_holds(eta: float, closest: float, farthest: float, baseline: float,
                              speed: float, constants: Constants) -> bool:
    """Whether a uniform chunk's receivers take their offsets as polynomials
    (:func:`receiver_polynomial_bound` within :data:`RECEIVER_PHASE_TOLERANCE` and
    :data:`RECEIVER_BIN_TOLERANCE`; arguments as there)."""
    phase, bins = receiver_polynomial_bound(eta, closest, farthest, baseline, speed, constants)
    return phase <= RECEIVER_PHASE_TOLERANCE and bins <= RECEIVER_BIN_TOLERANCE


def receiver_offsets(o0: list[Any], receiver_o0: list[Any], step: list[Any],
                     velocity: list[Any], centre: Any, half: Any, constants: Constants,
                     nodes: tuple[float, ...], monomial: list[list[float]]
                     ) -> SimpleNamespace:
    """Per lane, the coefficients (Float32, in ``t``) of a receiver's bin offset [bins] and
    phase offset [cycles, less whole turns] from the transmitter's deposit.

    Parameters
    ----------
    o0, receiver_o0 : list of mi.Float64
        The scatterer less the transmitter's and the receiver's phase centre at the anchor
        sweep [m].
    step, velocity : list of mi.Float64
        The antenna's step per sweep [m] and velocity [m/s] over the chunk.
    centre, half : mi.Float64
        Sweep ``j = centre + half t`` (counted from the anchor) at ``t`` in [-1, 1].
    constants : Constants
    nodes, monomial : sequence
        The Chebyshev nodes in ``t`` and the inverse Vandermonde matrix of their polynomial
        (:data:`~.blocks.AMPLITUDE_NODES`, ``_MONOMIAL``).

    Returns
    -------
    SimpleNamespace
        ``bins`` and ``phase``: coefficients of ``t^0 .. t^degree``.
    """
    f32 = mi.Float
    doppler = constants["fc"] / constants["chirp_rate"]  # [s]: apparent range per range rate
    bins, phase = [], []
    for t in nodes:
        j = centre + half * t
        o = [a - j * s for a, s in zip(o0, step, strict=True)]
        o_rx = [a - j * s for a, s in zip(receiver_o0, step, strict=True)]
        r = dr.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
        r_rx = dr.sqrt(o_rx[0] * o_rx[0] + o_rx[1] * o_rx[1] + o_rx[2] * o_rx[2])
        half_change = 0.5 * (r_rx - r)  # P - R [m]
        # (dP/dt - dR/dt) with dR/dt = -(o.v)/R
        rate = 0.5 * (sum(a * v for a, v in zip(o, velocity, strict=True)) / r
                      - sum(a * v for a, v in zip(o_rx, velocity, strict=True)) / r_rx)
        bins.append((half_change + doppler * rate) * constants["inv_step"])
        # the exact change of the deposit phase (not a difference of two ~2e4-cycle values)
        phase.append(hg.deposit_cycles_change(half_change, r, constants, constants["rvp"]))
    turns = dr.round(phase[len(phase) // 2])  # whole turns dropped: |values| ~ 1 cycle
    phase = [value - turns for value in phase]
    return SimpleNamespace(
        bins=[f32(sum(row[i] * bins[i] for i in range(len(bins)))) for row in monomial],
        phase=[f32(sum(row[i] * phase[i] for i in range(len(phase)))) for row in monomial])


def horner(coefficients: list[Any], t: Any) -> Any:
    """``sum_p coefficients[p] t^p`` by Horner's rule (fma)."""
    value = coefficients[-1]
    for c in reversed(coefficients[:-1]):
        value = dr.fma(value, t, c)
    return value


__all__ = ["RECEIVER_BIN_TOLERANCE", "RECEIVER_DEGREE", "RECEIVER_PHASE_TOLERANCE", "horner",
           "receiver_offsets", "receiver_polynomial_bound", "receiver_polynomial_holds"]
