"""Element beams in focusing (issue 22; docs/interferometry.md §8, "Element beams in
focusing"): the channels of a radar whose elements have beams of their own are processed on
one common Doppler band, centred on the mean of the channels' two-way beam centres.

Closed forms: a channel whose transmit and receive elements both look along
``b = Rz(s) (0, sin theta, -cos theta)`` (a Look of off-nadir theta and squint s) has its
two-way beam centred on b, so on a level track at speed v along x its Doppler centroid is
``2 v (x . b) / lambda = -2 v sin(s) sin(theta) / lambda``; and a radar whose elements all
look along b focuses as the radar mounted with that Look (same samples, same band).
"""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import mitsar
from mitsar.errors import MitsarWarning
from mitsar.focus.channels import channel_view
from mitsar.focus.grid import SlantGrid, track_frame
from mitsar.model.elements import Element

START = np.array([14.8, 1.4, 4.5])
SPEED = 0.5
TRACK = mitsar.Trajectory.linear(START, [SPEED, 0.0, 0.0], 3.0)
OFF_NADIR, SQUINT = 55.7, 10.0
BASELINE = (0.0, 0.0, 0.05)
R0, STEP = 8.0, 0.01


def _squinted(position):
    return Element(position, off_nadir_deg=OFF_NADIR, squint_deg=SQUINT)


@pytest.fixture(scope="module")
def case():
    """Elements squinted 10 deg on a radar looking broadside, and the radar mounted squinted;
    a scatterer 10 cm off the slant grid's plane where the squinted beam crosses mid-track."""
    elements = mitsar.Radar(transmitters=[_squinted((0, 0, 0))],
                            receivers=[_squinted((0, 0, 0)), _squinted(BASELINE)])
    mounted = mitsar.Radar(receivers=[(0, 0, 0), BASELINE])
    squinted_look = mitsar.Look(OFF_NADIR, SQUINT)
    with warnings.catch_warnings():  # a probe for the track's frame: its target is moot
        warnings.simplefilter("ignore", MitsarWarning)
        probe = mitsar.simulate_point_targets(mounted, TRACK, squinted_look,
                                              [mitsar.PointTarget(START)], normalized=True)
    origin, along, sight = track_frame(probe)
    a0 = 0.75 - R0 * math.tan(math.radians(SQUINT))
    target = mitsar.PointTarget(origin + a0 * along + R0 * sight
                                + 0.1 * np.cross(along, sight))
    grid = SlantGrid(along_track=a0 + STEP * np.arange(-15, 16),
                     slant_range=R0 + STEP * np.arange(-15, 16))
    raws = {"elements": mitsar.simulate_point_targets(elements, TRACK, mitsar.Look(OFF_NADIR),
                                                      [target], normalized=True),
            "mounted": mitsar.simulate_point_targets(mounted, TRACK, squinted_look, [target],
                                                     normalized=True)}
    return raws, grid


def test_channel_doppler_centroid_is_the_elements_boresight_closed_form(case):
    raws, grid = case
    image = mitsar.focus(raws["elements"], "bpa", grid, azimuth_resolution=0.1)
    expected = (-2 * SPEED * math.sin(math.radians(SQUINT)) * math.sin(math.radians(OFF_NADIR))
                / mitsar.Radar().wavelength)
    np.testing.assert_allclose(image["channel_doppler_centroid"].values, expected, rtol=1e-9)
    assert image.attrs["processed_doppler_centroid"] == pytest.approx(expected, rel=1e-9)
    # a radar without element beams records nothing new (its products are unchanged)
    plain = mitsar.focus(raws["mounted"], "bpa", grid, azimuth_resolution=0.1)
    assert "channel_doppler_centroid" not in plain.variables


@pytest.mark.parametrize("algorithm", ["bpa", "rda"])
def test_elements_looking_along_a_squint_focus_as_the_radar_mounted_so(case, algorithm):
    """The same samples on the same band: images equal to 1e-6 of the peak (measured 0 for
    BPA, 4e-16 for RDA). The look's own band (broadside, what a channel got before) holds the
    target 10 deg behind it only in its sidelobes: its peak is < 10 % (measured 0.06 %)."""
    raws, grid = case
    images = {name: mitsar.focus(raw, algorithm, grid, azimuth_resolution=0.1)["image"].values
              for name, raw in raws.items()}
    peak = np.abs(images["mounted"]).max()
    assert np.abs(images["elements"] - images["mounted"]).max() < 1e-6 * peak
    flat = [np.angle(v[0] * np.conj(v[1]))[15, 15] for v in images.values()]
    assert 0.5 < abs(flat[0]) < 2.5 and abs(flat[0] - flat[1]) < 1e-6
    if algorithm == "bpa":
        broadside = mitsar.focus(channel_view(raws["elements"], 0), "bpa", grid,
                                 azimuth_resolution=0.1)["image"].values
        assert np.abs(broadside).max() < 0.1 * peak


