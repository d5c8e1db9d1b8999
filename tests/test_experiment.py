"""TOML experiments: loading, defaults, strict validation naming the key, bundled examples."""

from __future__ import annotations

import copy
import json
import re
from pathlib import Path

import numpy as np
import pytest

from mitsar.errors import MitsarError, ParameterError
from mitsar.experiment.examples import example_path, examples_dir
from mitsar.experiment.loading import (
    experiment_from_dict,
    focus_options_from_config,
    load_experiment,
    load_grid,
)
from mitsar.experiment.options import Experiment
from mitsar.experiment.runs import run_simulation

BASE = {
    "trajectory": {"kind": "linear", "start": [14.9, 1.4, 4.5], "velocity": [0.5, 0.0, 0.0],
                   "duration": 0.4},
    "look": {"off_nadir_deg": 55.7},
    "targets": [{"position": [15.0, 8.0, 0.0]}],
}

TOML = """
name = "tiny"
[radar]
prf = 250.0
[trajectory]
kind = "linear"
start = [14.9, 1.4, 4.5]
velocity = [0.5, 0.0, 0.0]
duration = 0.4
[look]
off_nadir_deg = 55.7
[[targets]]
position = [15.0, 8.0, 0.0]
rcs = 2.0
[[targets]]
position = [15.1, 8.2, 0.0]
[background]
center = [15.0, 8.0, 0.0]
size = [0.4, 0.4]
[simulation]
seed = 7
[focus]
azimuth_resolution = 0.1
[focus.grid]
kind = "slant"
along_track = [0.0, 0.2, 0.01]
slant_range = [7.8, 8.2, 0.01]
[metrics]
islr_extent = "isce3"
"""


def _with(**changes) -> dict:
    """BASE with dotted-key changes, e.g. ``_with(**{"radar.prf": -1})``; None deletes."""
    data = copy.deepcopy(BASE)
    for dotted, value in changes.items():
        *parents, last = dotted.split(".")
        table = data
        for key in parents:
            table = table[int(key)] if isinstance(table, list) else table.setdefault(key, {})
        if value is None:
            table.pop(last, None)
        else:
            table[last] = value
    return data


def _error(data: dict) -> ParameterError:
    with pytest.raises(ParameterError) as info:
        experiment_from_dict(data, source="exp.toml")
    return info.value


def test_minimal_experiment_gets_defaults():
    exp = experiment_from_dict(BASE)
    assert isinstance(exp, Experiment)
    assert exp.radar.prf == 250.0 and exp.radar.carrier_frequency == 94e9
    assert exp.look.squint_deg == 0.0
    assert exp.targets[0].rcs == 1.0 and exp.background is None
    assert exp.simulation.seed == 0 and exp.simulation.rvp is True
    assert exp.focus.algorithm == "bpa" and exp.focus.grid is None
    assert exp.metrics.islr_extent == "paper"
    assert exp.metrics_target() == (15.0, 8.0, 0.0)
    assert exp.config["radar"]["bandwidth"] == 1.5e9  # effective values recorded


def test_load_file(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TOML)
    exp = load_experiment(path)
    assert exp.source == path.resolve() and exp.name == "tiny"
    assert [t.rcs for t in exp.targets] == [2.0, 1.0]
    assert exp.background.size == (0.4, 0.4) and exp.background.mode == "pulse"
    assert exp.simulation.seed == 7
    assert exp.focus.azimuth_resolution == 0.1
    assert exp.focus.grid["along_track"] == [0.0, 0.2, 0.01]
    assert exp.metrics.islr_extent == "isce3"


def test_config_round_trips(tmp_path):
    path = tmp_path / "tiny.toml"
    path.write_text(TOML)
    exp = load_experiment(path)
    again = experiment_from_dict(json.loads(json.dumps(exp.config)))
    assert again.config == exp.config
    assert again.radar == exp.radar and again.targets == exp.targets
    assert focus_options_from_config(json.dumps(exp.config)) == exp.focus


