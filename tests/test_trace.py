"""The ray tracer (``radar`` integrator + mitsar.raw.traced) against the analytic simulator and the
radar equation; invariances (chunking, seeds), shadowing, parameter errors."""

import math

import numpy as np
import pytest

import mitsar
from mitsar.errors import ParameterError
from mitsar.focus.grid import SlantGrid, equivalent_position
from mitsar.model.doublelobe import DoubleLobe
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.quality.impulse import measure_impulse_response
from mitsar.raw.traced import histogram_to_raw_product, simulate_scene, trace

mi = pytest.importorskip("mitsuba")

RADAR = mitsar.Radar()
LOOK = mitsar.Look(55.71)
TRACK = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.6)  # 150 sweeps
CANNED_TARGET = np.array([15.0, 8.0, 0.03])  # scenes/point_target.xml


def _relative_error_db(value, reference):
    return 10 * math.log10(np.sum(np.abs(value - reference) ** 2)
                           / np.sum(np.abs(reference) ** 2))


def _write(tmp_path, name, body):
    path = tmp_path / f"{name}.xml"
    path.write_text(f'<scene version="3.0.0">{body}</scene>')
    return path


def _rectangle(ident, centre, half, bsdf, rotate=""):
    return (f'<shape type="rectangle" id="{ident}"><transform name="to_world">'
            f'<scale x="{half[0]}" y="{half[1]}"/>{rotate}'
            f'<translate x="{centre[0]}" y="{centre[1]}" z="{centre[2]}"/></transform>'
            f'{bsdf}</shape>')


def _sphere_target(centre, rcs=1.0, radius=0.02):
    return (f'<shape type="sphere"><point name="center" x="{centre[0]}" y="{centre[1]}" '
            f'z="{centre[2]}"/><float name="radius" value="{radius}"/>'
            f'<bsdf type="pointtarget"><float name="rcs" value="{rcs}"/></bsdf></shape>')


CONCRETE = '<bsdf type="doublelobe"><string name="preset" value="concrete_94ghz"/></bsdf>'
ABSORBER = '<bsdf type="doublelobe"><string name="preset" value="absorber"/></bsdf>'


# --- point targets: the ray-traced chain reproduces the analytic simulator -----------------------

@pytest.fixture(scope="module")
def canned_pair():
    traced = simulate_scene(RADAR, TRACK, LOOK, "point_target")
    analytic = mitsar.simulate_point_targets(RADAR, TRACK, LOOK,
                                             [mitsar.PointTarget(CANNED_TARGET)])
    return traced, analytic


def test_traced_point_target_reproduces_the_analytic_raw_data(canned_pair):
    traced, analytic = canned_pair
    assert traced["raw"].shape == analytic["raw"].shape == (150, 660)
    # Measured -57.6 dB (16 bins per cell, linear splitting; docs/design.md §5.5: -54 dB).
    assert _relative_error_db(traced["raw"].values, analytic["raw"].values) < -50.0
    np.testing.assert_allclose(traced["platform_position"], analytic["platform_position"])
    assert traced.attrs["point_target_count"] == 1 and traced.attrs["scatterer_count"] == 0


def test_traced_point_target_focuses_like_the_analytic_one(canned_pair):
    grid = SlantGrid(along_track=[-0.6, 1.0, 0.02], slant_range=[7.2, 8.8, 0.02])
    metrics = []
    for raw in canned_pair:
        image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1)
        metrics.append(measure_impulse_response(image, CANNED_TARGET))
    traced, analytic = metrics
    assert np.linalg.norm(np.subtract(traced["peak_position"], analytic["peak_position"])) < 1e-3
    # The slant grid holds the target at its equivalent position (same range and along-track).
    assert np.linalg.norm(traced["peak_position"] - equivalent_position(image, CANNED_TARGET)) \
        < 0.01
    assert traced["peak_db"] == pytest.approx(analytic["peak_db"], abs=0.05)
    for axis in ("range", "azimuth"):
        assert traced[axis]["irw_m"] == pytest.approx(analytic[axis]["irw_m"], rel=0.01)
        assert traced[axis]["pslr_db"] == pytest.approx(analytic[axis]["pslr_db"], abs=0.2)


