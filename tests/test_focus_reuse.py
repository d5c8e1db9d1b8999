"""Geometry computed once for autofocus's two focuses (mitsar.focus.reuse): the values come
back by content within a scope and are recomputed outside it, and the refocus inside
focus(..., autofocus=...) equals a plain focus of the corrected product bit for bit while the
aspect frames are computed once instead of twice."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import mitsar
from mitsar.errors import MitsarWarning
from mitsar.focus import bpa
from mitsar.focus.autofocus import correct_raw
from mitsar.focus.grid import SlantGrid
from mitsar.focus.reuse import geometry_shared, reuse, shared_geometry


def test_values_are_kept_by_content_within_a_scope_only():
    calls = []

    def compute(value):
        calls.append(value)
        return np.full(3, value)

    pixels = np.arange(12.0).reshape(4, 3)
    assert not geometry_shared()
    reuse("a", (pixels, 0.5), lambda: compute(1))
    reuse("a", (pixels, 0.5), lambda: compute(2))
    assert calls == [1, 2]  # no scope: computed every time
    with shared_geometry():
        assert geometry_shared()
        first = reuse("a", (pixels, 0.5, None), lambda: compute(3))
        again = reuse("a", (pixels.copy(), 0.5, None), lambda: compute(4))  # equal content
        other = reuse("a", (pixels, 0.25, None), lambda: compute(5))
        named = reuse("b", (pixels, 0.5, None), lambda: compute(6))
        shaped = reuse("a", (pixels.reshape(3, 4), 0.5, None), lambda: compute(7))
    assert again is first and calls == [1, 2, 3, 5, 6, 7]
    assert other[0] == 5 and named[0] == 6 and shaped[0] == 7
    assert not geometry_shared()


@pytest.fixture(scope="module")
def curved():
    """A point target seen from an arc bowed 1 cm over 0.4 m (tests/test_autofocus.py), an
    injected phase error, BPA at 0.1 m: the aspect-angle window of curved tracks."""
    radar = mitsar.Radar()
    start, target = np.array([14.8, 1.4, 4.5]), np.array([15.0, 8.0, 0.0])
    along = np.linspace(0.0, 0.4, 5)
    waypoints = start + np.stack([along, 0.01 * (1 - ((along - 0.2) / 0.2) ** 2), 0 * along],
                                 axis=1)
    raw = mitsar.simulate_point_targets(
        radar, mitsar.Trajectory.waypoints(waypoints, 0.5),
        mitsar.Look(math.degrees(math.atan2(6.6, 4.5))), [mitsar.PointTarget(target)],
        normalized=True)
    phase = 3.0 * np.sin(np.linspace(0, 3 * np.pi, raw.sizes["sweep"]))
    raw["raw"] = raw["raw"] * np.exp(1j * phase)[:, None]
    slant = math.hypot(6.6, 4.5)
    grid = SlantGrid(along_track=[-0.2, 0.6, 0.025], slant_range=[slant - 0.4, slant + 0.4, 0.025])
    return raw, grid


def test_the_refocus_reuses_the_geometry_and_equals_a_plain_focus(curved, monkeypatch):
    raw, grid = curved
    calls = []
    original = bpa.aspect_frames

    def counted(*args, **kwargs):
        calls.append(1)
        return original(*args, **kwargs)

    monkeypatch.setattr(bpa, "aspect_frames", counted)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MitsarWarning)
        image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1, autofocus="pga")
    assert image.attrs["autofocus_applied"] == 1
    assert len(calls) == 1  # focus and refocus: one set of aspect frames
    plain = mitsar.focus(correct_raw(raw, image["autofocus_phase"].values), grid=grid,
                         azimuth_resolution=0.1, band_limit=False)
    assert len(calls) == 2  # outside autofocus: computed again
    np.testing.assert_array_equal(image["image"].values, plain["image"].values)