@pytest.mark.parametrize(("changes", "key", "pattern"), [
    ({"radar.prff": 250.0}, "radar.prff", r"keys of \[radar\]: .*\(did you mean 'prf'"),
    ({"radr": {}}, "radr", "keys of the top level.*did you mean 'radar'"),
    ({"look.squint": 3.0}, "look.squint", "did you mean 'squint_deg'"),
    ({"radar.prf": -250.0}, "radar.prf", r"a number \[Hz\] > 0"),
    ({"radar.prf": "250"}, "radar.prf", r"'250' \(string\)"),
    ({"radar.bandwidth": True}, "radar.bandwidth", r"True \(boolean\)"),
    ({"trajectory.start": [14.9, 1.4]}, "trajectory.start", r"an array of 3 numbers.*2 items"),
    ({"trajectory.velocity": "fast"}, "trajectory.velocity", "an array of 3 numbers"),
    ({"trajectory.duration": 0}, "trajectory.duration", "> 0"),
    ({"trajectory.duration": None}, "trajectory.duration", "required key"),
    ({"trajectory.kind": "spiral"}, "trajectory.kind", "one of 'linear', 'waypoints'"),
    ({"look.off_nadir_deg": 200.0}, "look.off_nadir_deg", "< 180"),
    ({"targets.0.rcs": 0.0}, "targets[0].rcs", "> 0"),
    ({"targets.0.position": [1, 2, "z"]}, "targets[0].position", "3 numbers"),
    ({"simulation.seed": 1.5}, "simulation.seed", r"an integer.*\(number\)"),
    ({"simulation.rvp": 1}, "simulation.rvp", "true or false"),
    ({"focus.algorithm": "fft"}, "focus.algorithm", "one of 'bpa'"),
    ({"focus.window": "blackman"}, "focus.window", "one of 'rect'"),
    ({"focus.grid": {"kind": "slant", "along_track": [0, 1, -0.1],
                     "slant_range": [7, 9, 0.1]}}, "focus.grid.along_track", "step > 0"),
    ({"focus.grid": {"kind": "plane", "origin": [0, 0, 0], "axis_u": [1, 0, 0],
                     "axis_v": [1, 1, 0], "u": [0, 1, 0.1], "v": [0, 1, 0.1]}},
     "focus.grid.axis_v", "orthogonal"),
    ({"metrics.islr_extent": "huge"}, "metrics.islr_extent", "'paper'"),
    ({"metrics.target": [1, 2]}, "metrics.target", "3 numbers"),
    ({"background": {"center": [15, 8, 0], "size": [1.0]}}, "background.size",
     "2 numbers"),
    ({"background": {"center": [15, 8, 0], "size": [1, 1], "mode": "static"}},
     "background.mode", "'pulse', 'frozen'"),
    ({"look": None}, "look", "required"),
])
def test_validation_names_key_expectation_and_value(changes, key, pattern):
    error = _error(_with(**changes))
    assert error.where == "exp.toml"
    assert error.name == key
    message = str(error)
    assert message.startswith(f"exp.toml: parameter '{key}': expected ")
    assert re.search(pattern, message), message
    assert isinstance(error, ValueError) and isinstance(error, MitsarError)


def test_radar_physics_error_is_prefixed():
    # beat frequency at max_range above Nyquist: raised by Radar itself
    error = _error(_with(**{"radar.max_range": 100.0}))
    assert error.name == "radar.max_range" and "Nyquist" in str(error)


def test_trajectory_error_is_prefixed():
    error = _error(_with(trajectory={"kind": "waypoints", "points": [[0, 0, 1], [0, 0, 1]],
                                     "speed": 1.0}))
    assert error.name == "trajectory.points" and "distinct" in str(error)


def test_background_axes_error_is_prefixed():
    error = _error(_with(background={"center": [15, 8, 0], "size": [1, 1],
                                     "axis_u": [2, 0, 0]}))
    assert error.name.startswith("background.axis_u")


def test_nothing_to_simulate():
    error = _error(_with(targets=None))
    assert error.name == "targets"


def test_waypoints_and_navigation(tmp_path):
    exp = experiment_from_dict(_with(trajectory={
        "kind": "waypoints", "points": [[14.9, 1.4, 4.5], [15.1, 1.4, 4.5]], "speed": 0.5}))
    assert exp.trajectory.kind == "waypoints" and exp.trajectory.duration == pytest.approx(0.4)
    exp = experiment_from_dict(_with(trajectory={
        "kind": "navigation", "times": [0.0, 0.2, 0.4],
        "positions": [[14.9, 1.4, 4.5], [15.0, 1.4, 4.5], [15.1, 1.4, 4.5]],
        "attitude_deg": [[0, 0, 0], [0, 0, 0], [0, 0, 0]]}))
    assert exp.trajectory.kind == "navigation"
    error = _error(_with(trajectory={"kind": "navigation", "times": [0.0, 0.2, 0.4],
                                     "positions": [[14.9, 1.4, 4.5], [15.0, 1.4, 4.5]]}))
    assert error.name == "trajectory.positions" and "3 rows" in str(error)


def test_navigation_csv_relative_to_file(tmp_path):
    (tmp_path / "nav").mkdir()
    (tmp_path / "nav" / "track.csv").write_text(
        "time,x,y,z,heading_deg,pitch_deg,roll_deg\n0.0,14.9,1.4,4.5,0,0,0\n"
        "0.2,15.0,1.4,4.5,0,0,1\n0.4,15.1,1.4,4.5,0,0,0\n")
    text = TOML.replace('kind = "linear"\nstart = [14.9, 1.4, 4.5]\nvelocity = [0.5, 0.0, 0.0]'
                        '\nduration = 0.4', 'kind = "navigation"\nfile = "nav/track.csv"')
    path = tmp_path / "exp.toml"
    path.write_text(text)
    exp = load_experiment(path)
    assert exp.trajectory.kind == "navigation" and exp.trajectory.attitude is not None
    assert exp.config["trajectory"]["file"] == str((tmp_path / "nav" / "track.csv").resolve())
    (tmp_path / "nav" / "track.csv").write_text("t,a\n1,2\n")
    with pytest.raises(ParameterError, match="trajectory.file.*time,x,y,z"):
        load_experiment(path)


