"""Resumable commands (docs/reliability.md §5, issue 27 item 5): ``mitsar simulate`` (chunks of
sweeps, analytic and traced), ``mitsar run`` (stages) and ``mitsar ambiguity`` (trajectories)
interrupted by SIGINT or SIGKILL at a known point (the test hook
``MITSAR_TEST_INTERRUPT_AFTER_CHUNK``) leave nothing at their destination and, run again, give
the bits of an uninterrupted run."""

from __future__ import annotations

import json
import os
import signal
import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from mitsar.cli import main
from mitsar.errors import MitsarError, MitsarWarning
from mitsar.experiment.examples import example_path
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.runs import run_simulation
from mitsar.io import (
    INTERRUPT_ENV,
    INTERRUPT_SIGNAL_ENV,
    OutputExistsError,
    WorkFolder,
    load,
    save,
    work_folder_path,
)

POINT = str(example_path("paper_point_target"))
SCENE = str(example_path("scene_point_target"))
SHORT = ["--set", "trajectory.duration=0.6"]  # 150 sweeps
SPARSE = ["--set", "simulation.scatterer_density=20"]  # the canned floor, few scatterers
CHUNKS = ["--chunk-sweeps", "64"]  # three chunks


def _mitsar(args: list[str], cwd: Path, after: int | None = None, sig: str = "INT"
            ) -> subprocess.CompletedProcess:
    """``mitsar ARGS`` in a subprocess, signalled after its ``after``-th finished chunk."""
    env = {key: value for key, value in os.environ.items()
           if key not in (INTERRUPT_ENV, INTERRUPT_SIGNAL_ENV)}
    if after is not None:
        env.update({INTERRUPT_ENV: str(after), INTERRUPT_SIGNAL_ENV: sig})
    return subprocess.run([sys.executable, "-m", "mitsar.cli", *args, "-q"], cwd=cwd, env=env,
                          capture_output=True, text=True, timeout=300)


def _nothing_partial(destination: Path) -> None:
    """The destination does not exist and nothing but the work folder lies beside it."""
    assert not destination.exists()
    beside = {p.name for p in destination.parent.iterdir()
              if p.name.startswith(f".{destination.name}")}
    assert beside == {work_folder_path(destination).name}
    manifests = [json.loads(path.read_text())
                 for path in work_folder_path(destination).rglob("manifest.json")]
    assert any(manifest["finished"] for manifest in manifests)  # (nested: run's raw product)


def _same_files(left: Path, right: Path, skip: tuple[str, ...] = ()) -> list[str]:
    """Names of the files of two folders, asserting they are equal byte for byte."""
    names = sorted(str(p.relative_to(left)) for p in left.rglob("*") if p.is_file())
    assert names == sorted(str(p.relative_to(right)) for p in right.rglob("*") if p.is_file())
    for name in names:
        if name not in skip:
            assert (left / name).read_bytes() == (right / name).read_bytes(), name
    return names


def test_simulate_resumes_after_sigint_and_sigkill(tmp_path: Path) -> None:
    """Analytic simulator, background redrawn every sweep: an interrupt after chunk 1 (SIGINT)
    and another after the next (SIGKILL) leave no raw.nc; the rerun writes the bytes of an
    uninterrupted run, which are those of one simulate_point_targets call."""
    full, raw = tmp_path / "full.nc", tmp_path / "raw.nc"
    assert main(["simulate", POINT, *SHORT, *CHUNKS, "-o", str(full), "-q"]) == 0
    stopped = _mitsar(["simulate", POINT, *SHORT, *CHUNKS, "-o", "raw.nc"], tmp_path, 1)
    assert stopped.returncode == 130, stopped.stderr
    _nothing_partial(raw)
    killed = _mitsar(["simulate", POINT, *SHORT, *CHUNKS, "-o", "raw.nc"], tmp_path, 1, "KILL")
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    _nothing_partial(raw)
    finished = json.loads((work_folder_path(raw) / "manifest.json").read_text())["finished"]
    assert sorted(finished) == ["chunk0", "chunk1"]
    assert main(["simulate", POINT, *SHORT, *CHUNKS, "-o", str(raw), "-q"]) == 0
    assert raw.read_bytes() == full.read_bytes()
    assert not work_folder_path(raw).exists()
    # the chunks are the acquisition one call makes (the kernel is per lane, draws in order)
    whole = tmp_path / "whole.nc"
    assert main(["simulate", POINT, *SHORT, "--chunk-sweeps", "1024", "-o", str(whole),
                 "-q"]) == 0
    assert whole.read_bytes() == full.read_bytes()


