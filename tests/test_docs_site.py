"""The documentation site builds with ``mkdocs build --strict`` and renders the public API.

Skipped, with the reason, where MkDocs is not installed (``pip install -e ".[docs]"``). The
tutorials are not executed here (``MITSAR_DOCS_EXECUTE=0``: tests/test_tutorials.py runs them);
``make docs`` executes them.
"""

from __future__ import annotations

import os
import re
import subprocess
import sys
from pathlib import Path

import pytest

import mitsar

ROOT = Path(__file__).resolve().parents[1]
pytest.importorskip("mkdocs", reason="MkDocs is not installed (the 'docs' extra)")
pytest.importorskip("mkdocstrings", reason="mkdocstrings is not installed (the 'docs' extra)")
pytest.importorskip("material", reason="mkdocs-material is not installed (the 'docs' extra)")
pytest.importorskip("jupytext", reason="jupytext is not installed (the 'docs' extra)")


@pytest.fixture(scope="module")
def site(tmp_path_factory: pytest.TempPathFactory) -> Path:
    out = tmp_path_factory.mktemp("site")
    env = dict(os.environ, MITSAR_DOCS_EXECUTE="0", NO_MKDOCS_2_WARNING="1", MPLBACKEND="Agg")
    done = subprocess.run([sys.executable, "-m", "mkdocs", "build", "--strict", "-q",
                           "-d", str(out)], cwd=ROOT, env=env, capture_output=True, text=True,
                          timeout=300)
    assert done.returncode == 0, done.stdout[-4000:] + done.stderr[-4000:]
    return out


@pytest.mark.slow
def test_every_public_name_has_a_rendered_api_section(site: Path) -> None:
    html = "".join(p.read_text() for p in (site / "api").rglob("*.html"))
    missing = [name for name in mitsar.__all__ if f'id="mitsar.{name}"' not in html]
    assert not missing


@pytest.mark.slow
def test_plugin_tables_list_every_parameter(site: Path) -> None:
    from mitsar.plugins.bsdfs import doublelobe, pointtarget
    from mitsar.plugins.integrators.radar.config import PARAMETERS

    html = (site / "plugins" / "index.html").read_text()
    for name in (*PARAMETERS, *doublelobe.PARAMETERS, *pointtarget.PARAMETERS):
        assert re.search(rf"<td><code>{name}</code></td>", html), name


@pytest.mark.slow
def test_tutorial_pages_and_guides_are_in_the_site(site: Path) -> None:
    for path in (ROOT / "tutorials").glob("[0-9]*.py"):
        assert (site / "tutorials" / path.stem / "index.html").is_file(), path.name
    assert (site / "gallery" / "index.html").is_file()
    assert (site / "focusing" / "index.html").is_file()
