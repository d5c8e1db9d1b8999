"""The ``mitsar`` command line end to end on a tiny experiment."""

from __future__ import annotations

import json
import subprocess
import sys

import pytest

from mitsar.cli import build_parser, demo_examples, main
from mitsar.experiment.examples import example_path
from mitsar.experiment.loading import apply_overrides
from mitsar.io import load
from mitsar.products.requests import CARRIED_ATTRS

# One point target seen over +-0.6 m of track (2.8 s), a small image around it: fast, and wide
# enough for the +-5-cell ISLR of the paper.
TINY = """
name = "tiny"
[trajectory]
kind = "linear"
start = [14.3, 1.4, 4.5]
velocity = [0.5, 0.0, 0.0]
duration = 2.8
[look]
off_nadir_deg = 55.71
[[targets]]
position = [15.0, 8.0, 0.0]
[simulation]
seed = 3
[focus]
azimuth_resolution = 0.10
[focus.grid]
kind = "slant"
along_track = [0.1, 1.3, 0.02]
slant_range = [7.39, 8.59, 0.02]
[metrics]
islr_extent = "paper"
"""

# Short track with a small background patch, for the demo's figures (metrics not checked).
TINY_BACKGROUND = TINY.replace("duration = 2.8", "duration = 0.4").replace(
    "start = [14.3, 1.4, 4.5]", "start = [14.9, 1.4, 4.5]").replace(
    "along_track = [0.1, 1.3, 0.02]", "along_track = [-0.5, 0.7, 0.02]").replace(
    'islr_extent = "paper"', 'islr_extent = "chip"') + """
[background]
center = [15.0, 8.0, 0.0]
size = [0.3, 0.3]
cell_rcs_db = -20.0
"""


@pytest.fixture(scope="module")
def products(tmp_path_factory):
    """simulate -> focus on the tiny experiment, once for the module."""
    folder = tmp_path_factory.mktemp("cli")
    experiment = folder / "tiny.toml"
    experiment.write_text(TINY)
    raw, image = folder / "raw.nc", folder / "image.nc"
    assert main(["simulate", str(experiment), "-o", str(raw), "-q"]) == 0
    assert main(["focus", str(raw), "-o", str(image), "-q"]) == 0
    return {"folder": folder, "experiment": experiment, "raw": raw, "image": image}


def test_simulate_writes_a_raw_product(products):
    raw = load(products["raw"])
    assert raw.attrs["product"] == "raw" and raw["raw"].dtype.kind == "c"
    assert raw.sizes["sweep"] == 700
    assert json.loads(raw.attrs["experiment"])["name"] == "tiny"
    assert raw.attrs["experiment_source"] == str(products["experiment"].resolve())


def test_focus_uses_the_experiment_focus_table(products):
    image = load(products["image"])
    assert image.attrs["product"] == "image" and image.attrs["algorithm"] == "bpa"
    assert image.sizes["azimuth"] == 61 and image.sizes["range"] == 61
    assert image.attrs["azimuth_resolution"] == pytest.approx(0.10, rel=0.01)
    assert "experiment" in image.attrs


def test_metrics_json(products, capsys):
    out = products["folder"] / "metrics.json"
    assert main(["metrics", str(products["image"]), "--json", "-o", str(out), "-q"]) == 0
    printed = json.loads(capsys.readouterr().out)
    assert json.loads(out.read_text()) == printed
    assert printed["target"] == [15.0, 8.0, 0.0]
    assert printed["peak_offset_m"] < 0.02
    for name in ("range", "azimuth"):  # unweighted sinc: 0.8859 cells, -13.26 dB
        assert printed[name]["irw_cells"] == pytest.approx(0.8859, abs=0.05)
        assert printed[name]["pslr_db"] < -11.0
    assert printed["range"]["pslr_db"] == pytest.approx(-13.26, abs=0.5)


