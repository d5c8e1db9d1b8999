"""Campaign start-up proportionate to the work (issue 27 item 3).

The default scheduler is chosen by the estimated cost (a small campaign runs in this process and
starts no Dask cluster); a no-op rerun of a finished sweep or Monte Carlo simulates nothing,
starts no cluster and rewrites nothing; a script without ``if __name__ == "__main__":`` gets a
mitsar error naming the script and the fix (or, for the cost-chosen default, a warning and this
process) instead of Dask's ``Nanny failed to start``; every phase is said on stderr.

The experiment is ``examples/campaign_tiny.toml`` (well under a second a run). Timings on the
shared 2-core machine vary several-fold with its load, so the mechanism is asserted (what runs,
what is written) and times only against generous bounds, with the reason given.
"""

from __future__ import annotations

import subprocess
import sys
import textwrap
import time
import types
from pathlib import Path

import numpy as np
import pytest

from mitsar.cli import main
from mitsar.errors import MitsarError, MitsarWarning
from mitsar.experiment import campaign, montecarlo, runs
from mitsar.experiment.campaign import (
    AUTO,
    INLINE,
    OUTPUTS_FILE,
    SCHEDULER_ENV,
    ClusterStartError,
    PointFolder,
    SchedulerChoice,
    Task,
    choose_scheduler,
    missing_main_guard,
    resolve_scheduler,
    run_tasks,
)
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.sweep import run_sweep

ROOT = Path(__file__).resolve().parents[1]
TINY = ROOT / "examples" / "campaign_tiny.toml"
PAPER = ROOT / "examples" / "paper_point_target.toml"
VARY = ["look.off_nadir_deg=55,56", "trajectory.speed=0.5,1.0"]


@pytest.fixture(autouse=True)
def _default_scheduler(monkeypatch):
    """The default scheduler, whatever the environment of the test run says."""
    monkeypatch.delenv(SCHEDULER_ENV, raising=False)


def _no_cluster(*args, **kwargs):
    raise AssertionError("a Dask cluster was started")


def _no_run(*args, **kwargs):
    raise AssertionError("a task was run")


def test_the_default_scheduler_is_chosen_by_the_estimated_cost():
    assert resolve_scheduler(None) == AUTO
    tiny = montecarlo.estimate_run_seconds(load_experiment(TINY), ["bpa"])
    paper = montecarlo.estimate_run_seconds(load_experiment(PAPER),
                                            ["bpa", "rda", "wda", "fsa", "ffbp"])
    # Measured on the loaded 2-core machine: tiny 0.2-0.5 s a run, paper 4-8 s (5 algorithms).
    assert 0.1 < tiny < 2.0 and 3.0 < paper < 20.0
    # Small campaigns stay in this process: the issue's `montecarlo -n 2` and 2 x 2 sweeps.
    for cores in (2, 4, 16):
        assert choose_scheduler(2, paper, cores=cores).scheduler == INLINE
        assert choose_scheduler(4, tiny, cores=cores).scheduler == INLINE
    # One worker or one task can never gain from a cluster.
    assert choose_scheduler(10_000, 60.0, workers=1, cores=8).scheduler == INLINE
    assert choose_scheduler(1, 1e5, cores=8).scheduler == INLINE
    # A cluster when it pays: 20 paper realisations on 4 cores, 100 traced runs on 2 cores.
    assert choose_scheduler(20, paper, cores=4).scheduler == "local:4"
    assert choose_scheduler(100, 60.0, cores=2).scheduler == "local:2"
    # Monotone in the number of tasks: once chosen, the cluster stays chosen.
    picks = [choose_scheduler(n, paper, cores=2).scheduler != INLINE for n in range(1, 300)]
    assert picks == sorted(picks) and any(picks)
    choice = choose_scheduler(2, paper, cores=2)
    assert "in this process" in choice.reason and choice.inline_seconds < choice.cluster_seconds


def test_a_worker_count_asks_for_a_local_cluster(tmp_path, monkeypatch):
    """``--workers N`` without ``--scheduler`` keeps meaning a local cluster of N workers."""
    asked = []

    class Refused(Exception):
        """The stand-in cluster's refusal to start."""

    def client(scheduler, workers):
        asked.append((scheduler, workers))
        raise Refused

    monkeypatch.setattr(campaign, "dask_client", client)
    with pytest.raises(Refused):
        run_tasks(_square, [Task("t0", (0,)), Task("t1", (1,))], PointFolder(tmp_path),
                  workers=3, progress=False)
    assert asked == [("local:3", 3)]


def test_a_small_monte_carlo_runs_in_this_process_and_says_so(tmp_path, monkeypatch, capsys):
    monkeypatch.setattr(campaign, "dask_client", _no_cluster)
    out = tmp_path / "mc"
    arguments = ["montecarlo", str(TINY), "-o", str(out), "-n", "2", "-a", "bpa", "rda",
                 "--cuts", "1"]
    assert main(arguments) == 0
    err = capsys.readouterr().err
    for phase in ("Monte Carlo: 2 realisations x bpa, rda",
                  "montecarlo: 2 realisations to run", "in this process",
                  "montecarlo: table of 2 realisations",
                  "cuts: drawing 2 figures of 1 realisations",
                  "cut figures:"):
        assert phase in err, (phase, err)
    assert (out / "cuts_bpa.png").is_file() and (out / montecarlo.CUTS_RECORD).is_file()

    # The rerun finds everything recorded: nothing simulated, no cluster, cuts not redrawn.
    figure = (out / "cuts_rda.png").stat().st_mtime_ns
    monkeypatch.setattr(runs, "run_simulation", _no_run)
    monkeypatch.setattr(campaign, "_run_inline", _no_run)
    assert main(arguments) == 0
    err = capsys.readouterr().err
    assert "all 2 realisations already recorded, nothing to run" in err
    assert "cuts: 2 figures up to date" in err
    assert (out / "cuts_rda.png").stat().st_mtime_ns == figure


