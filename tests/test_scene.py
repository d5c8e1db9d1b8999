"""Scenes: variant and plugins, canned scenes, point targets, surface scatterers, errors, PLY."""

from __future__ import annotations

import math
from pathlib import Path

import numpy as np
import pytest

import mitsar.scene as ms
from mitsar import backend
from mitsar.backend import BackendError
from mitsar.errors import MissingFileError, ParameterError
from mitsar.plugins import variant as pv
from mitsar.plugins.kind import PluginKind, plugin_kind
from mitsar.scene import canned as scenes

ROOM = (np.zeros(3), np.array([30.0, 10.0, 6.0]))


@pytest.fixture(scope="module")
def mi():
    pv.register_plugins()
    import mitsuba

    return mitsuba


# --------------------------------------------------------------------------------------------
# Variant and plugins
# --------------------------------------------------------------------------------------------


def test_register_plugins_is_idempotent(mi) -> None:
    assert pv.register_plugins() == mi.variant()
    assert pv.register_plugins() in pv.SUPPORTED_VARIANTS
    bsdf = mi.load_dict({"type": "doublelobe"})
    assert plugin_kind(bsdf) is PluginKind.DOUBLELOBE


def test_plugins_follow_variant_changes(mi) -> None:
    variant = mi.variant()
    try:
        mi.set_variant("llvm_ad_rgb")
        mi.set_variant(variant)
        assert mi.load_dict({"type": "pointtarget", "rcs": 1.0}).rcs == 1.0
    finally:
        mi.set_variant(variant)


def test_ensure_variant_errors(mi, monkeypatch: pytest.MonkeyPatch) -> None:
    with pytest.raises(ParameterError, match="parameter 'variant'"):
        pv.ensure_variant("scalar_rgb")
    assert backend.llvm_probe()[0]
    monkeypatch.setattr(backend, "llvm_probe", lambda: (False, "LLVM ERROR: Cannot select"))
    with pytest.raises(BackendError, match="libllvm19") as info:
        pv.ensure_variant("llvm_ad_mono")
    assert "DRJIT_LIBLLVM_PATH" in str(info.value)


# --------------------------------------------------------------------------------------------
# Canned scenes
# --------------------------------------------------------------------------------------------

EXPECTED_SHAPES = {
    "control_volume": {"floor", "ceiling", "wall_y0", "wall_y10", "wall_x0", "wall_x30"},
    "point_target": {"floor", "target"},
    "dihedral": {"floor", "wall_y10"},
    "trihedral": {"floor", "wall_y10", "wall_x0"},
    "cross_section_2d": {"floor", "ceiling", "wall_y0", "wall_y10"},
    "box_obstacle": {"floor", "cabinet"},
    "walking_person": {"floor", "wall_y10", "wall_target", "person"},
    "sionna_room": {"floor", "ceiling", "wall_y0", "wall_y5", "wall_x0", "wall_x8", "window",
                    "cabinet", "target"},
}


def test_scene_names_and_paths() -> None:
    assert set(scenes.names()) == set(EXPECTED_SHAPES)
    assert scenes.path("dihedral") == scenes.path("dihedral.xml")
    assert scenes.path("dihedral").is_file()
    with pytest.raises(ParameterError, match="control_volume") as info:
        scenes.path("no_such_scene")
    assert info.value.name == "name"


@pytest.mark.parametrize("name", sorted(EXPECTED_SHAPES))
def test_canned_scene_loads(mi, name: str) -> None:
    scene = ms.load_scene(name)
    surfaces = ms.scene_surfaces(scene)
    assert {s.id for s in surfaces} == EXPECTED_SHAPES[name]
    assert [s.index for s in surfaces] == list(range(len(surfaces)))
    for s in surfaces:
        if name == "point_target" or s.id in ("wall_target", "target"):
            assert s.material is None  # absorbing floor and the point targets
        elif name == "sionna_room":  # ITU and radio materials: tests/test_sionna_scenes.py
            assert s.material is not None
        else:
            assert s.material is not None and s.material.name == "concrete_94ghz_paper"
        lo, hi = (np.array(v) for v in (s.shape.bbox().min, s.shape.bbox().max))
        if name != "box_obstacle":
            assert np.all(lo >= ROOM[0] - 1e-4) and np.all(hi <= ROOM[1] + 1e-4)


