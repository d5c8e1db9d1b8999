"""Several acquisitions in one experiment (``[[passes]]``, issue 23): parsing and inheritance,
errors naming ``passes[i].key``, one raw product per pass on its own track (closed-form heights
of the vertical stack), seeds derived and recorded (same numbers twice, independent noise per
pass, one scene for all), the scene of traced passes loaded and its scatterers drawn once, and
the bundled examples through ``mitsar simulate`` and ``mitsar run``."""

from __future__ import annotations

import copy
import json

import numpy as np
import pytest

import mitsar.experiment.runs as runs
import mitsar.raw.trace_run as trace_run
from mitsar.cli import demo_examples, main
from mitsar.errors import ParameterError
from mitsar.experiment import example_path, experiment_from_dict, load_experiment
from mitsar.experiment.loading import read_toml
from mitsar.experiment.options import pass_seed
from mitsar.experiment.runs import pass_path, run_simulation, simulate_passes
from mitsar.model.noise import thermal_noise
from mitsar.report.html import RUN_RECORD

BASE = {
    "name": "passes",
    "trajectory": {"kind": "linear", "start": [14.9, 1.4, 4.5], "velocity": [0.5, 0.0, 0.0],
                   "duration": 0.4},
    "look": {"off_nadir_deg": 55.71},
    "targets": [{"position": [15.0, 8.0, 0.0]}],
    "simulation": {"seed": 7},
}


def _experiment(passes, **changes):
    document = copy.deepcopy(BASE)
    document["passes"] = passes
    document.update(changes)
    return experiment_from_dict(document, source="passes.toml")


def _refused(passes, key, expected, **changes):
    with pytest.raises(ParameterError) as caught:
        _experiment(passes, **changes)
    assert caught.value.name == key
    assert expected in str(caught.value)
    return caught.value


# --------------------------------------------------------------------------------------------
# parsing
# --------------------------------------------------------------------------------------------

def test_passes_inherit_the_experiment_key_by_key():
    exp = _experiment([
        {},
        {"name": "higher", "offset": [0.0, 0.0, 0.1], "seed": 5},
        {"trajectory": {"start": [14.9, 1.0, 4.5], "duration": 0.8},
         "look": {"squint_deg": 2.0}},
        {"trajectory": {"kind": "waypoints", "points": [[14.9, 1.4, 4.6], [15.1, 1.4, 4.6]],
                        "speed": 0.25}, "offset": [0.0, 0.1, 0.0]},
    ])
    first, higher, moved, waypoints = exp.passes
    assert [p.index for p in exp.passes] == [0, 1, 2, 3]
    assert first.name == "pass0" and higher.name == "higher"
    np.testing.assert_allclose(first.trajectory.position(0.0), [14.9, 1.4, 4.5])
    np.testing.assert_allclose(higher.trajectory.position(0.2), [15.0, 1.4, 4.6], atol=1e-12)
    assert higher.trajectory.duration == pytest.approx(0.4)        # inherited
    np.testing.assert_allclose(moved.trajectory.position(0.0), [14.9, 1.0, 4.5])
    np.testing.assert_allclose(moved.trajectory.velocity(0.0), [0.5, 0.0, 0.0])
    assert moved.trajectory.duration == pytest.approx(0.8)
    assert (moved.look.off_nadir_deg, moved.look.squint_deg) == (55.71, 2.0)
    assert (first.look.off_nadir_deg, first.look.squint_deg) == (55.71, 0.0)
    assert waypoints.trajectory.duration == pytest.approx(0.8)     # its own kind, no inheritance
    np.testing.assert_allclose(waypoints.trajectory.position(0.0), [14.9, 1.5, 4.6])
    assert exp.config["passes"][3]["trajectory"]["points"][0] == [14.9, 1.4, 4.6]  # pre-offset
    # tools that fly one track fly pass 0
    assert exp.trajectory is first.trajectory and exp.look is first.look
    # seeds: the pass's own, else the documented rule on [simulation] seed
    assert higher.seed == 5 and exp.pass_seed(1) == 5
    expected = np.random.SeedSequence(7, spawn_key=(2,)).generate_state(1, np.uint64)[0] >> 1
    assert exp.pass_seed(2) == pass_seed(7, 2) == int(expected)
    assert len({exp.pass_seed(i) for i in range(4)}) == 4
    # the effective configuration records every pass and loads back to the same passes
    assert [p["name"] for p in exp.config["passes"]] == ["pass0", "higher", "pass2", "pass3"]
    again = experiment_from_dict(json.loads(json.dumps(exp.config)))
    for one, other in zip(exp.passes, again.passes, strict=True):
        np.testing.assert_array_equal(one.trajectory.position([0.0, 0.3]),
                                      other.trajectory.position([0.0, 0.3]))
        assert (one.look, one.seed, one.offset) == (other.look, other.seed, other.offset)