def test_moving_point_target_and_normalized_mode():
    """Target motion (Doppler range shift, range walk over 3 sweep chunks) and the normalised
    amplitude (eq. 1)."""
    velocity = (0.3, -0.2, 0.0)
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.6)
    traced = simulate_scene(RADAR, track, LOOK, "point_target", normalized=True,
                               scene_params={"velocity": "0.3, -0.2, 0", "rcs": 2.0})
    analytic = mitsar.simulate_point_targets(
        RADAR, track, LOOK, [mitsar.PointTarget(CANNED_TARGET, 2.0, velocity)], normalized=True)
    # -40 dB (issue): the histogram holds each echo as a tone, first order in fast time; the
    # second-order term of a target and platform both moving costs ~10 dB against the
    # static-target cases (measured -45 dB here, -57 dB static).
    assert _relative_error_db(traced["raw"].values, analytic["raw"].values) < -40.0


def test_simulate_scene_adds_analytic_targets_and_selects_orders():
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.08)
    extra = mitsar.PointTarget([15.2, 7.5, 0.0], 0.5)
    both = simulate_scene(RADAR, track, LOOK, "point_target", targets=[extra], orders=0)
    analytic = mitsar.simulate_point_targets(
        RADAR, track, LOOK, [mitsar.PointTarget(CANNED_TARGET), extra])
    assert _relative_error_db(both["raw"].values, analytic["raw"].values) < -50.0
    hist = trace(RADAR, track, LOOK, "point_target")
    assert hist["histogram"].dims == ("sweep", "order", "bin")
    assert hist.attrs["product"] == "histogram" and list(hist["order"].values) == [0]
    assert hist["apparent_range"].attrs["units"] == "m"
    only = histogram_to_raw_product(hist, orders=[0])
    none = histogram_to_raw_product(hist, orders=[1])
    assert np.abs(none["raw"].values).max() == 0.0
    np.testing.assert_array_equal(only["raw"].values,
                                  histogram_to_raw_product(hist)["raw"].values)


# --- surfaces: the radar equation --------------------------------------------------------------

def _incoherent_power(scene, histogram, look, material, density, seed):
    """Closed form per scatterer, P_r = P_T G^2 lambda^2 sigma0 A P^2 / ((4 pi)^3 R^4),
    summed over the scatterers (mean over sweeps); P: the one-way sinc^2 aperture pattern."""
    from mitsar.scene import sample_surface_scatterers

    scatterers = sample_surface_scatterers(scene, density, seed)
    offset = scatterers.positions[None] - histogram["platform_position"].values[:, None]
    distance = np.linalg.norm(offset, axis=-1)
    direction = offset / distance[..., None]
    frames = antenna_frame(look, *histogram["attitude"].values.T)
    local = np.einsum("sji,smj->smi", frames, direction)
    pattern = (np.sinc(local[..., 0] / RADAR.azimuth_beamwidth) ** 2
               * np.sinc(local[..., 1] / RADAR.elevation_beamwidth) ** 2)
    sigma0 = material.sigma0_monostatic(np.abs(direction[..., 2]))
    power = (RADAR.transmit_power * RADAR.antenna_gain**2 * RADAR.wavelength**2 * sigma0
             * scatterers.area[None] * pattern**2 / ((4 * np.pi) ** 3 * distance**4))
    return power.sum(axis=1).mean()


