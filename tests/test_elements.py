"""Per-element patterns and boresights (issue 22 item 1, docs/interferometry.md §8).

Closed form: the two-way amplitude of channel (transmitter i, receiver j) towards direction d
is ``sqrt(P_T G_i G_j lambda^2 sigma / ((4 pi)^3 R^4)) f_i(d) f_j(d)`` (radar equation, paper
eq. 2, with each element's gain ``4 pi / (beta_az beta_el)`` and one-way field pattern
``sinc(u_az / beta_az) sinc(u_el / beta_el)`` in its own frame, Balanis). With a single point
target the dechirped samples' magnitude is that amplitude, so the ratio of two receivers'
samples is the ratio of their ``sqrt(G_j) f_j(d)``.
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import mitsar
from mitsar.errors import MitsarWarning, ParameterError
from mitsar.experiment import experiment_from_dict
from mitsar.model.elements import (
    Element,
    channel_amplitude_factor,
    element_beam,
    element_field_pattern,
)
from mitsar.model.geometry.antenna import direction_sines, field_pattern
from mitsar.model.geometry.attitude import antenna_frame, body_to_world
from mitsar.raw.analytic import stream_point_targets

TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.2)
LOOK = mitsar.Look(55.7)
TARGET = np.array([15.0, 8.0, 0.3])


def _simulate(radar, **kwargs):
    return mitsar.simulate_point_targets(radar, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                         **kwargs)


def _closed_form_one_way(off_nadir_deg, squint_deg, az_deg, el_deg, direction, attitude):
    """sqrt(G) sinc(u_az/b_az) sinc(u_el/b_el) of an antenna mounted as Look(off, squint)
    (its gain 4 pi / (b_az b_el)), written out from the Look's frame and Balanis' pattern."""
    th, sq = math.radians(off_nadir_deg), math.radians(squint_deg)
    boresight = np.array([-math.sin(sq) * math.sin(th), math.cos(sq) * math.sin(th),
                          -math.cos(th)])
    azimuth = np.array([math.cos(sq), math.sin(sq), 0.0])
    elevation = np.cross(boresight, azimuth)
    rotation = body_to_world(*attitude)
    local = [direction @ (rotation @ axis) for axis in (azimuth, elevation, boresight)]
    b_az, b_el = math.radians(az_deg), math.radians(el_deg)
    field = np.sinc(local[0] / b_az) * np.sinc(local[1] / b_el) * (local[2] > 0)
    return math.sqrt(4 * math.pi / (b_az * b_el)) * field


@pytest.mark.parametrize("backend", ["numpy", "drjit"])
def test_two_receivers_with_different_boresights_get_the_patterns_amplitude_ratio(backend):
    radar = mitsar.Radar(azimuth_beamwidth_deg=9.0, elevation_beamwidth_deg=18.0, receivers=[
        (0, 0, 0),
        {"position": (0, 0, 0.05), "off_nadir_deg": 62.0, "squint_deg": 3.0,
         "azimuth_beamwidth_deg": 12.0, "elevation_beamwidth_deg": 25.0}])
    raw = _simulate(radar, backend=backend)
    sweep = 25  # the target is 0.3 beamwidths off both receivers' boresights here
    time = float(raw["slow_time"][sweep]) + radar.sweep_duration / 2
    offset = TARGET - TRACK.position(time)
    direction = offset / np.linalg.norm(offset)
    attitude = TRACK.attitude_at(time)
    g0 = _closed_form_one_way(55.7, 0.0, 9.0, 18.0, direction, attitude)
    g1 = _closed_form_one_way(62.0, 3.0, 12.0, 25.0, direction, attitude)
    samples = np.abs(raw["raw"].values[:, sweep])
    ratio = samples[1] / samples[0]
    assert 0.2 < g1 / g0 < 5 and abs(g1 / g0 - 1) > 0.05  # a real difference to see
    np.testing.assert_allclose(ratio, g1 / g0, rtol=1e-6)


def test_a_receiver_whose_beam_misses_the_target_gets_nothing_and_a_warning():
    radar = mitsar.Radar(receivers=[(0, 0, 0), {"position": (0, 0, 0.05),
                                                 "boresight": (0.0, -0.8, -0.6)}])
    with pytest.warns(MitsarWarning, match=r"receiver element at \[0, 0, 0.05\].*behind"):
        raw = _simulate(radar, backend="numpy")
    assert "behind" in raw.attrs["reception_warnings"]
    assert np.abs(raw["raw"].values[0]).max() > 0
    assert np.abs(raw["raw"].values[1]).max() == 0.0  # the target is behind that element
    # sidelobes only: an element looking 40 deg steeper than the target (field ratio < -20 dB)
    radar = mitsar.Radar(receivers=[(0, 0, 0), {"position": (0, 0, 0.05),
                                                 "off_nadir_deg": 15.0}])
    with pytest.warns(MitsarWarning, match=r"outside its main lobe.*sidelobes only"):
        raw = _simulate(radar, backend="numpy")
    level = np.abs(raw["raw"].values[1]).max() / np.abs(raw["raw"].values[0]).max()
    assert 0 < level < 10 ** (-20 / 20)


def test_streamed_chunks_with_elements_are_the_simulation():
    radar = mitsar.Radar(receivers=[(0, 0, 0), {"position": (0, 0, 0.05),
                                                 "off_nadir_deg": 60.0}])
    whole = _simulate(radar, backend="numpy")["raw"].values
    chunks = stream_point_targets(radar, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                         backend="numpy", sweeps_per_chunk=16)
    streamed = np.concatenate([chunk["raw"].values for chunk in chunks], axis=1)
    assert np.array_equal(streamed, whole)


def test_elements_that_are_the_radars_antenna_give_todays_samples_bit_for_bit():
    plain = mitsar.Radar(azimuth_beamwidth_deg=9.0, receivers=[(0, 0, 0), (0, 0, 0.05)])
    same = mitsar.Radar(azimuth_beamwidth_deg=9.0, receivers=[
        Element((0, 0, 0)),
        {"position": (0, 0, 0.05), "azimuth_beamwidth_deg": 9.0, "off_nadir_deg": 55.7}])
    assert same.has_element_beams and not plain.has_element_beams
    for backend in ("numpy", "drjit"):
        a, b = (_simulate(r, backend=backend)["raw"].values for r in (plain, same))
        assert np.array_equal(a, b)


def test_element_pattern_is_the_closed_form_and_the_radars_for_its_own_beam():
    radar, look = mitsar.Radar(), mitsar.Look(50.0, 10.0)
    widths = (radar.azimuth_beamwidth, radar.elevation_beamwidth)
    rng = np.random.default_rng(3)
    directions = rng.normal(size=(500, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    frame = antenna_frame(look)
    u = direction_sines(directions, frame)
    own = element_beam(Element(), widths, look)
    f = field_pattern(u[0], u[1], radar.azimuth_beamwidth, radar.elevation_beamwidth)
    assert own.identity
    assert np.array_equal(channel_amplitude_factor(*u, own, own, None),
                          np.where(u[2] > 0, f * f, 0.0))
    # an element looking elsewhere, as a body-frame vector: its own frame's sines
    vector = Element((0, 0, 0), elevation_beamwidth_deg=30.0, boresight=(0.2, 0.7, -0.5))
    beam = element_beam(vector, widths, look)
    b = np.array([0.2, 0.7, -0.5]) / np.linalg.norm([0.2, 0.7, -0.5])
    az = np.cross(b, [0, 0, 1.0])
    az /= np.linalg.norm(az)
    s = directions @ np.stack([az, np.cross(b, az), b], axis=-1)
    expected = (np.sinc(s[:, 0] / radar.azimuth_beamwidth) * np.sinc(s[:, 1] / math.radians(30))
                * (s[:, 2] > 0))
    np.testing.assert_allclose(element_field_pattern(*u, beam), expected, rtol=0, atol=1e-12)
    g = math.sqrt(beam.gain * own.gain) / radar.antenna_gain
    np.testing.assert_allclose(channel_amplitude_factor(*u, own, beam, radar.antenna_gain),
                               g * expected * np.where(u[2] > 0, f, 0.0), rtol=0, atol=1e-12)
    # a vector boresight a Look can express gives that Look's frame
    b_look = look.boresight_body()
    same = element_beam(Element(boresight=tuple(b_look)), widths, look)
    np.testing.assert_allclose(same.rotation, np.eye(3), atol=1e-12)


def test_elements_validate_round_trip_and_parse_from_toml():
    radar = mitsar.Radar(receivers=[(0, 0, 0), {"position": (0, 0, 0.05),
                                                 "off_nadir_deg": 40.0,
                                                 "elevation_beamwidth_deg": 20.0}])
    assert radar.receivers == ((0.0, 0.0, 0.0), (0.0, 0.0, 0.05))
    assert mitsar.Radar.from_attrs(radar.to_attrs()) == radar
    assert "radar_receiver_elements" not in mitsar.Radar(receivers=[(0, 0, 0)]).to_attrs()
    for bad, name in (({"position": (0, 0, 0), "squint_deg": 5.0}, "off_nadir_deg"),
                      ({"position": (0, 0, 0), "off_nadir_deg": 200.0}, "off_nadir_deg"),
                      ({"position": (0, 0, 0), "boresight": (0, 0, 0)}, "boresight"),
                      ({"position": (0, 0, 0), "elevation_beamwidth_deg": 0}, "elevation"),
                      ({"position": (0, 0, 0), "gain": 2}, "gain"),
                      ({"position": (0, 0, 0), "off_nadir_deg": 40.0,
                        "boresight": (0, 1, 0)}, "boresight")):
        with pytest.raises(ParameterError, match=rf"receivers\[1\]\.{name}"):
            mitsar.Radar(receivers=[(0, 0, 0), bad])
    base = {"trajectory": {"kind": "linear", "start": [14.8, 1.4, 4.5],
                           "velocity": [0.5, 0, 0], "duration": 0.2},
            "look": {"off_nadir_deg": 55.7}, "targets": [{"position": [15, 8, 0]}]}
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MitsarWarning)
        parsed = experiment_from_dict({**base, "radar": {"receivers": [
            {"position": [0, 0, 0]},
            {"position": [0, 0, 0.05], "off_nadir_deg": 40.0,
             "elevation_beamwidth_deg": 20.0}]}}).radar
    assert parsed == radar
    with pytest.raises(ParameterError, match=r"radar.receivers\[1\].boresight"):
        experiment_from_dict({**base, "radar": {"receivers": [
            {"position": [0, 0, 0]}, {"position": [0, 0, 0.05], "boresight": [0, 1]}]}})


def test_channel_amplitude_factor_runs_on_drjit_arrays_as_on_numpy():
    """The tracer's entry point (docs/interferometry.md §8): the same formula with
    DRJIT_OPS on Float32 sines, within float32 rounding (1e-6) of NumPy's float64."""
    mi = pytest.importorskip("mitsuba")
    from mitsar.plugins.variant import register_plugins
    register_plugins()
    from mitsar.plugins.ops import DRJIT_OPS

    radar, look = mitsar.Radar(), mitsar.Look(55.7)
    beams = mitsar.Radar(receivers=[(0, 0, 0), {"position": (0, 0, 0.05),
                                                 "off_nadir_deg": 50.0, "squint_deg": 2.0,
                                                 "azimuth_beamwidth_deg": 12.0}]
                         ).channel_beams(look)[1]
    rng = np.random.default_rng(5)
    directions = rng.normal([0, 0.8, -0.6], 0.1, size=(4000, 3))
    directions /= np.linalg.norm(directions, axis=1, keepdims=True)
    u = direction_sines(directions, antenna_frame(look))
    expected = channel_amplitude_factor(*u, *beams, radar.antenna_gain)
    got = channel_amplitude_factor(*(mi.Float(np.float32(c)) for c in u), *beams,
                                   radar.antenna_gain, DRJIT_OPS)
    assert np.abs(expected).max() > 0.5
    np.testing.assert_allclose(np.asarray(got), expected, rtol=0, atol=1e-6)