def test_metrics_table_with_explicit_target(products, capsys):
    assert main(["metrics", str(products["image"]), "--target", "15", "8", "0",
                 "--islr-extent", "5"]) == 0
    text = capsys.readouterr().out
    assert "IRW [m]" in text and "range" in text and "azimuth" in text


def test_plot_raw_and_image(products):
    for source in ("raw", "image"):
        figure = products["folder"] / f"{source}.png"
        assert main(["plot", str(products[source]), "-o", str(figure), "-q"]) == 0
        assert figure.read_bytes()[:8] == b"\x89PNG\r\n\x1a\n"


def test_range_command(products):
    out = products["folder"] / "profile.nc"
    assert main(["range", str(products["raw"]), "-o", str(out), "-q"]) == 0
    assert "profile" in load(out)


def test_focus_overrides_and_grid_file(products):
    grid = products["folder"] / "grid.toml"
    grid.write_text('[grid]\nkind = "slant"\nalong_track = [0.5, 0.9, 0.02]\n'
                    'slant_range = [7.8, 8.2, 0.02]\n')
    out = products["folder"] / "image_hamming.nc"
    assert main(["focus", str(products["raw"]), "-o", str(out), "--window", "hamming",
                 "--azimuth-resolution", "0.2", "--grid", str(grid), "-q"]) == 0
    image = load(out)
    assert image.attrs["window"] == "hamming"
    assert image.sizes["azimuth"] == 21
    assert image.attrs["azimuth_resolution"] == pytest.approx(0.2, rel=0.01)


def test_no_overwrite_without_flag(products, capsys):
    before = products["image"].stat().st_mtime_ns
    code = main(["focus", str(products["raw"]), "-o", str(products["image"]), "-q"])
    assert code == 2
    err = capsys.readouterr().err
    assert "file exists" in err and "--overwrite" in err and "Traceback" not in err
    assert products["image"].stat().st_mtime_ns == before


def test_bad_experiment_exit_code_2(tmp_path, capsys):
    bad = tmp_path / "bad.toml"
    bad.write_text(TINY.replace("[look]", "[look]\nsquint = 3.0"))
    assert main(["simulate", str(bad), "-o", str(tmp_path / "raw.nc")]) == 2
    err = capsys.readouterr().err
    assert "parameter 'look.squint'" in err and "did you mean 'squint_deg'" in err
    assert not (tmp_path / "raw.nc").exists()


def test_wrong_product_type(products, capsys):
    assert main(["focus", str(products["image"]), "-o", str(products["folder"] / "x.nc")]) == 2
    assert "expected a product of type 'raw'" in capsys.readouterr().err


def test_not_a_product_file(tmp_path, capsys):
    junk = tmp_path / "junk.nc"
    junk.write_text("hello")
    assert main(["metrics", str(junk), "--target", "0", "0", "0"]) == 2
    err = capsys.readouterr().err
    assert "not a readable netCDF4/HDF5" in err and "Traceback" not in err


def test_debug_shows_the_traceback(tmp_path):
    with pytest.raises(Exception, match="no such file"):
        main(["focus", str(tmp_path / "missing.nc"), "-o", str(tmp_path / "x.nc"), "--debug"])


@pytest.mark.parametrize("module", ["mitsar.cli", "mitsar"])
def test_entry_point_subprocess(tmp_path, module):
    """The installed ways: python -m mitsar(.cli), a bad file, exit status 2, one clean line."""
    result = subprocess.run(
        [sys.executable, "-m", module, "plot", str(tmp_path / "missing.nc"), "-o",
         str(tmp_path / "fig.png")], capture_output=True, text=True, timeout=120)
    assert result.returncode == 2
    assert "no such file" in result.stderr and "Traceback" not in result.stderr


