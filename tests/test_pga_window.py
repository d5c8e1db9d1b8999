"""PGA's window (mitsar.focus.autofocus.pga.energy_window) and its stopping floor against
closed forms: a focused point's sinc^2 energy, a quadratic phase error's stationary-phase
spread, and the spread of an ML phase-gradient estimate of noisy lines."""

from __future__ import annotations

import numpy as np
import pytest
from scipy.optimize import brentq
from scipy.special import sici

from mitsar.focus.autofocus.pga import _noise_floor, energy_window
from mitsar.focus.autofocus.phase import integrate_gradient, remove_linear_phase

SAMPLES = 256  # sweeps of the aperture
POINTS = 2  # line points per resolution cell (PGA's default oversampling)


def _line(phase):
    """Centred intensity of a unit point seen through a rectangular aperture of SAMPLES
    sweeps with the phase error ``phase`` (the azimuth line, sampled at POINTS a cell)."""
    spectrum = np.fft.fftshift(np.fft.fft(np.exp(1j * phase), POINTS * SAMPLES))
    return np.abs(spectrum) ** 2


def _sinc2_energy(w):
    """Share of sinc^2's energy within +-w cells, F(w) = (2/pi) [Si(2 pi w) - sin^2(pi w) /
    (pi w)] (integration by parts of sin^2(pi x) / (pi x)^2)."""
    return 2 / np.pi * (sici(2 * np.pi * w)[0] - np.sin(np.pi * w) ** 2 / (np.pi * w))


def _held(line, points):
    """Share of a centred line's energy within +-points of its centre (no floor)."""
    offset = np.abs(np.arange(len(line)) - len(line) // 2)
    return line[offset <= points].sum() / line.sum()


def test_the_sinc2_closed_form():
    """F(1) = (2/pi) Si(2 pi) = 0.9028 (90.3 % within the first nulls), F = 0.95 at 2.07
    cells and 0.99 at 10.3 (1 - F(w) ~ 1 / (pi^2 w)); the focused line (a Dirichlet kernel
    sampled at two points a cell) holds F(w) within 0.005 at those widths."""
    assert _sinc2_energy(1.0) == pytest.approx(0.9028, abs=1e-4)
    line = _line(np.zeros(SAMPLES))
    for fraction, cells in ((0.95, 2.0729), (0.99, 10.2858)):
        assert brentq(lambda w, f=fraction: _sinc2_energy(w) - f, 1.5, 50) == pytest.approx(
            cells, abs=1e-3)
    for cells in (1.0, 2.0, 10.0):
        assert _held(line, POINTS * cells) == pytest.approx(_sinc2_energy(cells), abs=0.005)


@pytest.mark.parametrize("fraction", [0.95, 0.99])
def test_a_focused_point_gets_the_width_of_its_sinc2_energy(fraction):
    """No phase error: the window holds ``fraction`` of the focused line (F(w) above), less
    the part of its tail the floor (taken over the outer half of the line) removes: the
    smallest width with that share is 3 and 21 points (1.5 and 10.5 cells); the floor takes
    the tail's 0.3 % beyond the inner half, which at 99 % (1 - F ~ 1 / (pi^2 w)) is worth 2
    cells: within one cell or 20 %. Speckle clutter 35 dB under the peak on every line
    (independent from line to line) is removed by the floor: the width stays as clean (at
    25 dB the last percent wanders with the clutter: the 99 % width doubles, wider, not
    narrower)."""
    line = _line(np.zeros(SAMPLES))
    lines = np.tile(line, (8, 1))
    expected = next(w for w in range(SAMPLES) if _held(line, w) >= fraction)
    bound = max(POINTS, 0.2 * expected)
    assert abs(energy_window(lines, fraction) - expected) <= bound
    rng = np.random.default_rng(11)
    clutter = rng.exponential(line.max() * 10 ** -3.5, lines.shape)
    assert abs(energy_window(lines + clutter, fraction) - expected) <= bound
    assert energy_window(lines + clutter * 10, fraction) >= expected - bound


@pytest.mark.parametrize("q", [20.0, 40.0])
def test_a_quadratic_error_gets_its_stationary_phase_spread(q):
    """q u^2 over u in [-1, 1] sends sweep u to 2 q u / pi cells: the energy lies evenly over
    +-2 q / pi cells (12.7 and 25.5), so 95 % of it within 0.95 of that, to about a cell (the
    Fresnel edges and the one-cell blur of the aperture)."""
    u = np.linspace(-1, 1, SAMPLES, endpoint=False) + 1 / SAMPLES
    window = energy_window(_line(q * u**2)[None, :], 0.95) / POINTS
    assert window == pytest.approx(0.95 * 2 * q / np.pi, abs=1.0)


def test_the_noise_floor_is_the_spread_of_the_integrated_ml_gradient():
    """P lines whose sweep-to-sweep phase differences scatter by sigma about a common
    gradient: the ML gradient scatters by sigma / sqrt(P), and its integral stripped of a line
    by sqrt(sigma^2 S / (15 P)); the floor predicts the update rms of 200 such draws within
    10 %."""
    rng = np.random.default_rng(2)
    sweeps, lines, sigma = 300, 12, 0.3
    coverage = np.ones(sweeps)
    predicted, measured = [], []
    for _ in range(200):
        truth = rng.normal(0, 0.5, sweeps - 1)
        pairs = np.exp(1j * (truth[:, None] + rng.normal(0, sigma, (sweeps - 1, lines))))
        predicted.append(_noise_floor(pairs, coverage))
        error = np.angle(pairs.sum(axis=1) * np.exp(-1j * truth))
        measured.append(np.sqrt(np.mean(remove_linear_phase(integrate_gradient(error)) ** 2)))
    assert np.mean(predicted) == pytest.approx(sigma * np.sqrt(sweeps / (12 * lines)), rel=0.05)
    assert np.sqrt(np.mean(np.square(measured))) == pytest.approx(np.mean(predicted), rel=0.1)