def test_raw_products_carry_the_elements_through_netcdf(tmp_path):
    from mitsar.products.raw import radar_of
    radar = mitsar.Radar(receivers=[(0, 0, 0), {"position": (0, 0, 0.05),
                                                 "off_nadir_deg": 50.0}])
    raw = _simulate(radar, normalized=True)
    mitsar.save(raw, tmp_path / "raw.nc")
    assert radar_of(mitsar.load(tmp_path / "raw.nc")) == radar


@pytest.mark.parametrize(("transmit", "receive", "tolerance"), [
    ((0.0, None), (3.0, None), 5e-5),     # equal beams 3 deg apart: measured 2e-6
    ((0.0, None), (8.0, None), 1e-4),     # equal beams 8 deg apart: measured 4.5e-5
    ((0.0, None), (3.0, 18.0), 1e-4),     # 9.1 and 18 deg beams: measured 4e-5
    ((-2.0, 5.0), (4.0, 12.0), 1.5e-3),   # 5 and 12 deg beams 6 deg apart: measured 7e-4
])
def test_two_way_boresight_is_the_peak_of_the_two_way_pattern(transmit, receive, tolerance):
    """The channel's two-way beam centre (the boresights weighted by 1/beta_az^2, the peak of
    f_t f_r with each sinc to second order) against the peak of the exact product pattern
    found by scanning the squint at the look's off-nadir angle: the along-track (Doppler)
    component within ``tolerance`` in direction sine."""
    from mitsar.model.elements import two_way_boresight

    radar = mitsar.Radar()
    widths = (radar.azimuth_beamwidth, radar.elevation_beamwidth)
    t, r = (Element((0, 0, 0), off_nadir_deg=55.7, squint_deg=squint,
                    azimuth_beamwidth_deg=width) for squint, width in (transmit, receive))
    squints = np.radians(np.linspace(-15.0, 15.0, 30001))
    theta = math.radians(55.7)
    directions = np.stack([-np.sin(squints) * math.sin(theta),
                           np.cos(squints) * math.sin(theta),
                           np.full_like(squints, -math.cos(theta))], axis=-1)
    sines = directions @ LOOK.antenna_to_body()
    pattern = np.abs(element_field_pattern(*sines.T, element_beam(t, widths, LOOK))
                     * element_field_pattern(*sines.T, element_beam(r, widths, LOOK)))
    peak = directions[np.argmax(pattern)]
    assert abs(two_way_boresight(t, r, widths, LOOK)[0] - peak[0]) < tolerance