def test_control_volume_geometry(mi) -> None:
    surfaces = {s.id: s for s in ms.scene_surfaces(ms.load_scene("control_volume"))}
    areas = {k: s.area for k, s in surfaces.items()}
    assert areas == pytest.approx({"floor": 300.0, "ceiling": 300.0, "wall_y0": 180.0,
                                   "wall_y10": 180.0, "wall_x0": 60.0, "wall_x30": 60.0})
    scene = ms.load_scene("control_volume", material="concrete_94ghz")
    assert all(s.material.sigma0_db is None for s in ms.scene_surfaces(scene))


def test_point_target_extraction(mi) -> None:
    (target,) = ms.scene_point_targets(ms.load_scene("point_target"))
    np.testing.assert_allclose(target.position, [15.0, 8.0, 0.03], atol=1e-5)
    assert target.rcs == 1.0 and target.shape_id == "target"
    np.testing.assert_array_equal(target.velocity, [0.0, 0.0, 0.0])
    (target,) = ms.scene_point_targets(
        ms.load_scene("point_target", rcs=2.5, velocity="0.5, 0, 0"))
    assert target.rcs == 2.5
    np.testing.assert_array_equal(target.velocity, [0.5, 0.0, 0.0])
    assert ms.scene_point_targets(ms.load_scene("dihedral")) == []


def test_load_scene_accepts_a_loaded_scene(mi) -> None:
    scene = ms.load_scene("dihedral")
    assert ms.load_scene(scene) is scene
    with pytest.raises(ParameterError):
        ms.load_scene(scene, material="absorber")


# --------------------------------------------------------------------------------------------
# Surface scatterers
# --------------------------------------------------------------------------------------------


def test_scatterers_reproducible(mi) -> None:
    scene = ms.load_scene("trihedral")
    a = ms.sample_surface_scatterers(scene, 20.0, seed=11)
    b = ms.sample_surface_scatterers(ms.load_scene("trihedral"), 20.0, seed=11)
    c = ms.sample_surface_scatterers(scene, 20.0, seed=12)
    for field in ("positions", "normals", "area", "shape_index", "phase"):
        np.testing.assert_array_equal(getattr(a, field), getattr(b, field))
    assert not np.allclose(a.positions, c.positions)
    assert not np.allclose(a.phase, c.phase)


def test_scatterer_density_and_geometry(mi) -> None:
    density = 50.0
    scene = ms.load_scene("control_volume")
    surfaces = ms.scene_surfaces(scene)
    sc = ms.sample_surface_scatterers(scene, density, seed=1)
    assert len(sc) == sum(round(density * s.area) for s in surfaces) == 54_000
    assert sc.surface_ids == tuple(s.id for s in surfaces)
    assert np.sum(sc.area) == pytest.approx(sum(s.area for s in surfaces), rel=1e-9)
    for s in surfaces:
        mine = sc.shape_index == s.index
        assert np.count_nonzero(mine) == pytest.approx(density * s.area, abs=0.5)
    # on the room's boundary, inside its extent, normals pointing inward
    p, n = sc.positions, sc.normals
    assert np.all(p >= ROOM[0] - 1e-4) and np.all(p <= ROOM[1] + 1e-4)
    on_face = np.min(np.concatenate([np.abs(p - ROOM[0]), np.abs(p - ROOM[1])], 1), 1)
    assert np.max(on_face) < 1e-4
    np.testing.assert_allclose(np.linalg.norm(n, axis=1), 1.0, atol=1e-6)
    assert np.all(np.sum(n * (np.array([15.0, 5.0, 3.0]) - p), axis=1) > 0)
    floor = sc.shape_index == [s.index for s in surfaces if s.id == "floor"][0]
    np.testing.assert_allclose(n[floor], np.tile([0.0, 0.0, 1.0], (floor.sum(), 1)), atol=1e-6)
    # stratified: counts per m² of floor scatter far less than Poisson's sqrt(50) = 7.1
    counts, _, _ = np.histogram2d(p[floor, 0], p[floor, 1], bins=(30, 10),
                                  range=((0, 30), (0, 10)))
    assert np.std(counts) < 0.5 * math.sqrt(density)
    assert np.all(np.abs(counts - density) <= 0.2 * density)
    # speckle phases uniform on [0, 2π)
    assert np.all((sc.phase >= 0) & (sc.phase < 2 * math.pi))
    assert np.mean(np.exp(1j * sc.phase)) == pytest.approx(0.0, abs=0.02)


