"""The paper's control volume mapped from a vertical stack of passes (issue 23 must-show).

Scannapieco, Renga & Moccia 2016 fly their 3-D trihedral example (§4.3, Figs. 14-15;
``examples/trihedral_3d.toml``) from P0 = [0.4, 8, 1] m along +x at 0.5 m/s for 4 s, 60 deg
off-nadir with 15 deg squint (looking back toward -x), so that the corner [0, 10, 0] m of the
floor and the walls y = 10 m and x = 0 is in the beam; multipath up to three reflections
(max_depth = 4: the triple bounce is what makes the corner bright). Here the same pass is flown
over the whole control volume (``control_volume``: the 30 x 10 x 6 m room) as a vertical stack
of 16 passes 2.5 mm apart, with the paper's radar (Table 1) and receiver noise (10 dB noise
figure), and mapped by :func:`mitsar.map_scene` (3-D back-projection of all passes, CA-CFAR,
map scores against the scene; docs/features.md "Mapping the control volume").

The stack is designed from docs/focusing.md eqs. T2-T3 at the corner (R = 2.2 m, baseline
across the line of sight 0.91 of the vertical one): L_perp = 16 x 2.5 mm x 0.91 = 36 mm gives
rho_e = lambda R / (2 L_perp) = 0.08 m, about the range resolution c / 2B = 0.10 m, and the
grating lobes lie lambda / (2 d_perp) = 0.7 apart in direction sine, more than the 0.56 the
lit volume spans seen from the stack, so no grating lobe of a lit surface falls inside it.

Sweeps: every 4th of the 1000 (8 mm of track, a Doppler sampling of 62.5 Hz for the 49 Hz the
9 deg beam spans; :func:`mitsar.map_scene` records the stride, ``sweep_stride``, that
back-projection's Doppler band selection needs; the image then agrees with the full-rate one to
a coherence of 0.993). Scatterers: 2 per resolution cell (a modest density: the corner's echo
is specular). Seeds: scene 0 for every pass (one scatterer set), receiver noise 1000 + pass index.
"""

from __future__ import annotations

import math

import numpy as np
import pytest

import mitsar
from mitsar.budget import set_memory_limit
from mitsar.errors import MemoryBudgetError, ParameterError
from mitsar.features.mapping import (
    SceneMap,
    map_grid,
    map_resolution,
    map_scene,
    pass_weights,
    window_broadening,
)
from mitsar.features.scores import map_scores
from mitsar.model.noise import thermal_noise
from mitsar.scene import load_scene

RADAR = mitsar.Radar(noise_figure_db=10.0)       # paper Table 1 + a receiver noise figure
LOOK = mitsar.Look(60.0, 15.0)                   # paper §4.3, trihedral example
START = np.array([0.4, 8.0, 1.0])                # P0 [m]
VELOCITY = [0.5, 0.0, 0.0]                       # m/s
DURATION = 4.0                                   # s
PASSES = 16
SPACING = 0.0025                                 # m between passes, vertical
SCENE_SEED = 0
NOISE_SEED = 1000
SWEEPS = slice(0, None, 4)
CORNER = np.array([0.0, 10.0, 0.0])
PFA = 1e-6
TAU = 0.05


def _stack(scene, x0: float, count: int) -> list:
    """``count`` passes of the paper's trihedral pass, started at x = ``x0`` and raised by
    ``SPACING`` each; the scene's draws seeded ``SCENE_SEED`` in every pass, the receiver
    noise of pass k seeded ``NOISE_SEED + k`` (recorded as ``noise_seed``)."""
    raws = []
    for k in range(count):
        track = mitsar.Trajectory.linear(START + [x0 - START[0], 0.0, k * SPACING], VELOCITY,
                                         DURATION)
        raw = mitsar.simulate_scene(RADAR, track, LOOK, scene, max_depth=4, rays=4096,
                                    scatterers_per_cell=2, seed=SCENE_SEED, sweeps=SWEEPS)
        sweeps = np.asarray(raw["sweep"].values, dtype=np.int64)
        raw["raw"] = raw["raw"] + thermal_noise(RADAR, NOISE_SEED + k, sweeps)
        raw.attrs.update(noise=1, noise_power=RADAR.noise_power, noise_seed=NOISE_SEED + k,
                         pass_name=f"z+{k * SPACING * 1000:.1f}mm")
        raws.append(raw)
    return raws