def test_scene_resolved_against_the_file(tmp_path):
    (tmp_path / "scenes").mkdir()
    (tmp_path / "scenes" / "room.xml").write_text("<scene/>")
    path = tmp_path / "exp.toml"
    path.write_text('scene = "scenes/room.xml"\n' + TOML)
    assert load_experiment(path).scene == str((tmp_path / "scenes" / "room.xml").resolve())
    path.write_text('scene = "control_volume"\n' + TOML)
    assert load_experiment(path).scene == "control_volume"  # a canned scene name


def test_missing_and_malformed_files(tmp_path):
    with pytest.raises(MitsarError, match="no such file"):
        load_experiment(tmp_path / "missing.toml")
    bad = tmp_path / "bad.toml"
    bad.write_text("[radar\nprf = 1\n")
    with pytest.raises(MitsarError, match="not a valid TOML file"):
        load_experiment(bad)


def test_load_grid(tmp_path):
    path = tmp_path / "grid.toml"
    path.write_text('[grid]\nkind = "plane"\norigin = [14, 7, 0]\naxis_u = [1, 0, 0]\n'
                    'axis_v = [0, 1, 0]\nu = [0, 2, 0.05]\nv = [0, 2, 0.05]\n')
    assert load_grid(path)["kind"] == "plane"
    path.write_text('[grid]\nkind = "plane"\norigin = [14, 7]\n')
    with pytest.raises(ParameterError, match="'grid.origin'"):
        load_grid(path)


def test_bundled_paper_example():
    assert examples_dir().is_dir()
    exp = load_experiment(example_path("paper_point_target"))
    assert exp.targets[0].position == (15.0, 8.0, 0.0)
    assert exp.look.off_nadir_deg == pytest.approx(55.7, abs=0.05)
    assert exp.focus.azimuth_resolution == 0.10
    assert exp.background.cell_rcs_db == -20.0
    # the track passes the paper's P_0 = [14.8, 1.4, 4.5] at constant v = [0.5, 0, 0]
    t = (14.8 - exp.trajectory.positions[0][0]) / 0.5
    assert exp.trajectory.position(t) == pytest.approx([14.8, 1.4, 4.5])


def test_unknown_example():
    with pytest.raises(MitsarError, match="available: .*paper_point_target"):
        example_path("no_such_example")


def test_docs_examples_are_valid():
    """Every complete ```toml block in docs/experiments.md loads."""
    docs = Path(__file__).resolve().parent.parent / "docs" / "experiments.md"
    blocks = re.findall(r"```toml\n(.*?)```", docs.read_text(encoding="utf-8"), flags=re.S)
    complete = [b for b in blocks if "[trajectory]" in b and "[look]" in b]
    assert complete
    import tomllib
    for block in complete:
        experiment_from_dict(tomllib.loads(block), source="docs/experiments.md")


def test_tracer_options_reach_the_integrator(tmp_path):
    """``[simulation] visibility_feature`` and ``block_kernel`` (docs/experiments.md) are the
    tracer's: the raw product's integrator record holds them, and the lane kernels with a
    shadow ray per sweep give the block kernel's raw data of the canned point target to
    -90 dB (the block kernel's float32 advance, docs/integrator.md §"Performance")."""
    toml = ('scene = "point_target"\n' + TOML).replace("duration = 0.4", "duration = 0.1")
    path = tmp_path / "exp.toml"
    path.write_text(toml.replace("[simulation]\n", "[simulation]\nvisibility_feature = 0.0\n"
                                 "block_kernel = false\n"))
    lanes = run_simulation(load_experiment(path))
    record = json.loads(lanes.attrs["integrator"])
    assert record["visibility_feature"] == 0.0 and record["block_kernel"] is False
    path.write_text(toml)
    blocks = run_simulation(load_experiment(path))
    assert json.loads(blocks.attrs["integrator"])["block_kernel"] is True
    error = np.sum(np.abs(blocks["raw"].values - lanes["raw"].values) ** 2) / np.sum(
        np.abs(lanes["raw"].values) ** 2)
    assert 0 < error < 1e-9
    bad = toml.replace("[simulation]\n", "[simulation]\nvisibility_feature = -1.0\n")
    path.write_text(bad)
    with pytest.raises(ParameterError, match="visibility_feature"):
        load_experiment(path)
