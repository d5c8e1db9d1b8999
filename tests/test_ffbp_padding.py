"""FFBP's first stage and merges launched past Dr.Jit 1.5's crashing widths (issue 27 item 4).

:func:`mitsar.backend.safe_width` pads a kernel's lanes past the widths at which Dr.Jit 1.5's
LLVM backend crashes (docs/reliability.md §5); the final stage was padded already
(tests/test_drjit_width.py), the first stage (four nodes a lane) and every merge (one node a
lane) now are too: the extra lanes repeat the last one and are masked out of the scatters, so
forcing extra lanes on a small case must leave every image bit for bit as it was.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.focus import ffbp_stages
from mitsar.focus.grid import PlaneGrid

RADAR = mitsar.Radar()
TARGET = np.array([15.0, 8.0, 0.0])


@pytest.mark.parametrize("curved", [False, True], ids=["straight", "turn-pixel-band"])
def test_first_stage_and_merge_padding_changes_no_pixel(monkeypatch, curved):
    if curved:  # a 20-degree turn of 3 m radius past the target: every stage's images read
        turn = math.radians(20.0)
        track = mitsar.Trajectory.flight(
            [[13.5, 1.4, 4.5], [15.0, 1.4, 4.5],
             [15.0 + 1.5 * math.cos(turn), 1.4 + 1.5 * math.sin(turn), 4.5]], 0.5,
            turn_radius=3.0)
    else:
        track = mitsar.Trajectory.linear([14.6, 1.4, 4.5], [0.5, 0, 0], 0.8)
    raw = mitsar.simulate_point_targets(RADAR, track, mitsar.Look(55.7),
                                        [mitsar.PointTarget(TARGET)], normalized=True)
    grid = PlaneGrid(origin=TARGET, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-0.1, 0.1, 0.01],
                     v=[-0.1, 0.1, 0.01])
    options = {"azimuth_resolution": 0.1, "window": "hamming"} if curved else {}
    image = mitsar.focus(raw, "ffbp", grid, **options)
    widths = []

    def padded(width: int) -> int:
        widths.append(width)
        return width + 9

    monkeypatch.setattr(ffbp_stages, "safe_width", padded)
    forced = mitsar.focus(raw, "ffbp", grid, **options)
    assert len(widths) == image.attrs["ffbp_stages"]  # the first stage and every merge
    assert image.attrs["ffbp_final"] == ("pixel band" if curved else "sub-apertures")
    assert np.array_equal(image["image"].values, forced["image"].values)
    assert np.array_equal(image["coverage"].values, forced["coverage"].values)
    assert np.abs(image["image"].values).max() > 0