@pytest.mark.parametrize("incidence_deg", [20.0, 40.0, 60.0])
def test_floor_patch_returns_the_radar_equation_power(tmp_path, incidence_deg):
    """A 1 m x 2 m floor patch at 6 m seen at 20/40/60 deg incidence: the mean raw power
    (speckle averaged over 200 sweeps of a 0.2 m track and 6 seeds) equals the incoherent sum of
    the closed-form radar equation over its scatterers, within 0.5 dB, for the double-lobe
    model's sigma0 and for a given sigma0_db = -20 dB. Measured: within 0.15 dB (per-seed
    spread 0.2-0.35 dB)."""
    theta = math.radians(incidence_deg)
    look = mitsar.Look(incidence_deg)
    track = mitsar.Trajectory.linear([14.9, 8 - 6 * math.sin(theta), 6 * math.cos(theta)],
                                     [0.5, 0.0, 0.0], 0.4)
    density = 900.0
    for bsdf, material in ((CONCRETE, DoubleLobe.preset("concrete_94ghz")),
                           ('<bsdf type="doublelobe"><float name="sigma0_db" value="-20"/>'
                            '</bsdf>', DoubleLobe(sigma0_db=-20.0))):
        path = _write(tmp_path, "patch", _rectangle("patch", (15, 8, 0), (0.5, 1.0), bsdf))
        from mitsar.scene import load_scene

        scene = load_scene(path)
        ratios = []
        for seed in range(6):
            hist = trace(RADAR, track, look, scene, density=density, seed=seed)
            raw = histogram_to_raw_product(hist)["raw"].values
            measured = np.mean(np.abs(raw) ** 2)
            ratios.append(measured / _incoherent_power(scene, hist, look, material, density,
                                                       seed))
        assert 10 * math.log10(np.mean(ratios)) == pytest.approx(0.0, abs=0.5)


# --- invariances and shadowing ---------------------------------------------------------------

@pytest.fixture(scope="module")
def room(tmp_path_factory):
    """A floor, a wall and a point target; 2 cm-cell density keeps it small."""
    path = tmp_path_factory.mktemp("room") / "room.xml"
    body = (_rectangle("floor", (15, 8, 0), (1.5, 1.5), CONCRETE)
            + _rectangle("wall", (15, 9.5, 1), (1.5, 1.0), CONCRETE,
                         '<rotate x="1" angle="90"/>')
            + _sphere_target((15.2, 8.4, 0.0)))
    path.write_text(f'<scene version="3.0.0">{body}</scene>')
    return path


@pytest.mark.parametrize("block_kernel", [False, True])
def test_one_call_equals_several_calls_and_chunks_do_not_matter(room, block_kernel):
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.06)  # 15 sweeps
    options = dict(density=200.0, seed=3, block_kernel=block_kernel)
    whole = trace(RADAR, track, LOOK, room, **options)
    parts = [trace(RADAR, track, LOOK, room, sweeps=part, **options)
             for part in (slice(0, 4), slice(4, 11), slice(11, None))]
    small = trace(RADAR, track, LOOK, room, chunk_lanes=5000, **options)
    joined = np.concatenate([p["histogram"].values for p in parts])
    reference = whole["histogram"].values
    scale = np.abs(reference).max()
    assert scale > 0 and whole.attrs["scatterer_count"] > 1000
    # Lane kernels: only the order of the float64 atomic sums differs. The block kernel
    # advances each visibility block from its first sweep in float32 (phase ~1e-5 rad per
    # contribution, docs/integrator.md §"Performance"), and pieces start blocks elsewhere.
    atol = (2e-5 if block_kernel else 1e-9) * scale
    np.testing.assert_allclose(joined, reference, rtol=0, atol=atol)
    np.testing.assert_allclose(small["histogram"].values, reference, rtol=0, atol=1e-9 * scale)
    assert list(np.concatenate([p["sweep"].values for p in parts])) == list(range(15))
    np.testing.assert_array_equal(parts[1]["apparent_range"], whole["apparent_range"])


def test_same_seed_same_result_other_seed_other_speckle(room):
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.02)
    first = trace(RADAR, track, LOOK, room, density=200.0, seed=1)["histogram"].values
    again = trace(RADAR, track, LOOK, room, density=200.0, seed=1)["histogram"].values
    other = trace(RADAR, track, LOOK, room, density=200.0, seed=2)["histogram"].values
    scale = np.abs(first).max()
    np.testing.assert_allclose(again, first, rtol=0, atol=1e-9 * scale)
    assert np.abs(other - first).max() > 0.1 * scale


