"""TDM-MIMO (issue 22): several transmitters taking turns sweep by sweep, 3 x 4 channels.

Layout (94 GHz, lambda = 3.19 mm): four receivers lambda/2 apart along the body z axis and
three transmitters 2 lambda (= N_rx lambda/2) apart along z, the vertical form of TI's
3 TX x 4 RX pattern: its far-field virtual array t_i + r_j is a filled 12-element line with
lambda/2 steps (docs/interferometry.md §8, "TDM-MIMO"). Sweep k is transmitted by transmitter
k mod 3; channel c = i N_rx + j is (transmitter i, receiver j).

Closed forms: the dechirped phase of a sample at fast time t of a sweep that channel (i, j)
fires is 2 pi [f_c tau + K tau t - K tau^2 / 2] with tau = (|t_i - q| + |q - r_j|) / c, the
phase centres at that sample's own time (paper eqs. 1-2; Rosen et al. 2000 §II). The
far-field path ``2 R - u.(t + r)`` misses ``(|t_perp|^2 + |r_perp|^2) / (2 R)`` to second
order (../shared/reference/interferometry-notes.md §3).
"""

from __future__ import annotations

import numpy as np
import pytest
import xarray as xr

import mitsar
from mitsar.errors import ParameterError
from mitsar.focus.channels import channel_view
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import fast_time
from mitsar.raw.analytic import stream_point_targets

WAVELENGTH = SPEED_OF_LIGHT / 94e9
RECEIVERS = [(0.0, 0.0, j * WAVELENGTH / 2) for j in range(4)]
TRANSMITTERS = [(0.0, 0.0, i * 2 * WAVELENGTH) for i in range(3)]
RADAR = mitsar.Radar(receivers=RECEIVERS, transmitters=TRANSMITTERS)
TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.8)
LOOK = mitsar.Look(55.7)
TARGET = np.array([15.0, 8.0, 0.0])


@pytest.fixture(scope="module")
def raw():
    return mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                         normalized=True)


def _wrap(phase):
    return np.angle(np.exp(1j * phase))


def _closed_form_phase(channel, sweep, sample):
    """2 pi [f_c tau + K tau t - K tau^2/2] of channel (i, j) at one sample, with t_i and r_j
    on the track at that sample's own time (a straight level track: body = world axes)."""
    i, j = divmod(channel, len(RECEIVERS))
    t = fast_time(RADAR)[sample]
    time = sweep * RADAR.sweep_duration + RADAR.sweep_duration / 2 + t
    body = TRACK.position(time)
    tau = (np.linalg.norm(body + np.asarray(TRANSMITTERS[i]) - TARGET)
           + np.linalg.norm(body + np.asarray(RECEIVERS[j]) - TARGET)) / SPEED_OF_LIGHT
    k = RADAR.chirp_rate
    return 2 * np.pi * (RADAR.carrier_frequency * tau + k * tau * t - k * tau**2 / 2)


def test_radar_declares_the_pairs_and_round_trips():
    assert RADAR.is_tdm and RADAR.transmitter_count == 3 and RADAR.channel_count == 12
    assert RADAR.channel_pairs()[5] == (1, 1)
    transmitters, receivers = RADAR.channel_offsets()
    assert transmitters[5] == TRANSMITTERS[1] and receivers[5] == RECEIVERS[1]
    assert mitsar.Radar.from_attrs(RADAR.to_attrs()) == RADAR
    firing = RADAR.firing(np.arange(7))
    assert firing.shape == (12, 7) and firing[4:8, 4].all()
    assert firing.sum(axis=0).tolist() == [4] * 7
    # the far-field virtual array: a filled line of 12 elements lambda/2 apart
    heights = np.sort(RADAR.virtual_phase_centres()[:, 2])
    assert np.allclose(np.diff(heights), WAVELENGTH / 2, rtol=0, atol=1e-15)
    with pytest.raises(ParameterError, match="channels"):
        mitsar.Radar(receivers=[(0, 0, 0)] * 16, transmitters=[(0, 0, 0)] * 5)


def test_each_channel_phase_is_the_closed_form_at_its_own_slot_time(raw):
    """All 12 channels, one sample of a sweep each channel fires (three consecutive sweeps,
    one per slot): the phase against the closed form within 1 mrad (measured 1e-7 rad);
    the platform moves 2 mm per sweep, so evaluating slot i at slot 0's sweep instead would be
    wrong by far more (> 0.1 rad; measured 0.136 rad at least)."""
    sample = 100
    values = raw["raw"].values
    worst, wrong_slot = 0.0, []
    for channel in range(12):
        i = channel // 4
        sweep = 30 + i  # sweeps 30, 31, 32: slots 0, 1, 2
        assert raw["fires"].values[channel, sweep]
        measured = np.angle(values[channel, sweep, sample])
        worst = max(worst, abs(_wrap(measured - _closed_form_phase(channel, sweep, sample))))
        if i:
            wrong_slot.append(abs(_wrap(measured - _closed_form_phase(channel, 30, sample))))
    assert worst < 1e-3
    assert min(wrong_slot) > 0.1


