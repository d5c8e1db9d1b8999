"""Map accuracy against the scene (docs/features.md "Map scores"): the truth's features at the
canned scenes' XML positions, observability from the track, and the scores on point clouds
with known answers (Knapitsch et al. 2017; Schöps et al. 2017)."""

from __future__ import annotations

import math
import xml.etree.ElementTree as ET

import numpy as np
import pytest
import xarray as xr

import mitsar
from mitsar.errors import ParameterError
from mitsar.features.scores import map_scores, scores_dataset, scores_table
from mitsar.features.truth import (
    Observer,
    observer_from_track,
    scene_features,
    scene_truth,
)
from mitsar.model.geometry.attitude import antenna_frame
from mitsar.scene import box_mesh, canned, load_scene, write_ply

CANNED = canned.SCENE_DIR  # scenes/ (installed as mitsar._scenes)
RADAR = mitsar.Radar()
TAU = 0.05


# ---------------------------------------------------------------------------- closed forms


def _rotation(axis: np.ndarray, angle_deg: float) -> np.ndarray:
    axis = axis / np.linalg.norm(axis)
    a = math.radians(angle_deg)
    k = np.array([[0, -axis[2], axis[1]], [axis[2], 0, -axis[0]], [-axis[1], axis[0], 0]])
    return np.eye(3) + math.sin(a) * k + (1 - math.cos(a)) * k @ k


def _xml_transform(shape: ET.Element) -> np.ndarray:
    """The 4 x 4 ``to_world`` of a shape, composed in document order (Mitsuba's rule)."""
    matrix = np.eye(4)
    for step in shape.find("transform"):
        get = {k: float(v) for k, v in step.attrib.items() if k != "angle"}
        m = np.eye(4)
        if step.tag == "scale":
            m[:3, :3] = np.diag([get.get("x", 1.0), get.get("y", 1.0), get.get("z", 1.0)])
        elif step.tag == "rotate":
            m[:3, :3] = _rotation(np.array([get.get("x", 0.0), get.get("y", 0.0),
                                            get.get("z", 0.0)]), float(step.attrib["angle"]))
        elif step.tag == "translate":
            m[:3, 3] = [get.get("x", 0.0), get.get("y", 0.0), get.get("z", 0.0)]
        matrix = m @ matrix
    return matrix


def _rectangle_corners(name: str) -> dict[str, np.ndarray]:
    """Corners (4, 3) [m] of every rectangle of a canned XML scene: the transform applied to
    Mitsuba's rectangle [-1, 1]^2 x {0}."""
    unit = np.array([[-1, -1, 0, 1], [1, -1, 0, 1], [1, 1, 0, 1], [-1, 1, 0, 1]], float)
    root = ET.parse(CANNED / f"{name}.xml").getroot()
    return {s.attrib["id"]: (unit @ _xml_transform(s).T)[:, :3]
            for s in root.iter("shape") if s.attrib["type"] == "rectangle"}


def _expected_corners(name: str) -> tuple[np.ndarray, list[tuple[np.ndarray, np.ndarray]]]:
    """Trihedral corners (points shared by three rectangles) and dihedral edges (two corners
    shared by two rectangles) from the XML alone."""
    corners = _rectangle_corners(name)
    points = np.vstack(list(corners.values())).round(6)
    unique, counts = np.unique(points, axis=0, return_counts=True)
    trihedrals = unique[counts == 3]
    edges = []
    names = sorted(corners)
    for i, a in enumerate(names):
        for b in names[i + 1:]:
            shared = [p for p in corners[a].round(6) if (np.abs(corners[b].round(6) - p)
                                                         .max(axis=1) < 1e-9).any()]
            if len(shared) == 2:
                edges.append((shared[0], shared[1]))
    return trihedrals, edges


def _same_segment(start, end, a, b, tol=1e-4) -> bool:
    return ((np.allclose(start, a, atol=tol) and np.allclose(end, b, atol=tol))
            or (np.allclose(start, b, atol=tol) and np.allclose(end, a, atol=tol)))


