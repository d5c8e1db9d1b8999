"""Receive elements with their own pattern and boresight in the ray tracer (issue 22 item 1,
docs/interferometry.md §8): each channel's deposits take the channel's two-way factor
``f_t f_r sqrt(G_t G_r) / G`` (:func:`mitsar.model.elements.channel_amplitude_factor`) in place
of the radar's shared ``f^2``; the analytic simulator is the independent reference."""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.errors import MitsarWarning

TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
SCENE_LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.47)))  # the canned target's line
CANNED_TARGET = np.array([15.0, 8.0, 0.03])  # scenes/point_target.xml
# a receive element 5 cm up, looking 6 degrees steeper with a 12-degree elevation beam
ELEMENT = {"position": (0, 0, 0.05), "off_nadir_deg": SCENE_LOOK.off_nadir_deg - 6.0,
           "elevation_beamwidth_deg": 12.0}


def _error_db(value: np.ndarray, reference: np.ndarray) -> float:
    return 10 * math.log10(np.sum(np.abs(value - reference) ** 2)
                           / np.sum(np.abs(reference) ** 2))


def test_traced_element_beams_reproduce_the_analytic_channels():
    """-50 dB per channel (the histogram's first-order tone model, docs/design.md §5.5: -54 to
    -56 dB), and the channels' amplitude ratio of the tracer equals the analytic one within
    1 % over the sweeps where both are above 1 % of their peak (the tone model's amplitude
    error is far below that); the element's beam makes a ratio to see (> 5 % from 1)."""
    radar = mitsar.Radar(receivers=[(0, 0, 0), ELEMENT])
    assert radar.has_element_beams
    traced = mitsar.simulate_scene(radar, TRACK, SCENE_LOOK, "point_target")
    analytic = mitsar.simulate_point_targets(radar, TRACK, SCENE_LOOK,
                                             [mitsar.PointTarget(CANNED_TARGET)])
    for k in range(2):
        assert _error_db(traced["raw"].values[k], analytic["raw"].values[k]) < -50
    power = [np.sqrt(np.sum(np.abs(p["raw"].values) ** 2, axis=-1)) for p in (traced, analytic)]
    strong = (power[1][0] > 0.01 * power[1][0].max()) & (power[1][1] > 0.01 * power[1][1].max())
    ratio_traced = power[0][1][strong] / power[0][0][strong]
    ratio_analytic = power[1][1][strong] / power[1][0][strong]
    assert np.all(np.abs(ratio_analytic - 1) > 0.05)
    np.testing.assert_allclose(ratio_traced, ratio_analytic, rtol=0.01)


def test_receive_elements_like_the_radar_trace_as_before():
    """Elements that declare the radar's own beam and boresight give the same bits as plain
    phase centres: the lane kernels with the element factor against the shared pattern."""
    plain = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.05)])
    same = mitsar.Radar(receivers=[(0, 0, 0), {"position": (0, 0, 0.05),
                                                "off_nadir_deg": SCENE_LOOK.off_nadir_deg,
                                                "squint_deg": 0.0}])
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.1)
    a = mitsar.simulate_scene(plain, track, SCENE_LOOK, "point_target", block_kernel=False)
    b = mitsar.simulate_scene(same, track, SCENE_LOOK, "point_target")
    assert _error_db(b["raw"].values, a["raw"].values) < -120


TRANSMIT = {"position": (0, 0, 0.0001), "off_nadir_deg": SCENE_LOOK.off_nadir_deg + 5.0,
            "azimuth_beamwidth_deg": 14.0, "elevation_beamwidth_deg": 10.0}
"""A transmit element 0.1 mm up, looking 5 degrees shallower with a 14 x 10-degree beam. (The
analytic simulator takes every channel's pattern and range at the track point, the tracer at
the transmitter's phase centre: on this beam's slope 1 cm up moves the echo power by 1.2 %,
-44 dB; 0.1 mm by 0.01 %.)"""


