"""Imports proportionate to the work (issue 27 item 3): ``import mitsar`` and a no-op campaign
rerun load neither Mitsuba, Dr.Jit, Matplotlib nor Dask's distributed scheduler.

The public names are imported on first use (PEP 562 ``__getattr__`` in ``mitsar`` and its
sub-packages), the CLI imports a command's module when it runs, and Matplotlib, Dr.Jit and
SciPy's signal tools are imported where they are used. Each check runs in a fresh interpreter
(``sys.modules`` of this test process holds whatever other tests imported).

Timing: the no-op rerun's CPU time is asserted, not its wall time, which on the shared 2-core
machine varies several-fold with the other sessions' load. Measured (load 4-6, the whole
process): sweep 1.4-1.5 CPU-s (1.5-1.6 s wall), Monte Carlo 1.7-2.3 CPU-s, against 2.7-3.1 and
3.4-4.0 before (docs/reliability.md §7). The bound, 3 CPU-s, is the issue's 2 s with 50 % slack
for a loaded machine (CPU time grows with the load too, by cache and memory contention).
"""

from __future__ import annotations

import importlib
import json
import subprocess
import sys
from pathlib import Path

import pytest

import mitsar
from mitsar.cli import main

ROOT = Path(__file__).resolve().parents[1]
TINY = ROOT / "examples" / "campaign_tiny.toml"
HEAVY = ("mitsuba", "drjit", "matplotlib", "distributed")
"""Packages a command that computes and draws nothing must not load."""

_PROBE = """
import json, sys, time
clock = time.process_time()
{body}
print(json.dumps({{"heavy": sorted({{m.split(".")[0] for m in sys.modules}} & set({heavy!r})),
                  "cpu": time.process_time() - clock, "result": result}}))
"""


def _probe(body: str) -> dict:
    """Run ``body`` (which sets ``result``) in a fresh interpreter; its heavy modules, CPU-s."""
    done = subprocess.run([sys.executable, "-c", _PROBE.format(body=body, heavy=HEAVY)],
                          capture_output=True, text=True, timeout=120, cwd=ROOT)
    assert done.returncode == 0, done.stderr[-2000:]
    return json.loads(done.stdout.strip().splitlines()[-1])


def test_import_mitsar_loads_no_stage():
    out = _probe("import mitsar, mitsar.experiment, mitsar.focus, mitsar.scene\n"
                 "result = sorted(m for m in sys.modules if m.startswith('mitsar.'))")
    assert out["heavy"] == []
    assert not [m for m in out["result"] if m.split(".")[1] in ("focus", "raw", "scene")
                and m.count(".") > 1], out["result"]  # the stages wait for a name's first use
    out = _probe("import mitsar.cli\nresult = None")  # the parser: option choices, no command
    assert out["heavy"] == []


def test_every_public_name_resolves_and_focus_stays_the_function():
    importlib.import_module("mitsar.focus.grid")  # binds the sub-package mitsar.focus on mitsar
    from mitsar.focus.dispatch import focus

    for name in mitsar.__all__:
        assert getattr(mitsar, name) is not None, name
    assert getattr(mitsar.focus, "__wrapped__", mitsar.focus) is focus  # mitsar.errors.public
    assert mitsar.grid.__name__ == "mitsar.focus.grid"
    assert mitsar.ambiguity.__name__ == "mitsar.ambiguity"
    assert set(mitsar.__all__) <= set(dir(mitsar))
    with pytest.raises(AttributeError, match="no attribute 'nonexistent'"):
        mitsar.nonexistent  # noqa: B018


@pytest.mark.slow
def test_a_no_op_campaign_rerun_loads_no_heavy_package(tmp_path):
    """A finished 2 x 2 sweep and a finished Monte Carlo, rerun from the command line in a
    fresh interpreter: nothing runs, nothing is drawn, nothing heavy is imported."""
    sweep = ["sweep", str(TINY), "--vary", "look.off_nadir_deg=55,56",
             "--vary", "trajectory.speed=0.5,1.0", "-o", str(tmp_path / "sweep"), "-q"]
    monte_carlo = ["montecarlo", str(TINY), "-n", "2", "-a", "bpa", "--cuts", "1",
                   "-o", str(tmp_path / "mc"), "-q"]
    for arguments in (sweep, monte_carlo):
        assert main(arguments) == 0  # the campaign, in this process
        out = _probe(f"from mitsar.cli import main\nresult = main({arguments!r})")
        assert out["result"] == 0
        assert out["heavy"] == [], (arguments[0], out)
        assert out["cpu"] < 3.0, (arguments[0], out)