@pytest.mark.parametrize("name, trihedrals, dihedrals", [
    ("dihedral", 0, 1), ("trihedral", 1, 3), ("control_volume", 8, 12)])
def test_corners_of_the_canned_rooms_are_at_their_xml_positions(name, trihedrals, dihedrals):
    """The rooms build their corners from separate rectangles that share no mesh edge: every
    trihedral and dihedral the XML implies is found, with its kind, and nothing else."""
    features = scene_features(load_scene(name))
    corners, edges = _expected_corners(name)
    assert len(corners) == trihedrals and len(edges) == dihedrals
    kinds = features.kind.tolist()
    assert kinds.count("trihedral") == trihedrals and kinds.count("dihedral") == dihedrals
    assert len(features) == trihedrals + dihedrals                # no convex edges in a room
    found = features.start[features.kind == "trihedral"]
    for corner in corners:
        assert np.min(np.linalg.norm(found - corner, axis=1)) < 1e-4
    for i in np.flatnonzero(features.kind == "trihedral"):
        normals = features.normals[i]
        np.testing.assert_allclose(np.abs(normals @ normals.T), np.eye(3), atol=1e-6)
        # Normals point into the room: towards the corner's air octant.
        room_centre = np.array([15.0, 5.0, 3.0])
        assert np.all((room_centre - features.start[i]) @ normals.T > 0)
    dihedral = np.flatnonzero(features.kind == "dihedral")
    for a, b in edges:
        assert any(_same_segment(features.start[i], features.end[i], a, b) for i in dihedral)
    np.testing.assert_allclose(features.angle_deg, 90.0, atol=1e-6)


def test_cabinet_on_the_floor_has_four_dihedral_and_eight_convex_edges():
    """A PLY box standing on a floor rectangle: its bottom lies back to back on the floor (no
    edges there), its sides meet the floor inside the floor's triangle (dihedrals), its other
    edges are convex (air wedge 270 deg). Positions from the XML transform of the unit cube."""
    features = scene_features(load_scene("box_obstacle"))
    root = ET.parse(CANNED / "box_obstacle.xml").getroot()
    cabinet = next(s for s in root.iter("shape") if s.attrib["id"] == "cabinet")
    matrix = _xml_transform(cabinet)
    low = (matrix @ [-0.5, -0.5, -0.5, 1])[:3]
    high = (matrix @ [0.5, 0.5, 0.5, 1])[:3]
    np.testing.assert_allclose([low, high], [[9.5, 7.75, 0.0], [10.5, 8.25, 2.0]])
    kinds = features.kind.tolist()
    assert kinds.count("dihedral") == 4 and kinds.count("convex_edge") == 8
    assert len(features) == 12
    dihedral = features.kind == "dihedral"
    np.testing.assert_allclose(features.start[dihedral][:, 2], 0.0, atol=1e-6)
    ends = np.vstack([features.start, features.end])
    assert np.all((ends >= low - 1e-6) & (ends <= high + 1e-6))
    np.testing.assert_allclose(features.angle_deg[~dihedral], 270.0, atol=1e-6)
    lengths = np.sort(np.linalg.norm(features.end - features.start, axis=1)[dihedral])
    np.testing.assert_allclose(lengths, [0.5, 0.5, 1.0, 1.0], atol=1e-5)


