"""Sionna RT scenes in mitsar (docs/scenes.md, docs/materials.md §4): the ``itu-radio-material`` and
``radio-material`` BSDFs, the ITU-R P.2040-3 permittivities, the Fresnel specular reflection
in the ray tracer, and the canned ``sionna_room`` scene simulated and focused."""

import math

import numpy as np
import pytest

import mitsar
from mitsar.errors import ParameterError
from mitsar.focus.grid import PlaneGrid
from mitsar.model import itu
from mitsar.model import multipath as mp
from mitsar.model.doublelobe import (
    DoubleLobe,
    RadioMaterial,
    radio_material_from_sionna,
    specular_field_table,
    theta_table_cosines,
)
from mitsar.model.fresnel import reflectance
from mitsar.model.geometry.antenna import direction_sines, one_way_pattern
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.quality.impulse import measure_impulse_response
from mitsar.raw.traced import trace
from mitsar.scene.canned import SIONNA_ROOM

mi = pytest.importorskip("mitsuba")

WIDE = mitsar.Radar(azimuth_beamwidth_deg=30.0, elevation_beamwidth_deg=30.0)
F = 94e9


def _closed_form_reflectance(theta_deg, eta):
    """Textbook Fresnel power reflectances of a half-space (air -> eta), TE and TM."""
    c = math.cos(math.radians(theta_deg))
    s2 = 1.0 - c * c
    w = np.sqrt(eta - s2 + 0j)
    return abs((c - w) / (c + w)) ** 2, abs((eta * c - w) / (eta * c + w)) ** 2


def _write(tmp_path, name, body):
    path = tmp_path / f"{name}.xml"
    path.write_text(f'<scene version="3.0.0">{body}</scene>')
    return path


def _look_at(origin, point):
    d = np.asarray(point, float) - origin
    d /= np.linalg.norm(d)
    return mitsar.Look(math.degrees(math.acos(-d[2])), math.degrees(math.atan2(-d[0], d[1])))


def _pattern(radar, look, direction):
    u_az, u_el, _ = direction_sines(direction / np.linalg.norm(direction), antenna_frame(look))
    return float(one_way_pattern(u_az, u_el, radar.azimuth_beamwidth, radar.elevation_beamwidth))


# --- ITU-R P.2040-3 and the material model --------------------------------------------------------

def test_itu_coefficients_give_the_standards_permittivity():
    """ε_r' = a f^b, σ = c f^d (f in GHz) and ε_r'' = 17.98 σ / f_GHz (ITU-R P.2040-3)."""
    eps, sigma = itu.itu_properties("concrete", F)
    assert eps == 5.24 and sigma == pytest.approx(0.0462 * 94.0**0.7822, rel=1e-12)
    assert sigma == pytest.approx(1.6144, abs=1e-4)
    eta = itu.complex_permittivity(eps, sigma, F)
    assert eta.real == 5.24
    assert -eta.imag == pytest.approx(17.98 * sigma / 94.0, rel=3e-4)  # 17.98 is rounded
    for name, (a, b, c, d) in {"glass": (6.31, 0, 0.0036, 1.3394),
                               "plasterboard": (2.73, 0, 0.0085, 0.9395),
                               "wood": (1.99, 0, 0.0047, 1.0718),
                               "metal": (1.0, 0, 1e7, 0.0)}.items():
        assert itu.itu_properties(name, F) == pytest.approx((a * 94.0**b, c * 94.0**d))
    material = radio_material_from_sionna(itu_type="glass")
    assert material.eta == pytest.approx(complex(6.31, -17.975 * 0.0036 * 94**1.3394 / 94),
                                         rel=1e-4)
    with pytest.raises(ParameterError, match="frequency"):
        itu.itu_properties("brick", F)             # Table 3: brick only up to 40 GHz
    with pytest.raises(ParameterError, match="type"):
        itu.itu_properties("adamantium", F)