@pytest.mark.parametrize("layout", ["tdm", "ping-pong", "single"])
def test_transmit_elements_with_their_own_beam_reproduce_the_analytic_channels(layout):
    """A transmit element with its own boresight and beam (TDM-MIMO: two transmitters, one of
    them the radar's antenna, and the receive element above; ping-pong: each element
    transmits its own): the tracer follows the transmit element's beam (its frame,
    beamwidths and gain: trace_run._transmit_beam) and gives each receiver its own element
    beam in that frame. Every channel within -50 dB of the analytic simulator, which models
    the elements independently, and the channels' amplitude ratio per sweep within 1 % of its
    (> 5 % from 1: the beams make a difference). Measured -54 to -55 dB."""
    if layout == "tdm":
        radar = mitsar.Radar(transmitters=[(0, 0, 0), TRANSMIT],
                             receivers=[(0, 0, 0), ELEMENT])
    elif layout == "ping-pong":
        radar = mitsar.Radar(receivers=[TRANSMIT, (0, 0, 0.001)], ping_pong=True)
    else:   # one transmitter, its own beam, and plain receivers (the radar's antenna)
        radar = mitsar.Radar(transmitters=[TRANSMIT], receivers=[(0, 0, 0), (0, 0, 0.001)])
    traced = mitsar.simulate_scene(radar, TRACK, SCENE_LOOK, "point_target")
    analytic = mitsar.simulate_point_targets(radar, TRACK, SCENE_LOOK,
                                             [mitsar.PointTarget(CANNED_TARGET)])
    values = [p["raw"].values for p in (traced, analytic)]
    for k in range(radar.channel_count):
        assert _error_db(values[0][k], values[1][k]) < -50, k
    if layout == "single":   # the element's beam, not the radar's: 0.49 of the power here
        plain = mitsar.Radar(transmitters=[TRANSMIT["position"]],
                             receivers=[(0, 0, 0), (0, 0, 0.001)])
        shared = mitsar.simulate_scene(plain, TRACK, SCENE_LOOK, "point_target")
        assert abs(np.sum(np.abs(values[0]) ** 2)
                   / np.sum(np.abs(shared["raw"].values) ** 2) - 1) > 0.1
        return
    power = [np.sqrt(np.sum(np.abs(v) ** 2, axis=-1)) for v in values]
    own = [k for k in range(radar.channel_count)
           if radar.channel_elements()[0][k].has_own_beam]
    reference = 0 if layout == "tdm" else 1   # a channel through another transmitter
    for k in own:
        fired = (power[1][k] > 0.01 * power[1][k].max())
        other = power[1][reference] > 0.01 * power[1][reference].max()
        if layout == "tdm":   # the transmitters fire in turn: compare slot-mean powers
            traced_ratio = power[0][k][fired].mean() / power[0][reference][other].mean()
            analytic_ratio = power[1][k][fired].mean() / power[1][reference][other].mean()
        else:
            strong = fired & other
            traced_ratio = power[0][k][strong] / power[0][reference][strong]
            analytic_ratio = power[1][k][strong] / power[1][reference][strong]
        assert np.all(np.abs(np.asarray(analytic_ratio) - 1) > 0.05)
        np.testing.assert_allclose(traced_ratio, analytic_ratio, rtol=0.01)


def _error(value: np.ndarray, reference: np.ndarray) -> float:
    difference = np.sum(np.abs(value - reference) ** 2)
    return -np.inf if difference == 0 else _error_db(value, reference)