def test_hidden_scatterers_and_point_targets_contribute_nothing(tmp_path):
    """An absorbing screen between the antenna and a concrete patch and a point target hides
    both completely; without the screen both return."""
    track = mitsar.Trajectory.linear([14.9, 1.4, 4.5], [0.5, 0.0, 0.0], 0.02)
    things = (_rectangle("patch", (15, 8, 0), (0.3, 0.3), CONCRETE)
              + _sphere_target((15.0, 7.9, 0.0)))
    screen = _rectangle("screen", (15, 5, 2.5), (2.0, 2.0), ABSORBER,
                        '<rotate x="1" angle="90"/>')
    open_scene = _write(tmp_path, "open", things)
    hidden_scene = _write(tmp_path, "hidden", things + screen)
    visible = trace(RADAR, track, LOOK, open_scene, density=900.0)
    hidden = trace(RADAR, track, LOOK, hidden_scene, density=900.0)
    assert hidden.attrs["scatterer_count"] == visible.attrs["scatterer_count"] > 100
    assert np.abs(visible["histogram"].values).max() > 0
    assert np.abs(hidden["histogram"].values).max() == 0.0
    target_only = trace(RADAR, track, LOOK, _write(tmp_path, "target", _sphere_target(
        (15.0, 7.9, 0.0)) + screen))
    assert np.abs(target_only["histogram"].values).max() == 0.0


def test_point_target_on_a_floor_is_not_shadowed_by_it(tmp_path):
    """A target whose centre lies in the floor plane (the paper's T_p = [15, 8, 0]) is seen:
    the shadow ray stops at the target's bounding sphere."""
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.04)
    path = _write(tmp_path, "floor", _rectangle("floor", (15, 8, 0), (1, 1), ABSORBER)
                  + _sphere_target((15.0, 8.0, 0.0)))
    traced = simulate_scene(RADAR, track, LOOK, path)
    analytic = mitsar.simulate_point_targets(RADAR, track, LOOK,
                                             [mitsar.PointTarget([15.0, 8.0, 0.0])])
    assert _relative_error_db(traced["raw"].values, analytic["raw"].values) < -50.0


# --- parameters --------------------------------------------------------------------------------

def test_integrator_rejects_unknown_parameters_and_unsupported_depth(tmp_path):
    from mitsar.plugins.variant import register_plugins

    register_plugins()
    with pytest.raises(Exception, match="bogus"):
        mi.load_dict({"type": "radar", "bogus": 1.0})
    with pytest.raises(Exception, match="chunk_lanes"):
        mi.load_dict({"type": "radar", "chunk_lanes": 2**27})
    from mitsar.scene import load_scene

    bogus = _write(tmp_path, "bogus", '<integrator type="radar"><float name="bogus" '
                   'value="1"/></integrator>')
    with pytest.raises(ParameterError, match="'bogus'"):
        load_scene(bogus)
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.02)
    # The XML integrator's parameters are the defaults of trace().
    declared = _write(tmp_path, "declared", '<integrator type="radar"><integer name="seed" '
                      'value="5"/><integer name="bins_per_cell" value="8"/></integrator>'
                      + _sphere_target((15.0, 8.0, 0.0)))
    hist = trace(RADAR, track, LOOK, declared)
    assert hist.attrs["seed"] == 5 and hist.attrs["bins_per_cell"] == 8
    assert trace(RADAR, track, LOOK, declared, seed=2).attrs["seed"] == 2
    deep = _write(tmp_path, "deep", '<integrator type="radar"><integer name="max_depth" '
                  'value="99"/></integrator>' + _sphere_target((15.0, 8.0, 0.0)))
    with pytest.raises(ParameterError, match="max_depth"):
        trace(RADAR, track, LOOK, deep)
    with pytest.raises(ParameterError, match="sweeps"):
        trace(RADAR, track, LOOK, "point_target", sweeps=slice(3, 3))