def test_channels_are_zero_where_their_transmitter_is_silent(raw):
    fires = raw["fires"].values
    sweeps = raw["sweep"].values
    slots = raw["channel_transmitter"].values
    assert np.array_equal(fires, (sweeps[None, :] % 3) == slots[:, None])
    assert raw["channel_receiver"].values.tolist() == [0, 1, 2, 3] * 3
    values = raw["raw"].values
    assert not np.any(values[~fires]) and np.all(np.abs(values[fires]).max(axis=-1) > 0)


def test_streamed_chunks_keep_the_slots():
    """Chunks of 7 sweeps (not a multiple of 3) concatenate to the whole product: the slot of
    a sweep follows its acquisition index."""
    target = [mitsar.PointTarget(TARGET)]
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.1)
    whole = mitsar.simulate_point_targets(RADAR, track, LOOK, target, normalized=True)
    parts = list(stream_point_targets(RADAR, track, LOOK, target, normalized=True,
                                             sweeps_per_chunk=7))
    joined = xr.concat([p["raw"] for p in parts], dim="sweep")
    assert np.array_equal(joined.values, whole["raw"].values)
    assert np.array_equal(xr.concat([p["fires"] for p in parts], dim="sweep").values,
                          whole["fires"].values)


def test_prf_is_checked_per_transmitter():
    """At 0.9 m/s the beam's Doppler bandwidth (~90 Hz) fits the PRF of 250 Hz but not the
    83 Hz at which each of 3 transmitters' channels is sampled: refused before any compute."""
    fast = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.9, 0.0, 0.0], 0.8)
    mitsar.Radar(receivers=RECEIVERS).check_prf(0.9)  # one transmitter: fine
    with pytest.raises(ParameterError, match=r"prf.*3 transmitters") as error:
        mitsar.simulate_point_targets(RADAR, fast, LOOK, [mitsar.PointTarget(TARGET)])
    assert "raise the PRF" in str(error.value)


def test_channel_view_keeps_its_firing_sweeps(raw):
    view = channel_view(raw, 6)  # transmitter 1, receiver 2
    assert view.attrs["sweep_stride"] == 3 and view["raw"].dims == ("sweep", "sample")
    assert np.array_equal(view["sweep"].values, raw["sweep"].values[1::3])
    assert np.array_equal(view["platform_position"].values,
                          raw["platform_position"].values[1::3])  # its own slot's motion
    # sampled at PRF / 3: the whole beam's Doppler band does not fit (any focuser)
    with pytest.raises(ParameterError, match=r"sweep rate 83.3+ Hz \(PRF 250 Hz / 3 trans"):
        mitsar.focus(view, "rda")


def test_twelve_channels_focus_onto_one_grid_with_a_flat_phase(raw):
    """Every channel back-projected from its own sweeps onto channel 0's pixels: at the target's
    pixel (on the grid, so the reference surface's phase is removed by construction) the 12
    phases agree within 1 mrad (measured 0.50 mrad), and each channel's amplitude is the
    single-transmitter radar's within 1% (the normalisation counts only the channel's sweeps;
    measured 0.2%)."""
    grid = mitsar.grid.PlaneGrid(origin=(14.9, 7.9, 0.0), axis_u=(1, 0, 0), axis_v=(0, 1, 0),
                                 u=(0.0, 0.2, 0.01), v=(0.0, 0.2, 0.01))
    image = mitsar.focus(raw, "bpa", grid, azimuth_resolution=0.1)
    assert image["image"].shape[0] == 12
    assert image["channel_transmitter"].values.tolist() == [0] * 4 + [1] * 4 + [2] * 4
    peak = np.unravel_index(np.abs(image["image"].values[0]).argmax(),
                            image["image"].shape[1:])
    assert np.allclose(image["position"].values[peak], TARGET, atol=1e-9)
    values = image["image"].values[(slice(None), *peak)]
    assert np.abs(np.angle(values * np.conj(values[0]))).max() < 1e-3
    single = mitsar.simulate_point_targets(mitsar.Radar(receivers=RECEIVERS[:1]), TRACK, LOOK,
                                           [mitsar.PointTarget(TARGET)], normalized=True)
    reference = mitsar.focus(single, "bpa", grid, azimuth_resolution=0.1)["image"].values
    assert np.abs(values) == pytest.approx(abs(reference[(0, *peak)]), rel=0.01)


