"""focus()'s ``band_limit`` option (mitsar.focus.band_limit): checked like the other options,
and one band selection for every channel of an interferometric product, also when autofocus
(which turns band-limiting off for the image it corrects) runs on channel 0."""

from __future__ import annotations

import warnings

import numpy as np
import pytest

import mitsar
from mitsar.errors import ParameterError
from mitsar.focus import dispatch


def _curved_pair():
    """Two receivers 5 mm apart on a curved, wandering flight (tests/test_band_limit.py's)."""
    t = np.linspace(0.0, 2.4, 241)
    wave, bob, curve, wander = 2 * np.pi / 0.8, 2 * np.pi / 1.1, 0.04, 0.03
    position = np.c_[14.8 + 0.5 * t, 1.4 + curve * (t / 2.4) ** 2 + wander * np.sin(wave * t),
                     4.5 + wander / 3 * np.sin(bob * t)]
    velocity = np.c_[0.5 + 0 * t, 2 * curve * t / 2.4 ** 2 + wander * wave * np.cos(wave * t),
                     wander / 3 * bob * np.cos(bob * t)]
    track = mitsar.Trajectory.navigation(t, position, velocity)
    radar = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.005)])
    raw = mitsar.simulate_point_targets(radar, track, mitsar.Look(55.71),
                                        [mitsar.PointTarget([15.4, 8.0, 0.0])], normalized=True)
    grid = mitsar.grid.SlantGrid(along_track=[0.4, 0.9, 0.01], slant_range=[7.9, 8.3, 0.01])
    return raw, grid


def test_band_limit_must_be_a_boolean():
    raw, grid = _curved_pair()
    with pytest.raises(ParameterError, match="band_limit"):
        mitsar.focus(raw, "bpa", grid, band_limit="no")


@pytest.mark.parametrize("autofocus", [None, "pga"])
def test_every_channel_gets_the_same_band_selection(monkeypatch, autofocus):
    raw, grid = _curved_pair()
    calls = []
    original = dispatch.band_limited_focus

    def spy(focuser, raw, radar, positions, half_width, window, enabled=True):
        calls.append(bool(enabled))
        return original(focuser, raw, radar, positions, half_width, window, enabled)

    monkeypatch.setattr(dispatch, "band_limited_focus", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        mitsar.focus(raw, "bpa", grid, azimuth_resolution=0.1, autofocus=autofocus)
    assert len(calls) >= 2 and len(set(calls)) == 1  # channel 0 (and its refocus), channel 1
    assert calls[0] is (autofocus is None)