def test_scatterers_skip_absorbers_and_targets(mi) -> None:
    sc = ms.sample_surface_scatterers(ms.load_scene("point_target"), 100.0, seed=0)
    assert len(sc) == 0 and sc.positions.shape == (0, 3)


def test_scatterers_on_mesh_have_outward_normals(mi) -> None:
    scene = ms.load_scene("box_obstacle")
    surfaces = {s.id: s for s in ms.scene_surfaces(scene)}
    assert surfaces["cabinet"].area == pytest.approx(2 * (0.5 + 2.0 + 1.0))
    sc = ms.sample_surface_scatterers(scene, 400.0, seed=2)
    cab = sc.shape_index == surfaces["cabinet"].index
    assert np.count_nonzero(cab) == 2800
    centre = np.array([10.0, 8.0, 1.0])
    p, n = sc.positions[cab], sc.normals[cab]
    assert np.all(np.sum(n * (p - centre), axis=1) > 0)
    half = np.array([0.5, 0.25, 1.0])
    d = np.abs(p - centre)
    assert np.all(d <= half + 1e-5)
    assert np.all(np.min(np.abs(d - half), axis=1) < 1e-5)


def test_scatterer_arguments_checked(mi) -> None:
    scene = ms.load_scene("dihedral")
    with pytest.raises(ParameterError, match="density_per_m2"):
        ms.sample_surface_scatterers(scene, 0.0)
    with pytest.raises(ParameterError, match="seed"):
        ms.sample_surface_scatterers(scene, 1.0, seed=-1)


# --------------------------------------------------------------------------------------------
# Errors naming file, element and parameter
# --------------------------------------------------------------------------------------------


def write(tmp_path: Path, name: str, body: str) -> Path:
    path = tmp_path / name
    path.write_text(f'<scene version="3.0.0">\n{body}\n</scene>\n')
    return path


def test_error_unknown_plugin_parameter(mi, tmp_path: Path) -> None:
    path = write(tmp_path, "a.xml", '<bsdf type="doublelobe" id="wallmat">\n'
                 '  <float name="alpha_x" value="3"/>\n</bsdf>')
    with pytest.raises(ParameterError) as info:
        ms.load_scene(path)
    assert info.value.name == "alpha_x"
    assert "a.xml" in str(info.value) and "'wallmat'" in str(info.value)
    assert "line 2" in str(info.value)


def test_error_out_of_range_inline(mi, tmp_path: Path) -> None:
    path = write(tmp_path, "b.xml", '<shape type="rectangle" id="floor">\n'
                 '  <bsdf type="doublelobe"><float name="alpha_b" value="-1"/></bsdf>\n</shape>')
    with pytest.raises(ParameterError, match="parameter 'alpha_b'") as info:
        ms.load_scene(path)
    assert "shape 'floor'" in str(info.value) and "doublelobe" in str(info.value)


def test_error_unknown_builtin_parameter(mi, tmp_path: Path) -> None:
    path = write(tmp_path, "c.xml", '<shape type="sphere" id="ball">\n'
                 '  <float name="radiuss" value="1"/>\n</shape>')
    with pytest.raises(ParameterError) as info:
        ms.load_scene(path)
    assert info.value.name == "radiuss" and "'ball'" in str(info.value)