@pytest.fixture(scope="module")
def scene():
    return load_scene("control_volume")


@pytest.fixture(scope="module")
def stack(scene):
    return _stack(scene, START[0], PASSES)


@pytest.fixture(scope="module")
def mapped(stack, scene) -> SceneMap:
    return map_scene(stack, scene, pfa=PFA, tau=TAU)


def _record(scores, kind, shapes):
    return next(r for r in scores["features"] if r["kind"] == kind and r["shapes"] == shapes)


# ---------------------------------------------------------------------------- the must-show

PINNED = {
    # Measured (docs/features.md "Mapping the control volume"); the simulation is seeded and
    # bit-identical run after run (docs/integrator.md "Determinism"), so these move only when
    # the physics or the processing changes.
    "precision": 0.751412, "completeness": 0.172509, "f_score": 0.280599,
    "accuracy": 0.048526, "accuracy_median": 0.002783, "map_points": 177,
    "truth_samples": 1084, "localisation_error_max": 0.000891,
}
"""Scores of the stack's map at tau = 5 cm, CA-CFAR at pfa 1e-6."""

TOLERANCE = {
    # A regression guard, not a physics bound (those are asserted separately below). One map
    # cell is 1/177 = 0.0056 of the precision and one truth sample 1/1084 = 0.0009 of the
    # completeness: allow two of either (another machine's float rounding in the ray tracer or
    # the back-projection can move a cell across the CFAR threshold or tau), F by as much as
    # those move it, distances by 2 mm (1/25 of a voxel step, 1/50 of a resolution cell).
    "precision": 0.012, "completeness": 0.002, "f_score": 0.004, "accuracy": 0.002,
    "accuracy_median": 0.002, "map_points": 2, "truth_samples": 0,
    "localisation_error_max": 0.002,
}


def test_every_corner_feature_in_the_footprint_is_found_within_a_resolution_cell(mapped):
    """The observable corner features of the room inside the mapped volume are the trihedral
    [0, 10, 0] m and the three dihedral edges that meet there; every one is found by a
    detection within one resolution cell, and the trihedral's detection lies inside the 3-D
    resolution ellipsoid (range, azimuth, elevation components)."""
    scores, cell = mapped.scores, mapped.resolution
    scored = [r for r in scores["features"] if r["scored"]]
    observable = sorted((r["kind"], r["shapes"]) for r in scored if r["observable"])
    assert observable == [("dihedral", "floor|wall_x0"), ("dihedral", "floor|wall_y10"),
                          ("dihedral", "wall_x0|wall_y10"),
                          ("trihedral", "floor|wall_x0|wall_y10")]
    assert scores["missed"] == [] and scores["feature_recall"] == 1.0
    assert scores["feature_radius"] == pytest.approx(cell.extent.max())
    for record in scored:
        assert record["status"] == "found" and record["error"] < scores["feature_radius"]
    corner = _record(scores, "trihedral", "floor|wall_x0|wall_y10")
    np.testing.assert_allclose(corner["position"], CORNER, atol=1e-6)
    found = mapped.detections["position"].values[corner["detection"]]
    offset = found - CORNER
    assert np.linalg.norm(offset) == pytest.approx(corner["error"])
    # One resolution cell in 3-D: inside the ellipsoid of semi-axes rho_r, rho_a, rho_e.
    assert cell.within(offset)
    assert np.all(np.abs(cell.components(offset)) < 1.0)
    # The resolution cell is the stack's design (module docstring): rho_e about rho_r.
    assert cell.elevation_resolved
    assert cell.cells[0] == pytest.approx(RADAR.range_resolution)
    assert 0.06 < cell.cells[2] < 0.10
    # The corner is the strongest detection of the map.
    assert corner["detection"] == 0