def test_a_crate_against_the_wall_of_a_one_mesh_room_makes_trihedrals(tmp_path):
    """A room as one inward PLY box (corners on shared mesh edges) and a crate pushed against
    its wall x = 0 (corners where the crate's faces meet the inside of the room's triangles):
    two more trihedrals at the crate's foot by the wall, its back face hidden on the wall, and
    a sphere makes no feature."""
    vertices, faces = box_mesh([0.0, 0.0, 0.0], [4.0, 3.0, 2.5], inward=True)
    write_ply(tmp_path / "room.ply", vertices, faces)
    vertices, faces = box_mesh([0.0, 1.0, 0.0], [0.5, 1.4, 0.8])
    write_ply(tmp_path / "crate.ply", vertices, faces)
    shapes = "".join(
        f'<shape type="ply" id="{name}"><string name="filename" value="{name}.ply"/>'
        '<boolean name="face_normals" value="true"/><ref id="c"/></shape>'
        for name in ("room", "crate"))
    (tmp_path / "room.xml").write_text(
        '<scene version="3.0.0"><bsdf type="doublelobe" id="c"><string name="preset" '
        f'value="concrete_94ghz_paper"/></bsdf>{shapes}<shape type="sphere" id="ball">'
        '<point name="center" x="3" y="2" z="1"/><float name="radius" value="0.2"/>'
        '<ref id="c"/></shape></scene>')
    features = scene_features(load_scene(str(tmp_path / "room.xml")))
    kinds = features.kind.tolist()
    # Room: 8 + 12; crate: 3 sides on the floor, 2 sides and the top on the wall (dihedrals),
    # 3 top edges and 2 front vertical edges convex.
    assert kinds.count("trihedral") == 10 and kinds.count("dihedral") == 18
    assert kinds.count("convex_edge") == 5 and len(features) == 33
    crate = np.array([("crate" in s) and k == "trihedral" for s, k in
                      zip(features.shapes, kinds, strict=True)])
    np.testing.assert_allclose(np.sort(features.start[crate][:, 1]), [1.0, 1.4], atol=1e-6)
    np.testing.assert_allclose(features.start[crate][:, [0, 2]], 0.0, atol=1e-6)
    assert not any("ball" in s for s in features.shapes)


def test_feature_extraction_rejects_bad_tolerances():
    scene = load_scene("dihedral")
    with pytest.raises(ParameterError, match="tolerance"):
        scene_features(scene, tolerance=-1.0)
    with pytest.raises(ParameterError, match="bounds"):
        scene_truth(scene, bounds=[[0, 0, 0], [-1, 1, 1]])


# ---------------------------------------------------------------------------- observability

OCCLUDED_TRIHEDRAL = """<scene version="3.0.0">
    <bsdf type="doublelobe" id="concrete">
        <string name="preset" value="concrete_94ghz_paper"/>
    </bsdf>
    <shape type="rectangle" id="floor">
        <transform name="to_world"><scale x="15" y="5"/><translate x="15" y="5" z="0"/>
        </transform><ref id="concrete"/>
    </shape>
    <shape type="rectangle" id="wall_y10">
        <transform name="to_world"><scale x="15" y="3"/><rotate x="1" angle="90"/>
            <translate x="15" y="10" z="3"/></transform><ref id="concrete"/>
    </shape>
    <shape type="rectangle" id="wall_x0">
        <transform name="to_world"><scale x="3" y="5"/><rotate y="1" angle="90"/>
            <translate x="0" y="5" z="3"/></transform><ref id="concrete"/>
    </shape>
    <shape type="rectangle" id="screen">
        <transform name="to_world"><scale x="1.5" y="1"/><rotate x="1" angle="90"/>
            <translate x="1.5" y="9" z="1"/></transform><ref id="concrete"/>
    </shape>
</scene>
"""
"""The canned trihedral with a screen (y = 9 m, x in [0, 3] m, z in [0, 2] m) between the
paper's track (y = 8 m, z = 1 m) and the corner [0, 10, 0] m."""


def _paper_observer() -> Observer:
    """The paper's trihedral pass (§4.3): P0 = [0.4, 8, 1] m, 0.5 m/s along +x for 4 s, 60 deg
    off-nadir, squint 15 deg; 21 antenna positions."""
    x = np.linspace(0.4, 2.4, 21)
    positions = np.stack([x, np.full_like(x, 8.0), np.ones_like(x)], axis=1)
    frames = np.broadcast_to(antenna_frame(mitsar.Look(60.0, 15.0)), (len(x), 3, 3))
    return Observer(positions, np.array(frames), RADAR.azimuth_beamwidth,
                    RADAR.elevation_beamwidth, RADAR.max_range)


