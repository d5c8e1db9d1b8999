"""FFBP of a multi-channel product (issue 22: "BPA/FFBP: same pixels, so co-registered by
construction"), against BPA of the same channels on the same grid.

A channel whose receiver is not its transmitter is back-projected on half its exact path in
every stage of FFBP (mitsar.focus.ffbp step 3; docs/focusing.md § FFBP, "Channels"): the first
stage through BPA's own per-pulse sum, each polar image demodulated by half its node's path
from the sub-aperture's two phase-centre centres, every merge re-phased by half the change of
both ranges. The error is ``20 log10(||ffbp - bpa|| / ||bpa||)`` per channel, and the bound is
the monostatic channel's own error (FFBP's approximation, -35 dB at worst:
tests/test_ffbp_turns.py) plus 1.5 dB: a channel must not focus worse for its receiver.
"""

import math

import numpy as np
import pytest

import mitsar
from mitsar.focus.grid import PlaneGrid

LOOK = mitsar.Look(55.7)
HEIGHT = 4.5
TARGET = np.array([15.0, 8.0, 0.3])
VERTICAL = (0.0, 0.0, 0.05)   # the bundled interferometer's baseline (docs/interferometry.md)
OBLIQUE = (0.3, 0.2, 0.4)     # 0.54 m, 0.3 m of it along track
MARGIN_DB = 1.5


def _error_db(image, reference):
    return 20 * math.log10(np.linalg.norm(image - reference) / np.linalg.norm(reference))


def _plane(target, extent=0.6, step=0.005):
    axis = [-extent / 2, extent / 2, step]
    return PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=axis, v=axis)


def _both(raw, grid, resolution=0.1, **options):
    return [mitsar.focus(raw, algorithm, grid, azimuth_resolution=resolution, **options)
            for algorithm in ("bpa", "ffbp")]


@pytest.mark.parametrize("receiver", [VERTICAL, OBLIQUE], ids=["vertical-5cm", "oblique-54cm"])
def test_ffbp_focuses_every_channel_as_bpa_on_a_straight_track(receiver):
    """Measured: -48.4 dB (channel 0) and -48.6 / -48.7 dB (the receiver's channel); the
    interferogram at the target within 0.6 mrad of BPA's. Demodulating the receiver's channel
    by the transmitter's range instead (the monostatic stages) gave +2.7 dB on the oblique
    baseline."""
    radar = mitsar.Radar(receivers=[(0, 0, 0), receiver])
    raw = mitsar.simulate_point_targets(mitsar.Radar(receivers=[(0, 0, 0), receiver]),
                                        mitsar.Trajectory.linear([14.8, 1.4, HEIGHT],
                                                                 [0.5, 0.0, 0.0], 0.8),
                                        LOOK, [mitsar.PointTarget(TARGET)], normalized=True)
    bpa, ffbp = _both(raw, _plane(TARGET))
    assert ffbp["image"].dims == bpa["image"].dims and ffbp.sizes["channel"] == 2
    np.testing.assert_array_equal(ffbp["receiver_offset"].values, radar.channel_offsets()[1])
    errors = [_error_db(ffbp["image"].values[k], bpa["image"].values[k]) for k in range(2)]
    assert errors[0] < -40.0
    assert errors[1] < errors[0] + MARGIN_DB
    peak = np.unravel_index(np.argmax(np.abs(bpa["image"].values[0])), bpa["image"].shape[1:])
    b0, b1 = bpa["image"].values[(slice(None), *peak)]
    f0, f1 = ffbp["image"].values[(slice(None), *peak)]
    # FFBP's -48 dB is ~4 mrad of phase per channel at most; the pair's errors are common
    assert abs(np.angle(f0 * np.conj(f1) * np.conj(b0 * np.conj(b1)))) < 2e-3


def _turn_raw(radar, turn_deg=20.0, radius=10.0):
    """A left turn (default the 20-degree turn of radius 10 m of tests/test_ffbp_turns.py),
    the point broadside at its middle: "pixel" band selection, each pixel's band summed from
    sub-apertures of any stage (mitsar.focus.ffbp_band.merge_band)."""
    turn = math.radians(turn_deg)
    points = [[12.0, 1.4, HEIGHT], [15.0, 1.4, HEIGHT],
              [15.0 + 3 * math.cos(turn), 1.4 + 3 * math.sin(turn), HEIGHT]]
    track = mitsar.Trajectory.flight(points, 0.5, turn_radius=radius)
    time = (3 - radius * math.tan(turn / 2) + radius * turn / 2) / 0.5
    position, velocity = track.position(np.array([time]))[0], track.velocity(np.array([time]))[0]
    heading = velocity / np.linalg.norm(velocity)
    target = (np.array([position[0], position[1], 0.0]) + HEIGHT
              * math.tan(math.radians(LOOK.off_nadir_deg)) * np.array([-heading[1], heading[0], 0]))
    raw = mitsar.simulate_point_targets(radar, track, LOOK, [mitsar.PointTarget(target)],
                                        normalized=True)
    return raw, target


@pytest.mark.parametrize(("receiver", "turn", "radius", "resolution", "windows"), [
    (OBLIQUE, 20.0, 10.0, 0.1, ("hamming", "rect")),
    ((0.0, 0.6, 0.0), 40.0, 3.0, 0.05, ("hamming",))], ids=["oblique", "lateral-tight"])
def test_ffbp_channels_on_a_turn_with_a_tapered_window(receiver, turn, radius, resolution,
                                                       windows):
    """The Hamming window weights a whole sub-aperture by reading its image at shifted
    direction cosines (mitsar.focus.ffbp_band._windowed_piece). For the receiver's channel
    the step also moves half its path, so the read moves in range too, and the receiver's
    phase ramp turns at kappa times the transmitter's (_receiver_read). Measured, oblique
    receiver on the 20-degree turn: channel 0 -41.8 dB, the receiver's -41.6 dB; without the
    range shift -35.5 dB; rect -48.8 and -49.4 dB. A receiver 0.6 m to the side on a
    40-degree turn of radius 3 m at 5 cm: -46.0 and -46.3 dB; with kappa = 1, -42.5 dB."""
    raw, target = _turn_raw(mitsar.Radar(receivers=[(0, 0, 0), receiver]), turn, radius)
    for window in windows:
        bpa, ffbp = _both(raw, _plane(target), window=window, resolution=resolution)
        assert ffbp.attrs["ffbp_final"] == "pixel band"
        errors = [_error_db(ffbp["image"].values[k], bpa["image"].values[k]) for k in range(2)]
        assert errors[0] < -35.0, window
        assert errors[1] < errors[0] + MARGIN_DB, window