def test_scores_are_pinned(mapped):
    """Accuracy, completeness and F-score at tau = 5 cm against their stored values (a
    regression guard; tolerances in TOLERANCE say why)."""
    scores = mapped.scores
    for name, value in PINNED.items():
        assert scores[name] == pytest.approx(value, abs=TOLERANCE[name]), name
    assert scores["f_score"] == pytest.approx(
        2 * scores["precision"] * scores["completeness"]
        / (scores["precision"] + scores["completeness"]))


def test_scores_obey_physics_bounds(mapped):
    """Bounds that do not depend on the stored values.

    - Localisation: every found feature within one resolution cell (the test above); the
      trihedral, a bright point echo (SNR > 20 dB), within a tenth of a cell.
    - Precision floor from the CFAR: every voxel is tested at the same pfa, so false alarms
      fall uniformly over the voxels and a map of false alarms would have the precision p0 =
      the share of voxels within tau of a surface. The pfa allows pfa x N_voxels = 0.03 of
      them; the map's precision must beat p0 by five binomial standard deviations of its n
      cells (its cells are echoes of the surfaces, not false alarms).
    - Accuracy: the median map cell lies within tau of a surface (most cells are surface
      echoes).
    - Completeness: each map cell can bring the truth samples within tau of it, at most
      (2 tau / spacing)^2 = 4 of them, into the completeness.
    """
    scores, found, cell = mapped.scores, mapped.detections, mapped.resolution
    corner = _record(scores, "trihedral", "floor|wall_x0|wall_y10")
    assert found["snr_db"].values[corner["detection"]] > 20.0
    assert corner["error"] < 0.1 * cell.cells.min()
    voxels = mapped.volume["position"].values.reshape(-1, 3)
    p0 = map_scores(voxels, mapped.truth, tau=TAU)["precision"]     # voxels as a map
    assert PFA * len(voxels) < 0.1
    n = scores["map_points"]
    assert n == found.sizes["cell"] > 0
    floor = p0 + 5.0 * math.sqrt(p0 * (1.0 - p0) / n)
    assert scores["precision"] > floor
    assert scores["accuracy_median"] <= TAU
    reach = n * (2 * TAU) ** 2 / mapped.truth.spacing**2
    assert scores["completeness"] * scores["truth_samples"] <= reach
    assert 0.0 < scores["completeness"] <= 1.0


def test_a_pass_pair_elsewhere_reports_the_corner_not_visible(scene, mapped):
    """Two passes of the same stack flown 10 m down the room (x = 10.4 ... 12.4 m, looking the
    same way) mapped onto the same volume: no pass has the corner or its edges in its beam, so
    they are "not_visible" (outside the footprint), never "missed", and the feature recall has
    nothing to count. The pair's own default volume lies around its own footprint."""
    far = _stack(scene, 10.4, 2)
    result = map_scene(far, scene, grid=mapped.grid, pfa=PFA, tau=TAU)
    scores = result.scores
    corner = _record(scores, "trihedral", "floor|wall_x0|wall_y10")
    assert corner["status"] == "not_visible" and corner["reason"] == "outside_footprint"
    assert not corner["in_footprint"] and corner["id"] in scores["not_visible"]
    assert scores["missed"] == [] and math.isnan(scores["feature_recall"])
    assert all(r["status"] == "not_visible" for r in scores["features"])
    assert scores["truth_samples"] == 0
    # In slabs, none of them lit by the pair: one is focused to say so, and nothing is found.
    tiled = map_scene(far, scene, grid=mapped.grid, pfa=PFA, tau=TAU, tile_voxels=15000)
    assert tiled.tiles == 1 and tiled.tiles_skipped == 2
    assert tiled.detections.sizes["detection"] == result.detections.sizes["detection"] == 0
    own = map_grid(far, scene)
    low = np.array([own.x[0], own.y[0], own.z[0]])
    assert low[0] > 9.0 > CORNER[0]                   # around x = 10 ... 12 m, not the corner