def _corner_record(scores, corner):
    return next(r for r in scores["features"] if r["kind"] == "trihedral"
                and np.allclose(r["position"], corner, atol=1e-3))


def test_a_corner_behind_a_screen_is_not_visible_not_missed(tmp_path):
    """The paper's pass sees the trihedral [0, 10, 0] m; with a screen in between the same
    corner is inside the footprint but occluded: "not_visible", never "missed", and it does
    not count against the feature recall. A detection at the corner scores it found."""
    observer = _paper_observer()
    corner = np.array([0.0, 10.0, 0.0])
    bounds = [[-0.5, 7.0, -0.5], [3.0, 10.5, 2.5]]
    open_truth = scene_truth(load_scene("trihedral"), TAU, track=observer, bounds=bounds)
    path = tmp_path / "occluded.xml"
    path.write_text(OCCLUDED_TRIHEDRAL)
    hidden_truth = scene_truth(load_scene(str(path)), TAU, track=observer, bounds=bounds)

    seen = map_scores(corner[None] + 0.01, open_truth, TAU, radius=0.1)
    record = _corner_record(seen, corner)
    assert record["observable"] and record["status"] == "found"
    assert record["error"] == pytest.approx(0.01 * math.sqrt(3), abs=1e-6)

    for detections in (np.zeros((0, 3)), np.array([[2.0, 8.5, 0.0]])):
        scores = map_scores(detections, hidden_truth, TAU, radius=0.1)
        record = _corner_record(scores, corner)
        assert record["status"] == "not_visible" and record["reason"] == "occluded"
        assert record["in_footprint"] and not record["observable"]
        assert record["id"] in scores["not_visible"] and record["id"] not in scores["missed"]
    # The screen makes its own trihedral with the floor and the wall x = 0.
    assert _corner_record(scores, [0.0, 9.0, 0.0])["shapes"] == "floor|screen|wall_x0"
    # The surface behind the screen is not observable, the screen is.
    behind = (hidden_truth.points[:, 1] > 9.0) & (hidden_truth.points[:, 0] < 1.0)
    assert not hidden_truth.observable[behind & (hidden_truth.points[:, 2] < 0.5)].any()
    assert hidden_truth.observable.sum() < open_truth.observable.sum()


def test_observer_from_raw_passes_and_outside_footprint():
    """Positions and frames come from the raw product's track and look; a corner the beam
    never reaches is "outside_footprint"."""
    trajectory = mitsar.Trajectory.linear([0.4, 8.0, 1.0], [0.5, 0.0, 0.0], 2.0)
    raw = mitsar.simulate_point_targets(RADAR, trajectory, mitsar.Look(60.0, 15.0),
                                        [mitsar.PointTarget([1.0, 10.0, 0.0], 1.0)],
                                        normalized=True)
    observer = observer_from_track([raw, raw], samples=5)
    assert observer.positions.shape == (10, 3) and observer.passes == 2
    np.testing.assert_allclose(observer.positions[0], [0.4, 8.0, 1.0], atol=1e-3)
    np.testing.assert_allclose(observer.frames[0], antenna_frame(mitsar.Look(60.0, 15.0)),
                               atol=1e-9)
    truth = scene_truth("control_volume", 0.1, track=raw, bounds=[[-1, -1, -1], [31, 11, 7]])
    features = truth.features
    far = np.flatnonzero((features.kind == "trihedral") & (features.start[:, 0] > 29))
    assert len(far) == 4 and not features.in_footprint[far].any()
    assert set(features.reason[far]) == {"outside_footprint"}
    near = np.flatnonzero((features.kind == "trihedral")
                          & np.all(np.abs(features.start - [0, 10, 0]) < 1e-3, axis=1))
    assert features.observable[near].all()
    with pytest.raises(ParameterError, match="track"):
        observer_from_track([])


