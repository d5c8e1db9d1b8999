"""Kernel widths padded past Dr.Jit 1.5's crashing band (issue 27 item 4).

Dr.Jit 1.5's LLVM backend crashes the process (SIGSEGV) on kernels whose width lies just below a
power of two from 2^20 up (docs/reliability.md §5, ``scripts/drjit_width_crash.py``);
:func:`mitsar.backend.safe_width` names the band and every kernel whose width the data set pads
its lanes past it. Padded lanes must contribute nothing: forcing extra lanes on a small case
must give the same bits as no padding. The crash itself is tested at back-projection's
2^20 - 8 lanes (about 4.2 million pixels), which crashed in the first kernel without the padding,
in a subprocess so that a crash fails the test and not the suite.
"""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mitsar
from mitsar.backend import UNSAFE_WIDTH_BAND, safe_width
from mitsar.focus import backprojection, bp_tiled
from mitsar.focus.compression import range_spectrum
from mitsar.focus.windows import window_coefficients

ROOT = Path(__file__).resolve().parents[1]
RADAR = mitsar.Radar()
TARGET = np.array([15.0, 8.0, 0.0])


def test_safe_width_pads_the_band_below_every_power_of_two_from_2_20():
    for power in (2**20, 2**21, 2**22, 2**23):
        for d in range(1, UNSAFE_WIDTH_BAND):
            assert safe_width(power - d) == power
        for width in (power, power - UNSAFE_WIDTH_BAND, power + 1, power - 1000):
            assert safe_width(width) == width
    for width in (0, 1, 1000, 2**19 - 4, 2**20 - 100):  # below the band: as they are
        assert safe_width(width) == width


def _inputs(pixel_count: int) -> tuple:
    """A short straight track past the paper's target and a row of pixels around it."""
    raw = mitsar.simulate_point_targets(
        RADAR, mitsar.Trajectory.linear([14.9, 1.4, 4.5], [0.5, 0, 0], 0.4),
        mitsar.Look(55.7), [mitsar.PointTarget(TARGET)], normalized=True)
    frequency, profile = range_spectrum(raw["raw"].values, RADAR, upsample=4)
    pixels = TARGET + np.column_stack([np.linspace(-0.2, 0.2, pixel_count),
                                       np.zeros(pixel_count), np.zeros(pixel_count)])
    centroid = raw["boresight"].values @ np.array([1.0, 0, 0])
    return (profile, frequency, RADAR, pixels, raw["platform_position"].values,
            raw["platform_velocity"].values, centroid, 0.15, window_coefficients("hann"))


@pytest.mark.parametrize("extra", [1, 7, 15])
def test_padded_lanes_contribute_nothing(monkeypatch, extra):
    """Exact kernel (4 pixels a lane) and pixel-group kernel (row segments, sweep parts):
    ``extra`` padded lanes leave every value and total bit for bit as they were."""
    arguments = _inputs(203)  # 51 lanes of 4, the last one part padding already
    exact = backprojection.backproject_drjit(*arguments)
    tiled = bp_tiled.backproject_tiled(*arguments, row_length=203)[:2]
    monkeypatch.setattr(backprojection, "safe_width", lambda width: width + extra)
    monkeypatch.setattr(bp_tiled, "safe_width", lambda width: width + extra)
    assert backprojection._lane_groups(np.zeros(203), 4).shape == (51 + extra, 4)
    padded_exact = backprojection.backproject_drjit(*arguments)
    padded_tiled = bp_tiled.backproject_tiled(*arguments, row_length=203)[:2]
    for before, after in ((exact, padded_exact), (tiled, padded_tiled)):
        for a, b in zip(before, after, strict=True):
            assert a.shape == b.shape and np.array_equal(a, b)
    assert np.abs(exact[0]).max() > 0  # the target is there: the comparison means something


_CRASH_WIDTH = """
import sys
import drjit  # loaded first, as a traced run does: loaded after NumPy and SciPy, it crashed less
import numpy as np
import mitsar
from mitsar.focus import backprojection
from mitsar.focus.windows import window_coefficients

if sys.argv[1] == "unpadded":  # the check that the test can fail (not run by the suite)
    backprojection.safe_width = lambda width: width
lanes = 2**20 - 8
sweeps, bins = 4, 64
rng = np.random.default_rng(0)
profile = rng.standard_normal((sweeps, bins)) + 1j * rng.standard_normal((sweeps, bins))
positions = np.column_stack([14.6 + 0.002 * np.arange(sweeps), np.full(sweeps, 1.4),
                             np.full(sweeps, 4.5)])
count = lanes * backprojection.LANE_PIXELS
pixels = np.column_stack([15 + np.linspace(-0.1, 0.1, count), np.full(count, 8.0),
                          np.zeros(count)])
sums = []
for _ in range(2):  # twice in a row: the crash may come in a later launch
    values, totals = backprojection.backproject_drjit(
        profile, np.arange(bins) * 1e3, mitsar.Radar(), pixels, positions,
        np.tile([0.5, 0.0, 0.0], (sweeps, 1)), np.zeros(sweeps), 0.15,
        window_coefficients("hann"))
    sums.append(complex(values.sum()))
print(len(values) == count and sums[0] == sums[1])
"""


@pytest.mark.slow
def test_back_projection_runs_at_a_crashing_width():
    """2^20 - 8 lanes, which crashed ``backproject_drjit`` in its first kernel before the
    padding (measured with Dr.Jit imported first: 3 crashes in 3 runs with ``unpadded``, 0 in
    3 padded; with Dr.Jit imported after NumPy and SciPy, 0 crashes in 5 unpadded runs). The
    padded runs take ~4-15 s and ~1 GB."""
    done = subprocess.run([sys.executable, "-c", _CRASH_WIDTH, "padded"], capture_output=True,
                          text=True, timeout=300, cwd=ROOT)
    assert done.returncode == 0, (done.returncode, done.stderr[-2000:])
    assert done.stdout.strip().endswith("True")


@pytest.mark.parametrize("curved", [False, True], ids=["sub-apertures", "pixel-band"])
def test_ffbp_final_stage_padding_changes_no_pixel(monkeypatch, curved):
    """FFBP's first stage (four nodes a lane), merges (one node a lane) and final stage (one
    lane a pixel, onto sub-apertures on a straight track, each pixel's own band on a turn):
    extra lanes change no pixel's value."""
    import math

    from mitsar.focus import ffbp, ffbp_stages
    from mitsar.focus.grid import PlaneGrid

    if curved:  # a 20-degree turn of 10 m radius past the target
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
    monkeypatch.setattr(ffbp, "safe_width", lambda width: width + 9)
    monkeypatch.setattr(ffbp_stages, "safe_width", lambda width: widths.append(width) or width + 9)
    padded = mitsar.focus(raw, "ffbp", grid, **options)
    assert len(widths) == image.attrs["ffbp_stages"]  # the first stage and every merge
    assert image.attrs["ffbp_final"] == ("pixel band" if curved else "sub-apertures")
    assert np.array_equal(image["image"].values, padded["image"].values)
    assert np.array_equal(image["coverage"].values, padded["coverage"].values)
    assert np.abs(image["image"].values).max() > 0
