"""Visibility per receiver (issue 22: "bistatic path length and visibility per receiver"):
with ``receiver_visibility`` (the default) every receive channel away from its transmitter
casts its own shadow rays for the direct backscatter, in the block probes and sweep by sweep
where the probes disagree (docs/interferometry.md §8, "Visibility per receiver").

Scene: a 4 cm concrete patch on the floor at the paper's broadside point, and a bar of a
non-radar material 1 m in front of it, 0.72-1.48 m high, which cuts the line of sight from a
receiver 0.5 m above the transmitter (0.75-0.77 m high there) and not the transmitter's
(0.67-0.69 m).
"""

import numpy as np
import pytest

import mitsar

mi = pytest.importorskip("mitsuba")

TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.8)
LOOK = mitsar.Look(55.71)
RADAR = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.5)])
OPTIONS = {"scatterer_density": 1e5}   # ~160 scatterers on the patch


def _rectangle(centre, u, v, bsdf):
    matrix = np.eye(4)
    matrix[:3, 0], matrix[:3, 1] = u, v
    matrix[:3, 2] = np.cross(u, v) / np.linalg.norm(np.cross(u, v))
    matrix[:3, 3] = centre
    return {"type": "rectangle", "to_world": mi.ScalarTransform4f(matrix.tolist()),
            "bsdf": bsdf}


def _scene(bar_x=(13.0, 17.0)):
    from mitsar.plugins.variant import register_plugins

    register_plugins()
    middle, half = 0.5 * (bar_x[0] + bar_x[1]), 0.5 * (bar_x[1] - bar_x[0])
    return mi.load_dict({
        "type": "scene",
        "patch": _rectangle([15.0, 8.0, 0.0], [0.02, 0, 0], [0, 0.02, 0],
                            {"type": "doublelobe", "preset": "concrete_94ghz"}),
        "bar": _rectangle([middle, 7.0, 1.1], [half, 0, 0], [0, 0, 0.38], {"type": "diffuse"})})


def _energy(values):
    return np.sum(np.abs(values) ** 2, axis=-1)


@pytest.mark.filterwarnings("ignore:radar integrator. shapes without a radar material")
@pytest.mark.parametrize("block_kernel", [True, False], ids=["block-kernel", "lane-kernels"])
def test_a_receiver_behind_an_occluder_gets_no_echo(block_kernel):
    """The bar hides the patch from the receiver only: its channel is silent (exact zeros)
    while the transmitter's channel keeps the echo; sharing the transmitter's shadow rays
    (receiver_visibility=False) gives the receiver the echo it cannot see (0.75 of channel
    0's energy here)."""
    scene = _scene()
    raw = mitsar.simulate_scene(RADAR, TRACK, LOOK, scene, block_kernel=block_kernel, **OPTIONS)
    energy = _energy(raw["raw"].values.reshape(2, -1))
    assert energy[0] > 0 and energy[1] == 0.0
    assert raw.attrs["receiver_visibility"] == 1   # recorded with the product
    shared = mitsar.simulate_scene(RADAR, TRACK, LOOK, scene, block_kernel=block_kernel,
                                   receiver_visibility=False, **OPTIONS)
    energy = _energy(shared["raw"].values.reshape(2, -1))
    assert energy[1] > 0.5 * energy[0]


@pytest.mark.filterwarnings("ignore:radar integrator. shapes without a radar material")
def test_shared_probes_agree_with_a_shadow_ray_per_sweep():
    """A bar that ends at x = 15 m hides the patch from the receiver over part of the pass
    only: the block kernel (probes shared across sweeps, each receiver its own; the pairs
    whose probes disagree traced sweep by sweep) gives every sweep of both channels the
    energy of the lane kernels with a shadow ray per sweep and receiver
    (visibility_feature = 0), within their float32 rounding; some sweeps of the receiver's
    channel are silent, others not."""
    scene = _scene(bar_x=(13.0, 15.0))
    fast = mitsar.simulate_scene(RADAR, TRACK, LOOK, scene, **OPTIONS)
    exact = mitsar.simulate_scene(RADAR, TRACK, LOOK, scene, block_kernel=False,
                                  visibility_feature=0.0, **OPTIONS)
    assert int(fast.attrs["traced_visibility_split"]) > 0
    a, b = _energy(fast["raw"].values), _energy(exact["raw"].values)
    np.testing.assert_allclose(a, b, rtol=1e-4, atol=1e-6 * b.max())
    silent = b[1] == 0.0
    assert silent.any() and (~silent).any() and not (b[0] == 0.0).any()
