"""Physical optics of finite planar facets (docs/physical_optics.md): Gordon's closed form against
direct quadrature, the flat plate, dihedral and trihedral closed forms (Knott et al.; notes in
/work/shared/reference/radar-simulators-notes.md §4), reciprocity, and a large plate close to
the antenna against the image method."""

import itertools
import math

import numpy as np
import pytest
from scipy.special import fresnel

from mitsar.errors import MitsarWarning, ParameterError
from mitsar.model import physical_optics as po
from mitsar.model.polygons import area_vector, clip_convex, pad_polygons

LAM = 299_792_458.0 / 94e9            # Table 1 carrier, 3.19 mm
K = 2 * math.pi / LAM


def _plate(lx, ly=None, z=0.0):
    ly = lx if ly is None else ly
    return np.array([[-lx / 2, -ly / 2, z], [lx / 2, -ly / 2, z], [lx / 2, ly / 2, z],
                     [-lx / 2, ly / 2, z]])


def _db(x):
    return 10 * np.log10(x)


def test_gordon_integral_matches_quadrature_and_is_smooth_through_specular(monkeypatch):
    rng = np.random.default_rng(3)
    ang = np.sort(rng.uniform(0, 2 * np.pi, 6))
    radius = 0.035                                       # on a circle: convex
    local = np.stack([radius * np.cos(ang), radius * np.sin(ang)], -1)
    u = np.array([1.0, 0.3, 0.2]) / np.linalg.norm([1.0, 0.3, 0.2])
    n = np.cross(u, [0, 0, 1.0])
    n /= np.linalg.norm(n)
    v = np.cross(n, u)
    centre = np.array([0.3, -0.2, 0.5])
    poly = centre + local[:, :1] * u + local[:, 1:] * v
    # midpoint quadrature on a 0.05 mm grid (phase step < 0.1 rad for |w| <= 2)
    g = (np.arange(1600) + 0.5) / 1600 * 0.08 - 0.04
    x, y = np.meshgrid(g, g)
    inside = np.ones(x.shape, bool)
    for a, b in zip(local, np.roll(local, -1, 0), strict=True):
        inside &= (b[0] - a[0]) * (y - a[1]) - (b[1] - a[1]) * (x - a[0]) >= 0
    pts = centre + x[..., None] * u + y[..., None] * v
    for w in (np.array([0.01, 0.02, 0.0]), 2 * n + 0.3 * u - 0.2 * v, 2 * n + 1e-7 * u):
        exact = np.sum(np.exp(1j * K * pts[inside] @ w)) * (g[1] - g[0]) ** 2
        got = po.facet_integral(poly, w, K)
        # quadrature error of a staircase boundary on a 0.05 mm grid: ~1e-3 of the area
        assert abs(got - exact) < 3e-3 * abs(exact)
    # series (specular neighbourhood) and Gordon's edge sum agree where they meet
    size = np.linalg.norm(poly - poly[0], axis=-1).max()
    w0 = 2 * n + po.SERIES_THRESHOLD / (K * size) * u
    branches = []
    for threshold in (np.inf, 0.0):                        # series only, Gordon only
        monkeypatch.setattr(po, "SERIES_THRESHOLD", threshold)
        branches.append(po.facet_integral(poly, w0, K, poly[0]))
    monkeypatch.undo()
    assert abs(branches[0] - branches[1]) < 1e-12 * abs(branches[0])   # measured ~2e-14
    # exactly specular: the area term
    area = np.linalg.norm(area_vector(poly))
    assert po.facet_integral(poly, 2 * n, K, poly[0]) == pytest.approx(area, rel=1e-12)