def test_tiles_give_the_same_map(stack, scene, mapped):
    """The volume focused and tested in slabs (``tile_voxels``) gives the same detections as
    at once: each slab carries the CFAR window's half-width on either side and the cores'
    cells are clustered together. The same cells and clusters; the CFAR's running box sums
    of a slab round differently from the whole volume's, so the noise estimates (and SNRs)
    agree to 1e-9, not bit for bit. Four of the passes, to keep it quick."""
    passes = stack[:4]
    whole = map_scene(passes, scene, grid=mapped.grid, pfa=PFA, tau=TAU)
    tiled = map_scene(passes, scene, grid=mapped.grid, pfa=PFA, tau=TAU, tile_voxels=15000)
    assert whole.tiles == 1 and tiled.tiles == 3 and tiled.volume is None
    assert whole.detections.sizes == tiled.detections.sizes
    assert whole.detections.sizes["detection"] > 1
    for name in ("cells", "cell_detection", "cell_position", "cell_amplitude"):
        np.testing.assert_array_equal(tiled.detections[name].values,
                                      whole.detections[name].values, err_msg=name)
    for name in whole.detections.data_vars:
        np.testing.assert_allclose(tiled.detections[name].values,
                                   whole.detections[name].values, rtol=1e-9, err_msg=name)
    assert tiled.scores["f_score"] == whole.scores["f_score"]


# ---------------------------------------------------------------------------- the interface


def test_map_scene_unpacks_records_and_is_exported(mapped, stack):
    volume, found, scores = mapped
    # mitsar.__all__ functions are wrapped by mitsar.errors.public (argument checks)
    assert getattr(mitsar.map_scene, "__wrapped__", None) is map_scene
    assert "map_scene" in mitsar.__all__
    assert volume.attrs["passes"] == PASSES and found.attrs["method"] == "ca"
    assert volume.attrs["pass_noise_seeds"] == [NOISE_SEED + k for k in range(PASSES)]
    assert mapped.attrs["pass_raw_seeds"] == [SCENE_SEED] * PASSES
    assert scores["seed"] == mapped.attrs["truth_seed"] == 0
    # The default grid: the lit surfaces' box padded by two resolution extents, half-cell steps.
    grid = mapped.grid
    steps = np.array([grid.x[2], grid.y[2], grid.z[2]])
    np.testing.assert_allclose(steps, 0.5 * mapped.resolution.cut_width, rtol=0.05)
    low = np.array([grid.x[0], grid.y[0], grid.z[0]])
    assert np.all(low <= CORNER - mapped.resolution.extent)
    again = map_resolution(stack, CORNER)
    assert again.slant_range == pytest.approx(np.linalg.norm(CORNER - START), rel=0.1)


def test_map_scene_refuses_before_computing(stack, scene, mapped):
    """A tile that does not fit the memory budget is refused before any focusing; bad
    arguments are named."""
    set_memory_limit("8M")     # the voxels fit (5.5 MB), the tile does not (9.8 MB)
    try:
        with pytest.raises(MemoryBudgetError, match="map_scene"):
            map_scene(stack, scene, grid=mapped.grid)
    finally:
        set_memory_limit(None)
    with pytest.raises(ParameterError, match="tile_voxels"):
        map_scene(stack, scene, grid=mapped.grid, tile_voxels=0)
    with pytest.raises(ParameterError, match="focus_options"):
        map_scene(stack, scene, grid=mapped.grid, focus_options={"combine": "incoherent"})
    with pytest.raises(ParameterError, match="raws"):
        map_scene([], scene)
    with pytest.raises(ParameterError, match="grid"):
        map_scene(stack, scene, grid={"kind": "volume"})


