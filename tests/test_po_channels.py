"""Physical optics of receive channels (issue 22: "bistatic path length and visibility per
receiver; one trace serves all receivers of a transmitter"), docs/interferometry.md §8.

The facets' chains and lit apertures are the transmitter's; each receiver gets its own echo of
every chain and sub-facet: the scattered direction toward it (so a plate's bistatic pattern),
its range in the bistatic radar equation ``1 / (R_t R_r)``, its pattern, its shadow ray and
its own path ``R_t + R_r`` (mitsar.raw.physical_optics.FacetEchoes, ``receivers``).

Closed forms: the plate's echo at finite range against a scalar Kirchhoff quadrature of
``exp(j k (R_t + R_r))`` over the plate (independent of mitsar's sub-facets and Gordon
integrals), and the trihedral's phase centre at its apex (the exact bistatic path through it,
from the analytic simulator).
"""

import math

import numpy as np
import pytest
from test_physical_optics import _plate_scene  # tests/ is on sys.path (no __init__.py)
from test_po_multipath import _ply, _setup

BASELINE = 0.05  # receiver above the transmitter [m] (docs/interferometry.md)


def _plate_axes(normal):
    """The in-plane axes of ``_plate_scene``'s plate of unit normal ``normal``."""
    u = np.cross(normal, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    return u, np.cross(normal, u)


def _kirchhoff(centre, u, w, side, transmitter, receiver, k, points=400, weight=None):
    """``sum exp(j k (|x - t| + |x - r|)) dA`` over a square plate (midpoint rule, 0.125 mm
    cells at 5 cm: 1/25 of a wavelength), each point times ``weight(x)`` if given."""
    g = (np.arange(points) + 0.5) / points - 0.5
    x = centre + side * (g[:, None, None] * u + g[None, :, None] * w)
    path = (np.linalg.norm(x - transmitter, axis=-1) + np.linalg.norm(x - receiver, axis=-1))
    terms = np.exp(1j * k * path) if weight is None else weight(x) * np.exp(1j * k * path)
    return terms.sum() * (side / points) ** 2


@pytest.mark.filterwarnings("ignore:radar integrator. shapes without a radar material")
def test_a_plates_channels_follow_its_bistatic_kirchhoff_integral():
    """A 5 cm plate at 5 m facing the transmitter; a receiver 5 cm above sees it 0.01 rad off
    its specular direction. Measured: channel 1 / channel 0 power -0.261 dB against the
    closed form's -0.260 dB (Kirchhoff -0.204 dB, the receiver's longer range -0.056 dB);
    interferometric phase 0.96 mrad from the quadrature's. The monostatic echo sent to every
    receiver would give 0 dB; the transmitter's range in the radar equation -0.204 dB."""
    mitsar, mi, _, look, track, boresight = _setup()
    radar = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, BASELINE)])
    side, distance = 0.05, 5.0
    antenna = np.array([0.0, 0.0, 3.0])
    centre = antenna + distance * boresight
    scene = _plate_scene(mi, centre, -boresight, side)
    raw = mitsar.simulate_scene(radar, track, look, scene, physical_optics=["plate"])
    assert raw["raw"].dims[0] == "channel"
    values = raw["raw"].values
    # channel 0 is at the transmitter: the monostatic trace's deposits (its bin grid is
    # widened by the channels' reach, so the synthesis rounds differently: 1e-15)
    alone = mitsar.simulate_scene(mitsar.Radar(), track, look, scene, physical_optics=True)
    np.testing.assert_allclose(values[0], alone["raw"].values, rtol=0,
                               atol=1e-12 * abs(values[0]).max())
    # closed form at the middle sweep (5 sweeps over 4 mm: the ratio moves < 1e-4 dB)
    u, w = _plate_axes(-boresight)
    k = 2 * math.pi / radar.wavelength
    receivers = [antenna, antenna + [0.0, 0.0, BASELINE]]
    fields = [_kirchhoff(centre, u, w, side, antenna, r, k) for r in receivers]
    ranges = [np.linalg.norm(centre - r) for r in receivers]
    expected_db = 20 * math.log10(abs(fields[1]) / abs(fields[0]) * ranges[0] / ranges[1])
    measured_db = 10 * math.log10(np.sum(abs(values[1]) ** 2) / np.sum(abs(values[0]) ** 2))
    # the linear split of the histogram at the channels' different fractional bins moves a
    # channel's power by up to 0.04 dB (docs/design.md §5.5)
    assert measured_db == pytest.approx(expected_db, abs=0.05)
    assert expected_db < -0.2   # the plate's bistatic loss is what is measured
    interferometric = np.angle(np.vdot(values[1], values[0]))
    closed = np.angle(fields[0] * np.conj(fields[1]))
    assert abs(np.angle(np.exp(1j * (interferometric - closed)))) < 2e-3
    assert abs(closed) > 0.5