def test_square_plate_peak_null_and_sidelobe():
    side = 0.1
    plate = _plate(side)
    peak = abs(po.monostatic_amplitude(plate, [0, 0, -1], LAM)) ** 2
    closed = 4 * math.pi * side**4 / LAM**2                # Knott et al.: 4πA²/λ²
    assert abs(_db(peak / closed)) < 1e-9                   # Must-show asks 0.5 dB
    theta = np.linspace(0.0, 0.06, 60001)
    d = np.stack([np.sin(theta), 0 * theta, -np.cos(theta)], -1)
    sigma = abs(po.monostatic_amplitude(plate, d, LAM)) ** 2
    minima = np.flatnonzero((sigma[1:-1] < sigma[:-2]) & (sigma[1:-1] < sigma[2:])) + 1
    maxima = np.flatnonzero((sigma[1:-1] > sigma[:-2]) & (sigma[1:-1] > sigma[2:])) + 1
    # first null at sin θ = λ/(2L), to the 1 µrad grid
    assert math.sin(theta[minima[0]]) == pytest.approx(LAM / (2 * side), abs=2e-6)
    # first sidelobe of sinc²: −13.26 dB (cos²θ at 2.4° lowers it by 0.008 dB)
    assert _db(sigma[maxima[0]] / sigma[0]) == pytest.approx(-13.26, abs=0.02)
    # the full closed form cos²θ sinc²(kL sinθ) away from the nulls, and a rectangle cut in φ
    closed_cut = closed * np.cos(theta) ** 2 * np.sinc(2 * side * np.sin(theta) / LAM) ** 2
    assert np.allclose(sigma, closed_cut, rtol=1e-9, atol=1e-12 * closed)


def test_reciprocity_and_lit_side():
    rng = np.random.default_rng(7)
    tri = np.array([[0.0, 0.0, 0.0], [0.07, 0.01, 0.0], [0.02, 0.05, 0.01]])
    k_i = rng.normal(size=(50, 3))
    k_s = rng.normal(size=(50, 3))
    k_i /= np.linalg.norm(k_i, axis=1, keepdims=True)
    k_s /= np.linalg.norm(k_s, axis=1, keepdims=True)
    forward = po.scattering_amplitude(tri, k_i, k_s, LAM, 0.8, origin=[0.01, 0.02, 0.0])
    backward = po.scattering_amplitude(tri, -k_s, -k_i, LAM, 0.8, origin=[0.01, 0.02, 0.0])
    assert np.allclose(forward, backward, rtol=1e-12, atol=0)
    n = area_vector(tri)
    same_side = (k_i @ n) * (k_s @ n) < 0
    assert np.all(forward[~same_side] == 0) and np.all(forward[same_side] != 0)
    one_sided = po.scattering_amplitude(tri, k_i, k_s, LAM, two_sided=False)
    assert np.all(one_sided[(k_i @ n) > 0] == 0)
    with pytest.raises(ParameterError, match="incident"):
        po.scattering_amplitude(tri, [0, 0, 0], [0, 0, 1], LAM)


def test_dihedral_double_bounce_closed_form():
    a, b = 0.1, 0.06            # seam length a, face width b
    face_a = np.array([[0, 0, 0], [a, 0, 0], [a, 0, b], [0, 0, b]], float)   # y = 0
    face_b = np.array([[0, 0, 0], [0, b, 0], [a, b, 0], [a, 0, 0]], float)   # z = 0
    phi = np.deg2rad(np.array([0.0, 10.0, 20.0, 30.0, 40.0]))    # from the bisector, ⊥ seam
    k_i = -np.stack([0 * phi, np.cos(np.pi / 4 + phi), np.sin(np.pi / 4 + phi)], -1)
    total = sum(po.chain_amplitude(c, k_i, -k_i, LAM, origin=[a / 2, 0, 0])
                for c in ([face_a, face_b], [face_b, face_a]))
    sigma = abs(total) ** 2
    # 8πa²b²/λ² on the bisector; 16πa²b² sin²(45° − |φ|)/λ² off it (double-bounce aperture
    # 2ab sin(45° − |φ|)); exact in PO (the apertures are exact, w is normal to the last face)
    closed = 16 * math.pi * a**2 * b**2 * np.sin(np.pi / 4 - phi) ** 2 / LAM**2
    assert sigma[0] == pytest.approx(8 * math.pi * a**2 * b**2 / LAM**2, rel=1e-9)
    assert np.allclose(sigma, closed, rtol=1e-9)
    # within 20° of the bisector the single bounces are sidelobes of the faces, < −30 dB
    single = sum(po.chain_amplitude([f], k_i, -k_i, LAM) for f in (face_a, face_b))
    assert np.all(abs(single[:3]) ** 2 < 1e-3 * sigma[:3])


