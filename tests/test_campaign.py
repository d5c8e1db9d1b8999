"""Campaigns on Dask: sweep parsing, per-task seeds, identical tables on 1 and 2 workers, and a
sweep interrupted by SIGINT that resumes computing only the missing points.

The experiment is tiny (a 0.6 m pass, 100-300 sweeps, a 21 x 21 slant grid, a 0.3 m
background patch) so that one run takes well under a second; one local cluster is shared by the
module (a cluster start costs seconds).
"""

from __future__ import annotations

import json
import math
import os
import signal
import subprocess
import sys
import time
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

from mitsar.errors import ParameterError
from mitsar.experiment import montecarlo
from mitsar.experiment.campaign import (
    INLINE,
    PointFolder,
    Task,
    resolve_scheduler,
    run_tasks,
    task_seed,
)
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.sweep import parse_variation, run_sweep, sweep_points

TINY = Path(__file__).resolve().parents[1] / "examples" / "campaign_tiny.toml"

VARY = ["look.off_nadir_deg=54:57:1.5", "trajectory.speed=0.5,1.0,1.5"]
"""3 x 3 points; with 2 realisations, 18 runs."""


@pytest.fixture(scope="module")
def experiment(tmp_path_factory):
    path = tmp_path_factory.mktemp("sweep") / "tiny.toml"
    path.write_text(TINY.read_text(encoding="utf-8"), encoding="utf-8")
    return path


@pytest.fixture(scope="module")
def cluster():
    """One local cluster for the module: 1 worker first, scaled to 2 by the test that needs it."""
    distributed = pytest.importorskip("distributed")
    with distributed.LocalCluster(n_workers=1, threads_per_worker=1, processes=True,
                                  dashboard_address=":0") as local, \
            distributed.Client(local) as client:
        yield local, client


@pytest.fixture(scope="module")
def tables(experiment, cluster, tmp_path_factory):
    """The same sweep on a 1-worker and on a 2-worker local cluster."""
    local, client = cluster
    out = {}
    for workers in (1, 2):
        local.scale(workers)
        client.wait_for_workers(workers, timeout=120)
        assert len(client.scheduler_info()["workers"]) == workers
        folder = tmp_path_factory.mktemp(f"workers{workers}")
        out[workers] = (run_sweep(experiment, VARY, folder, realisations=2, client=client,
                                  progress=False), folder)
    return out


def test_variations_parse_ranges_and_lists_and_name_the_key_on_errors():
    assert parse_variation("look.off_nadir_deg=40:70:5").values == (40, 45, 50, 55, 60, 65, 70)
    speeds = parse_variation("trajectory.speed=0.3,0.5,1.0")
    assert speeds.key == "trajectory.speed" and speeds.values == (0.3, 0.5, 1.0)
    assert parse_variation("focus.algorithm=bpa,wda").values == ("bpa", "wda")
    # 0.1 is not exact in binary: the range still ends at 1.0, not 0.9 or 1.1.
    assert parse_variation("x.y=0.5:1.0:0.1").values == (0.5, 0.6, 0.7, 0.8, 0.9, 1.0)
    for bad, key in (("look.off_nadir_deg=70:40:5", "look.off_nadir_deg"),
                     ("look.off_nadir_deg=40:70:0", "look.off_nadir_deg"),
                     ("look.off_nadir_deg", "look.off_nadir_deg"),
                     ("trajectory.speed=0.3,,1", "trajectory.speed")):
        with pytest.raises(ParameterError, match=key.replace(".", r"\.")):
            parse_variation(bad)
    points = sweep_points([parse_variation(v) for v in VARY])
    assert len(points) == 9 and points[1] == {"look.off_nadir_deg": 54.0,
                                              "trajectory.speed": 1.0}


def test_an_unknown_varied_key_is_refused_before_anything_runs(experiment, tmp_path):
    with pytest.raises(ParameterError, match="off_nadir_degs"):
        run_sweep(experiment, ["look.off_nadir_degs=50,60"], tmp_path, scheduler=INLINE)
    assert not (tmp_path / "points").exists()


def test_task_seeds_depend_on_the_index_only():
    assert task_seed(7, 3, 1) == task_seed(7, 3, 1)
    seeds = {task_seed(7, i, r) for i in range(50) for r in range(4)}
    assert len(seeds) == 200 and all(0 <= s < 2**63 for s in seeds)
    assert task_seed(8, 0, 0) != task_seed(7, 0, 0)


