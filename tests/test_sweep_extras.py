"""Sweeps of ambiguity files (issue #14), the Monte Carlo's refusal of a target outside the
image before its first realisation, and stale ``.zarr`` temporaries (issue #15 leftovers).

Everything runs in this process (``--scheduler inline``) on tiny inputs: an ambiguity file
of two 8 m passes over two rectangles at 0.5 m spacing (a second or two per map), and the
point-target experiment of ``tests/test_campaign.py`` cut to 0.3 m of flight.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import time

import numpy as np
import pytest
import xarray as xr

from mitsar import cli
from mitsar.ambiguity import sweep as ambiguity_sweep
from mitsar.errors import ParameterError
from mitsar.experiment.coverage import grid_layout, target_axes
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.runs import run_focus, run_simulation
from mitsar.experiment.sweep import run_sweep
from mitsar.io import STALE_AGE, atomic_directory, remove_stale_temporaries

AMBIGUITY = """
name = "tiny-ambiguity"
required_resolution = [0.15, 0.10]
[look]
off_nadir_deg = {off_nadir}
[trajectories.side]
kind = "linear"
start = [2.0, 1.4, 4.5]
velocity = [0.5, 0.0, 0.0]
duration = 8.0
[trajectories.squinted]
kind = "linear"
start = [2.0, 1.4, 4.5]
velocity = [0.5, 0.0, 0.0]
duration = 8.0
[trajectories.squinted.look]
off_nadir_deg = 55.71
squint_deg = 15.0
[ambiguity]
spacing = 0.5
max_states = 60
[[surfaces]]
name = "floor"
origin = [0.0, 0.0, 0.0]
axis_u = [1.0, 0.0, 0.0]
axis_v = [0.0, 1.0, 0.0]
size = [8.0, 10.0]
[[surfaces]]
name = "wall"
origin = [0.0, 10.0, 0.0]
axis_u = [1.0, 0.0, 0.0]
axis_v = [0.0, 0.0, 1.0]
size = [8.0, 6.0]
[output]
figures = false
"""

POINT_TARGET = """
name = "precheck"
[radar]
[trajectory]
kind = "waypoints"
points = [[14.85, 1.4, 4.5], [15.15, 1.4, 4.5]]
speed = 1.0
[look]
off_nadir_deg = 55.71
[[targets]]
position = [{x}, 8.0, 0.0]
rcs = 1.0
[background]
center = [15.0, 8.0, 0.0]
size = [0.3, 0.3]
cell_rcs_db = -20.0
mode = "pulse"
[simulation]
seed = 7
normalized = true
[focus]
algorithm = "bpa"
window = "rect"
azimuth_resolution = 0.1
{grid}
"""

SLANT_GRID = """[focus.grid]
kind = "slant"
along_track = [0.0, 0.3, 0.03]
slant_range = [7.69, 8.29, 0.03]"""


def _cli(*argv: str) -> int:
    return cli.main(list(argv))


def test_a_sweep_of_an_ambiguity_file_gives_the_fractions_of_mitsar_ambiguity_per_point(
        tmp_path, monkeypatch):
    swept = tmp_path / "tiny.toml"
    swept.write_text(AMBIGUITY.format(off_nadir=55.71), encoding="utf-8")
    out = tmp_path / "sweep"
    assert _cli("sweep", str(swept), "--vary", "look.off_nadir_deg=45,60", "--ambiguity",
                "-o", str(out), "--scheduler", "inline", "-q") == 0
    table = xr.open_dataset(out / "sweep.nc")
    assert table["trajectory"].values.tolist() == ["side", "squinted"]
    expected = {}
    for value in (45, 60):
        # The independent path: the point written as its own file, mapped by the command.
        point = tmp_path / f"point{value}" / "tiny.toml"
        point.parent.mkdir()
        point.write_text(AMBIGUITY.format(off_nadir=value), encoding="utf-8")
        assert _cli("ambiguity", str(point), "-o", str(point.parent / "maps"), "-q") == 0
        summary = json.loads((point.parent / "maps" / "summary.json").read_text())
        expected[value] = summary["trajectories"]
        for name in ("side", "squinted"):
            for fraction in ambiguity_sweep.FRACTIONS:
                got = float(table[fraction].sel({"look.off_nadir_deg": value,
                                                 "trajectory": name}))
                # The same maps of the same points: equal up to the JSON round trip (exact).
                assert got == pytest.approx(summary["trajectories"][name]["overall"][fraction],
                                            abs=1e-12)
    # The varied key matters for the pass that uses the file's [look], not for the one with
    # its own look (so the comparison above cannot pass by accident on constant numbers).
    side = [expected[v]["side"]["overall"]["fraction_resolved"] for v in (45, 60)]
    squinted = [expected[v]["squinted"]["overall"]["fraction_resolved"] for v in (45, 60)]
    assert side[0] != side[1] and squinted[0] == squinted[1]
    assert all(table["ambiguity_error"].values == "")
    rows = (out / "sweep_ambiguity.csv").read_text().splitlines()
    assert len(rows) == 1 + 2 * 2 and rows[0].startswith("look.off_nadir_deg,trajectory,")
    records = sorted(p.name for p in (out / "points").glob("*.json"))
    assert records == ["p00000-ambiguity.json", "p00001-ambiguity.json"]
    assert all(json.loads((out / "points" / r).read_text())["inputs"] for r in records)
    table.close()

    # Resumable: a rerun reuses the records (the maps would fail now) and gives the same table.
    def broken(*args, **kwargs):
        raise AssertionError("a finished point was computed again")

    monkeypatch.setattr(ambiguity_sweep, "ambiguity_products", broken)
    again = ambiguity_sweep.run_ambiguity_sweep(swept, ["look.off_nadir_deg=45,60"], out,
                                                scheduler="inline", progress=False,
                                                figures=False)
    for fraction in ambiguity_sweep.FRACTIONS:
        np.testing.assert_array_equal(again[fraction].values,
                                      xr.open_dataset(out / "sweep.nc")[
                                          fraction].values)
    assert again.attrs["failed_runs"] == 0


def test_ambiguity_sweeps_are_asked_for_and_refused_where_they_make_no_sense(tmp_path):
    ambiguity_file = tmp_path / "tiny.toml"
    ambiguity_file.write_text(AMBIGUITY.format(off_nadir=55.71), encoding="utf-8")
    experiment = tmp_path / "target.toml"
    experiment.write_text(POINT_TARGET.format(x=15.0, grid=SLANT_GRID), encoding="utf-8")
    # An ambiguity file without --ambiguity, an experiment with it: exit 2, nothing run.
    assert _cli("sweep", str(ambiguity_file), "--vary", "look.off_nadir_deg=45,60",
                "-o", str(tmp_path / "a"), "--scheduler", "inline", "-q") == 2
    assert _cli("sweep", str(experiment), "--vary", "look.off_nadir_deg=45,60",
                "--ambiguity", "-o", str(tmp_path / "b"), "--scheduler", "inline", "-q") == 2
    assert not (tmp_path / "a" / "points").exists() and not (tmp_path / "b").exists()
    # A bad point is refused before anything runs, naming the key.
    with pytest.raises(ParameterError, match="spacing"):
        ambiguity_sweep.run_ambiguity_sweep(ambiguity_file, ["ambiguity.spacing=0.5,-1"],
                                            tmp_path / "c", scheduler="inline")
    assert not (tmp_path / "c" / "points").exists()
    with pytest.raises(ParameterError, match="realisations"):
        run_sweep(ambiguity_file, ["look.off_nadir_deg=45"], tmp_path / "d", realisations=2,
                  measures=[ambiguity_sweep.AMBIGUITY_MEASURE], images=False)


def test_the_grid_resolved_without_simulating_is_the_focused_images_grid(tmp_path):
    # Default slant grid (no [focus.grid]): it depends on the track and the beam, so the
    # cheap path must rebuild it exactly as focusing does.
    path = tmp_path / "default.toml"
    path.write_text(POINT_TARGET.format(x=15.0, grid=""), encoding="utf-8")
    experiment = load_experiment(path)
    image = run_focus(run_simulation(experiment), experiment.focus)
    layout, straight = grid_layout(experiment)
    assert straight
    for dim in ("azimuth", "range"):
        # Same arithmetic on the same track samples: equal to rounding.
        np.testing.assert_allclose(layout["coords"][dim], image[dim].values, atol=1e-9)
    # The target's coordinates are where the image has its peak (within a pixel: the focused
    # response peaks at the target, its pixel is the nearest one).
    axes = target_axes(layout, experiment.metrics_target())
    peak = np.unravel_index(int(np.argmax(np.abs(image["image"].values))), image["image"].shape)
    for dim, index in zip(("azimuth", "range"), peak, strict=True):
        step = float(np.diff(image[dim].values[:2])[0])
        assert abs(axes[dim] - float(image[dim].values[index])) <= step


def test_a_monte_carlo_with_its_target_outside_the_image_stops_before_the_first_run(tmp_path):
    path = tmp_path / "outside.toml"
    # 0.5 m past the grid's along-track end (0.3 m + half a 0.03 m pixel).
    path.write_text(POINT_TARGET.format(x=15.65, grid=SLANT_GRID), encoding="utf-8")
    out = tmp_path / "mc"
    start = time.perf_counter()
    result = subprocess.run([sys.executable, "-m", "mitsar.cli", "montecarlo", str(path),
                             "-n", "20", "-a", "bpa", "-o", str(out), "--scheduler", "inline",
                             "--cuts", "0", "-q"], capture_output=True, text=True,
                            timeout=300, check=False)
    elapsed = time.perf_counter() - start
    assert result.returncode == 2, result.stderr
    assert "metrics.target" in result.stderr and "along_track" in result.stderr
    assert "0.315" in result.stderr  # the grid's extent is named (0.3 m + half a pixel)
    assert not (out / "montecarlo.json").exists()
    assert elapsed < 60  # no realisation ran (20 of them would take much longer)


def test_stale_zarr_temporaries_are_swept_up_like_files(tmp_path):
    target = tmp_path / "raw.zarr"
    dead = subprocess.run([sys.executable, "-c", "import os; print(os.getpid())"],
                          capture_output=True, text=True, check=True)
    pid = int(dead.stdout)  # a process that has exited
    killed = tmp_path / f".raw.zarr.{pid}.abc123.tmp.zarr"
    set_aside = tmp_path / f".raw.zarr.{pid}.def456.tmp.zarr.old"
    running = tmp_path / f".raw.zarr.{os.getpid()}.ghi789.tmp.zarr"
    old_legacy = tmp_path / ".raw.zarr.jkl012.tmp.zarr"
    new_legacy = tmp_path / ".raw.zarr.mno345.tmp.zarr"
    other = tmp_path / f".other.zarr.{pid}.pqr678.tmp.zarr"
    for folder in (killed, set_aside, running, old_legacy, new_legacy, other):
        (folder / "image" / "0").mkdir(parents=True)
        (folder / ".zgroup").write_text("{}")
    hour_ago = time.time() - STALE_AGE - 60
    os.utime(old_legacy, (hour_ago, hour_ago))
    removed = remove_stale_temporaries(target)
    assert sorted(removed) == sorted([killed, set_aside, old_legacy])
    assert all(p.exists() for p in (running, new_legacy, other))
    assert not any(p.exists() for p in removed)
    # The writer of a store cleans up before it starts.
    os.utime(new_legacy, (hour_ago, hour_ago))
    with atomic_directory(target) as tmp:
        (tmp / ".zgroup").write_text("{}")
    assert target.is_dir() and not new_legacy.exists() and running.exists()
