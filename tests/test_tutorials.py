"""The tutorials (tutorials/*.py, Jupytext percent scripts) run top to bottom.

Each runs as a script in a subprocess on reduced sizes (``MITSAR_TUTORIAL_QUICK=1``), with a
timeout; a tutorial ends with assertions on what it showed, so a wrong result fails too.
Measured on 2 shared cores: 3-16 s each, about 40 s for the six.
"""

from __future__ import annotations

import os
import subprocess
import sys
from pathlib import Path

import pytest

ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = sorted((ROOT / "tutorials").glob("[0-9]*.py"))
TIMEOUT_S = 120


def test_there_are_tutorials() -> None:
    assert len(TUTORIALS) >= 4, TUTORIALS


@pytest.mark.slow
@pytest.mark.parametrize("path", TUTORIALS, ids=lambda p: p.stem)
def test_tutorial_runs(path: Path, tmp_path: Path) -> None:
    env = dict(os.environ, MITSAR_TUTORIAL_QUICK="1", MPLBACKEND="Agg", TMPDIR=str(tmp_path))
    done = subprocess.run([sys.executable, str(path)], cwd=tmp_path, env=env,
                          capture_output=True, text=True, timeout=TIMEOUT_S)
    assert done.returncode == 0, \
        f"{path.name} failed:\n{done.stdout[-3000:]}\n{done.stderr[-3000:]}"


@pytest.mark.parametrize("path", TUTORIALS, ids=lambda p: p.stem)
def test_tutorial_is_a_percent_script(path: Path) -> None:
    text = path.read_text()
    assert text.startswith("# %% [markdown]\n# # "), "a tutorial opens with its title cell"
    assert text.count("# %%") >= 4