def test_triangular_trihedral_on_axis():
    a = 0.1
    faces = [np.array([[0, 0, 0], [a, 0, 0], [0, a, 0]], float),
             np.array([[0, 0, 0], [0, a, 0], [0, 0, a]], float),
             np.array([[0, 0, 0], [0, 0, a], [a, 0, 0]], float)]
    k_i = -np.ones((1, 3)) / math.sqrt(3)
    closed = 4 * math.pi * a**4 / (3 * LAM**2)
    triple = [po.chain_amplitude([faces[i] for i in p], k_i, -k_i, LAM)[0]
              for p in itertools.permutations(range(3))]
    # the six triple-bounce orders arrive in phase (one image) and add to the aperture a²/√3
    assert np.allclose(triple, triple[0], rtol=1e-9)
    assert abs(sum(triple)) ** 2 == pytest.approx(closed, rel=1e-9)
    # with every chain of 1-3 bounces the single/double-bounce sidelobes add ~0.06 dB
    everything = sum(po.chain_amplitude([faces[i] for i in seq], k_i, -k_i, LAM)[0]
                     for n in (1, 2, 3) for seq in itertools.product(range(3), repeat=n)
                     if all(seq[j] != seq[j + 1] for j in range(n - 1)))
    assert abs(_db(abs(everything) ** 2 / closed)) < 0.5


def test_convex_clip_of_squares():
    square = _plate(1.0)
    shifted = square[None] + np.array([[0.5, 0.25, 0.0]])[:, None]
    points, count = clip_convex(shifted, np.array([4]), square)
    assert count[0] == 4
    assert np.linalg.norm(area_vector(points[0])) == pytest.approx(0.5 * 0.75, rel=1e-12)
    far = square[None] + np.array([[3.0, 0.0, 0.0]])[:, None]
    points, count = clip_convex(far, np.array([4]), square)
    assert count[0] == 0 and np.linalg.norm(area_vector(points[0])) == 0


def _near_field(side, distance, scale=1.0):
    points, count = pad_polygons([_plate(side)])
    tri, _ = po.subdivide_facets(points, count, scale * po.subfacet_size(distance, LAM))
    antenna = np.array([0.0, 0.0, distance])
    return po.field_factor(tri, antenna, antenna, LAM).sum()


def test_plate_at_finite_range_fresnel_and_image_limit():
    # 0.3 m plate at 2 m (R < 2D²/λ = 56 m): against direct quadrature of the PO integral
    # with exact ranges, obliquity and 1/R² (independent of the sub-facet split)
    side, dist = 0.3, 2.0
    got = _near_field(side, dist)
    g = (np.arange(1500) + 0.5) / 1500 * side - side / 2
    x, y = np.meshgrid(g, g)
    r = np.sqrt(x**2 + y**2 + dist**2)
    quad = (K / math.sqrt(math.pi) * (dist / r) * np.exp(2j * K * r)
            / (math.sqrt(4 * math.pi) * r**2)).sum() * (side / 1500) ** 2
    assert abs(20 * np.log10(abs(got / quad))) < 0.05     # measured 0.013 dB
    assert abs(np.angle(got / quad)) < 0.05
    # and the paraxial closed form (C + jS)²/D of the Fresnel integrals, T = L/sqrt(λD) = 3.75
    s_t, c_t = fresnel(side / math.sqrt(LAM * dist))
    assert abs(20 * np.log10(abs(got) * dist / abs((c_t + 1j * s_t) ** 2))) < 0.1
    # a 2 m plate at 1 m (~1200 Fresnel zones) is a mirror: image field Γ/L, L = 2D
    mirror = 1.0 / (2 * 1.0)
    big = _near_field(2.0, 1.0)
    # the edge ripple of a finite plate, ~1/(π T) per axis with T = L/sqrt(λD) = 35: 0.2 dB
    assert abs(20 * np.log10(abs(big) / mirror)) < 0.3


def _plate_scene(mi, centre, normal, side, screen=False):
    u = np.cross(normal, [1.0, 0.0, 0.0])
    u /= np.linalg.norm(u)
    w = np.cross(normal, u)
    matrix = np.eye(4)
    matrix[:3, 0], matrix[:3, 1], matrix[:3, 2], matrix[:3, 3] = (u * side / 2, w * side / 2,
                                                                  normal, centre)
    content = {"type": "scene", "plate": {
        "type": "rectangle", "to_world": mi.ScalarTransform4f(matrix.tolist()),
        "bsdf": {"type": "doublelobe", "preset": "mirror"}}}
    if screen:      # a non-radar surface half-way: blocks rays, returns nothing
        matrix[:3, 3] = centre + 2.5 * normal
        matrix[:3, :2] *= 4
        content["screen"] = {"type": "rectangle", "to_world": mi.ScalarTransform4f(
            matrix.tolist()), "bsdf": {"type": "diffuse"}}
    return mi.load_dict(content)


