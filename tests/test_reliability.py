"""Reliability (docs/reliability.md, issue #15): memory budget before compute, impossible inputs
refused, empty results said, no stale temporaries after SIGKILL, deterministic raw data."""

from __future__ import annotations

import math
import os
import subprocess
import sys
import time
import warnings
from pathlib import Path

import numpy as np
import pytest

import mitsar
from mitsar import budget
from mitsar.ambiguity.points import plane_points
from mitsar.cli import main
from mitsar.errors import MemoryBudgetError, MitsarWarning, ParameterError
from mitsar.experiment.loading import experiment_from_dict
from mitsar.experiment.runs import run_simulation
from mitsar.io import remove_stale_temporaries, save, write_json
from mitsar.model.doublelobe import DoubleLobe
from mitsar.model.multipath import ray_set
from mitsar.scene import load_scene, sample_surface_scatterers

RADAR = mitsar.Radar()
TRACK = mitsar.Trajectory.linear([14.9, 1.4, 4.5], [0.5, 0.0, 0.0], 0.2)
LOOK = mitsar.Look(55.71)
TARGET = mitsar.PointTarget([15.0, 8.0, 0.0])


def _experiment(**changes: dict) -> dict:
    """A small point-target experiment (50 sweeps) with some tables changed."""
    document = {"trajectory": {"start": [14.9, 1.4, 4.5], "velocity": [0.5, 0.0, 0.0],
                               "duration": 0.2},
                "look": {"off_nadir_deg": 55.71},
                "targets": [{"position": [15.0, 8.0, 0.0]}]}
    for table, values in changes.items():
        document.setdefault(table, {}).update(values)
    return document


@pytest.fixture
def limit(monkeypatch: pytest.MonkeyPatch) -> int:
    """A 1 GiB budget, whatever the machine has."""
    monkeypatch.setenv(budget.MEMORY_LIMIT_ENV, "1G")
    budget.set_memory_limit(None)
    return 2**30


# --- the budget itself --------------------------------------------------------------------------

def test_parse_size_and_precedence(monkeypatch: pytest.MonkeyPatch) -> None:
    assert budget.parse_size("4G") == 4 * 2**30
    assert budget.parse_size("512MiB") == 512 * 2**20
    assert budget.parse_size("2e9") == 2_000_000_000
    for bad in ("lots", "-1G", "0", "nanG", True):
        with pytest.raises(ParameterError, match="memory size"):
            budget.parse_size(bad)
    monkeypatch.setenv(budget.MEMORY_LIMIT_ENV, "3G")
    assert budget.available_memory() == (3 * 2**30, budget.MEMORY_LIMIT_ENV)
    budget.set_memory_limit("1M")  # the CLI's --memory-limit wins over the environment
    try:
        assert budget.available_memory() == (2**20, "--memory-limit")
    finally:
        budget.set_memory_limit(None)
    monkeypatch.delenv(budget.MEMORY_LIMIT_ENV)
    machine, source = budget.available_memory()
    assert machine > 0 and "MemAvailable" in source


def test_require_memory_names_the_parameter(limit: int) -> None:
    budget.require_memory("f", "knob", limit)  # exactly what there is: accepted
    for need in (limit + 1, math.inf, math.nan):
        with pytest.raises(MemoryBudgetError, match=r"f: parameter 'knob': needs about") as info:
            budget.require_memory("f", "knob", need, "a smaller knob")
        assert "1.00 GiB available" in str(info.value) and "a smaller knob" in str(info.value)


# --- each memory case of issue #15, refused in under a second with its key -----------------------

MEMORY_CASES = {
    "background cells": (lambda: mitsar.simulate_point_targets(
        RADAR, TRACK, LOOK, [TARGET], mitsar.Background((15, 8, 0), (1e4, 1e4))),
        "background.size"),
    "samples (duration)": (lambda: mitsar.simulate_point_targets(
        RADAR, mitsar.Trajectory.linear([14.9, 1.4, 4.5], [0.5, 0, 0], 1e4), LOOK, [TARGET]),
        "trajectory.duration"),
    "focus grid pixels (file)": (lambda: experiment_from_dict(_experiment(focus={
        "grid": {"kind": "slant", "along_track": [-1e3, 1e3, 1e-6],
                 "slant_range": [7.0, 9.0, 0.01]}})), "focus.grid.along_track"),
    "focus grid pixels (API)": (lambda: mitsar.grid.PlaneGrid(
        (0, 0, 0), (1, 0, 0), (0, 1, 0), [0, 1e3, 1e-4], [0, 1e3, 1e-4]).resolve(
        None, RADAR, 0.1), "u x v"),
    "ambiguity spacing": (lambda: plane_points((0, 0, 0), (1, 0, 0), (0, 1, 0), (30, 10), 1e-6),
                          "spacing"),
}