def test_kernel_equals_the_numpy_reference_for_surface_scatterers(tmp_path):
    """The Dr.Jit kernel against mitsar.model.histogram in NumPy on the same scatterers (double-lobe
    sigma0 model, fixed speckle phases, sinc^2 pattern without culling): the same numbers up to
    float32 directions and the sigma0 table (measured -118 dB)."""
    from mitsar.model import histogram as hg
    from mitsar.model.signal import radar_equation_amplitude
    from mitsar.scene import load_scene, sample_surface_scatterers

    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.04)
    path = _write(tmp_path, "two", _rectangle("floor", (15, 8, 0), (0.6, 0.6), CONCRETE)
                  + _rectangle("wall", (15.3, 9.0, 0.5), (0.4, 0.5), CONCRETE,
                               '<rotate x="1" angle="80"/>'))
    scene = load_scene(path)
    hist = trace(RADAR, track, LOOK, scene, density=300.0, seed=4, beam_cull=math.inf)
    traced = histogram_to_raw_product(hist)["raw"].values

    scatterers = sample_surface_scatterers(scene, 300.0, 4)
    material = DoubleLobe.preset("concrete_94ghz")
    offset = scatterers.positions[None] - hist["platform_position"].values[:, None]
    distance = np.linalg.norm(offset, axis=-1)
    direction = offset / distance[..., None]
    frames = antenna_frame(LOOK, *hist["attitude"].values.T)
    local = np.einsum("sji,smj->smi", frames, direction)
    pattern = np.where(local[..., 2] > 0, np.sinc(local[..., 0] / RADAR.azimuth_beamwidth) ** 2
                       * np.sinc(local[..., 1] / RADAR.elevation_beamwidth) ** 2, 0.0)
    cos_incidence = np.abs(np.einsum("smi,mi->sm", direction, scatterers.normals))
    amplitude = pattern * np.sqrt(material.sigma0_monostatic(cos_incidence)
                                  * scatterers.area[None]) \
        * radar_equation_amplitude(RADAR, 1.0, distance)
    ranges = hist["apparent_range"].values
    reference = np.zeros((len(distance), len(ranges)), complex)
    rate = -np.einsum("smi,si->sm", direction, hist["platform_velocity"].values)
    hg.deposit(reference, np.arange(len(distance))[:, None],
               hg.deposit_values(amplitude, 2 * distance / mitsar.model.radar.SPEED_OF_LIGHT, RADAR,
                                 scatterers.phase / (2 * np.pi)),
               hg.apparent_range(distance, rate, RADAR), ranges[0], ranges[1] - ranges[0])
    expected = hg.histogram_to_raw(reference, ranges, RADAR)
    assert _relative_error_db(traced, expected) < -90.0


def test_a_shape_without_a_radar_material_is_reported(tmp_path):
    """A floor left with Mitsuba's default BSDF blocks rays and returns nothing: say so."""
    scene = tmp_path / "plain.xml"
    scene.write_text("""<scene version="3.0.0">
    <shape type="rectangle" id="plain_floor">
        <transform name="to_world"><scale x="2" y="2"/><translate x="15" y="8"/></transform>
    </shape>
</scene>""")
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.02)
    with pytest.warns(UserWarning, match="plain_floor"):
        hist = trace(RADAR, track, LOOK, str(scene))
    assert np.abs(hist["histogram"].values).max() == 0.0


def test_strided_sweeps_record_their_pulse_rate():
    """simulate_scene(sweeps=slice(0, None, 4)) holds every 4th sweep: the product records
    sweep_stride = 4, so the focusers take PRF/4 (without it BPA chose its Doppler band at the
    full PRF and misfocused a corner to coherence 0.29 with the full-rate image); uneven
    selections are said."""
    import warnings as _warnings

    from mitsar.errors import MitsarWarning
    from mitsar.products.raw import sweep_rate

    radar = mitsar.Radar()
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.2)
    look = mitsar.Look(55.7)
    raw = mitsar.simulate_scene(radar, track, look, "point_target", sweeps=slice(0, None, 4))
    assert raw.attrs["sweep_stride"] == 4 and sweep_rate(raw) == radar.prf / 4
    whole = mitsar.simulate_scene(radar, track, look, "point_target", sweeps=slice(0, 40))
    assert "sweep_stride" not in whole.attrs
    with _warnings.catch_warnings(record=True) as caught:
        _warnings.simplefilter("always")
        mitsar.simulate_scene(radar, track, look, "point_target", sweeps=[0, 1, 5])
    assert any(issubclass(w.category, MitsarWarning) and "evenly" in str(w.message)
               for w in caught)