# ---------------------------------------------------------------------------- scores

FLOOR_BOX = [[5.0, 5.0, -0.5], [7.0, 8.0, 0.5]]
"""A 2 m x 3 m patch of the dihedral scene's floor, away from its wall."""


@pytest.fixture(scope="module")
def floor_truth():
    return scene_truth(load_scene("dihedral"), TAU, bounds=FLOOR_BOX, seed=3)


def test_a_perfect_map_scores_one(floor_truth):
    """Points on the truth, the samples themselves or uniformly drawn on the surface: P = R
    = F = 1 and accuracy 0."""
    assert len(floor_truth) == 40 * 60 and floor_truth.seed == 3
    rng = np.random.default_rng(0)
    drawn = np.column_stack([rng.uniform(5, 7, 20000), rng.uniform(5, 8, 20000),
                             np.zeros(20000)])
    for points in (floor_truth.points, drawn):
        scores = map_scores(points, floor_truth, TAU)
        assert scores["precision"] == 1.0 and scores["completeness"] == 1.0
        assert scores["recall"] == 1.0 and scores["f_score"] == 1.0
        assert scores["accuracy"] == pytest.approx(0.0, abs=1e-9)
        assert scores["seed"] == 3 and scores["tau"] == TAU


@pytest.mark.parametrize("offset", [0.02, 0.049, 0.08])
def test_a_map_offset_along_the_normal_has_accuracy_the_offset(floor_truth, offset):
    """A map ``d`` off the surface along its normal: accuracy d (sampling tolerance 1e-9);
    precision and completeness 1 for d <= tau, 0 beyond."""
    scores = map_scores(floor_truth.points + offset * floor_truth.normals, floor_truth, TAU)
    assert scores["accuracy"] == pytest.approx(offset, abs=1e-9)
    assert scores["accuracy_median"] == pytest.approx(offset, abs=1e-9)
    inside = float(offset <= TAU)
    assert scores["precision"] == inside and scores["completeness"] == inside
    assert scores["f_score"] == inside


def test_half_a_map_is_half_complete(floor_truth):
    """Half the patch mapped: completeness about 0.5 (the band within tau of the map's edge
    adds tau / 2 m = 0.025), precision 1, F = 2 P R / (P + R)."""
    half = floor_truth.points[floor_truth.points[:, 0] < 6.0]
    scores = map_scores(half, floor_truth, TAU)
    assert scores["completeness"] == pytest.approx(0.5, abs=0.03)
    assert scores["precision"] == 1.0
    p, r = scores["precision"], scores["completeness"]
    assert scores["f_score"] == pytest.approx(2 * p * r / (p + r))


def test_scores_of_a_detection_dataset_with_cells_and_resolution():
    """A ``mitsar.detect``-shaped Dataset: the map is ``cell_position``, the features are
    scored on ``position`` within one resolution cell (the largest of ``resolution``)."""
    truth = scene_truth(load_scene("trihedral"), TAU, bounds=[[-0.5, 8.0, -0.5], [2, 10.5, 2]])
    corner = np.array([0.0, 10.0, 0.0])
    found = xr.Dataset(
        {"position": (("detection", "xyz"), [corner + [0.03, -0.03, 0.02], [1.0, 9.0, 0.0]]),
         "cell_position": (("cell", "xyz"), truth.points)},
        attrs={"resolution": [0.1, 0.08, 0.05]})
    scores = map_scores(found, truth, TAU)
    assert scores["map_points_source"] == "cells" and scores["map_points"] == len(truth)
    assert scores["precision"] == 1.0 and scores["completeness"] == 1.0
    assert scores["feature_radius"] == pytest.approx(0.1)
    record = _corner_record(scores, corner)
    assert record["status"] == "found"
    assert record["error"] == pytest.approx(math.sqrt(0.03**2 * 2 + 0.02**2))
    # Every dihedral through the corner is found too; the second detection is on the floor.
    assert scores["feature_recall"] == 1.0 and scores["feature_precision"] == 0.5
    assert scores["features"]["recall"] == 1.0 and scores["missed"] == []
    data = scores_dataset(scores)
    assert float(data["f_score"]) == 1.0 and data["f_score"].attrs["units"] == "1"
    assert set(data["feature_status"].values) == {"found"}
    assert data.attrs["seed"] == 0
    assert [row[0] for row in scores_table(scores)][:3] == ["tau", "accuracy",
                                                           "accuracy_median"]


