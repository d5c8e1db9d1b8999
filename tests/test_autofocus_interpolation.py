"""Autofocus reads the range profiles as the focuser does (mitsar.focus.autofocus.contributions
with the focuser's ``range_interpolation``): the per-sweep terms c_k(x) sum to the numpy
reference back-projection's sum (mitsar.focus.backprojection.pulse_sum, unit weights) for each
interpolation, to float64 rounding."""

from __future__ import annotations

import numpy as np
import pytest

import mitsar
from mitsar.focus.aperture import doppler_geometry
from mitsar.focus.autofocus.contributions import PulseSettings, contributions, pulse_data
from mitsar.focus.backprojection import pulse_sum
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import beat_frequency

TARGET = np.array([15.0, 8.0, 0.0])


@pytest.fixture(scope="module")
def raw():
    track = mitsar.Trajectory.linear([14.9, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    return mitsar.simulate_point_targets(mitsar.Radar(), track, mitsar.Look(55.71),
                                         [mitsar.PointTarget(TARGET)], normalized=True)


def _reference(data, points, interpolation):
    """pulse_sum of the reference BP with unit weights (the same delay and beat model)."""
    slant_range, _, rate = doppler_geometry(points, data.positions, data.velocities)
    delay = 2.0 * slant_range / SPEED_OF_LIGHT
    beat = beat_frequency(delay, rate, data.radar.chirp_rate, data.radar.carrier_frequency)
    total, _ = pulse_sum(data.profile, data.frequency, delay, beat, np.ones(delay.shape),
                         data.radar.carrier_frequency, interpolation=interpolation)
    return total


def test_contributions_use_the_focusers_interpolation(raw):
    points = TARGET + np.stack([np.linspace(-0.03, 0.03, 7), np.linspace(-0.02, 0.02, 7),
                                np.zeros(7)], axis=-1)
    sums = {}
    for interpolation in ("linear", "cubic"):
        data = pulse_data(raw, PulseSettings(range_upsample=2,
                                             range_interpolation=interpolation))
        sums[interpolation] = contributions(data, points).sum(axis=0)
        reference = _reference(data, points, interpolation)
        scale = np.abs(reference).max()
        np.testing.assert_allclose(sums[interpolation], reference, atol=1e-9 * scale)
    # at 2x zero-padding the two interpolations differ (linear loses up to pi^2/32 = 31 %
    # at the band edge, mitsar.focus.interpolation eq. 2), so the check above tells them apart
    scale = np.abs(sums["cubic"]).max()
    assert np.abs(sums["cubic"] - sums["linear"]).max() > 1e-3 * scale
