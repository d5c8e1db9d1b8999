"""Echoes that cannot be received are said, naming the scatterer (issue 27 item 1;
docs/reliability.md §"Echoes that cannot be received"): beyond ``max_range`` the beat frequency
is above the receiver's band, outside the main lobe for the whole flight only sidelobes (or
nothing, behind the antenna) reach the receiver, and nearer than the Fraunhofer distance
2 D^2 / lambda (Balanis eq. 2-31) the far-field model does not hold."""

from __future__ import annotations

import math
import warnings

import numpy as np
import pytest

import mitsar
from mitsar.errors import MitsarWarning, ParameterError
from mitsar.model.reception import fraunhofer_distance

TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
LOOK = mitsar.Look(55.7)
IN_BEAM = np.array([15.0, 8.0, 0.3])  # the channels tests' target: in the main lobe
MIDDLE = np.array(TRACK.position(TRACK.duration / 2))


def _simulate(target, radar=None, **kwargs):
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        raw = mitsar.simulate_point_targets(radar or mitsar.Radar(), TRACK, LOOK,
                                            [mitsar.PointTarget(target)], **kwargs)
    return raw, [str(w.message) for w in caught if issubclass(w.category, MitsarWarning)]


def test_fraunhofer_distance_is_two_d_squared_over_lambda():
    radar = mitsar.Radar()
    diagonal = math.hypot(radar.wavelength / radar.azimuth_beamwidth,
                          radar.wavelength / radar.elevation_beamwidth)
    assert fraunhofer_distance(radar) == pytest.approx(2 * diagonal**2 / radar.wavelength)
    # paper Table 1 antenna (its beamwidths are lambda / l_AZ and lambda / d)
    assert diagonal == pytest.approx(math.hypot(radar.antenna_length, radar.antenna_width))


def test_a_target_in_the_beam_and_the_band_is_not_warned_about():
    raw, said = _simulate(IN_BEAM)
    assert said == [] and "reception_warnings" not in raw.attrs


def test_a_target_beyond_max_range_in_the_band_limit_is_named():
    """Between max_range (the receiver's band) and the Nyquist range the analytic model still
    writes the echo: it is said, with the target's name and range."""
    radar = mitsar.Radar()
    nyquist = radar.range_for_beat_frequency(radar.sampling_frequency / 2)
    assert nyquist > radar.max_range + 1.0
    direction = (IN_BEAM - MIDDLE) / np.linalg.norm(IN_BEAM - MIDDLE)
    target = MIDDLE + 0.5 * (radar.max_range + nyquist) * direction
    raw, said = _simulate(target, radar)
    assert len(said) == 1 and "targets[0]" in said[0] and "beyond max_range" in said[0]
    assert "every sweep" in said[0] and "beyond max_range" in raw.attrs["reception_warnings"]


def test_a_target_behind_a_down_looking_antenna_is_named_and_refused():
    """Above the platform, behind the antenna: the warning names it, and since nothing at
    all is received the simulation is refused."""
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        with pytest.raises(ParameterError, match="targets"):
            mitsar.simulate_point_targets(mitsar.Radar(), TRACK, LOOK,
                                          [mitsar.PointTarget(MIDDLE + [0, 0, 1.5])])
    said = [str(w.message) for w in caught if issubclass(w.category, MitsarWarning)]
    assert any("targets[0]" in s and "behind the antenna" in s for s in said)


def test_a_target_at_the_antenna_is_in_the_near_field_and_off_the_main_lobe():
    raw, said = _simulate(MIDDLE + [0.0, 0.05, 0.0])
    assert any("near field" in s and "targets[0]" in s for s in said)
    assert any("main lobe" in s for s in said)
    _, without_pattern = _simulate(MIDDLE + [0.0, 0.05, 0.0], pattern=False)
    assert not any("main lobe" in s for s in without_pattern)  # no pattern: no beam test


def test_a_scene_beyond_max_range_is_said_and_recorded():
    """The paper's room with max_range 8 m: part of the lit floor lies beyond it and its
    echoes are dropped by the tracer's bin grid: said and recorded; at the default 30 m
    nothing is said."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.1)
    for radar, expected in ((mitsar.Radar(), False), (mitsar.Radar(max_range=8.0), True)):
        with warnings.catch_warnings(record=True) as caught:
            warnings.simplefilter("always")
            raw = mitsar.simulate_scene(radar, track, LOOK, "control_volume", density=30.0)
        said = [str(w.message) for w in caught if "max_range" in str(w.message)]
        assert bool(said) == expected
        assert ("reception_warnings" in raw.attrs) == expected


def test_a_rendering_integrator_in_the_scene_is_said_to_be_ignored(tmp_path):
    """A scene written for rendering (``<integrator type="path"/>``) is traced by the default
    radar integrator, and the user is told (issue 27)."""
    scene = tmp_path / "rendering.xml"
    scene.write_text('<scene version="3.0.0"><integrator type="path"/>'
                     '<shape type="rectangle"><bsdf type="diffuse"/>'
                     '<transform name="to_world"><translate x="15" y="8" z="0"/></transform>'
                     '</shape></scene>')
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.02)
    with pytest.warns(MitsarWarning, match="PathIntegrator.*not a radar integrator"):
        try:
            mitsar.simulate_scene(mitsar.Radar(), track, LOOK, str(scene))
        except mitsar.MitsarError:
            pass  # whatever the scene gives: the warning came first