@pytest.mark.parametrize("mechanism", ["multipath", "physical-optics"])
def test_a_radar_of_elements_traces_as_the_radar_whose_antenna_they_share(mechanism):
    """Every element of a TDM radar (transmit and receive) declaring one beam X (14 x 10
    degrees) looking L' (5 degrees steeper, 3 degrees squint) under the look L is the radar
    whose own antenna is X looking L': the tracer follows the transmit element's frame,
    beamwidths and gain for the multipath rays (make_setup) and the facets' pattern
    (FacetEchoes), and each receive beam is the identity in that frame. Both sides' channels
    agree to rounding (measured below -140 dB); the radar's beam and frame in either
    mechanism would leave -15 to -50 dB."""
    from test_multipath import _look_at, _track
    from test_physical_optics import _plate_scene
    from test_po_multipath import _setup

    if mechanism == "multipath":
        start = np.array([5.0, 8.0, 1.0])
        look, track, scene = _look_at(start, [5.0, 10.0, 0.0]), _track(start), "dihedral"
        options = {"max_depth": 3, "rays": 1024, "backscatter": False}
    else:
        _, mi, _, look, track, boresight = _setup()
        scene = _plate_scene(mi, np.array([0.0, 0.0, 3.0]) + 5.0 * boresight, -boresight, 0.05)
        options = {"physical_optics": True}
    steeper = mitsar.Look(look.off_nadir_deg + 5.0, look.squint_deg + 3.0)
    beam = {"azimuth_beamwidth_deg": 14.0, "elevation_beamwidth_deg": 10.0}
    own = {**beam, "off_nadir_deg": steeper.off_nadir_deg, "squint_deg": steeper.squint_deg}
    transmitters, receivers = [(0, 0, 0), (0, 0.03, 0)], [(0, 0, 0), (0, 0, 0.05)]
    antenna = mitsar.Radar(transmitters=transmitters, receivers=receivers, **beam)
    elements = mitsar.Radar(transmitters=[{**own, "position": p} for p in transmitters],
                            receivers=[{**own, "position": p} for p in receivers])
    reference = mitsar.simulate_scene(antenna, track, steeper, scene, block_kernel=False,
                                      **options)["raw"].values
    traced = mitsar.simulate_scene(elements, track, look, scene, **options)["raw"].values
    assert np.abs(reference).max() > 0
    for k in range(antenna.channel_count):
        assert _error(traced[k], reference[k]) < -100, k


def test_co_located_ping_pong_elements_are_traced_each_with_its_beam():
    """Two ping-pong elements at one phase centre with different boresights are two
    transmitters: simulate_scene traces each with its own beam (they were one group, traced
    with the first element's beam: the second channel, looking at the target, came out
    zero), as trace(channel=k) does, within -50 dB of the analytic simulator."""
    from mitsar.raw.traced import histogram_to_raw_product, trace

    away = {"position": (0, 0, 0.0001), "off_nadir_deg": SCENE_LOOK.off_nadir_deg + 25.0,
            "azimuth_beamwidth_deg": 14.0, "elevation_beamwidth_deg": 10.0}
    toward = {**away, "off_nadir_deg": SCENE_LOOK.off_nadir_deg}
    radar = mitsar.Radar(receivers=[away, toward], ping_pong=True)
    traced = mitsar.simulate_scene(radar, TRACK, SCENE_LOOK, "point_target")["raw"].values
    analytic = mitsar.simulate_point_targets(radar, TRACK, SCENE_LOOK,
                                             [mitsar.PointTarget(CANNED_TARGET)])["raw"].values
    assert _error_db(traced[1], analytic[1]) < -50
    alone = histogram_to_raw_product(trace(radar, TRACK, SCENE_LOOK, "point_target",
                                           channel=1))["raw"].values
    np.testing.assert_array_equal(traced[1], alone)


def test_every_transmitters_reception_warnings_are_recorded():
    """A TDM transmitter element looking away from the scene (5 degrees off nadir) is warned
    about while its trace runs, and the product records the sentence though it is not the
    first transmitter (the attributes came from the first group's trace only)."""
    away = {"position": (0, 0.03, 0), "off_nadir_deg": 5.0, "azimuth_beamwidth_deg": 14.0,
            "elevation_beamwidth_deg": 10.0}
    radar = mitsar.Radar(transmitters=[(0, 0, 0), away], receivers=[(0, 0, 0)])
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.1)
    with pytest.warns(MitsarWarning) as caught:
        product = mitsar.simulate_scene(radar, track, SCENE_LOOK, "point_target")
    sentences = [str(w.message) for w in caught if "point target" in str(w.message)]
    assert sentences
    recorded = product.attrs.get("reception_warnings") or ""
    assert all(sentence.split(": ", 1)[1] in recorded for sentence in sentences)