def test_a_pair_looking_apart_shares_one_band_between_its_beams():
    """Receivers squinted +4 and -4 deg with the radar's transmitter: their two-way centroids
    are opposite and the common band is the look's (by symmetry, to rounding); one band for
    both channels keeps the pair coherent. Their beam centres are ~2 deg from the band's, within
    half the 9.1 deg azimuth beam: no warning. Squinted +-12 deg (centres ~6 deg off), the
    focuser warns naming both channels."""
    radar = mitsar.Radar(receivers=[Element((0, 0, 0), off_nadir_deg=OFF_NADIR, squint_deg=4.0),
                                    Element(BASELINE, off_nadir_deg=OFF_NADIR, squint_deg=-4.0)])
    track = mitsar.Trajectory.linear(START, [SPEED, 0.0, 0.0], 0.8)
    target = mitsar.PointTarget([15.0, 8.0, 0.1])
    raw = mitsar.simulate_point_targets(radar, track, mitsar.Look(OFF_NADIR), [target],
                                        normalized=True)
    grid = SlantGrid(along_track=0.2 + STEP * np.arange(-10, 11),
                     slant_range=R0 + STEP * np.arange(-10, 11))
    with warnings.catch_warnings():
        warnings.simplefilter("error", MitsarWarning)
        image = mitsar.focus(raw, "bpa", grid, azimuth_resolution=0.1)
    centroids = image["channel_doppler_centroid"].values
    assert centroids[0] < 0 < centroids[1]
    assert abs(centroids[0] + centroids[1]) < 1e-9 * abs(centroids[0])
    assert abs(image.attrs["processed_doppler_centroid"]) < 1e-9 * abs(centroids[0])
    apart = mitsar.Radar(receivers=[
        Element((0, 0, 0), off_nadir_deg=OFF_NADIR, squint_deg=12.0),
        Element(BASELINE, off_nadir_deg=OFF_NADIR, squint_deg=-12.0)])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MitsarWarning)  # the simulator's, about the target
        raw = mitsar.simulate_point_targets(apart, track, mitsar.Look(OFF_NADIR), [target],
                                            normalized=True)
    with pytest.warns(MitsarWarning, match=r"channels \[0, 1\].*common processed band"):
        mitsar.focus(raw, "bpa", grid, azimuth_resolution=0.1)


def test_a_selection_of_channels_gets_the_band_of_its_own_beams():
    """``raw.isel(channel=[0, 2])`` of three receivers (squinted +4 deg, -4 deg, the look's):
    the band is centred between the two selected beams (their mean Doppler to 1e-3), not the
    three's, and the centroids are the full product's for those channels."""
    radar = mitsar.Radar(receivers=[Element((0, 0, 0), off_nadir_deg=OFF_NADIR, squint_deg=4.0),
                                    Element(BASELINE, off_nadir_deg=OFF_NADIR, squint_deg=-4.0),
                                    (0.0, 0.0, 0.1)])
    track = mitsar.Trajectory.linear(START, [SPEED, 0.0, 0.0], 0.8)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MitsarWarning)
        raw = mitsar.simulate_point_targets(radar, track, mitsar.Look(OFF_NADIR),
                                            [mitsar.PointTarget([15.0, 8.0, 0.1])],
                                            normalized=True)
    grid = SlantGrid(along_track=0.2 + STEP * np.arange(-5, 6),
                     slant_range=R0 + STEP * np.arange(-5, 6))
    full = mitsar.focus(raw, "bpa", grid, azimuth_resolution=0.1)
    pair = mitsar.focus(raw.isel(channel=[0, 2]), "bpa", grid, azimuth_resolution=0.1)
    np.testing.assert_array_equal(pair["channel"].values, [0, 2])
    np.testing.assert_allclose(pair["channel_doppler_centroid"].values,
                               full["channel_doppler_centroid"].values[[0, 2]], rtol=1e-12)
    centroids = pair["channel_doppler_centroid"].values
    assert pair.attrs["processed_doppler_centroid"] == pytest.approx(centroids.mean(), rel=1e-3)
    assert abs(full.attrs["processed_doppler_centroid"]) < 1e-9 * abs(centroids[0])