def test_error_missing_mesh(mi, tmp_path: Path) -> None:
    path = write(tmp_path, "d.xml", '<default name="mesh" value="meshes/gone.ply"/>\n'
                 '<shape type="ply" id="cabinet">\n'
                 '  <string name="filename" value="$mesh"/>\n</shape>')
    with pytest.raises(MissingFileError) as info:
        ms.load_scene(path)
    text = str(info.value)
    assert "'cabinet'" in text and "parameter 'filename'" in text and "gone.ply" in text
    assert isinstance(info.value, FileNotFoundError)


def test_error_missing_file_and_undeclared_parameter(mi, tmp_path: Path) -> None:
    with pytest.raises(MissingFileError, match="nothing.xml.*control_volume"):
        ms.load_scene(tmp_path / "nothing.xml")
    with pytest.raises(ParameterError, match="parameter 'materal'.*material"):
        ms.load_scene("control_volume", materal="concrete_94ghz")
    with pytest.raises(ParameterError, match="parameter 'preset'"):
        ms.load_scene("control_volume", material="brick")


# --------------------------------------------------------------------------------------------
# PLY generation
# --------------------------------------------------------------------------------------------


@pytest.mark.parametrize("binary", [True, False])
@pytest.mark.parametrize("inward", [False, True])
def test_write_ply_round_trip(mi, tmp_path: Path, binary: bool, inward: bool) -> None:
    vertices, faces = ms.box_mesh([0, 0, 0], [2.0, 1.0, 3.0], inward=inward)
    path = ms.write_ply(tmp_path / "box.ply", vertices, faces, binary=binary)
    mesh = mi.load_dict({"type": "ply", "filename": str(path), "face_normals": True})
    assert mesh.vertex_count() == 8 and mesh.face_count() == 12
    assert float(mesh.surface_area()[0]) == pytest.approx(2 * (2 + 6 + 3))
    rng = np.random.default_rng(0)
    ps = mesh.sample_position(0.0, mi.Point2f(rng.random(500), rng.random(500)))
    p, n = np.array(ps.p).T, np.array(ps.n).T
    outward = np.sum(n * (p - np.array([1.0, 0.5, 1.5])), axis=1)
    assert np.all(outward < 0) if inward else np.all(outward > 0)


def test_committed_mesh_is_current(tmp_path: Path) -> None:
    vertices, faces = ms.box_mesh([-0.5] * 3, [0.5] * 3)
    fresh = ms.write_ply(tmp_path / "unit_box.ply", vertices, faces)
    assert fresh.read_bytes() == (scenes.SCENE_DIR / "meshes" / "unit_box.ply").read_bytes()


def test_scatterers_on_a_smooth_shaded_mesh_get_face_normals(tmp_path):
    """A box mesh loaded without face_normals interpolates vertex normals (up to ~55 deg off);
    scatterers must still carry the six face normals, or sigma0 is read at wrong angles."""
    import shutil

    import mitsar.scene.canned as canned
    from mitsar.scene import load_scene, sample_surface_scatterers, scene_surfaces

    source = canned.path("box_obstacle")
    shutil.copytree(source.parent / "meshes", tmp_path / "meshes")
    smooth = tmp_path / "box_smooth.xml"
    text = source.read_text()
    assert '<boolean name="face_normals" value="true"/>' in text
    smooth.write_text(text.replace('<boolean name="face_normals" value="true"/>', ""))
    scene = load_scene(smooth)
    scatterers = sample_surface_scatterers(scene, 200, seed=1)
    cabinet = [s.index for s in scene_surfaces(scene) if s.id == "cabinet"][0]
    normals = scatterers.normals[scatterers.shape_index == cabinet]
    axis_aligned = np.abs(normals).max(axis=1)
    np.testing.assert_allclose(axis_aligned, 1.0, atol=1e-5)
    assert len(np.unique(np.round(normals, 3), axis=0)) == 6