def test_navigation_errors_per_pass():
    errors = {"seed": 3, "position_noise": [0.001, 0.001, 0.001]}
    exp = _experiment([{}, {"trajectory": {"errors": {"position_offset": [0.01, 0, 0]}}},
                       {"trajectory": {"errors": {"seed": 11}}}],
                      trajectory=dict(BASE["trajectory"], errors=errors))
    first, second, third = (p.navigation for p in exp.passes)
    assert first.seed == pass_seed(3, 0) and second.seed == pass_seed(3, 1)   # derived
    assert third.seed == 11                                                   # given
    assert second.position_offset == (0.01, 0.0, 0.0)
    assert second.position_noise == first.position_noise == (0.001, 0.001, 0.001)
    assert exp.config["passes"][1]["trajectory"]["errors"]["seed"] == pass_seed(3, 1)
    none = _experiment([{}, {}])
    assert all(p.navigation is None for p in none.passes)


def test_passes_need_no_top_level_track_when_each_has_one():
    document = copy.deepcopy(BASE)
    track, look = document.pop("trajectory"), document.pop("look")
    document["passes"] = [{"trajectory": track, "look": look},
                          {"trajectory": dict(track, start=[14.9, 1.2, 4.5]), "look": look}]
    exp = experiment_from_dict(document)
    assert "trajectory" not in exp.config and len(exp.passes) == 2
    np.testing.assert_allclose(exp.trajectory.position(0.0), [14.9, 1.4, 4.5])
    document["passes"][1].pop("look")
    with pytest.raises(ParameterError) as caught:
        experiment_from_dict(document)
    assert caught.value.name == "passes[1].look"


def test_bad_passes_are_refused_by_key():
    _refused([{}, {"ofset": [0, 0, 1]}], "passes[1].ofset", "did you mean 'offset'")
    _refused([{"offset": [0, 1]}], "passes[0].offset", "an array of 3 numbers [m]")
    _refused([{}, {"trajectory": {"duration": -1.0}}], "passes[1].trajectory.duration", "> 0")
    _refused([{"trajectory": {"velocty": [1, 0, 0]}}], "passes[0].trajectory.velocty",
             "did you mean 'velocity'")
    _refused([{"look": {"off_nadir_deg": 200}}], "passes[0].look.off_nadir_deg", "< 180")
    _refused([{"seed": -1}], "passes[0].seed", "an integer >= 0")
    _refused([{"seed": 2**63}], "passes[0].seed", "recorded as 64 bits")
    _refused([{"errors": {"seed": 1}}], "passes[0].errors", "[passes.trajectory.errors]")
    _refused([{"navigation": {}}], "passes[0].navigation", "[passes.trajectory.errors]")
    _refused([{"trajectory": {"errors": {"position_nois": [0, 0, 0]}}}],
             "passes[0].trajectory.errors.position_nois", "did you mean 'position_noise'")
    _refused([{"trajectory": 3}], "passes[0].trajectory", "a table")
    _refused([{"trajectory": {"kind": "waypoints", "speed": 1.0}}], "passes[0].trajectory.points",
             "required key")                        # a new kind inherits none of the old keys
    _refused({"offset": [0, 0, 1]}, "passes", "an array of tables")
    with pytest.raises(ParameterError) as caught:
        experiment_from_dict({key: value for key, value in BASE.items() if key != "trajectory"}
                             | {"passes": [{}]})
    assert caught.value.name == "passes[0].trajectory"
    assert "no [trajectory] to inherit" in str(caught.value)


# --------------------------------------------------------------------------------------------
# simulation
# --------------------------------------------------------------------------------------------

