"""The minimum-entropy search's stopping and trend rules (mitsar.focus.autofocus.entropy):
convergence on the decrease *and* the step, not a count; the linear phase taken where the
scatterers are strong. Closed forms only (a quadratic bowl, a phase known per sweep)."""

from __future__ import annotations

import numpy as np

from mitsar.focus.autofocus.entropy import (
    EntropyOptions,
    _observable_size,
    estimate_entropy,
    image_entropy,
    minimise,
    trend_weight,
)
from mitsar.focus.autofocus.phase import remove_linear_phase, wrap


def _bowl(curvature, centre):
    """f(x) = sum a_i (x_i - c_i)^2 / 2 and its gradient."""
    return lambda x: (float(0.5 * np.sum(curvature * (x - centre) ** 2)),
                      curvature * (x - centre))


def test_the_search_ends_on_convergence_and_reports_its_bound():
    """An ill-conditioned bowl (curvatures 1 to 1000, the spread of block energies across a
    beam): converged with the minimum within the step tolerance; the same search stopped by
    a bound of 3 iterations says it did not converge."""
    rng = np.random.default_rng(3)
    curvature = np.geomspace(1.0, 1000.0, 40)
    centre = rng.uniform(-2, 2, 40)
    x, value, done, converged = minimise(_bowl(curvature, centre), np.zeros(40), 500,
                                         1e-12, 1e-6)
    assert converged and done < 500
    assert np.abs(x - centre).max() < 1e-4
    # the diagonal start (1/curvature, as 1/energy of a block) converges in fewer iterations
    _, _, scaled, ok = minimise(_bowl(curvature, centre), np.zeros(40), 500, 1e-12, 1e-6,
                                scale=1 / curvature)
    assert ok and scaled < done
    _, _, done, converged = minimise(_bowl(curvature, centre), np.zeros(40), 3, 1e-12, 1e-6)
    assert done == 3 and not converged


def test_a_small_decrease_with_a_large_step_does_not_end_the_search():
    """Nearly flat along one direction (curvature 1e-9): the first iterations gain little but
    move far; with the step test the search goes on to the minimum of the other direction,
    and measuring the step without a direction the entropy cannot see (here the flat one,
    as the linear phase) lets it end there."""
    curvature = np.array([1e-9, 1.0])
    centre = np.array([5.0, 1.0])
    flat = _bowl(curvature, centre)
    x, _, _, converged = minimise(flat, np.zeros(2), 200, 1e-3, 1e-6,
                                  step_size=lambda s: abs(float(s[1])))
    assert converged and abs(x[1] - 1.0) < 1e-5
    line = np.arange(8.0)
    assert _observable_size(0.3 + 0.02 * line, line) < 1e-12  # a line is not observable
    # a spike of 0.1 at k = 3 of 8: its least-squares line there is 0.1 (1/8 + 0.5^2 / 42)
    spike = 0.1 * (1 - 1 / 8 - 0.25 / 42)
    assert abs(_observable_size(np.where(line == 3, 0.1, 0.0), line) - spike) < 1e-12


def test_the_trend_is_taken_where_the_scatterers_are_strong():
    """A phase per sweep known exactly over the beam's centre (energy 1) with wild phases at
    its edges (energy 1e-3, 30 dB down): with the -10 dB sweeps the linear phase removed is
    the centre's, so the result equals the truth there to float precision; over every
    sweep the edges tilt it (a shift of the image)."""
    rng = np.random.default_rng(5)
    sweeps = np.arange(200)
    truth = 0.5 * np.sin(sweeps / 9.0) + 0.001 * (sweeps - 100.0) ** 2 / 10
    energy = np.where((sweeps > 20) & (sweeps < 180), 1.0, 1e-3)
    estimate = truth + 0.3 * sweeps + np.where(energy < 1, rng.uniform(-3, 3, 200), 0.0)
    weight = trend_weight(energy, 10.0)
    assert weight.sum() == 159 and set(np.unique(weight)) == {0.0, 1.0}
    centre = weight > 0
    good = remove_linear_phase(estimate, weight) - remove_linear_phase(truth, weight)
    assert np.abs(wrap(good[centre] - good[centre].mean())).max() < 1e-9
    tilted = remove_linear_phase(estimate, energy > 0) - remove_linear_phase(truth, weight)
    slope = np.polyfit(sweeps[centre], np.unwrap(wrap(tilted[centre])), 1)[0]
    assert abs(slope) > 1e-3


def test_the_returned_phase_is_the_kept_stage():
    """The estimate returned (and applied to the raw) is the stage ``kept_stage`` names: the
    check chips' entropy under the returned phase equals ``check_entropy_final``, and a kept
    stage 0 returns no correction. Check chips already focused at zero phase (a coherent
    column), a model smeared by a random-walk phase: stages disagree, so the choice matters."""
    rng = np.random.default_rng(0)
    sweeps, pixels = 64, 32
    error = np.cumsum(rng.normal(0, 0.5, sweeps))
    k, q = np.arange(sweeps)[:, None], np.arange(pixels)[None, :]
    terms = (np.exp(2j * np.pi * k * q / pixels / 4) * np.exp(1j * error)[:, None]
             ).astype(np.complex64)
    check = np.zeros((sweeps, 2), np.complex64)
    check[:, 0], check[:, 1] = 1.0, (-1.0) ** np.arange(sweeps)
    for margin in (0.0, EntropyOptions().check_margin):
        phase, info = estimate_entropy(terms, EntropyOptions(check_margin=margin), check=check)
        found = image_entropy((check * np.exp(-1j * phase)[:, None]).sum(axis=0))
        assert abs(found - info["check_entropy_final"]) < 1e-6
        if info["kept_stage"] == 0:
            assert np.all(phase == 0)
