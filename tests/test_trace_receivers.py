"""The block kernel's receivers away from the transmitter (issue 22's cost): their bin and phase
offsets from the transmitter's deposit as degree-6 polynomials in the sweep index
(``mitsar/plugins/integrators/radar/receivers.py``), within a rigorous bound.

Closed forms: the receiver's phase offset is ``deposit_cycles(2P/c) - deposit_cycles(2R/c)``
with ``P = (|o| + |o - b|)/2`` and ``R = |o|`` (paper eq. 1, docs/design.md §5.5), its bin
offset ``(P - R + (f_c/K)(dP/dt - dR/dt)) / dr`` (the apparent range,
docs/design.md §5.5); the interpolation error bound is Chebyshev's with Cauchy's estimate
(the module's docstring).
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.model import histogram as hg
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.plugins.integrators.radar import backscatter
from mitsar.plugins.integrators.radar.blocks import _MONOMIAL, AMPLITUDE_DEGREE, AMPLITUDE_NODES
from mitsar.plugins.integrators.radar.receivers import (
    RECEIVER_DEGREE,
    receiver_polynomial_bound,
    receiver_polynomial_holds,
)

RADAR = mitsar.Radar()
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
STEP = 0.5 / RADAR.prf  # the paper's 0.5 m/s at 250 Hz [m per sweep]
BIN = hg.range_step(RADAR, 16)  # [m]


class _Values:
    """What the bound reads of the kernel's constants (``Constants.value``)."""

    def __init__(self, rvp: float = 1.0) -> None:
        self._values = {"fc": RADAR.carrier_frequency, "chirp_rate": RADAR.chirp_rate,
                        "rvp": rvp, "inv_step": 1.0 / BIN}

    def value(self, name: str) -> float:
        return self._values[name]


def _offsets(o: np.ndarray, b: np.ndarray, v: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """Exact phase [cycles] and bin offsets of a receiver at ``b`` for scatterer vectors ``o``
    (..., 3) from the transmitter, antenna velocity ``v``."""
    r = np.linalg.norm(o, axis=-1)
    r_rx = np.linalg.norm(o - b, axis=-1)
    path = 0.5 * (r + r_rx)
    phase = (hg.deposit_cycles(2.0 * path / SPEED_OF_LIGHT, RADAR)
             - hg.deposit_cycles(2.0 * r / SPEED_OF_LIGHT, RADAR))
    rate = 0.5 * (-((o - b) @ v) / r_rx + (o @ v) / r)  # dP/dt - dR/dt, dR/dt = -o.v/R
    bins = (path - r + RADAR.carrier_frequency / RADAR.chirp_rate * rate) / BIN
    return phase, bins


def _interpolation_error(centre: np.ndarray, half_step: np.ndarray, b: np.ndarray,
                         v: np.ndarray) -> tuple[float, float]:
    """Largest error of the degree-6 interpolants through the Chebyshev nodes (as the kernel
    takes them) on a dense grid of t in [-1, 1], for ``o(t) = centre - t half_step``."""
    def at(t: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
        return _offsets(centre - t[:, None] * half_step, b, v)

    nodes = np.asarray(AMPLITUDE_NODES)
    dense = np.linspace(-1.0, 1.0, 2001)
    errors = []
    for exact_nodes, exact_dense in zip(at(nodes), at(dense), strict=True):
        coefficients = np.asarray(_MONOMIAL) @ exact_nodes
        errors.append(float(np.max(np.abs(np.polynomial.polynomial.polyval(dense, coefficients)
                                          - exact_dense))))
    return errors[0], errors[1]


def test_receiver_degree_is_the_amplitude_nodes_degree():
    """The kernel interpolates through the amplitude's nodes: the bound's degree is theirs."""
    assert RECEIVER_DEGREE == AMPLITUDE_DEGREE == len(AMPLITUDE_NODES) - 1


@pytest.mark.parametrize("closest, sweeps, baseline", [
    (0.6, 128, 0.05), (1.0, 128, 0.05), (1.5, 128, 0.2), (4.5, 128, 0.05), (2.0, 64, 0.5)])
def test_bound_holds_against_the_exact_offsets(closest, sweeps, baseline):
    """For scatterers at the chunk's closest range in several directions (ahead, abeam, below,
    oblique) and receivers along every axis, the interpolants' largest error on a dense grid
    stays below :func:`receiver_polynomial_bound`; the near cases have errors far above
    rounding (1e-9 cycles and more), so a bound too small would fail."""
    half = 0.5 * (sweeps - 1) * STEP
    velocity = np.array([0.5, 0.0, 0.0])
    half_step = half * velocity / np.linalg.norm(velocity)
    largest = [0.0, 0.0]
    bounds = receiver_polynomial_bound(half, closest, closest + 2 * half, baseline, 0.5,
                                       _Values())
    for direction in ([0.3, 1.0, -0.8], [0.0, 1.0, 0.0], [0.0, 0.0, -1.0], [1.0, 0.2, -0.3]):
        direction = np.asarray(direction) / np.linalg.norm(direction)
        # the chunk's closest point is at `closest` from the line of antenna positions
        centre = direction * (closest + half)
        for axis in np.eye(3):
            errors = _interpolation_error(centre, half_step, baseline * axis, velocity)
            largest = [max(a, e) for a, e in zip(largest, errors, strict=True)]
    assert largest[0] <= bounds[0] and largest[1] <= bounds[1]
    if closest < 1.2:  # the near chunks: errors measurable, so the check above has teeth
        assert largest[0] > 1e-9


def test_the_paper_geometry_takes_the_polynomial_and_near_chunks_do_not():
    """128 sweeps of 2 mm, a 5 cm baseline: candidates beyond ~2.5 m take the polynomial
    (bound < 1e-6 cycles and bins), nearer ones the exact half path."""
    half = 63.5 * STEP
    assert receiver_polynomial_holds(half, 4.4, 10.5, 0.05, 0.5, _Values())
    assert not receiver_polynomial_holds(half, 1.0, 10.5, 0.05, 0.5, _Values())
    assert not receiver_polynomial_holds(half, 0.04, 10.5, 0.05, 0.5, _Values())
    assert receiver_polynomial_bound(0.0, 4.4, 10.5, 0.05, 0.5, _Values()) == (0.0, 0.0)


def test_traced_receiver_offsets_equal_the_exact_half_path(monkeypatch):
    """The canned room (60 scatterers per m², 150 sweeps: chunks of 128 + 22), two receivers
    5 cm apart: the polynomial's traced raw data against the kernel's exact half path per
    sweep (the polynomial refused) within -110 dB (measured -125 dB; the bound's 1e-6 cycles
    is -104 dB at worst), channel 0 bit for bit."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 150.5 / RADAR.prf)
    radar = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.05)])
    options = {"density": 60.0, "seed": 2}
    original, taken = backscatter.receiver_polynomial_holds, []  # each chunk's decision
    monkeypatch.setattr(backscatter, "receiver_polynomial_holds",
                        lambda *args: taken.append(original(*args)) or taken[-1])
    polynomial = mitsar.simulate_scene(radar, track, LOOK, "control_volume", **options)
    assert taken and all(taken)
    monkeypatch.setattr(backscatter, "receiver_polynomial_holds", lambda *args: False)
    exact = mitsar.simulate_scene(radar, track, LOOK, "control_volume", **options)
    assert np.array_equal(polynomial["raw"].values[0], exact["raw"].values[0])
    reference = exact["raw"].values[1]
    error = np.sum(np.abs(polynomial["raw"].values[1] - reference) ** 2)
    assert 10 * np.log10(error / np.sum(np.abs(reference) ** 2)) < -110