def test_vertical_stack_raw_products_fly_their_heights():
    """Closed form: pass i of the bundled vertical stack flies the top-level track (x = 14.7 +
    0.5 t m at mid-sweep) raised by 0.05 i m, every sweep; x and y are pass 0's."""
    exp = load_experiment(example_path("vertical_stack_passes"))
    raws = simulate_passes(exp)
    assert len(raws) == 4
    reference = raws[0]["platform_position"].values
    mid_sweep = raws[0]["slow_time"].values + 0.5 / exp.radar.prf   # states at mid-sweep
    np.testing.assert_allclose(reference[:, 0], 14.7 + 0.5 * mid_sweep, atol=1e-12)
    for index, raw in enumerate(raws):
        assert (raw.attrs["pass"], raw.attrs["pass_count"]) == (index, 4)
        positions = raw["platform_position"].values
        np.testing.assert_allclose(positions[:, 2], 4.5 + 0.05 * index, atol=1e-12)
        np.testing.assert_array_equal(positions[:, :2], reference[:, :2])
        assert raw.attrs["seed"] == 2016 and raw.attrs["noise"] == 0
        assert raw.attrs["pass_seed"] == pass_seed(2016, index)
    # the farther passes see the target at a longer range: different echoes
    assert not np.allclose(raws[0]["raw"].values, raws[3]["raw"].values)
    # run_simulation of a multi-pass experiment is its pass 0
    np.testing.assert_array_equal(run_simulation(exp)["raw"].values, raws[0]["raw"].values)


def test_pass_seeds_recorded_reproducible_and_noise_independent():
    """The lawn-mower: every pass has its own noise seed (the rule), its noise is exactly
    thermal_noise of that seed, the same numbers twice, and two passes' noises uncorrelated."""
    exp = load_experiment(example_path("lawnmower_passes"))
    quiet = load_experiment(example_path("lawnmower_passes"), ["simulation.noise=false"])
    raws, again, clean = simulate_passes(exp), simulate_passes(exp), simulate_passes(quiet)
    noises = []
    for index, (raw, other, noiseless) in enumerate(zip(raws, again, clean, strict=True)):
        seed = pass_seed(23, index)
        assert raw.attrs["pass_seed"] == raw.attrs["noise_seed"] == seed
        assert raw.attrs["seed"] == 23 and raw.attrs["noise"] == 1
        assert raw.attrs["pass_name"] == f"leg {index}"
        assert "SeedSequence" in raw.attrs["pass_seed_rule"]
        np.testing.assert_array_equal(raw["raw"].values, other["raw"].values)
        noise = raw["raw"].values - noiseless["raw"].values
        np.testing.assert_allclose(noise, thermal_noise(exp.radar, seed, raw["sweep"].values),
                                   rtol=0, atol=1e-12 * np.abs(noise).max())
        noises.append(noise.ravel())
    correlation = abs(np.vdot(noises[0], noises[1])) / (np.linalg.norm(noises[0])
                                                        * np.linalg.norm(noises[1]))
    assert correlation < 5.0 / np.sqrt(noises[0].size)     # independent streams
    # a new experiment seed gives new pass seeds, as the rule says
    other = load_experiment(example_path("lawnmower_passes"), ["simulation.seed=24"])
    assert other.pass_seed(1) == pass_seed(24, 1) != exp.pass_seed(1)


def test_traced_passes_load_the_scene_and_draw_its_scatterers_once(monkeypatch):
    document = read_toml(example_path("dihedral_3d"))
    document["trajectory"].update(start=[0.9, 8.0, 1.0], duration=0.2)
    document["simulation"].update(max_depth=1)
    document["passes"] = [{}, {"offset": [0.0, 0.0, 0.05]}, {"offset": [0.0, -0.1, 0.0]}]
    exp = experiment_from_dict(document, base=example_path("dihedral_3d").parent)
    loads, draws = [], []
    load_scene, collect = runs.load_scene, trace_run.collect_scatterers

    def counted_load(scene, **params):
        if isinstance(scene, str):
            loads.append(scene)
        return load_scene(scene, **params)

    def counted_collect(*args, **kwargs):
        draws.append(args[1:])
        return collect(*args, **kwargs)

    monkeypatch.setattr(runs, "load_scene", counted_load)
    monkeypatch.setattr(trace_run, "load_scene", counted_load)
    monkeypatch.setattr(trace_run, "collect_scatterers", counted_collect)
    monkeypatch.setattr(trace_run, "_SCATTERER_SETS", {})
    raws = simulate_passes(exp)
    assert loads == ["dihedral"] and len(draws) == 1
    assert len({raw.attrs["scatterer_count"] for raw in raws}) == 1
    assert all(raw.attrs["scene"] == "dihedral" for raw in raws)
    assert [raw.attrs["pass"] for raw in raws] == [0, 1, 2]
    heights = [float(raw["platform_position"].values[0, 2]) for raw in raws]
    np.testing.assert_allclose(heights, [1.0, 1.05, 1.0], atol=1e-12)
    assert all(np.abs(raw["raw"].values).max() > 0 for raw in raws)


