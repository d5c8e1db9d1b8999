"""The tracer's Dr.Jit launches padded past Dr.Jit 1.5's crashing widths (docs/reliability.md
§5, :func:`mitsar.backend.safe_width`): forcing extra lanes on every launch of the radar
integrator (candidates, cull, probes, the lane and block kernels, the packets' fold, the split
pairs, multipath rays and captures) leaves the traced histograms bit for bit as they were. The
extra lanes repeat the last lane (their gathers in bounds) and contribute nothing; without the
masks they deposit the last lane again (checked: removing the block kernel's, the lane
kernel's or the multipath rays' mask fails the point-target, lanes and multipath cases)."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.plugins.integrators.radar import constants as radar_constants

LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 40.5 / 250.0)

TWO = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.05)])
CASES = {
    # block kernel, shared probes, split pairs, two receivers (their packet rows)
    "block": (TWO, "control_volume", {}),
    # the block kernel whose last candidate deposits (the target): the extra lanes would too
    "block_target": (TWO, "point_target", {}),
    # lane kernels with per-block probes
    "lanes": (mitsar.Radar(), "control_volume", {"block_kernel": False}),
    # lane kernels, a shadow ray per lane
    "rays": (mitsar.Radar(), "control_volume", {"block_kernel": False,
                                                "visibility_feature": 0.0}),
    # multipath: ray lanes and captured lanes (orders 1 and 2 of a corner)
    "multipath": (mitsar.Radar(), "dihedral", {"max_depth": 3, "rays": 2048}),
}


@pytest.mark.parametrize("case", sorted(CASES))
def test_extra_lanes_leave_the_trace_bit_identical(case, monkeypatch):
    radar, scene, options = CASES[case]
    options = {"density": 40.0, "seed": 3, **options}
    look = mitsar.Look(60.0) if scene == "dihedral" else LOOK
    reference = mitsar.trace(radar, TRACK, look, scene, **options)
    assert np.abs(reference["histogram"].values).max() > 0  # something was traced
    for extra in (1, 7):
        monkeypatch.setattr(radar_constants, "safe_width",
                            lambda width, extra=extra: width + extra if width else 0)
        padded = mitsar.trace(radar, TRACK, look, scene, **options)
        assert np.array_equal(padded["histogram"].values, reference["histogram"].values)
        for key in ("traced_shadow_rays", "traced_visibility_rays", "traced_launches"):
            assert padded.attrs.get(key) == reference.attrs.get(key), key