def test_demo_on_a_tiny_example(tmp_path, monkeypatch, capsys):
    examples = tmp_path / "examples"
    examples.mkdir()
    (examples / "tiny_background.toml").write_text(TINY_BACKGROUND)
    monkeypatch.setenv("MITSAR_EXAMPLES", str(examples))
    out = tmp_path / "demo"
    assert main(["demo", "-o", str(out), "--example", "tiny_background", "-q"]) == 0
    summary = capsys.readouterr().out
    assert "IRW" in summary and "paper Table 4" in summary
    names = sorted(p.name for p in out.iterdir())
    assert names == sorted(["raw.nc", "image.nc", "metrics.json", "range_compressed.png",
                            "image.png", "cuts.png", "background_histograms.png"])
    # a second run refuses to overwrite, before simulating anything
    assert main(["demo", "-o", str(out), "--example", "tiny_background", "-q"]) == 2
    assert "--overwrite" in capsys.readouterr().err


def test_metrics_needs_a_target(products, tmp_path, capsys):
    image = load(products["image"])
    for key in CARRIED_ATTRS:  # the experiment's record and requests (its target)
        image.attrs.pop(key, None)
    from mitsar.io import save

    bare = save(image, tmp_path / "bare.nc")
    assert main(["metrics", str(bare)]) == 2
    assert "no target position" in capsys.readouterr().err
    assert main(["metrics", str(bare), "--target", "15", "8", "0", "-q"]) == 0


def test_seed_override(products, tmp_path):
    out = tmp_path / "raw.nc"
    assert main(["simulate", str(products["experiment"]), "-o", str(out), "--seed", "5",
                 "-q"]) == 0
    raw = load(out)
    assert raw.attrs["seed"] == 5
    assert json.loads(raw.attrs["experiment"])["simulation"]["seed"] == 5


def test_scene_experiment_traces_and_focuses(tmp_path, capsys):
    """An experiment whose scene is a canned Mitsuba XML runs through the ray tracer.

    The traced point target (canned scene 'point_target', sphere centre [15, 8, 0.03]) focuses
    within 1 cm of its centre, with the unweighted range IRW of 0.886 cells (±0.01, as the
    analytic chain).
    """
    experiment = tmp_path / "scene.toml"
    experiment.write_text('scene = "point_target"\n' + TINY.split("[[targets]]")[0]
                          .replace('name = "tiny"', 'name = "tiny-scene"')
                          + TINY.split('position = [15.0, 8.0, 0.0]')[1]
                          .replace("[metrics]", "[metrics]\ntarget = [15.0, 8.0, 0.03]"))
    raw, image = tmp_path / "raw.nc", tmp_path / "image.nc"
    assert main(["simulate", str(experiment), "-o", str(raw), "-q"]) == 0
    assert load(raw).attrs["point_target_count"] == 1
    assert main(["focus", str(raw), "-o", str(image), "-q"]) == 0
    capsys.readouterr()
    assert main(["metrics", str(image), "--json"]) == 0
    metrics = json.loads(capsys.readouterr().out)
    assert metrics["peak_offset_m"] < 0.01
    assert metrics["range"]["irw_cells"] == pytest.approx(0.886, abs=0.01)


def test_ambiguity_command_compares_trajectories(tmp_path, capsys):
    """``mitsar ambiguity`` on the bundled two-trajectory example writes its products."""
    from mitsar.experiment.examples import example_path

    assert main(["ambiguity", str(example_path("ambiguity_box_obstacle")), "-o",
                 str(tmp_path), "--no-figures", "-q"]) == 0
    table = capsys.readouterr().out
    assert "| floor |" in table
    assert (tmp_path / "comparison.nc").exists() and (tmp_path / "summary.json").exists()
    summary = json.loads((tmp_path / "summary.json").read_text())
    assert summary["files"]


def test_montecarlo_command_resumes_and_plots(tmp_path, capsys):
    """``mitsar montecarlo`` writes the table, resumes a finished run, and plots the cuts."""
    experiment = tmp_path / "tiny_background.toml"
    experiment.write_text(TINY_BACKGROUND)
    out = tmp_path / "mc"
    arguments = ["montecarlo", str(experiment), "-o", str(out), "-n", "2", "-a", "bpa", "-q",
                 "--scheduler", "inline"]  # in this process: no Dask cluster to start
    assert main(arguments + ["--cuts", "1"]) == 0
    assert "(2 realisations, seeds 3..4)" in capsys.readouterr().out
    assert (out / "summary.nc").exists() and (out / "cuts_bpa.png").stat().st_size > 0
    record = (out / "montecarlo.json").read_text()
    assert main(arguments + ["--cuts", "0"]) == 0  # resumed: nothing new to compute
    assert (out / "montecarlo.json").read_text() == record


