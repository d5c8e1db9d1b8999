"""Shadow rays shared across sweeps (docs/integrator.md §"Visibility reuse"): the blocks obey
the stated sight-line bound, the traced data equal those with a shadow ray per sweep, and a
shadow boundary crossing a target inside a block is caught sweep by sweep."""

import math

import numpy as np
import pytest

import mitsar
from mitsar.errors import ParameterError
from mitsar.model.geometry.visibility import sight_line_motion, visibility_blocks
from mitsar.model.trace_options import TraceOptions
from mitsar.raw.traced import histogram_to_raw_product, trace
from mitsar.scene import load_scene

mi = pytest.importorskip("mitsuba")

RADAR = mitsar.Radar()
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))  # paper §4.1: boresight on [x, 8, 0]
SPEED = 0.5  # m/s: 2 mm per sweep at PRF 250 Hz
ABSORBER = '<bsdf type="doublelobe"><string name="preset" value="absorber"/></bsdf>'


def _error_db(value, reference):
    error = np.sum(np.abs(value - reference) ** 2)  # 0 when bit-identical (one Dr.Jit thread)
    return -math.inf if error == 0 else 10 * math.log10(error / np.sum(np.abs(reference) ** 2))


# --- the blocks ----------------------------------------------------------------------------------

def test_blocks_are_the_longest_runs_within_the_feature_width_and_the_cap():
    rng = np.random.default_rng(3)
    positions = np.cumsum(rng.uniform(0, 4e-3, size=(200, 3)), axis=0)
    positions[50:80] = positions[50]  # a hover: no motion, blocks limited by the cap only
    times = np.arange(200) / RADAR.prf
    motion = sight_line_motion(positions, times, target_speed=0.1)
    # Closed form of the bound: antenna path length plus target speed x elapsed time.
    steps = np.linalg.norm(np.diff(positions, axis=0), axis=1) + 0.1 / RADAR.prf
    np.testing.assert_allclose(motion[1:], np.cumsum(steps), rtol=1e-12)
    for feature, cap in ((0.03, 64), (0.03, 7), (0.0, 64), (1.0, 16)):
        blocks = visibility_blocks(motion, feature, cap)
        assert blocks[0] == 0 and np.all(np.diff(blocks) >= 0) and np.all(np.diff(blocks) <= 1)
        for b in range(blocks[-1] + 1):
            members = np.flatnonzero(blocks == b)
            first, last = members[0], members[-1]
            assert motion[last] - motion[first] <= feature and len(members) <= cap
            if last + 1 < len(motion):  # maximal: one more sweep would break a limit
                assert motion[last + 1] - motion[first] > feature or len(members) == cap
    assert np.all(np.diff(visibility_blocks(motion, 0.0, 64)) == 1)  # a ray per sweep


def test_visibility_feature_is_validated():
    with pytest.raises(ParameterError, match="visibility_feature"):
        TraceOptions(visibility_feature=-0.01).resolve()
    assert TraceOptions().replace(visibility_feature=0).resolve().visibility_feature == 0.0


# --- the paper's room ---------------------------------------------------------------------------