def test_virtual_array_far_field_error_is_the_near_field_term():
    """The far-field phase k (2 R - u.(t + r)) of each pair against the exact
    k (|t - q| + |q - r|): they differ by the near-field term pi (|t_perp|^2 + |r_perp|^2) /
    (lambda R) (here up to 16 mrad at 8 m, 20 mrad at 5.9 m: the virtual array is a far-field
    picture only), and the rest is third order, k (u.t) |t_perp|^2 / (2 R^2) and the same of
    r (< 1e-4 rad; measured 1.3e-5 rad)."""
    k = 2 * np.pi / WAVELENGTH
    transmitters, receivers = (np.asarray(a) for a in RADAR.channel_offsets())
    virtual = RADAR.virtual_phase_centres()
    body = TRACK.position(0.4)
    for target in (TARGET, np.array([14.0, 6.0, 1.0])):
        offset = target - body
        distance = np.linalg.norm(offset)
        unit = offset / distance
        exact = k * (np.linalg.norm(body + transmitters - target, axis=1)
                     + np.linalg.norm(body + receivers - target, axis=1))
        far_field = k * (2 * distance - virtual @ unit)
        across = (np.sum(transmitters**2, axis=1) - (transmitters @ unit) ** 2
                  + np.sum(receivers**2, axis=1) - (receivers @ unit) ** 2)
        near_field = np.pi * across / (WAVELENGTH * distance)
        assert near_field.max() > 1e-2  # the far-field picture is not exact at 8 m
        assert np.abs(exact - far_field - near_field).max() < 1e-4


def test_traced_channels_trace_their_own_slots():
    """The ray tracer traces channel (i, j) over the sweeps of slot i only: zeros elsewhere,
    and each channel against the analytic simulator's within -50 dB (the histogram's tone
    model, as tests/test_channels.py)."""
    radar = mitsar.Radar(receivers=RECEIVERS[:2], transmitters=TRANSMITTERS[:2])
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.2)
    look, target = mitsar.Look(55.71), np.array([15.0, 8.0, 0.03])  # canned point_target.xml
    traced = mitsar.simulate_scene(radar, track, look, "point_target")
    analytic = mitsar.simulate_point_targets(radar, track, look, [mitsar.PointTarget(target)])
    assert np.array_equal(traced["fires"].values, analytic["fires"].values)
    assert not np.any(traced["raw"].values[~traced["fires"].values])
    for k in range(4):
        error = np.sum(np.abs(traced["raw"].values[k] - analytic["raw"].values[k]) ** 2)
        assert 10 * np.log10(error / np.sum(np.abs(analytic["raw"].values[k]) ** 2)) < -50
    hist = mitsar.trace(radar, track, look, "point_target", channel=3)
    assert hist.attrs["sweep_stride"] == 2
    assert np.array_equal(hist["sweep"].values, traced["sweep"].values[1::2])


def test_toml_phase_centres_as_arrays_or_tables_are_the_same_radar():
    """``[radar] receivers = [[...], ...]`` or ``[[radar.receivers]]`` tables with
    ``position`` (issue 22's TOML spelling) give the same radar; an unknown key of an element
    is refused naming it."""
    from mitsar.experiment.loading import experiment_from_dict

    base = {"trajectory": {"start": [14.9, 1.4, 4.5], "velocity": [0.5, 0.0, 0.0],
                           "duration": 0.2},
            "look": {"off_nadir_deg": 55.71}, "targets": [{"position": [15.0, 8.0, 0.0]}]}
    transmitters, receivers = [(0.0, 0.0, 0.0), (0.0, 0.0, 0.01)], [(0.0, 0.0, 0.0),
                                                                     (0.0, 0.0, 0.05)]
    arrays = experiment_from_dict({**base, "radar": {
        "transmitters": [list(p) for p in transmitters],
        "receivers": [list(p) for p in receivers]}}).radar
    tables = experiment_from_dict({**base, "radar": {
        "transmitters": [{"position": list(p)} for p in transmitters],
        "receivers": [{"position": list(p)} for p in receivers]}}).radar
    assert arrays == tables and tables.channel_count == 4
    with pytest.raises(ParameterError, match=r"radar.receivers\[1\].gain"):
        experiment_from_dict({**base, "radar": {"receivers": [
            {"position": [0, 0, 0]}, {"position": [0, 0, 0.05], "gain": 2}]}})
