"""Radar parameters: Table 1 derived values and refusal of impossible set-ups."""

import math

import pytest

import mitsar
from mitsar.model.radar import SPEED_OF_LIGHT


def test_table1_derived_values():
    radar = mitsar.Radar()
    assert radar.chirp_rate == pytest.approx(1.5e9 * 250.0)  # K = B / T
    assert radar.samples_per_sweep == 660  # round(fs T) = 165e3 / 250
    assert radar.range_resolution == pytest.approx(SPEED_OF_LIGHT / 3e9)
    assert radar.wavelength == pytest.approx(3.19e-3, rel=1e-3)  # Table 1: 3.2 mm
    assert radar.max_beat_frequency == pytest.approx(75.05e3, rel=1e-3)  # 2 K 30 m / c
    # Table 1 beamwidths 9 deg (azimuth) and 18 deg (elevation) = lambda / D.
    assert radar.azimuth_beamwidth == pytest.approx(radar.wavelength / 0.02)
    assert math.degrees(radar.azimuth_beamwidth) == pytest.approx(9.0, abs=0.2)
    assert radar.elevation_beamwidth == pytest.approx(radar.wavelength / 0.01)
    assert math.degrees(radar.elevation_beamwidth) == pytest.approx(18.0, abs=0.3)
    # Uniform aperture gain 4 pi A / lambda^2 = 23.9 dBi.
    assert 10 * math.log10(radar.antenna_gain) == pytest.approx(23.93, abs=0.01)


def test_range_frequency_round_trip():
    radar = mitsar.Radar()
    assert radar.range_for_beat_frequency(radar.beat_frequency(12.3)) == pytest.approx(12.3)


@pytest.mark.parametrize(("name", "value"), [
    ("prf", -250.0), ("bandwidth", 0.0), ("carrier_frequency", float("nan")),
    ("antenna_width", -0.01), ("transmit_power", 0.0),
])
def test_non_positive_values_are_refused(name, value):
    with pytest.raises(mitsar.ParameterError, match=f"'{name}'"):
        mitsar.Radar(**{name: value})


def test_beat_frequency_above_nyquist_is_refused():
    # 2 K R / c at 35 m = 87.6 kHz > fs / 2 = 82.5 kHz.
    with pytest.raises(mitsar.ParameterError, match="'max_range'.*Nyquist") as info:
        mitsar.Radar(max_range=35.0)
    assert "32.977" in str(info.value)  # the largest range that fits, c fs / (4 K)


def test_prf_below_doppler_bandwidth_is_refused():
    radar = mitsar.Radar()
    band = radar.doppler_bandwidth(2.0)  # 4 v sin(4.57 deg) / lambda = 200 Hz
    assert band == pytest.approx(4 * 2.0 * math.sin(radar.azimuth_beamwidth / 2)
                                 / radar.wavelength)
    radar.check_prf(2.0)
    with pytest.raises(mitsar.ParameterError, match="'prf'.*Doppler bandwidth"):
        radar.check_prf(3.5)


def test_attrs_round_trip():
    radar = mitsar.Radar(prf=500.0, max_range=15.0, noise_figure_db=8.0)
    assert mitsar.Radar.from_attrs(radar.to_attrs()) == radar


@pytest.mark.parametrize(("name", "value"), [("transmit_power", 1e300), ("antenna_width", 1e300),
                                             ("sampling_frequency", 1e15)])
def test_impossible_radars_are_refused_before_any_compute(name, value):
    """Found by the fuzz campaign (issue 15): these overflowed or asked for petabytes later."""
    with pytest.raises(mitsar.ParameterError, match=name):
        mitsar.Radar(**{name: value})


def test_unknown_keywords_are_named():
    with pytest.raises(mitsar.ParameterError, match="bogus"):
        mitsar.Radar(bogus=1)
    with pytest.raises(mitsar.ParameterError, match="off_nadir"):
        mitsar.Look(off_nadir=55.0)
    with pytest.raises(mitsar.ParameterError, match="vibrations"):
        mitsar.NavigationErrors(vibrations=())