def test_paper_room_equals_a_shadow_ray_per_sweep():
    """The canned control volume (paper Table 3 room) at reduced size: 150 sweeps (two chunks
    of 128 + 22, so blocks restart at a chunk boundary), 60 scatterers per m² (about 65 000 instead
    of 0.97 M) and small launches (candidates split over several launches, so the probe codes
    must line up with the lanes of each launch). The room is convex and empty, so every
    scatterer in the beam is visible at every sweep: what can go wrong is the bookkeeping (a
    lane reading another pair's code drops or adds contributions), which the size reduction
    does not touch. Requirement: raw data within -50 dB of a ray per sweep."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [SPEED, 0.0, 0.0], 150.5 / RADAR.prf)
    scene = load_scene("control_volume")
    options = dict(density=60.0, seed=4, chunk_lanes=2**15)
    per_sweep = trace(RADAR, track, LOOK, scene, visibility_feature=0.0, **options)
    shared = trace(RADAR, track, LOOK, scene, **options)
    assert per_sweep.attrs["traced_visibility_rays"] == 0
    contributions = shared.attrs["traced_shadow_rays"]
    # The same lanes up to the bin grid's edge (the block kernel tests the bin in float32).
    assert per_sweep.attrs["traced_shadow_rays"] > 100_000
    assert abs(contributions - per_sweep.attrs["traced_shadow_rays"]) <= 1e-5 * contributions
    assert shared.attrs["traced_launches"] > 4  # several launches per chunk
    # 2 mm per sweep and 3 cm: blocks of 15-16 sweeps, 2 probe rays each instead of 15-16.
    assert shared.attrs["traced_visibility_rays"] < contributions / 5
    assert shared.attrs["traced_visibility_split"] == 0  # nothing occludes in an empty box
    raw_a = histogram_to_raw_product(per_sweep)["raw"].values
    raw_b = histogram_to_raw_product(shared)["raw"].values
    # Same lanes, same visibility: the lane kernels differ only in the float64 atomic summation
    # order (~-300 dB); the block kernel (default here) by its float32 advance (~-115 dB,
    # docs/integrator.md §"Performance").
    assert _error_db(raw_b, raw_a) < -50.0


# --- a shadow boundary inside a block ------------------------------------------------------------

TARGET = np.array([15.0, 8.0, 0.03])
START = np.array([14.8, 1.4, 4.5])
SCREEN_Y = 5.0  # plane of the absorbing screen(s), between the antenna and the target


def _scene(tmp_path, name, strips):
    """A point target (sphere, 2 cm) and absorbing vertical strips x in [x0, x1] at y = 5 m."""
    body = (f'<shape type="sphere"><point name="center" x="{TARGET[0]}" y="{TARGET[1]}" '
            f'z="{TARGET[2]}"/><float name="radius" value="0.02"/>'
            '<bsdf type="pointtarget"><float name="rcs" value="1"/></bsdf></shape>')
    for i, (x0, x1) in enumerate(strips):
        body += (f'<shape type="rectangle" id="strip{i}"><transform name="to_world">'
                 f'<scale x="{(x1 - x0) / 2}" y="3"/><rotate x="1" angle="90"/>'
                 f'<translate x="{(x0 + x1) / 2}" y="{SCREEN_Y}" z="3"/></transform>'
                 f'{ABSORBER}</shape>')
    path = tmp_path / f"{name}.xml"
    path.write_text(f'<scene version="3.0.0">{body}</scene>')
    return path


def _antenna(sweeps):
    """Mid-sweep antenna positions (docs/integrator.md: the state at eta_k + T/2)."""
    time = np.arange(sweeps) / RADAR.prf + RADAR.sweep_duration / 2
    return START + np.outer(time, [SPEED, 0.0, 0.0])


def _crossing_x(antenna):
    """Where the sight line antenna -> target crosses the screen plane y = 5 m (closed form)."""
    f = (SCREEN_Y - antenna[:, 1]) / (TARGET[1] - antenna[:, 1])
    return antenna[:, 0] + f * (TARGET[0] - antenna[:, 0])


def _seen(hist):
    return np.abs(hist["histogram"].values[:, 0, :]).max(axis=1) > 0


def test_a_shadow_boundary_crossing_the_target_mid_block_is_traced_sweep_by_sweep(tmp_path):
    """The screen's edge sweeps across the target's sight line between sweeps 23 and 24 of 64,
    inside the second visibility block (sweeps 15-29 at 3 cm, 2 mm per sweep): the block's ends
    disagree, so its sweeps are re-tested one by one and the target vanishes at exactly the
    sweep the closed form says."""
    sweeps = 64
    antenna = _antenna(sweeps)
    crossing = _crossing_x(antenna)
    edge = 0.5 * (crossing[23] + crossing[24])  # half a sweep (~0.9 mm) from either sweep
    track = mitsar.Trajectory.linear(START, [SPEED, 0.0, 0.0], (sweeps + 0.5) / RADAR.prf)
    scene = load_scene(_scene(tmp_path, "edge", [(-20.0, edge)]))  # hides x < edge
    expected = crossing >= edge  # the sight line passes to the right of the screen's edge
    assert 0 < expected.sum() < sweeps and not expected[23] and expected[24]

    blocks = visibility_blocks(sight_line_motion(antenna, np.arange(sweeps) / RADAR.prf, 0.0),
                               0.03, 64)
    inner = np.flatnonzero(blocks == blocks[23])
    assert inner[0] < 23 and 24 < inner[-1]  # the edge is mid-block
    shared = trace(RADAR, track, LOOK, scene, normalized=True)
    per_sweep = trace(RADAR, track, LOOK, scene, normalized=True, visibility_feature=0.0)
    assert shared.attrs["traced_visibility_split"] == 1  # that one (target, block) pair
    np.testing.assert_array_equal(_seen(per_sweep), expected)
    np.testing.assert_array_equal(_seen(shared), expected)
    # The lane kernels: one contribution per sweep, no summation order to differ: bit for bit.
    lanes = trace(RADAR, track, LOOK, scene, normalized=True, block_kernel=False)
    assert lanes.attrs["traced_visibility_split"] == 1
    np.testing.assert_array_equal(lanes["histogram"].values, per_sweep["histogram"].values)
    # The block kernel (default) traces the split block like the lane kernels and the others
    # from float32 range increments and an amplitude quadratic (docs/integrator.md
    # §"Performance": about -110 dB on the paper room).
    assert _error_db(shared["histogram"].values, per_sweep["histogram"].values) < -90.0


def test_an_occluder_narrower_than_the_feature_width_is_the_stated_limit(tmp_path):
    """The bound's other side: a strip whose shadow spans sweeps 20-26 only, all inside one
    block (15-29) whose ends both see the target, is missed with a 3 cm feature width (the
    sight line moves ~1.3 cm across the strip's plane over the block, more than the strip's
    6 mm), and caught when the feature width (4 mm: blocks of 3 sweeps) is below the strip's
    width."""
    sweeps = 64
    antenna = _antenna(sweeps)
    crossing = _crossing_x(antenna)
    x0, x1 = 0.5 * (crossing[19] + crossing[20]), 0.5 * (crossing[26] + crossing[27])
    track = mitsar.Trajectory.linear(START, [SPEED, 0.0, 0.0], (sweeps + 0.5) / RADAR.prf)
    scene = load_scene(_scene(tmp_path, "strip", [(x0, x1)]))
    hidden = (crossing >= x0) & (crossing <= x1)
    assert np.flatnonzero(hidden).tolist() == list(range(20, 27))
    blocks = visibility_blocks(sight_line_motion(antenna, np.arange(sweeps) / RADAR.prf, 0.0),
                               0.03, 64)
    inner = np.flatnonzero(blocks == blocks[20])
    assert inner[0] < 20 and 26 < inner[-1]  # hidden sweeps strictly inside one block
    assert 0.004 < x1 - x0 < 0.008
    coarse = trace(RADAR, track, LOOK, scene, normalized=True)
    fine = trace(RADAR, track, LOOK, scene, normalized=True, visibility_feature=0.004)
    assert np.all(_seen(coarse))  # missed: both ends of block 16-31 see the target
    np.testing.assert_array_equal(_seen(fine), ~hidden)