def test_traced_simulate_resumes_to_the_same_store(tmp_path: Path) -> None:
    """Ray-traced scene into a Zarr store, killed after chunk 1: the resumed store holds the
    uninterrupted run's data and attributes (the scatterer set is drawn again from the scene
    and seed; the tracer's counters are summed over chunks)."""
    full, raw = tmp_path / "full.zarr", tmp_path / "raw.zarr"
    arguments = ["simulate", SCENE, *SHORT, *SPARSE, *CHUNKS]
    assert main([*arguments, "-o", str(full), "-q"]) == 0
    killed = _mitsar([*arguments, "-o", "raw.zarr"], tmp_path, 1, "KILL")
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    _nothing_partial(raw)
    assert main([*arguments, "-o", str(raw), "-q"]) == 0
    expected, resumed = load(full), load(raw)
    assert resumed.identical(expected)
    assert np.array_equal(resumed["raw"].values, expected["raw"].values)
    assert resumed.attrs["traced_pairs"] == 150
    # chunks of 128 sweeps (the tracer's own) give one simulate_scene call's bytes
    chunked, whole = tmp_path / "chunked.nc", tmp_path / "whole.nc"
    assert main(["simulate", SCENE, *SHORT, *SPARSE, "--chunk-sweeps", "128", "-o",
                 str(chunked), "-q"]) == 0
    assert main(["simulate", SCENE, *SHORT, *SPARSE, "--chunk-sweeps", "1024", "-o",
                 str(whole), "-q"]) == 0
    assert chunked.read_bytes() == whole.read_bytes()


SCENE_AND_TARGETS = """
scene = "point_target"
[radar]
noise_figure_db = 10.0
[trajectory]
start = [14.8, 1.4, 4.5]
velocity = [0.5, 0.0, 0.0]
duration = 0.6
[look]
off_nadir_deg = 55.71
[[targets]]
position = [15.1, 8.0, 0.0]
rcs = 0.5
[background]
center = [15.0, 8.0, 0.0]
size = [0.6, 0.6]
cell_rcs_db = -20.0
mode = "pulse"
[simulation]
seed = 1
scatterer_density = 20
noise = true
"""


def test_traced_with_analytic_targets_resumes(tmp_path: Path,
                                              monkeypatch: pytest.MonkeyPatch) -> None:
    """A scene with analytic targets, a background redrawn every sweep and noise: each chunk
    adds its own analytic sweeps (earlier chunks' draws made, echoes skipped) and its noise;
    SIGINT after chunk 1 (in this process: ``main`` returns 130) and the rerun give the bytes
    of an uninterrupted run, and 128-sweep chunks the data of one simulate_scene call."""
    experiment = tmp_path / "scene.toml"
    experiment.write_text(SCENE_AND_TARGETS)
    full, raw = tmp_path / "full.nc", tmp_path / "raw.nc"
    assert main(["simulate", str(experiment), *CHUNKS, "-o", str(full), "-q"]) == 0
    monkeypatch.setattr("mitsar.io.work_folder._MARKS", [0])
    monkeypatch.setenv(INTERRUPT_ENV, "1")
    assert main(["simulate", str(experiment), *CHUNKS, "-o", str(raw), "-q"]) == 130
    monkeypatch.delenv(INTERRUPT_ENV)
    _nothing_partial(raw)
    assert main(["simulate", str(experiment), *CHUNKS, "-o", str(raw), "-q"]) == 0
    assert raw.read_bytes() == full.read_bytes()
    chunked = tmp_path / "chunked.nc"
    assert main(["simulate", str(experiment), "--chunk-sweeps", "128", "-o", str(chunked),
                 "-q"]) == 0
    whole = run_simulation(load_experiment(experiment))
    assert load(chunked).identical(load_dataset_like(whole, tmp_path / "whole.nc"))


def load_dataset_like(dataset: xr.Dataset, path: Path) -> xr.Dataset:
    """``dataset`` as a file gives it back (attributes sanitised)."""
    save(dataset, path)
    return load(path)


def test_simulate_starts_over_when_the_inputs_change(tmp_path: Path,
                                                     capsys: pytest.CaptureFixture) -> None:
    """A work folder left with seed 2016 is not resumed by a run with --seed 7: it says so and
    the product is the one of seed 7 (the same as a fresh run's)."""
    raw, fresh = tmp_path / "raw.nc", tmp_path / "fresh.nc"
    stopped = _mitsar(["simulate", POINT, *SHORT, *CHUNKS, "-o", "raw.nc"], tmp_path, 1)
    assert stopped.returncode == 130
    assert main(["simulate", POINT, *SHORT, *CHUNKS, "--seed", "7", "-o", str(raw)]) == 0
    err = capsys.readouterr().err
    assert "the inputs changed" in err and "starting over" in err
    assert main(["simulate", POINT, *SHORT, *CHUNKS, "--seed", "7", "-o", str(fresh),
                 "-q"]) == 0
    assert raw.read_bytes() == fresh.read_bytes()
    assert load(raw).attrs["seed"] == 7
    assert not work_folder_path(raw).exists()


