"""Interferometry from the command line, the experiment file and the report (issue 22 item 5):
``mitsar interferogram`` writes its files and refuses to overwrite them; ``[interferometry]`` is
validated strictly; ``mitsar run`` on the bundled interferometric example writes the
interferogram, whose height at the target's pixel is the target's true height (15 cm, closed
form) within 3 mm, and a report whose interferometry section renders in headless Chromium."""

from __future__ import annotations

import copy
import json
import re
import shutil
import subprocess

import numpy as np
import plyfile
import pytest

from mitsar.cli import main
from mitsar.errors import ParameterError
from mitsar.experiment import load_experiment, run_focus, run_simulation
from mitsar.experiment.examples import example_path
from mitsar.experiment.interferometry import INTERFEROMETRY_FILES
from mitsar.experiment.loading import experiment_from_dict, read_toml
from mitsar.io import load, save
from mitsar.report.html import RUN_RECORD
from mitsar.report.run import run_experiment

BROWSER = shutil.which("chromium-headless-shell") or shutil.which("chromium")
EXAMPLE = "interferometer_point_target"
TARGET = np.array([15.0, 8.0, 0.15])


@pytest.fixture(scope="module")
def image_file(tmp_path_factory):
    """A small two-channel BPA image of the bundled example (a 41 x 41 floor grid)."""
    folder = tmp_path_factory.mktemp("ifg")
    experiment = load_experiment(example_path(EXAMPLE), [
        "focus.grid.origin=[14.8, 7.7, 0.0]", "focus.grid.u=[0.0, 0.4, 0.01]",
        "focus.grid.v=[0.0, 0.4, 0.01]"])
    raw = run_simulation(experiment)
    image = run_focus(raw, experiment.focus)
    path = folder / "image.nc"
    save(image, path)
    return path


def test_interferogram_command_writes_its_files_and_refuses_to_overwrite(image_file, tmp_path,
                                                                         capsys):
    out = tmp_path / "out"
    assert main(["interferogram", str(image_file), "-o", str(out), "-q", "--looks", "1", "1",
                 "--pair", "0", "1", "--no-unwrap", "--min-coherence", "0.3"]) == 0
    printed = capsys.readouterr().out
    assert sorted(p.name for p in out.iterdir()) == sorted(INTERFEROMETRY_FILES.values())
    assert "pair 0-1" in printed and "ambiguity height 0.50" in printed
    assert "points with coherence" in printed and "snaphu" not in printed
    ifg = load(out / "interferogram.nc", product="interferogram")
    assert set(ifg["height"].dims) == {"v", "u"}
    vertex = plyfile.PlyData.read(str(out / "points.ply"))["vertex"]
    assert vertex.count == ifg.sizes["u"] * ifg.sizes["v"]  # one look: coherence 1 everywhere
    stamp = (out / "interferogram.nc").stat().st_mtime_ns
    assert main(["interferogram", str(image_file), "-o", str(out), "-q"]) == 2
    assert "exists" in capsys.readouterr().err
    assert (out / "interferogram.nc").stat().st_mtime_ns == stamp
    assert main(["interferogram", str(image_file), "-o", str(out), "-q", "--looks", "3", "3",
                 "--overwrite"]) == 0
    assert load(out / "interferogram.nc").attrs["looks_azimuth"] == 3


def test_interferogram_command_errors(image_file, tmp_path, capsys):
    single = tmp_path / "single.nc"
    save(load(image_file).isel(channel=0), single)
    assert main(["interferogram", str(single), "-o", str(tmp_path / "a"), "-q"]) == 2
    err = capsys.readouterr().err
    assert "'channel'" in err and "receivers" in err
    for flags, name in ((["--pair", "0", "2"], "--pair"), (["--looks", "0", "1"], "--looks"),
                        (["--min-coherence", "1.5"], "--min-coherence")):
        assert main(["interferogram", str(image_file), "-o", str(tmp_path / "b"), "-q",
                     *flags]) == 2
        assert f"'{name}'" in capsys.readouterr().err
    assert not (tmp_path / "b").exists() or not any((tmp_path / "b").iterdir())


def test_interferometry_table_is_validated():
    document = read_toml(example_path(EXAMPLE))
    experiment = experiment_from_dict(document)
    assert experiment.interferometry.looks == (1, 1) and not experiment.interferometry.unwrap
    assert experiment_from_dict(experiment.config).interferometry == experiment.interferometry
    for table, key in (({"pair": [0, 2]}, "interferometry.pair"),
                       ({"looks": [1.5, 1]}, "interferometry.looks"),
                       ({"unwrap": 1}, "interferometry.unwrap"),
                       ({"min_coherence": -0.1}, "interferometry.min_coherence"),
                       ({"nope": 1}, "interferometry.nope")):
        bad = copy.deepcopy(document)
        bad["interferometry"] = table
        with pytest.raises(ParameterError, match=re.escape(key)):
            experiment_from_dict(bad)
    single = copy.deepcopy(document)
    del single["radar"]["receivers"]
    with pytest.raises(ParameterError, match="receivers"):
        experiment_from_dict(single)