def test_radio_material_power_balance_and_lobes():
    """Γ²(θ) = slab reflectance, R = sqrt(1 - S²); the split sums to 1 at every incidence; the
    Sionna backscattering pattern maps to Λ = 1 - λ (docs/materials.md §1.7)."""
    m = radio_material_from_sionna(itu_type="concrete", thickness=0.2,
                                   scattering_coefficient=0.3,
                                   scattering_pattern="backscattering", alpha_r=3, alpha_i=6,
                                   lambda_=0.9)
    assert isinstance(m, RadioMaterial) and isinstance(m, DoubleLobe)
    assert m.backscatter_fraction == pytest.approx(0.1)
    assert (m.alpha_f, m.alpha_b) == (3.0, 6.0)
    assert m.scattering == pytest.approx(0.3)
    cos = np.cos(np.radians([0.0, 20.0, 45.0, 70.0, 85.0]))
    split = m.power_split(cos)
    np.testing.assert_allclose(split.specular + split.back + split.forward + split.loss, 1.0)
    np.testing.assert_allclose(split.specular, m.gamma2_at(cos) * (1 - 0.09))
    np.testing.assert_allclose(m.specular_field(cos), np.sqrt(m.gamma2_at(cos) * (1 - 0.09)))
    assert m.gamma2 == pytest.approx(float(m.gamma2_at(1.0)))
    assert m.transmission_loss_db == pytest.approx(10 * math.log10(1 - m.gamma2))
    # σ⁰ carries Γ²(θ): the ratio to the same lobes with a constant Γ² is Γ²(θ)/Γ²(0).
    flat = DoubleLobe(transmission_loss_db=m.transmission_loss_db,
                      reflection_reduction_db=m.reflection_reduction_db,
                      backscatter_fraction=0.1, alpha_b=6, alpha_f=3)
    np.testing.assert_allclose(m.sigma0_monostatic(cos[:4]) / flat.sigma0_monostatic(cos[:4]),
                               m.gamma2_at(cos[:4]) / m.gamma2, rtol=1e-9)
    # A double-lobe material's specular table is its constant Γ R.
    table = specular_field_table([None, DoubleLobe.preset("concrete_94ghz"), m], 33)
    assert np.all(table[0] == 0.0)
    np.testing.assert_allclose(table[1], math.sqrt(DoubleLobe.preset(
        "concrete_94ghz").specular_fraction))
    np.testing.assert_allclose(table[2], m.specular_field(theta_table_cosines(33)))
    # A 0.2 m concrete slab is a half-space at 94 GHz (its internal echo is ~ -370 dB).
    thick = reflectance(cos, m.eta, math.inf, F)
    np.testing.assert_allclose(m.gamma2_at(cos), thick, rtol=1e-12)
    # Lambertian is approximated and says so.
    with pytest.warns(UserWarning, match="lambertian"):
        radio_material_from_sionna(itu_type="concrete", scattering_coefficient=0.5)
    for bad in ({"scattering_coefficient": 1.5}, {"thickness": 0.0}, {"polarization": "rhcp"},
                {"scattering_pattern": "phong"}, {"xpd_coefficient": -1.0}):
        with pytest.raises(ParameterError, match=next(iter(bad))):
            radio_material_from_sionna(itu_type="concrete", **bad)
    with pytest.raises(ParameterError, match="relative_permittivity"):
        radio_material_from_sionna(relative_permittivity=0.5)


# --- the tracer's specular reflection against the Fresnel closed form -----------------------------

@pytest.mark.parametrize("theta_deg", [20.0, 45.0, 70.0])
def test_concrete_wall_reflects_the_fresnel_power(tmp_path, theta_deg):
    """Transmitter and receiver 2 m in front of an ITU concrete wall (94 GHz, S = 0), 2 · 2 tan θ
    apart, each squinted by ∓θ towards the specular point, which sees incidence θ: the order-1
    power is the image power P_T G_T G_R λ² Γ²(θ) P_tx P_rx / (4π d)² with Γ² the mean of the
    textbook TE and TM Fresnel reflectances of a half-space. Tolerance 0.1 dB: the tent capture
    across 4096 rays is measured at 0.02 dB on the bistatic corner (tests/test_multipath.py),
    the θ-table of Γ R adds < 1e-4 dB and the 0.2 m slab's internal echo nothing. Measured
    -0.007, -0.007, -0.006 dB at 20, 45, 70°; TE or TM alone would be off by 0.5 to 16 dB, the
    normal-incidence Γ by 0.01, 0.27 and 2.3 dB."""
    theta = math.radians(theta_deg)
    distance = 2.0
    half = distance * math.tan(theta)
    tx = np.array([-half, 0.0, 1.0])
    offset = np.array([2 * half, 0.0, 0.0])
    rx = tx + offset
    wall = ((0.0, distance, 0.0), (0.0, -1.0, 0.0))
    path = mp.image_path(tx, rx, [wall])
    assert path["valid"]
    np.testing.assert_allclose(path["points"][0], [0.0, distance, 1.0], atol=1e-12)
    scene = _write(tmp_path, "wall",
                   '<shape type="rectangle" id="wall"><transform name="to_world">'
                   '<scale x="14" y="14"/><rotate x="1" angle="90"/>'
                   f'<translate x="0" y="{distance}" z="1"/></transform>'
                   '<bsdf type="itu-radio-material"><string name="type" value="concrete"/>'
                   '<float name="thickness" value="0.2"/></bsdf></shape>')
    look_tx, look_rx = _look_at(tx, path["points"][0]), _look_at(rx, path["points"][0])
    hist = trace(WIDE, mitsar.Trajectory.linear(tx, [0.0, 0.0, 0.5], 0.02), look_tx, scene,
                 max_depth=2, rays=4096, receiver_offset=offset, receiver_look=look_rx,
                 backscatter=False)
    eta = itu.complex_permittivity(*itu.itu_properties("concrete", F), F)
    te, tm = _closed_form_reflectance(theta_deg, eta)
    expected = mp.image_power(WIDE, path["length"], math.sqrt(0.5 * (te + tm)),
                              _pattern(WIDE, look_tx, path["points"][0] - tx),
                              _pattern(WIDE, look_rx, path["points"][0] - rx))
    measured = np.abs(hist["histogram"].values[0, 1, :].sum()) ** 2
    assert 10 * np.log10(measured / expected) == pytest.approx(0.0, abs=0.1)