def test_rays_command_on_the_paper_2d_case(tmp_path, capsys):
    """``mitsar rays`` traces the paper's 2D case 2 and writes the ray and echo figures."""
    from mitsar.experiment.examples import example_path

    assert main(["rays", str(example_path("case2_2d")), "-o", str(tmp_path), "-q"]) == 0
    assert "captured reflected rays" in capsys.readouterr().out
    for name in ("echoes.png", "rays_2d.png", "summary.json"):
        assert (tmp_path / name).stat().st_size > 0
    assert main(["rays", str(example_path("case2_2d")), "-o", str(tmp_path), "-q"]) == 2


def test_set_overrides_experiment_keys(tmp_path):
    """--set changes any key before validation; the record holds the effective value, and a
    key that does not exist is refused by name."""
    document = {"background": {"cell_rcs_db": -20.0}, "targets": [{"rcs": 1.0}]}
    apply_overrides(document, ["background.cell_rcs_db=-10", "targets.0.rcs=2.5",
                               "focus.algorithm=wda", "focus.window=\"hamming\""])
    assert document == {"background": {"cell_rcs_db": -10}, "targets": [{"rcs": 2.5}],
                        "focus": {"algorithm": "wda", "window": "hamming"}}
    out = tmp_path / "raw.nc"
    assert main(["simulate", str(example_path("paper_point_target")), "-o", str(out), "-q",
                 "--set", "trajectory.duration=0.2", "--set", "simulation.seed=9"]) == 0
    raw = load(out)
    assert raw.sizes["sweep"] == 50
    assert json.loads(raw.attrs["experiment"])["simulation"]["seed"] == 9
    assert main(["simulate", str(example_path("paper_point_target")), "-o",
                 str(tmp_path / "x.nc"), "-q", "--set", "trajectory.bogus=1"]) == 2
    assert main(["simulate", str(example_path("paper_point_target")), "-o",
                 str(tmp_path / "x.nc"), "-q", "--set", "noequals"]) == 2


def test_global_options_before_or_after_the_command_and_defaults_in_help(capsys):
    parser = build_parser()
    for argv in (["-q", "focus", "a.nc", "-o", "b.nc"], ["focus", "a.nc", "-o", "b.nc", "-q"]):
        assert parser.parse_args(argv).quiet is True
    assert parser.parse_args(["focus", "a.nc", "-o", "b.nc"]).quiet is False
    assert parser.parse_args(["--debug", "metrics", "i.nc"]).debug is True
    with pytest.raises(SystemExit):
        parser.parse_args(["montecarlo", "--help"])
    assert "(default: 10)" in capsys.readouterr().out
    # The demo offers only bundled experiments with a target to measure.
    assert "paper_point_target" in demo_examples()
    assert not {"ambiguity_control_volume", "dihedral_3d"} & set(demo_examples())


@pytest.mark.parametrize("command", [["montecarlo"], ["sweep", "--vary", "seed=1,2"]])
def test_overwrite_on_a_resuming_command_says_what_to_do(command, tmp_path, capsys):
    """``--overwrite`` is refused by the commands that resume their folder, naming the option,
    what they do instead and what to pass (not argparse's "unrecognized arguments")."""
    with pytest.raises(SystemExit) as stop:
        main([command[0], "experiment.toml", "-o", str(tmp_path), *command[1:], "--overwrite"])
    assert stop.value.code == 2
    error = capsys.readouterr().err
    assert "--overwrite does not apply" in error and "--restart" in error
    assert "unrecognized" not in error