def _rendered(report):
    dom = subprocess.run([BROWSER, "--headless", "--no-sandbox", "--disable-gpu",
                          "--dump-dom", report.resolve().as_uri()],
                         capture_output=True, text=True, timeout=120, check=True).stdout
    figures = re.search(r'id="render-check" data-loaded="(\d+)" data-failed="(-?\d+)"', dom)
    canvas = re.search(r'<canvas id="point-cloud"[^>]*data-drawn="(\d+)"', dom)
    assert figures and canvas, "the page's scripts did not run"
    return int(figures.group(1)), int(figures.group(2)), int(canvas.group(1))


def test_run_of_the_bundled_example_forms_the_interferogram(tmp_path):
    out = tmp_path / "run"
    report = run_experiment(example_path(EXAMPLE), out)
    record = json.loads((out / RUN_RECORD).read_text())
    assert record["warnings"] == []
    assert isinstance(record["metrics"]["bpa"], dict)  # channel 0 measured
    summary = record["interferometry"]["summary"]
    assert summary["pair"] == [0, 1] and summary["ambiguity_height_m"] == pytest.approx(0.51,
                                                                                        abs=0.01)
    assert {"interferometry/interferogram.nc", "interferometry/points.ply"} <= set(
        record["products"])
    section = [f for f in record["figures"] if f.get("section") == "Interferometry"]
    assert len(section) == 5
    # the height at the target's pixel (the brightest: the floor pixel at the target's range,
    # broadside) is the target's true height, 15 cm, within 3 mm
    ifg = load(out / "interferometry" / "interferogram.nc", product="interferogram")
    amplitude = ifg["amplitude"].values
    pixel = np.unravel_index(int(np.nanargmax(amplitude)), amplitude.shape)
    height = float(ifg["height"].values[pixel])
    assert abs(height - TARGET[2]) < 3e-3, height
    assert np.abs(ifg["position"].values[pixel] - TARGET).max() < 3e-3
    page = report.read_text()
    assert "<h2>Interferometry</h2>" in page and "https://" not in page.split("<h2>Config")[0]
    if BROWSER is None:
        pytest.skip("no headless browser (chromium-headless-shell or chromium)")
    loaded, failed, drawn = _rendered(report)
    assert (loaded, failed) == (len(record["figures"]), 0)
    assert drawn > 0


def test_run_with_ffbp_forms_the_interferogram_of_its_image(tmp_path):
    """`mitsar run -a ffbp` of the bundled interferometer: the interferogram is formed from
    FFBP's image of the channels (docs/focusing.md § FFBP, "Channels"); the target's height
    within 3 mm as with BPA (measured 0.4 mm off)."""
    out = tmp_path / "run"
    run_experiment(example_path(EXAMPLE), out, algorithms=["ffbp"])
    record = json.loads((out / RUN_RECORD).read_text())
    assert record["warnings"] == []
    assert record["interferometry"]["algorithm"] == "ffbp"
    ifg = load(out / "interferometry" / "interferogram.nc", product="interferogram")
    amplitude = ifg["amplitude"].values
    pixel = np.unravel_index(int(np.nanargmax(amplitude)), amplitude.shape)
    assert abs(float(ifg["height"].values[pixel]) - TARGET[2]) < 3e-3


def test_interferogram_command_masks_layover_and_shadow_of_a_given_scene(tmp_path):
    """--scene: the scene's layover and shadow masks (mitsar.scene.masks) go into
    interferogram.nc; the canned point_target scene (a small sphere 3 cm over a floor) lays
    over onto the floor pixels of its own range cells, and the open floor is clean (measured:
    11.5 % of this small grid in layover, none in shadow: the sphere's shadow is shorter than
    a pixel)."""
    import mitsar

    radar = mitsar.Radar(receivers=[(0, 0, 0), (0, 0, 0.05)])
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], 0.4)
    raw = mitsar.simulate_scene(radar, track, mitsar.Look(55.71), "point_target")
    grid = mitsar.grid.PlaneGrid(origin=[15.0, 7.9, 0.0], axis_u=[0, 1, 0], axis_v=[1, 0, 0],
                                 u=[-0.2, 0.3, 0.02], v=[-0.05, 0.05, 0.02])
    image = tmp_path / "image.nc"
    save(mitsar.focus(raw, "bpa", grid), image)
    out = tmp_path / "ifg"
    assert main(["interferogram", str(image), "-o", str(out), "--no-unwrap", "-q",
                 "--scene", "point_target"]) == 0
    ifg = load(out / INTERFEROMETRY_FILES["interferogram"])
    names = set(map(str, ifg.variables))
    assert {"shadow", "layover"} <= names, sorted(names)
    assert ifg["layover"].values.any()       # the sphere's range cells
    assert not ifg["layover"].values.all()   # the open floor
    assert main(["interferogram", str(image), "-o", str(tmp_path / "plain"), "--no-unwrap",
                 "-q", "--no-masks"]) == 0
    assert "shadow" not in set(map(str, load(tmp_path / "plain" /
                                             INTERFEROMETRY_FILES["interferogram"]).variables))