@pytest.mark.parametrize("case", sorted(MEMORY_CASES))
def test_memory_refused_before_work(case: str, limit: int) -> None:
    call, parameter = MEMORY_CASES[case]
    start = time.perf_counter()
    with pytest.raises(MemoryBudgetError) as info:
        call()
    seconds = time.perf_counter() - start
    assert parameter in str(info.value)
    # "before any work": a refusal costs the estimate only (well under 1 s even on a loaded
    # machine; the simulation it replaces would take hours or fail in NumPy).
    assert seconds < 1.0, seconds


def test_sampling_frequency_bounded_by_key() -> None:
    with pytest.raises(ParameterError, match="radar.sampling_frequency"):
        experiment_from_dict(_experiment(radar={"sampling_frequency": 1e15}))


# --- impossible inputs ----------------------------------------------------------------------------

def test_levels_that_overflow_are_refused() -> None:
    with pytest.raises(ParameterError, match="cell_rcs_db"):
        mitsar.Background((0, 0, 0), (1, 1), cell_rcs_db=1e300)
    with pytest.raises(ParameterError, match="sigma0_db"):
        DoubleLobe(sigma0_db=1e300)
    with pytest.raises(ParameterError, match="rcs"):
        mitsar.PointTarget((0, 0, 0), rcs=1e300)
    # -inf dB is a valid level: lossless (P_L/P_i = 10^(-inf/10) = 0), no backscatter.
    material = DoubleLobe(transmission_loss_db=-math.inf, sigma0_db=-math.inf)
    assert material.transmission_loss_db == -math.inf


def test_ray_cover_beyond_the_hemisphere() -> None:
    # 2-D fan: direction sines cover * beamwidth must stay below 1 (in front of the antenna).
    limit = 0.999 / RADAR.elevation_beamwidth
    ray_set(RADAR, 10, 0.99 * limit, planar=True)
    with pytest.raises(ParameterError, match="ray_cover"):
        ray_set(RADAR, 10, 1e300, planar=True)


def test_prf_check_refuses_nan_speed() -> None:
    for speed in (math.nan, -1.0, "fast"):
        with pytest.raises(ParameterError, match="speed"):
            RADAR.check_prf(speed)


def test_vertical_track() -> None:
    with pytest.warns(MitsarWarning, match="heading is undefined"):
        mitsar.Trajectory.linear([0, 0, 1], [0, 0, 0.5], 1.0)
    with warnings.catch_warnings():
        warnings.simplefilter("error")
        mitsar.Trajectory.linear([0, 0, 1], [0.5, 0, 0.1], 1.0)  # climbing: a heading
    with pytest.raises(ParameterError, match="trajectory.velocity"):
        experiment_from_dict(_experiment(trajectory={"velocity": [0.0, 0.0, 0.5]}))


def test_empty_scene_is_refused_by_an_experiment(tmp_path: Path) -> None:
    scene = tmp_path / "empty.xml"
    scene.write_text('<scene version="3.0.0"/>')
    experiment = experiment_from_dict({**_experiment(), "scene": str(scene), "targets": []})
    experiment = experiment.__class__(**{**experiment.__dict__,
                                         "trajectory": mitsar.Trajectory.linear(
                                             [14.9, 1.4, 4.5], [0.5, 0, 0], 0.02)})
    with pytest.raises(mitsar.MitsarError, match="exact zeros"):
        run_simulation(experiment)


# --- interrupted writes ---------------------------------------------------------------------------

_KILLED_WRITER = """
import sys, time
from mitsar.io import atomic_output
with atomic_output(sys.argv[1]) as tmp:
    tmp.write_text("partial")
    print("writing", flush=True)
    time.sleep(60)
"""


def test_sigkill_during_a_write_leaves_nothing_after_the_next(tmp_path: Path) -> None:
    out = tmp_path / "out.json"
    process = subprocess.Popen([sys.executable, "-c", _KILLED_WRITER, str(out)],
                               stdout=subprocess.PIPE, text=True)
    assert process.stdout.readline().strip() == "writing"
    process.kill()
    process.wait()
    stale = list(tmp_path.glob(".out.json.*.tmp.json"))
    assert not out.exists() and len(stale) == 1  # the destination was never touched
    write_json({"ok": 1}, out)
    assert out.exists() and not list(tmp_path.glob(".out.json.*.tmp*"))