@pytest.mark.filterwarnings("ignore:radar integrator. shapes without a radar material")
def test_traced_plate_matches_the_radar_equation():
    pytest.importorskip("mitsuba")
    import mitsar
    from mitsar.plugins.variant import register_plugins
    from mitsar.raw.product import sweep_geometry
    from mitsar.raw.traced import simulate_scene

    register_plugins()
    import mitsuba as mi

    radar, look = mitsar.Radar(), mitsar.Look(50.0)
    track = mitsar.Trajectory.linear([0.0, 0.0, 3.0], [0.2, 0.0, 0.0], 0.02)   # 5 sweeps
    boresight = sweep_geometry(radar, track, look, 1).boresight[0]
    side, distance = 0.05, 5.0          # 2D²/λ = 3.1 m (D the diagonal): far field
    centre = np.array([0.0, 0.0, 3.0]) + distance * boresight
    scene = _plate_scene(mi, centre, -boresight, side)
    raw = simulate_scene(radar, track, look, scene, physical_optics=["plate"])["raw"].values
    sigma = 4 * math.pi * side**4 / radar.wavelength**2
    point = mitsar.simulate_point_targets(radar, track, look,
                                          [mitsar.PointTarget(centre, sigma)])["raw"].values
    # same echo as a point target of σ = 4πA²/λ² at the plate's centre (exact per-sample
    # delay, independent path), but for the plate's Fresnel loss at 5 m, (C+jS)²/T² per the
    # paraxial closed form (−0.047 dB); residual: sub-facet rule and synthesis, < 0.05 dB
    s_t, c_t = fresnel(side / math.sqrt(radar.wavelength * distance))
    fresnel_db = 20 * np.log10(abs((c_t + 1j * s_t) ** 2) * radar.wavelength * distance
                               / side**2)
    power_db = _db(np.sum(abs(raw) ** 2) / np.sum(abs(point) ** 2))
    assert power_db == pytest.approx(fresnel_db, abs=0.05)
    coherence = abs(np.vdot(raw, point)) / (np.linalg.norm(raw) * np.linalg.norm(point))
    assert coherence > 0.9999                      # same delay and Doppler history
    # shadowing: a screen half-way hides the plate
    hidden = _plate_scene(mi, centre, -boresight, side, screen=True)
    with pytest.warns(MitsarWarning, match="exact zeros"):
        dark = simulate_scene(radar, track, look, hidden, physical_optics=True)["raw"].values
    assert not np.any(dark)
    with pytest.raises(ParameterError, match="physical_optics"):
        simulate_scene(radar, track, look, scene, physical_optics=["nothing"])
    # with multipath on, the tracer's rays stop on PO shapes: its GO mirror return of the
    # plate (order 1, present without PO) is not added to PO's a second time
    go = simulate_scene(radar, track, look, scene, max_depth=2, orders=1)["raw"].values
    assert np.sum(abs(go) ** 2) > 1e-3 * np.sum(abs(raw) ** 2)
    both = simulate_scene(radar, track, look, scene, physical_optics=True,
                          max_depth=2)["raw"].values
    assert np.allclose(both, raw, rtol=0, atol=1e-9 * abs(raw).max())
    with pytest.raises(ParameterError, match="physical_optics"):
        simulate_scene(radar, track, look, scene, physical_optics=True, max_depth=2,
                       plane_normal=[1, 0, 0])


def test_toml_key_physical_optics():
    from pathlib import Path

    from mitsar.experiment.parsers import parse_simulation
    from mitsar.experiment.table import Table

    def parse(value):
        return parse_simulation(Table({"physical_optics": value}, "simulation", "x.toml",
                                      Path("."))).physical_optics

    assert parse(True) is True and parse(["plate", "wall"]) == ("plate", "wall")
    assert parse_simulation(Table({}, "simulation", "x.toml", Path("."))).physical_optics is False
    for bad in (3, [], ["plate", 2]):
        with pytest.raises(ParameterError, match="simulation.physical_optics"):
            parse(bad)