def test_map_scores_is_exported_and_checks_its_input(floor_truth):
    # mitsar.__all__ functions are wrapped by mitsar.errors.public (argument checks)
    assert getattr(mitsar.map_scores, "__wrapped__", None) is map_scores
    assert "map_scores" in mitsar.__all__
    with pytest.raises(ParameterError, match="tau"):
        map_scores(floor_truth.points, floor_truth, tau=0.0)
    with pytest.raises(ParameterError, match="found"):
        map_scores(np.zeros((4, 2)), floor_truth)
    with pytest.raises(ParameterError, match="found"):
        map_scores(xr.Dataset({"amplitude": ("detection", [1.0])}), floor_truth)
    empty = map_scores(np.zeros((0, 3)), floor_truth)
    assert empty["precision"] == 0.0 and empty["f_score"] == 0.0
    assert math.isnan(empty["accuracy"])


def test_paper_trihedral_from_two_passes_is_found_within_a_resolution_cell():
    """End to end: the paper's trihedral pass (P0 = [0.4, 8, 1] m, 60 deg off-nadir, squint
    15 deg) and a second one 0.3 m higher see a point echo at the corner [0, 10, 0] m; the
    volume (``mitsar.focus`` of both) gives a detection (``mitsar.detect``) at the corner within
    one resolution cell, and ``bounds=grid`` cuts the truth to the volume. A pass pair 10 m
    down the room (looking the same way) does not have the corner in its beam: the same
    detections then report it not visible, not missed."""
    look = mitsar.Look(60.0, 15.0)
    corner = [0.0, 10.0, 0.0]

    def passes(x0):
        return [mitsar.simulate_point_targets(
            RADAR, mitsar.Trajectory.linear([x0, 8.0, z], [0.5, 0.0, 0.0], 4.0), look,
            [mitsar.PointTarget(corner, 1.0)], normalized=True, seed=1) for z in (1.0, 1.3)]

    raws = passes(0.4)
    grid = mitsar.grid.VolumeGrid(x=[-0.3, 0.3, 0.02], y=[9.6, 10.2, 0.02], z=[-0.3, 0.3, 0.02])
    volume = mitsar.focus(raws, algorithm="bpa", grid=grid)
    found = mitsar.detect(volume, pfa=1e-6)
    scores = mitsar.map_scores(found, "trihedral", tau=TAU, track=raws, bounds=grid)
    by_image = mitsar.map_scores(found, "trihedral", tau=TAU, track=raws, bounds=volume)
    assert by_image["truth_samples"] == scores["truth_samples"] > 0
    record = _corner_record(scores, corner)
    cell = max(found.attrs["resolution"])
    assert scores["feature_radius"] == pytest.approx(cell)
    assert record["status"] == "found" and record["error"] < cell
    assert scores["feature_recall"] == 1.0 and scores["missed"] == []
    assert np.all(scores["features"][0]["position"] == record["position"])
    far = mitsar.map_scores(found, "trihedral", tau=TAU, track=passes(10.4), bounds=grid)
    record = _corner_record(far, corner)
    assert record["status"] == "not_visible" and record["reason"] == "outside_footprint"
    assert record["id"] in far["not_visible"] and far["missed"] == []
    assert far["truth_samples"] == 0 and math.isnan(far["feature_recall"])