def test_window_broadening_and_pass_weights():
    """The Hamming window widens the -3 dB width by 1.30 / 0.886 = 1.47 (Harris 1978, Table
    1); pass weights follow the window over the stack's extent, mean 1, symmetric for a
    uniform stack; rect and a single pass weigh 1."""
    assert window_broadening("hamming") == pytest.approx(1.30 / 0.8859, rel=0.01)
    assert window_broadening(None) == pytest.approx(1.0)
    weights = pass_weights(np.arange(16) * SPACING, "hamming")
    assert weights.mean() == pytest.approx(1.0)
    np.testing.assert_allclose(weights, weights[::-1])
    assert weights[0] < 0.2 < 1.8 < weights[7]
    np.testing.assert_array_equal(pass_weights([0.0, 1.0], None), [1.0, 1.0])
    np.testing.assert_array_equal(pass_weights([0.0], "hamming"), [1.0])


@pytest.mark.slow
def test_paper_dihedral_pass_maps_the_floor_wall_edge(scene):
    """The paper's first 3-D example (§4.3, Figs. 12-13; ``examples/dihedral_3d.toml``): the
    same pass side-looking (no squint), as the same 16-pass stack over the control volume. The
    dihedral floor / wall y = 10 m retro-reflects at broadside along its length (the double
    bounce returns at the edge's range from every sweep): one long cluster along the edge,
    found within one resolution cell, its cells within one cell of the edge line over most of
    the 2 m of track; the trihedral [0, 10, 0] m stays outside the beam (not in the volume).
    Scores pinned as above (measured: P 0.922, completeness 0.165, F 0.280)."""
    side = []
    for k in range(PASSES):
        track = mitsar.Trajectory.linear(START + [0.0, 0.0, k * SPACING], VELOCITY, DURATION)
        raw = mitsar.simulate_scene(RADAR, track, mitsar.Look(60.0, 0.0), scene, max_depth=4,
                                    scatterers_per_cell=2, seed=SCENE_SEED, sweeps=SWEEPS)
        sweeps = np.asarray(raw["sweep"].values, dtype=np.int64)
        raw["raw"] = raw["raw"] + thermal_noise(RADAR, NOISE_SEED + k, sweeps)
        side.append(raw.assign_attrs(noise=1, noise_seed=NOISE_SEED + k))
    result = map_scene(side, scene, pfa=PFA, tau=TAU)
    scores, found = result.scores, result.detections
    scored = [r for r in scores["features"] if r["scored"]]
    assert [(r["kind"], r["shapes"], r["status"]) for r in scored if r["observable"]] == [
        ("dihedral", "floor|wall_y10", "found")]
    assert not any(r["kind"] == "trihedral" for r in scores["features"])
    assert scores["missed"] == [] and scores["feature_recall"] == 1.0
    edge = _record(scores, "dihedral", "floor|wall_y10")
    cell = float(result.resolution.extent.max())
    assert edge["error"] < 0.1 * cell
    cells = found["cell_position"].values[found["cell_detection"].values == edge["detection"]]
    off_line = np.hypot(cells[:, 1] - 10.0, cells[:, 2])
    assert np.all(off_line < cell)
    assert np.ptp(cells[:, 0]) > 1.5                    # along the edge, of 2 m of track
    p0 = map_scores(result.volume["position"].values.reshape(-1, 3), result.truth,
                    tau=TAU)["precision"]
    n = scores["map_points"]
    assert scores["precision"] > p0 + 5.0 * math.sqrt(p0 * (1.0 - p0) / n)
    pinned = {"precision": (0.922018, 0.010), "completeness": (0.165289, 0.002),
              "f_score": (0.280325, 0.004), "map_points": (218, 2),
              "localisation_error_max": (0.002518, 0.002)}
    for name, (value, tolerance) in pinned.items():
        assert scores[name] == pytest.approx(value, abs=tolerance), name
