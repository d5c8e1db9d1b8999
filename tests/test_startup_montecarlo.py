"""A finished Monte Carlo run again costs only its reading (docs/reliability.md §7).

A no-op rerun (every realisation on disk, ``summary.nc`` and ``summary.txt`` made from these
records) prints the recorded table: in a fresh interpreter it loads no Mitsuba, Dr.Jit,
Matplotlib, Dask (xarray imports Dask's arrays for any Dataset it builds, so the rerun builds
none), no focuser and no simulator. Reading the experiment needs neither the focusers (the
algorithms' names are written out in :mod:`mitsar.experiment.options`) nor SciPy's splines.

Measured (2 shared cores, load 3-5, the whole process, CPU-s): 0.8-1.0 against 1.4-1.7
before. The CPU bound below, 2 CPU-s, is issue 27's bound with room for a loaded machine; what
can fail here even on an idle one is the list of modules loaded.
"""

from __future__ import annotations

import json
import subprocess
import sys
from pathlib import Path

from mitsar.cli import main
from mitsar.experiment import montecarlo, options
from mitsar.experiment.loading import load_experiment
from mitsar.focus import dispatch

ROOT = Path(__file__).resolve().parents[1]
TINY = ROOT / "examples" / "campaign_tiny.toml"
NOT_LOADED = ("mitsuba", "drjit", "matplotlib", "distributed", "dask", "mitsar.focus.dispatch",
              "mitsar.raw.analytic", "mitsar.raw.traced", "mitsar.quality.impulse",
              "mitsar.experiment.runs", "scipy.interpolate")
"""Modules a no-op Monte Carlo rerun must not load."""

_PROBE = """
import json, sys, time
clock = time.process_time()
from mitsar.cli import main
result = main({arguments!r})
print(json.dumps({{"loaded": sorted(m for m in {names!r} if m in sys.modules),
                  "cpu": time.process_time() - clock, "result": result}}))
"""


def _probe(arguments: list[str]) -> tuple[dict, list[str]]:
    """``mitsar ARGUMENTS`` in a fresh interpreter: which of :data:`NOT_LOADED` it loaded, its
    CPU-s and exit code; and the lines it printed before that."""
    done = subprocess.run([sys.executable, "-c", _PROBE.format(arguments=arguments,
                                                               names=NOT_LOADED)],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    lines = done.stdout.rstrip("\n").splitlines()
    return json.loads(lines[-1]), lines[:-1]


def test_the_algorithm_names_are_the_focusers():
    """The names written out for the experiment are :func:`mitsar.focus`'s."""
    assert options.ALGORITHMS == dispatch.ALGORITHMS


def test_a_no_op_montecarlo_rerun_reads_its_table_and_loads_no_stage(tmp_path):
    out = tmp_path / "mc"
    arguments = ["montecarlo", str(TINY), "-n", "2", "-a", "bpa", "--cuts", "0", "-o", str(out),
                 "-q"]
    assert main(arguments) == 0  # the campaign, in this process
    table = (out / "summary.txt").read_text(encoding="utf-8")

    probe, printed = _probe(arguments)
    assert probe["result"] == 0
    assert probe["loaded"] == [], probe
    assert "\n".join(printed) + "\n" == table  # what the first run printed and wrote
    assert probe["cpu"] < 2.0, probe

    # The probe can see a stage: a rerun that has a realisation left to run loads them.
    probe, _ = _probe(arguments[:2] + ["-n", "3"] + arguments[4:-1]
                      + ["--scheduler", "inline", "-q"])
    assert "mitsar.focus.dispatch" in probe["loaded"] and "dask" in probe["loaded"], probe


def test_finished_table_is_none_until_everything_is_recorded_and_written(tmp_path):
    experiment = load_experiment(TINY)
    out = tmp_path / "mc"
    assert montecarlo.finished_table(experiment, 1, ["bpa"], out_dir=out, progress=False) is None
    summary = montecarlo.run(experiment, 1, ["bpa"], out_dir=out, progress=False,
                             scheduler="inline")
    table = montecarlo.finished_table(experiment, 1, ["bpa"], out_dir=out, progress=False)
    assert table == montecarlo.format_table(summary)
    # another realisation to run, or a table file gone: the full run decides
    assert montecarlo.finished_table(experiment, 2, ["bpa"], out_dir=out, progress=False) is None
    (out / montecarlo.TABLE_FILE).unlink()
    assert montecarlo.finished_table(experiment, 1, ["bpa"], out_dir=out, progress=False) is None