def test_a_trihedrals_channels_share_one_trace_and_its_apex(tmp_path):
    """A 4 cm trihedral at 5 m (triple bounce, max_depth 4): the interferometric phase of
    the two channels within 2 mrad of the exact bistatic paths through its apex (analytic
    simulator; measured 0.74 mrad), and one trace of both receivers gives each channel the
    bits of a trace of that channel alone."""
    mitsar, mi, _, look, track, boresight = _setup()
    from mitsar.raw.traced import histogram_to_raw_product, trace

    radar = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, BASELINE)])
    edge, apex, axis = 0.04, np.array([0.0, 0.0, 3.0]) + 5.0 * boresight, -boresight
    e1 = np.cross(axis, [1.0, 0, 0])
    e1 /= np.linalg.norm(e1)
    e2 = np.cross(axis, e1)
    basis = [axis / math.sqrt(3) + math.sqrt(2 / 3) * (math.cos(t) * e1 + math.sin(t) * e2)
             for t in (0, 2 * math.pi / 3, 4 * math.pi / 3)]
    _ply(tmp_path / "corner.ply", np.array([[apex, apex + edge * basis[i], apex + edge * basis[j]]
                                            for i, j in ((0, 1), (1, 2), (2, 0))]))
    scene = mi.load_dict({"type": "scene", "corner": {
        "type": "ply", "filename": str(tmp_path / "corner.ply"),
        "bsdf": {"type": "doublelobe", "preset": "mirror"}}})
    options = {"physical_optics": True, "max_depth": 4}
    values = mitsar.simulate_scene(radar, track, look, scene, orders=3, **options)["raw"].values
    point = mitsar.simulate_point_targets(radar, track, look, [mitsar.PointTarget(
        apex, 4 * math.pi * edge**4 / (3 * radar.wavelength**2))])["raw"].values
    measured = np.angle(np.vdot(values[1], values[0]))
    expected = np.angle(np.vdot(point[1], point[0]))
    assert abs(np.angle(np.exp(1j * (measured - expected)))) < 2e-3
    for channel in (0, 1):
        coherence = abs(np.vdot(values[channel], point[channel])) / (
            np.linalg.norm(values[channel]) * np.linalg.norm(point[channel]))
        assert coherence > 0.9999
        alone = histogram_to_raw_product(trace(radar, track, look, scene, channel=channel,
                                               **options), orders=3)["raw"].values
        np.testing.assert_array_equal(values[channel], alone)


def test_a_receive_element_weights_its_plate_echo_by_its_own_beam():
    """The plate of the Kirchhoff test seen by a receive element 5 cm above with its own
    boresight (6 degrees off the look) and a 4-degree elevation beam: channel 1 / channel 0 is
    the ratio of the Kirchhoff quadratures with each receiver's field pattern and 1/R_r at
    every point of the plate (the narrow beam changes across it), times the element's gain
    over the radar's, G_r / G (mitsar.model.elements). Measured -7.059 dB against -7.070 dB;
    the radar's beam would be 6.8 dB off."""
    from mitsar.model.elements import element_field_pattern
    from mitsar.model.geometry.antenna import direction_sines
    from mitsar.model.geometry.attitude import antenna_frame

    mitsar, mi, plain, look, track, boresight = _setup()
    element = {"position": (0.0, 0.0, BASELINE), "off_nadir_deg": look.off_nadir_deg - 6.0,
               "elevation_beamwidth_deg": 4.0}
    radar = mitsar.Radar(receivers=[(0, 0, 0), element])
    side, antenna = 0.05, np.array([0.0, 0.0, 3.0])
    centre = antenna + 5.0 * boresight
    scene = _plate_scene(mi, centre, -boresight, side)
    values = mitsar.simulate_scene(radar, track, look, scene, physical_optics=True)["raw"].values
    u, w = _plate_axes(-boresight)
    k = 2 * math.pi / radar.wavelength
    receivers = [antenna, antenna + [0.0, 0.0, BASELINE]]
    frame = antenna_frame(look)
    beams = radar.channel_beams(look)

    def weight(receiver, beam):
        def at(x):
            line = x - receiver
            distance = np.linalg.norm(line, axis=-1)
            sines = direction_sines((line / distance[..., None]).reshape(-1, 3), frame)
            return (element_field_pattern(*sines, beam).reshape(distance.shape) / distance)
        return at

    fields = [_kirchhoff(centre, u, w, side, antenna, receivers[c], k,
                         weight=weight(receivers[c], beams[c][1])) for c in (0, 1)]
    gains = [beams[c][1].gain for c in (0, 1)]
    expected_db = 10 * math.log10((abs(fields[1]) / abs(fields[0])) ** 2 * gains[1] / gains[0])
    measured_db = 10 * math.log10(np.sum(abs(values[1]) ** 2) / np.sum(abs(values[0]) ** 2))
    assert measured_db == pytest.approx(expected_db, abs=0.05)   # the split, as above
    radar_beam = _kirchhoff(centre, u, w, side, antenna, receivers[1], k,
                            weight=weight(receivers[1], beams[0][1]))
    assert abs(20 * math.log10(abs(fields[1]) / abs(radar_beam)) + 10 * math.log10(
        gains[1] / gains[0])) > 3.0   # the element's beam is what counts


def test_a_receiver_far_behind_the_transmitter_keeps_its_echo():
    """A receiver 0.8 m behind the transmitter on its line of sight to the plate: the same
    scattered direction (no bistatic loss), a half path 0.4 m longer than the transmitter's
    range, beyond the facets' range margin (the bin grid is widened by the channels' reach;
    the echo fell off it, silently, before). Closed form: the power ratio of the two channels
    is (R_0 / R_1)^2 = (5 / 5.8)^2, -1.289 dB (within the histogram split's 0.04 dB)."""
    mitsar, mi, _, look, track, boresight = _setup()
    radar = mitsar.Radar(receivers=[(0, 0, 0), tuple(-0.8 * boresight)])  # level track: body
    centre = np.array([0.0, 0.0, 3.0]) + 5.0 * boresight                  # frame = world
    scene = _plate_scene(mi, centre, -boresight, 0.05)
    values = mitsar.simulate_scene(radar, track, look, scene, physical_optics=["plate"],
                                   backscatter=False)["raw"].values
    measured_db = 10 * math.log10(np.sum(abs(values[1]) ** 2) / np.sum(abs(values[0]) ** 2))
    assert measured_db == pytest.approx(20 * math.log10(5.0 / 5.8), abs=0.05)
