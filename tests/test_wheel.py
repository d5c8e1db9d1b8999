"""A wheel that works anywhere (issue 26): build the sdist and the wheel from the checkout,
install the wheel in a fresh virtual environment in a temporary folder and run the command line
from a folder that is not the checkout: ``mitsar --help``, every sub-command's ``--help``,
``mitsar demo``, ``mitsar run`` on the smallest bundled example, ``mitsar preview`` of a scene
example, and every bundled scene loaded by name.

The fresh environment reuses the checkout environment's installed dependencies (a ``.pth`` file
naming its site-packages: installing Mitsuba, Dr.Jit, SciPy, Dask, ... from the registry would
take minutes) but holds its own ``mitsar``, from the wheel: the test asserts that ``mitsar``,
its examples and its scenes are imported and read from the fresh environment. A ``.pth`` line
only extends ``sys.path``; the checkout's editable-install finder (itself started by a ``.pth``
file in the checkout's site-packages) is not run there.

``make test`` runs this module, so CI builds and smoke-tests the wheel on every run (about a
minute on 2 cores: the build takes seconds, the commands a few seconds each).
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import sysconfig
import time
import zipfile
from pathlib import Path

import pytest

pytestmark = pytest.mark.slow

ROOT = Path(__file__).resolve().parents[1]

SMALLEST_EXAMPLE = "campaign_tiny"
"""The smallest bundled experiment with a point target (0.6 m of track, a 21 x 21 grid)."""

SCENE_EXAMPLE = "scene_point_target"
"""A bundled experiment whose scene is a bundled scene named in its TOML file."""

TIMES: dict[str, float] = {}
"""Wall time of each step [s], printed at the end (pytest -s) and written beside the venv."""


def _run(command: list[str], cwd: Path, env: dict[str, str] | None = None,
         step: str | None = None, timeout: float = 300) -> subprocess.CompletedProcess:
    start = time.perf_counter()
    result = subprocess.run(command, cwd=cwd, env=env, capture_output=True, text=True,
                            timeout=timeout)
    if step:
        TIMES[step] = time.perf_counter() - start
    assert result.returncode == 0, (
        f"{' '.join(command)} (in {cwd}) exited {result.returncode}\n"
        f"--- stdout\n{result.stdout[-4000:]}\n--- stderr\n{result.stderr[-4000:]}")
    return result


def _inside(path: str | Path, folder: Path) -> bool:
    return Path(path).resolve().is_relative_to(folder.resolve())


@pytest.fixture(scope="module")
def dist(tmp_path_factory) -> dict[str, Path]:
    """The sdist and the wheel, built from the checkout (without build isolation: the checkout
    environment's setuptools, so no download)."""
    out = tmp_path_factory.mktemp("dist")
    _run([sys.executable, "-m", "build", "--no-isolation", "--outdir", str(out), str(ROOT)],
         cwd=ROOT, step="build sdist + wheel")
    wheels, sdists = sorted(out.glob("*.whl")), sorted(out.glob("*.tar.gz"))
    assert len(wheels) == 1 and len(sdists) == 1, sorted(out.iterdir())
    return {"wheel": wheels[0], "sdist": sdists[0]}


@pytest.fixture(scope="module")
def venv(dist, tmp_path_factory) -> dict:
    """A fresh virtual environment in a temporary folder with the wheel installed, and the
    environment variables and working folder to run it outside the checkout."""
    home = tmp_path_factory.mktemp("wheel-venv")
    prefix = home / "venv"
    clean = {key: value for key, value in os.environ.items()
             if key not in ("PYTHONPATH", "PYTHONHOME", "VIRTUAL_ENV", "MITSAR_EXAMPLES")}
    start = time.perf_counter()
    _run([sys.executable, "-m", "venv", "--without-pip", str(prefix)], cwd=home, env=clean)
    python = prefix / "bin" / "python"
    # the wheel first, alone (pip must not see the checkout's editable mitsar)
    _run([sys.executable, "-m", "pip", "--python", str(python), "install", "--no-deps",
          "--no-index", "--no-compile", "-q", str(dist["wheel"])], cwd=home, env=clean)
    purelib = Path(_run([str(python), "-c", "import sysconfig; print(sysconfig.get_paths()"
                         "['purelib'])"], cwd=home, env=clean).stdout.strip())
    assert (purelib / "mitsar" / "__init__.py").is_file(), "the wheel was not installed"
    dependencies = sorted({sysconfig.get_paths()[key] for key in ("purelib", "platlib")})
    (purelib / "_checkout_dependencies.pth").write_text("\n".join(dependencies) + "\n")
    TIMES["fresh venv + pip install wheel"] = time.perf_counter() - start
    work = home / "work"  # not the checkout: no examples/ or scenes/ beside it
    work.mkdir()
    env = dict(clean)
    env.update(PATH=f"{prefix / 'bin'}{os.pathsep}{os.environ.get('PATH', '')}",
               PYTHONNOUSERSITE="1", VIRTUAL_ENV=str(prefix))
    yield {"prefix": prefix, "python": python, "mitsar": prefix / "bin" / "mitsar",
           "env": env, "work": work}
    print("\nwheel smoke test [s]: " + ", ".join(f"{k} {v:.1f}" for k, v in TIMES.items()))
    (home / "times.json").write_text(json.dumps(TIMES, indent=1))


def _checkout_files(folder: str, patterns: tuple[str, ...]) -> set[str]:
    return {str(p.relative_to(ROOT / folder)) for pattern in patterns
            for p in (ROOT / folder).rglob(pattern) if "__pycache__" not in p.parts}


def test_wheel_and_sdist_carry_everything(dist):
    """Every module, example and scene file of the checkout is in the wheel and the sdist."""
    from mitsar.scene import canned

    names = set(zipfile.ZipFile(dist["wheel"]).namelist())
    modules = _checkout_files("mitsar", ("*.py",))
    assert not {f"mitsar/{m}" for m in modules} - names
    examples = _checkout_files("examples", ("*.toml", "*.py"))
    assert examples and not {f"mitsar/_examples/{e}" for e in examples} - names
    scene_root = Path(canned.SCENE_DIR)
    scene_files = {str(p.relative_to(scene_root)) for pattern in ("*.xml", "*.ply")
                   for p in scene_root.rglob(pattern)}
    installed_root = scene_root.relative_to(ROOT)
    if installed_root.parts[0] != "mitsar":  # a top-level data folder, installed in mitsar
        installed_root = Path(canned.PACKAGE.replace(".", "/"))
    assert scene_files and not {f"{installed_root}/{s}" for s in scene_files} - names
    import tarfile

    with tarfile.open(dist["sdist"]) as sdist:
        members = {m.split("/", 1)[1] for m in sdist.getnames() if "/" in m}
    assert {"pyproject.toml", "setup.py", "README.md"} <= members
    assert not {f"examples/{e}" for e in examples} - members
    assert not {f"{scene_root.relative_to(ROOT)}/{s}" for s in scene_files} - members
    size = dist["wheel"].stat().st_size
    print(f"\nwheel {dist['wheel'].name}: {size / 1e3:.0f} kB, {len(names)} files")


def test_installed_mitsar_is_the_wheel(venv):
    """mitsar, its examples and its scenes come from the fresh environment, not the checkout."""
    code = ("import json, mitsar\n"
            "from mitsar.experiment.examples import examples_dir\n"
            "from mitsar.scene import canned\n"
            "print(json.dumps({'module': mitsar.__file__, 'examples': str(examples_dir()),\n"
            "                  'scenes': str(canned.SCENE_DIR), 'names': canned.names()}))")
    found = json.loads(_run([str(venv["python"]), "-c", code], cwd=venv["work"],
                            env=venv["env"]).stdout)
    for key in ("module", "examples", "scenes"):
        assert _inside(found[key], venv["prefix"]), (key, found[key])
        assert not _inside(found[key], ROOT), (key, found[key])
    assert {"control_volume", "point_target", "dihedral"} <= set(found["names"])


def test_help_of_every_command(venv):
    """``mitsar --help`` (the installed script) and each sub-command's ``--help``."""
    result = _run([str(venv["mitsar"]), "--help"], cwd=venv["work"], env=venv["env"],
                  step="mitsar --help")
    assert "demo" in result.stdout and "Traceback" not in result.stderr
    code = ("import argparse, contextlib, io, sys\n"
            "from mitsar.cli import build_parser, main\n"
            "parser = build_parser()\n"
            "action = next(a for a in parser._actions\n"
            "              if isinstance(a, argparse._SubParsersAction))\n"
            "for name in action.choices:\n"
            "    text = io.StringIO()\n"
            "    with contextlib.redirect_stdout(text):\n"
            "        try:\n"
            "            main([name, '--help'])\n"
            "        except SystemExit as stop:\n"
            "            assert stop.code == 0, (name, stop.code)\n"
            "    assert 'usage: mitsar ' + name in text.getvalue(), name\n"
            "    print(name)\n")
    result = _run([str(venv["python"]), "-c", code], cwd=venv["work"], env=venv["env"],
                  step="every sub-command --help")
    helped = result.stdout.split()
    assert {"simulate", "focus", "demo", "run", "preview", "sweep", "montecarlo"} <= set(helped)


def test_demo_run_and_preview(venv):
    """``mitsar demo``, ``mitsar run`` on the smallest example, ``mitsar preview`` of a bundled
    scene example, all with outputs in a folder that is not the checkout."""
    mitsar, work, env = str(venv["mitsar"]), venv["work"], venv["env"]
    result = _run([mitsar, "demo", "-o", "demo", "--example", SMALLEST_EXAMPLE, "-q"], cwd=work,
                  env=env, step="mitsar demo")
    assert "paper Table 4" in result.stdout
    assert {"raw.nc", "image.nc", "metrics.json", "image.png"} <= {
        p.name for p in (work / "demo").iterdir()}
    example = _run([str(venv["python"]), "-c", "from mitsar.experiment import example_path; "
                    f"print(example_path({SMALLEST_EXAMPLE!r}))"], cwd=work, env=env)
    example_file = example.stdout.strip()
    assert _inside(example_file, venv["prefix"])
    _run([mitsar, "run", example_file, "-o", "run", "-q"], cwd=work, env=env, step="mitsar run")
    assert (work / "run" / "report.html").is_file() and (work / "run" / "run.json").is_file()
    scene_example = _run([str(venv["python"]), "-c", "from mitsar.experiment import "
                          f"example_path; print(example_path({SCENE_EXAMPLE!r}))"],
                         cwd=work, env=env).stdout.strip()
    _run([mitsar, "preview", scene_example, "-o", "preview.png", "-q"], cwd=work, env=env,
         step="mitsar preview")
    assert (work / "preview.png").stat().st_size > 10_000


def test_every_bundled_scene_loads_by_name(venv):
    """Each bundled scene (``mitsar.scene.canned.names()``) loads by name from the wheel."""
    code = ("from mitsar.scene import canned, load_scene, scene_surfaces\n"
            "for name in canned.names():\n"
            "    surfaces = scene_surfaces(load_scene(name))\n"
            "    assert surfaces, name\n"
            "    print(name, canned.path(name))\n")
    result = _run([str(venv["python"]), "-c", code], cwd=venv["work"], env=venv["env"],
                  step="load every scene by name")
    lines = [line.split() for line in result.stdout.splitlines() if line.strip()]
    assert len(lines) >= 7
    for name, path in lines:
        assert _inside(path, venv["prefix"]), (name, path)


def test_parser_needs_no_data_files(monkeypatch, tmp_path, capsys):
    """Without the examples, the parser still builds and every command but the demo runs; the
    demo says what is missing (issue 26: every command died in build_parser)."""
    from mitsar.cli import build_parser, demo, main
    from mitsar.errors import MitsarError
    from mitsar.experiment import examples

    def missing() -> Path:
        raise MitsarError("bundled examples not found (test)")

    monkeypatch.setattr(examples, "examples_dir", missing)
    monkeypatch.setattr(demo, "examples_dir", missing)
    build_parser()
    for command in ([], ["demo"], ["run"], ["simulate"]):
        with pytest.raises(SystemExit) as stop:
            main([*command, "--help"])
        assert stop.value.code == 0
    capsys.readouterr()
    assert main(["demo", "-o", str(tmp_path / "demo")]) == 2
    assert "bundled examples not found" in capsys.readouterr().err