def test_a_no_op_sweep_rerun_runs_nothing_and_rewrites_nothing(tmp_path, monkeypatch, capsys):
    out = tmp_path / "sweep"
    first = run_sweep(TINY, VARY, out, scheduler=None, progress=False)
    assert first.attrs["runs"] == 4 and (out / OUTPUTS_FILE).is_file()
    files = sorted(p for p in out.rglob("*") if p.is_file())
    before = {p: p.stat().st_mtime_ns for p in files}
    monkeypatch.setattr(campaign, "dask_client", _no_cluster)
    monkeypatch.setattr(campaign, "_run_inline", _no_run)
    start = time.perf_counter()
    again = run_sweep(TINY, VARY, out, progress=True)
    elapsed = time.perf_counter() - start
    # In this process (imports done) the rerun costs ~0.1-0.3 s: validating 4 points, reading
    # their records, building the table. 2 s is the bound for the whole command,
    # generous here for a loaded shared machine.
    assert elapsed < 2.0
    assert {p: p.stat().st_mtime_ns for p in files} == before
    err = capsys.readouterr().err
    assert "all 4 runs already recorded, nothing to run" in err and "up to date" in err
    np.testing.assert_array_equal(again["range_irw_cells"].values,
                                  first["range_irw_cells"].values)
    # A changed sweep is not a no-op: a new point runs and the outputs are rewritten.
    monkeypatch.undo()
    bigger = run_sweep(TINY, ["look.off_nadir_deg=55,56,57", VARY[1]], out, scheduler=INLINE,
                       progress=False, figures=False)
    assert bigger.attrs["runs"] == 6
    assert (out / "sweep.nc").stat().st_mtime_ns > before[out / "sweep.nc"]


def test_cuts_simulate_each_realisation_once_for_all_algorithms(monkeypatch):
    experiment = load_experiment(TINY)
    single = montecarlo.realisation_cuts(experiment, "rda", 2)
    calls = []
    simulate = runs.run_simulation

    def counted(trial, *args, **kwargs):
        calls.append(trial.simulation.seed)
        return simulate(trial, *args, **kwargs)

    monkeypatch.setattr(runs, "run_simulation", counted)
    both = montecarlo.realisations_cuts(experiment, ["bpa", "rda"], 2, progress=False)
    assert len(calls) == 3  # the nominal response and 2 realisations, not 3 per algorithm
    for direction in ("range", "azimuth"):
        np.testing.assert_array_equal(both["rda"]["nominal"][direction],
                                      single["nominal"][direction])
        for mine, theirs in zip(both["rda"]["realisations"], single["realisations"],
                                strict=True):
            np.testing.assert_array_equal(mine[direction], theirs[direction])


def test_a_script_without_a_main_guard_is_recognised(tmp_path, monkeypatch):
    guarded = tmp_path / "guarded.py"
    guarded.write_text("import x\nif __name__ == '__main__':\n    x.run()\n")
    bare = tmp_path / "bare.py"
    bare.write_text("import x\nx.run()\n")
    monkeypatch.setitem(sys.modules, "__main__", types.SimpleNamespace(__file__=str(guarded)))
    assert missing_main_guard() is None
    monkeypatch.setitem(sys.modules, "__main__", types.SimpleNamespace(__file__=str(bare)))
    assert missing_main_guard() == str(bare)
    # Asked for a local cluster: a mitsar error naming the script and the fix, before any
    # worker process is started.
    with pytest.raises(ClusterStartError, match=r"bare\.py.*if __name__ == '__main__':") as error:
        run_tasks(_square, [Task(f"t{i}", (i,)) for i in range(3)], PointFolder(tmp_path),
                  scheduler="local:2", progress=False)
    assert isinstance(error.value, MitsarError)
    # Chosen by cost: the same numbers in this process, with a warning naming the fix.
    monkeypatch.setattr(campaign, "choose_scheduler", lambda *a, **k: SchedulerChoice(
        "local:2", 3, 100.0, 300.0, 160.0, "on a local cluster of 2 workers (test)"))
    with pytest.warns(MitsarWarning, match=r"bare\.py.*in this process instead"):
        records = run_tasks(_square, [Task(f"u{i}", (i,)) for i in range(3)],
                            PointFolder(tmp_path), progress=False)
    assert [records[f"u{i}"]["result"] for i in range(3)] == [0, 1, 4]


def _square(i: int) -> int:
    return i * i


def test_a_script_without_a_main_guard_gets_the_fix_not_a_nanny_traceback(tmp_path):
    """The issue's case end to end: `python script.py` (no guard) asking for a local cluster."""
    script = tmp_path / "campaign_script.py"
    script.write_text(textwrap.dedent(f"""
        from mitsar.experiment.sweep import run_sweep
        run_sweep({str(TINY)!r}, ["look.off_nadir_deg=55,56"], {str(tmp_path / "out")!r},
                  scheduler="local:2", progress=False, figures=False)
        """))
    result = subprocess.run([sys.executable, str(script)], capture_output=True, text=True,
                            timeout=300, cwd=tmp_path)
    assert result.returncode != 0
    assert "ClusterStartError" in result.stderr
    assert "campaign_script.py has no `if __name__ == '__main__':` guard" in result.stderr
    assert "Nanny" not in result.stderr  # refused before any worker process started