def test_refused_simulate_leaves_nothing(tmp_path: Path) -> None:
    """Inputs refused before or after the chunks (here: every echo zero, found after the last
    chunk) leave neither the product nor a work folder: there is nothing to resume."""
    raw = tmp_path / "raw.nc"
    behind = ["--set", "targets.0.position=[15.0,-8.0,0.0]",
              "--set", "background.center=[15.0,-8.0,0.0]"]
    with pytest.warns(MitsarWarning, match="behind the antenna"):
        assert main(["simulate", POINT, "--set", "trajectory.duration=0.2", *behind, "-o",
                     str(raw), "-q"]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == []


def test_run_resumes_by_stage(tmp_path: Path) -> None:
    """``mitsar run`` interrupted inside its simulate stage (SIGINT after the raw product's first
    chunk) and after that stage (SIGKILL) leaves no output folder; the rerun reuses the raw
    product and writes the products and figures of an uninterrupted run, byte for byte."""
    arguments = ["run", POINT, "--set", "trajectory.duration=1.2", "-a", "bpa", "wda"]
    assert main([*arguments, "-o", str(tmp_path / "full"), "-q"]) == 0
    out = tmp_path / "out"
    stopped = _mitsar([*arguments, "-o", "out"], tmp_path, 1)
    assert stopped.returncode == 130, stopped.stderr
    _nothing_partial(out)
    killed = _mitsar([*arguments, "-o", "out"], tmp_path, 2, "KILL")  # after focus bpa
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    _nothing_partial(out)
    finished = json.loads((work_folder_path(out) / "manifest.json").read_text())["finished"]
    assert list(finished) == ["simulate raw.nc", "focus image_bpa.nc"]
    assert main([*arguments, "-o", str(out), "-q"]) == 0
    names = _same_files(tmp_path / "full", out, skip=("run.json", "report.html"))
    assert {"raw.nc", "image_bpa.nc", "image_wda.nc", "cuts_bpa.png"} <= set(names)
    record = json.loads((out / "run.json").read_text())
    expected = json.loads((tmp_path / "full" / "run.json").read_text())
    assert record["metrics"] == expected["metrics"]
    assert record["resumed"] == ["simulate raw.nc", "focus image_bpa.nc"]
    assert set(record["steps"]) == set(expected["steps"])
    assert not work_folder_path(out).exists()
    # a finished run is not replaced without --overwrite (checked before any work)
    assert main([*arguments, "-o", str(out), "-q"]) == 2


def test_ambiguity_resumes_by_trajectory(tmp_path: Path) -> None:
    """``mitsar ambiguity`` of two trajectories killed after the first: nothing in the output
    folder; the rerun maps the second only and writes the bytes of an uninterrupted run."""
    example = str(example_path("ambiguity_box_obstacle"))
    arguments = ["ambiguity", example, "--no-figures"]
    assert main([*arguments, "-o", str(tmp_path / "full"), "-q"]) == 0
    out = tmp_path / "out"
    killed = _mitsar([*arguments, "-o", "out"], tmp_path, 1, "KILL")
    assert killed.returncode == -signal.SIGKILL, killed.stderr
    _nothing_partial(out)
    assert main([*arguments, "-o", str(out), "-q"]) == 0
    _same_files(tmp_path / "full", out, skip=("summary.json",))
    summary = json.loads((out / "summary.json").read_text())
    expected = json.loads((tmp_path / "full" / "summary.json").read_text())
    assert summary["trajectories"] == expected["trajectories"]
    assert all(Path(file).parent == out for file in summary["files"])


def test_work_folder_lock_and_clashes(tmp_path: Path) -> None:
    """A work folder held by a live process is refused; a finished result meeting existing
    files without overwrite waits in the work folder, and the rerun with overwrite moves it."""
    destination = tmp_path / "out"
    holder = WorkFolder(destination, {"a": 1}, command="test")
    holder.open()
    (holder.path / "lock").write_text(str(os.getppid()))  # a live process that is not us
    with pytest.raises(MitsarError, match="another mitsar process"):
        WorkFolder(destination, {"a": 1}, command="test").open()
    (holder.path / "lock").write_text("999999999")  # one that no longer runs
    with WorkFolder(destination, {"a": 1}, command="test") as work:
        folder = work.file("result")
        folder.mkdir()
        (folder / "a.txt").write_text("new")
        destination.mkdir()
        (destination / "a.txt").write_text("old")
        with pytest.raises(OutputExistsError, match="waits in"):
            work.move_folder(folder, overwrite=False)
        assert (destination / "a.txt").read_text() == "old"
        work.move_folder(folder, overwrite=True)
        work.remove()
    assert (destination / "a.txt").read_text() == "new"
    assert not work_folder_path(destination).exists()