# --------------------------------------------------------------------------------------------
# command line and bundled examples
# --------------------------------------------------------------------------------------------

def test_simulate_writes_one_file_per_pass_and_never_overwrites(tmp_path):
    out = tmp_path / "raw.nc"
    path = str(example_path("vertical_stack_passes"))
    assert main(["simulate", path, "-o", str(out), "-q"]) == 0
    written = sorted(p.name for p in tmp_path.iterdir())
    assert written == [f"raw_pass{i}.nc" for i in range(4)]
    assert pass_path(out, 2) == tmp_path / "raw_pass2.nc"
    assert main(["simulate", path, "-o", str(out), "-q"]) == 2          # exists: refused
    assert main(["simulate", path, "-o", str(out), "-q", "--overwrite"]) == 0


@pytest.mark.parametrize("name", ["lawnmower_passes", "vertical_stack_passes"])
def test_bundled_pass_examples_run(name, tmp_path):
    exp = load_experiment(example_path(name))
    out = tmp_path / name
    assert main(["run", str(example_path(name)), "-o", str(out), "-q"]) == 0
    record = json.loads((out / RUN_RECORD).read_text())
    count = len(exp.passes)
    assert [entry["raw"] for entry in record["passes"]] == [f"raw_pass{i}.nc"
                                                           for i in range(count)]
    assert {f"raw_pass{i}.nc" for i in range(count)} <= set(record["products"])
    assert {f"image_bpa_pass{i}.nc" for i in range(count)} <= set(record["products"])
    assert record["provenance"]["seeds"]["passes"] == [exp.pass_seed(i) for i in range(count)]
    assert not record["warnings"]
    for index in range(count):
        metrics = record["metrics"][f"bpa pass{index}"]
        assert metrics["peak_offset_m"] < 0.01                  # on the common floor grid
        assert metrics["range"]["irw_m"] == pytest.approx(0.107, abs=0.01)
    # all passes combined coherently on the same grid (mitsar.focus of the list)
    assert "image_bpa_passes.nc" in record["products"]
    assert record["metrics"]["bpa passes"]["peak_offset_m"] < 0.01
    assert main(["run", str(example_path(name)), "-o", str(out), "-q"]) == 2   # no overwrite
    assert name not in demo_examples()     # the demo runs one acquisition



def test_mapping_table_is_validated_at_load():
    """``[mapping]`` (issue 23): defaults, bounds refused by key, and a scene required (the map
    is scored against the scene's own ground truth)."""
    from mitsar.experiment.examples import example_path
    from mitsar.experiment.loading import experiment_from_dict, read_toml

    document = read_toml(example_path("mapping_trihedral_passes"))
    experiment = experiment_from_dict(document)
    assert experiment.mapping.pfa == 1e-6 and experiment.mapping.method == "ca"
    for key, value in (("pfa", 1.5), ("method", "median"), ("tau", -0.1),
                       ("elevation_window", "boxcar"), ("threshold", 3)):
        bad = {**document, "mapping": {**document["mapping"], key: value}}
        with pytest.raises(ParameterError, match=f"mapping.{key}"):
            experiment_from_dict(bad)
    no_scene = {key: value for key, value in document.items() if key != "scene"}
    no_scene["targets"] = [{"position": [0.0, 10.0, 0.0]}]
    with pytest.raises(ParameterError, match="scene"):
        experiment_from_dict(no_scene)