def test_live_writers_are_left_alone(tmp_path: Path) -> None:
    out = tmp_path / "x.nc"
    live = tmp_path / f".x.nc.{os.getppid()}.abcd1234.tmp.nc"  # our parent: running
    live.write_text("")
    fresh_legacy = tmp_path / ".x.nc.abcd1234.tmp.nc"  # no pid, recent: maybe a writer
    fresh_legacy.write_text("")
    old_legacy = tmp_path / ".x.nc.efgh5678.tmp.nc"
    old_legacy.write_text("")
    os.utime(old_legacy, (0, 0))
    other = tmp_path / ".y.nc.1.abcd1234.tmp.nc"  # another destination
    other.write_text("")
    assert remove_stale_temporaries(out) == [old_legacy]
    assert live.exists() and fresh_legacy.exists() and other.exists()


# --- determinism ----------------------------------------------------------------------------------

def test_analytic_raw_data_is_bit_identical() -> None:
    background = mitsar.Background((15.0, 8.0, 0.0), (0.3, 0.3))
    runs = [mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [TARGET], background, seed=7)
            for _ in range(2)]
    assert np.array_equal(runs[0]["raw"].values, runs[1]["raw"].values)
    assert np.array_equal(runs[0]["background_reflectivity"].values,
                          runs[1]["background_reflectivity"].values)
    other = mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [TARGET], background, seed=8)
    assert not np.array_equal(runs[0]["raw"].values, other["raw"].values)  # the seed matters


def test_traced_raw_data_is_bit_identical() -> None:
    track = mitsar.Trajectory.linear([0.4, 8.0, 1.0], [0.5, 0.0, 0.0], 0.02)
    runs = [mitsar.simulate_scene(RADAR, track, mitsar.Look(60.0), "dihedral", density=400.0,
                                  seed=3) for _ in range(2)]
    assert np.any(runs[0]["raw"].values)
    assert np.array_equal(runs[0]["raw"].values, runs[1]["raw"].values)


def test_saved_products_round_trip_bit_identical(tmp_path: Path) -> None:
    raw = mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [TARGET], seed=1)
    save(raw, tmp_path / "raw.nc")
    assert np.array_equal(mitsar.load(tmp_path / "raw.nc")["raw"].values, raw["raw"].values)


def test_scatterer_density_refused_before_sampling(limit: int) -> None:
    scene = load_scene("dihedral")  # loading is not part of the refusal
    start = time.perf_counter()
    with pytest.raises(MemoryBudgetError, match="scatterer_density"):
        sample_surface_scatterers(scene, 1e12)
    assert time.perf_counter() - start < 1.0  # the estimate only: no sampling (as above)


def test_montecarlo_with_the_target_outside_the_image_fails(tmp_path: Path,
                                                            capsys: pytest.CaptureFixture) -> None:
    """Every realisation "not measurable" used to exit 0: now status 2, the reason quoted."""
    experiment = tmp_path / "mc.toml"
    experiment.write_text(
        "[trajectory]\nstart = [14.9, 1.4, 4.5]\nvelocity = [0.5, 0.0, 0.0]\nduration = 0.2\n"
        "[look]\noff_nadir_deg = 55.71\n[[targets]]\nposition = [15.0, 8.0, 0.0]\n"
        "[background]\ncenter = [15.0, 8.0, 0.0]\nsize = [0.3, 0.3]\n"
        "[metrics]\ntarget = [15.0, 30.0, 0.0]\n"
        "[focus.grid]\nkind = \"slant\"\nalong_track = [-0.1, 0.1, 0.02]\n"
        "slant_range = [7.7, 8.3, 0.02]\n")
    status = main(["-q", "montecarlo", str(experiment), "-n", "1", "-a", "bpa", "--cuts", "0",
                   "-o", str(tmp_path / "mc")])
    assert status == 2
    assert "outside the image" in capsys.readouterr().err


def test_absurd_lengths_are_refused_at_load_whatever_the_command() -> None:
    """Issue 27: ``[metrics] target = [1e300, 8, 0]`` and ``simulation.slab_width = 1e300``
    passed ``mitsar simulate``; every length or position [m] of an experiment is now bounded
    at load (mitsar.checks.MAX_LENGTH, 10 km), and the trace request refuses the same."""
    for table, key, value in (("metrics", "target", [1e300, 8.0, 0.0]),
                              ("simulation", "slab_width", 1e300),
                              ("trajectory", "start", [1e5, 1.4, 4.5])):
        with pytest.raises(ParameterError, match=f"{table}.{key}.*10000 m"):
            experiment_from_dict(_experiment(**{table: {key: value}}))
    with pytest.raises(ParameterError, match="slab_width"):
        mitsar.TraceOptions(slab_width=1e300).resolve("test")
    experiment_from_dict(_experiment(metrics={"target": [15.0, 8.0, 0.0]}))  # still fine