# --- XML: parameters, the canned scene, simulation and focusing -----------------------------------

def test_unknown_and_bad_parameters_are_refused(tmp_path):
    from mitsar.scene import load_scene

    cases = {
        "bogus": '<bsdf type="itu-radio-material" id="w"><string name="type" value="concrete"/>'
                 '<float name="bogus" value="1"/></bsdf>',
        "type": '<bsdf type="itu-radio-material" id="w"><string name="type" value="brick"/>'
                '</bsdf>',
        "conductivity": '<bsdf type="radio-material" id="w"><float name="conductivity" '
                        'value="-1"/></bsdf>',
        "scattering_coefficient": '<bsdf type="radio-material" id="w">'
                                  '<float name="scattering_coefficient" value="2"/></bsdf>',
    }
    for name, bsdf in cases.items():
        path = _write(tmp_path, name, f'<shape type="rectangle">{bsdf}</shape>')
        with pytest.raises(ParameterError, match=name if name != "type" else "frequency") as err:
            load_scene(path)
        assert "bsdf 'w' (type " in str(err.value) and "radio-material" in str(err.value)


def test_canned_sionna_room_loads_with_its_materials():
    from mitsar.scene import load_scene, scene_surfaces

    surfaces = {s.shape.id(): s for s in scene_surfaces(load_scene(SIONNA_ROOM))}
    assert set(surfaces) == {"floor", "ceiling", "wall_y0", "wall_y5", "wall_x0", "wall_x8",
                             "window", "cabinet", "target"}
    floor = surfaces["floor"].material
    assert floor.itu_type == "concrete" and floor.scattering == pytest.approx(0.3)
    assert surfaces["cabinet"].material.itu_type == "metal"
    assert surfaces["cabinet"].material.gamma2 > 0.99
    assert surfaces["window"].material.relative_permittivity == 6.31
    assert surfaces["target"].material is None
    assert surfaces["floor"].area == pytest.approx(40.0)
    bsdf = surfaces["floor"].shape.bsdf()
    assert plugin_kind(bsdf) is PluginKind.DOUBLELOBE
    # The plugin's Dr.Jit σ⁰ follows the NumPy material (float32 and table interpolation).
    cos = np.cos(np.radians([10.0, 35.0, 60.0]))
    np.testing.assert_allclose(np.asarray(bsdf.sigma0_monostatic(mi.Float(cos))),
                               floor.sigma0_monostatic(cos), rtol=1e-4)


def test_sionna_room_simulates_and_focuses_the_target():
    """The canned room (concrete floor and walls with S = 0.3, glass, metal cabinet, a 1 m² point
    target at [4, 3, 0.03] m) traced with specular multipath and focused by BPA on the floor:
    the target is the brightest pixel, at its place, well above the concrete clutter."""
    target = np.array([4.0, 3.0, 0.03])
    start = np.array([3.85, 0.8, 2.0])
    off_nadir = math.degrees(math.atan2(target[1] - start[1], start[2] - target[2]))
    radar = mitsar.Radar()
    raw = mitsar.simulate_scene(radar, mitsar.Trajectory.linear(start, [0.5, 0, 0], 0.6),
                                mitsar.Look(off_nadir), SIONNA_ROOM, max_depth=2)
    assert raw.attrs["point_target_count"] == 1 and raw.attrs["scatterer_count"] > 10_000
    grid = PlaneGrid(origin=target, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-1.0, 1.0, 0.02],
                     v=[-1.0, 1.0, 0.02])
    image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1)
    metrics = measure_impulse_response(image, target)
    assert np.linalg.norm(metrics["peak_position"] - target) < 0.03
    amplitude = np.abs(image["image"].values)
    assert 20 * np.log10(amplitude.max() / np.median(amplitude)) > 30.0