def test_failures_are_recorded_and_do_not_stop_the_campaign(tmp_path, monkeypatch):
    monkeypatch.setenv("MITSAR_DASK_SCHEDULER", INLINE)
    assert resolve_scheduler(None) == INLINE
    tasks = [Task(f"t{i}", (i,), str(i)) for i in range(4)]
    records = run_tasks(_fails_on_two, tasks, PointFolder(tmp_path), progress=False)
    assert [records[f"t{i}"]["status"] for i in range(4)] == ["ok", "ok", "failed", "ok"]
    assert "ValueError: two is not allowed" in records["t2"]["error"]
    assert records["t3"]["result"] == 9
    stored = json.loads((tmp_path / "points" / "t2.json").read_text())
    assert stored["status"] == "failed" and "two is not allowed" in stored["error"]
    # A rerun runs the failed task again, and only it.
    again = run_tasks(_square, tasks, PointFolder(tmp_path), progress=False)
    assert again["t2"]["result"] == 4 and again["t0"] == records["t0"]


def _fails_on_two(i: int) -> int:
    if i == 2:
        raise ValueError("two is not allowed")
    return i * i


def _square(i: int) -> int:
    return i * i


def test_one_and_two_workers_give_identical_tables(tables):
    one, two = tables[1][0], tables[2][0]
    xr.testing.assert_identical(one, two)  # bit-identical: every run carries its own seed
    assert one.attrs["failed_runs"] == 0
    assert dict(one.sizes) == {"look.off_nadir_deg": 3, "trajectory.speed": 3,
                               "realisation": 2, "algorithm": 1}
    seeds = one["seed"].values
    assert len(np.unique(seeds)) == 18
    assert seeds[1, 2, 1] == task_seed(7, 1 * 3 + 2, 1)
    # Physics: a -20 dB background barely changes a rect-window response, whose closed form
    # is IRW 0.886 cells and PSLR -13.26 dB; 0.05 cells and 3 dB allow for the clutter and the
    # short 0.6 m pass at 1.5 m/s (100 sweeps).
    irw = one["range_irw_cells"].values
    assert np.all(np.isfinite(irw)) and np.allclose(irw, 0.886, atol=0.05)
    assert np.all(np.abs(one["range_pslr_db"].values + 13.26) < 3.0)
    folder = tables[1][1]
    assert (folder / "sweep.csv").read_text().count("\n") == 19  # header + 18 runs
    assert (folder / "figures" / "range_pslr_db.png").stat().st_size > 0
    reread = xr.open_dataset(folder / "sweep.nc")
    np.testing.assert_array_equal(reread["azimuth_pslr_db"].values, one["azimuth_pslr_db"].values)


def test_a_sweep_interrupted_by_sigint_resumes_with_only_the_missing_points(
        experiment, tables, cluster, tmp_path):
    out = tmp_path / "interrupted"
    command = [sys.executable, "-m", "mitsar.cli", "sweep", str(experiment), "-o", str(out),
               "-n", "2", "-q", "--scheduler", INLINE] + [f"--vary={v}" for v in VARY]
    process = subprocess.Popen(command, stderr=subprocess.PIPE, text=True,
                               env={**os.environ, "MITSAR_SKIP_BACKEND_PROBE": "1"})
    points = out / "points"
    deadline = time.monotonic() + 240
    while time.monotonic() < deadline and process.poll() is None:
        if points.is_dir() and len(list(points.glob("*.json"))) >= 9:
            break
        time.sleep(0.05)
    process.send_signal(signal.SIGINT)
    assert process.wait(timeout=60) == 130, process.stderr.read()
    finished = {p.name: p.stat().st_mtime_ns for p in points.glob("*.json")}
    assert 9 <= len(finished) < 18
    _, client = cluster
    table = run_sweep(experiment, VARY, out, realisations=2, client=client, progress=False)
    after = {p.name: p.stat().st_mtime_ns for p in points.glob("*.json")}
    assert len(after) == 18
    assert all(after[name] == mtime for name, mtime in finished.items())  # not recomputed
    xr.testing.assert_identical(table.drop_attrs(), tables[2][0].drop_attrs())
    assert math.isfinite(float(table["azimuth_irw_cells"].mean()))


def test_the_monte_carlo_of_tables_4_5_runs_on_the_cluster_with_the_same_numbers(
        experiment, tables, cluster, tmp_path):
    """Monte Carlo is a campaign too: on 2 workers it gives the inline run's summary, and its
    record (montecarlo.json) resumes as before."""
    _, client = cluster
    trial = load_experiment(experiment)
    inline = montecarlo.run(trial, 3, ["bpa"], progress=False)
    on_dask = montecarlo.run(trial, 3, ["bpa"], progress=False, client=client,
                             out_dir=tmp_path)
    xr.testing.assert_identical(on_dask.drop_attrs(), inline.drop_attrs())
    assert list(on_dask["seed"].values) == [7, 8, 9]
    record = json.loads((tmp_path / montecarlo.RECORD_FILE).read_text())
    assert sorted(r["seed"] for r in record["records"]) == [7, 8, 9]
    assert "paper Table 4" in montecarlo.format_table(on_dask)  # -20 dB background
