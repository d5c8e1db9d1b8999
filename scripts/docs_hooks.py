"""MkDocs hooks of the documentation site (``mkdocs.yml``: ``hooks``).

What the site shows that is generated from the code at build time, so it cannot drift:

- ``<!-- mitsar:plugin-table NAME -->`` in a page becomes the XML parameter table of plugin NAME
  (``scripts/plugin_tables.py``);
- ``<!-- mitsar:api-index -->`` becomes the table of every name in ``mitsar.__all__`` with the
  API page that renders it; a public name that no page under ``docs/api/`` renders
  (``::: mitsar.NAME``) fails the build;
- the tutorials ``tutorials/*.py`` (Jupytext percent scripts) become the pages
  ``tutorials/NAME.md``: Markdown cells as text, code cells as code followed by what they
  printed, the value of their last expression and the figures they drew. The cells run in this
  process, in order, in one namespace per tutorial (a minimal notebook executor: no Jupyter
  kernel needed), with ``MITSAR_TUTORIAL_QUICK`` as set in the environment; a cell that raises
  fails the build. ``MITSAR_DOCS_EXECUTE=0`` renders the source only (the tests do that: they
  run the tutorials themselves, in ``tests/test_tutorials.py``).
"""

from __future__ import annotations

import ast
import contextlib
import io
import logging
import os
import re
import sys
import time
from pathlib import Path
from typing import Any

sys.path.insert(0, str(Path(__file__).resolve().parent))

import plugin_tables  # noqa: E402

LOG = logging.getLogger("mkdocs.hooks.mitsar")
ROOT = Path(__file__).resolve().parents[1]
TUTORIALS = ROOT / "tutorials"
PLUGIN_TABLE = re.compile(r"<!-- mitsar:plugin-table ([\w-]+) -->")
API_INDEX = "<!-- mitsar:api-index -->"
MAX_OUTPUT_LINES = 60


# ---- API index ---------------------------------------------------------------------------------

def api_index(docs_dir: Path) -> str:
    """The table of the public names and the API page of each (raises for a missing one)."""
    import mitsar

    pages: dict[str, str] = {}
    for page in sorted((docs_dir / "api").glob("*.md")):
        for name in re.findall(r"^::: mitsar\.(\w+)\s*$", page.read_text(), re.MULTILINE):
            pages.setdefault(name, page.name)
    missing = [name for name in mitsar.__all__ if name not in pages]
    if missing:
        raise LookupError(f"public names without an API page (add '::: mitsar.NAME' to a page "
                          f"of docs/api/): {missing}")
    rows = ["| name | kind | summary |", "|---|---|---|"]
    for name in sorted(mitsar.__all__, key=str.lower):
        obj = getattr(mitsar, name)
        kind = ("module" if type(obj).__name__ == "module" else "class" if isinstance(obj, type)
                else "function" if callable(obj) else "constant")
        summary = (getattr(obj, "__doc__", None) or "").strip().split("\n\n")[0]
        summary = " ".join(summary.split()) if kind != "constant" else f"`{obj!r}`"
        summary = plugin_tables._escape(summary)
        rows.append(f"| [`{name}`]({pages[name]}#mitsar.{name}) | {kind} | {summary} |")
    return "\n".join(rows)


# ---- tutorials ---------------------------------------------------------------------------------

def _figures() -> list[bytes]:
    """The open matplotlib figures as PNG bytes, then closed."""
    if "matplotlib.pyplot" not in sys.modules:
        return []
    plt = sys.modules["matplotlib.pyplot"]
    images = []
    for number in plt.get_fignums():
        buffer = io.BytesIO()
        plt.figure(number).savefig(buffer, format="png", dpi=90, bbox_inches="tight")
        images.append(buffer.getvalue())
    plt.close("all")
    return images


def _shown(value: Any) -> str | None:
    """What a notebook would show for a cell's last expression (text only; figures aside)."""
    if value is None or type(value).__module__.startswith("matplotlib"):
        return None
    if isinstance(value, list | tuple) and value and all(
            type(v).__module__.startswith("matplotlib") for v in value):
        return None
    return repr(value)


def _clip(text: str) -> str:
    lines = text.rstrip().splitlines()
    if len(lines) > MAX_OUTPUT_LINES:
        lines = lines[:MAX_OUTPUT_LINES] + [f"... ({len(lines) - MAX_OUTPUT_LINES} more lines)"]
    return "\n".join(lines)


def run_cell(source: str, namespace: dict[str, Any], where: str) -> tuple[str, list[bytes]]:
    """Execute one code cell; return its text output (stdout and the last expression's value)
    and its figures."""
    tree = ast.parse(source, filename=where)
    last = tree.body.pop() if tree.body and isinstance(tree.body[-1], ast.Expr) else None
    out = io.StringIO()
    with contextlib.redirect_stdout(out):
        exec(compile(tree, where, "exec"), namespace)  # noqa: S102 (the project's own tutorials)
        if last is not None:
            value = eval(compile(ast.Expression(last.value), where, "eval"), namespace)
            shown = _shown(value)
            if shown is not None:
                print(shown)
    return out.getvalue(), _figures()


def render_tutorial(path: Path, execute: bool) -> tuple[str, list[tuple[str, bytes]]]:
    """The Markdown page of a tutorial and its figures ``[(file name, PNG bytes)]``."""
    import jupytext

    notebook = jupytext.read(path)
    stem = path.stem
    parts: list[str] = []
    images: list[tuple[str, bytes]] = []
    namespace: dict[str, Any] = {"__name__": "__main__", "__file__": str(path)}
    started = time.perf_counter()
    cwd = os.getcwd()
    if execute:
        os.chdir(ROOT)
    try:
        for index, cell in enumerate(notebook.cells):
            source = cell.source.strip("\n")
            if cell.cell_type == "markdown":
                parts.append(source)
                continue
            if not source.strip():
                continue
            parts.append(f"```python\n{source}\n```")
            if not execute:
                continue
            text, figures = run_cell(source, namespace, f"{path.name}, cell {index}")
            if text.strip():
                parts.append(f'```text\n{_clip(text)}\n```')
            for figure in figures:
                name = f"{stem}_{len(images) + 1}.png"
                images.append((name, figure))
                parts.append(f"![figure {len(images)} of {stem}]({name})")
    finally:
        os.chdir(cwd)
        if "matplotlib.pyplot" in sys.modules:
            sys.modules["matplotlib.pyplot"].close("all")
    source_link = (f"*This page is the tutorial `tutorials/{path.name}` "
                   + (f"executed when the site was built ({time.perf_counter() - started:.0f} s"
                      ", reduced sizes)." if execute and os.environ.get("MITSAR_TUTORIAL_QUICK")
                      else f"executed when the site was built "
                      f"({time.perf_counter() - started:.0f} s)." if execute
                      else "(source only: this build did not execute it).")
                   + " Open it in Jupyter with `jupytext --to notebook` or run it as a script.*")
    return "\n\n".join([parts[0], source_link, *parts[1:]]) + "\n", images


def _execute() -> bool:
    return os.environ.get("MITSAR_DOCS_EXECUTE", "1") not in ("0", "", "false", "no")


# ---- hooks -------------------------------------------------------------------------------------

def on_config(config: Any) -> Any:
    """Render the plugins with the CPU (LLVM) backend and no GUI."""
    os.environ.setdefault("MPLBACKEND", "Agg")
    return config


def on_files(files: Any, config: Any) -> Any:
    """Add the tutorial pages (and their figures) to the site."""
    from mkdocs.structure.files import File

    execute = _execute()
    index = ["# Tutorials", "",
             "Each tutorial is a Jupytext percent script in `tutorials/` of the repository: "
             "run it as a script (`python tutorials/01_first_image.py`), or open it as a "
             "notebook (`jupytext --to notebook tutorials/01_first_image.py`). "
             "`MITSAR_TUTORIAL_QUICK=1` runs it on reduced sizes, as the tests do "
             "(`tests/test_tutorials.py`).", ""]
    for path in sorted(TUTORIALS.glob("[0-9]*.py")):
        started = time.perf_counter()
        page, images = render_tutorial(path, execute)
        LOG.info("tutorial %s: %.1f s%s", path.name, time.perf_counter() - started,
                 "" if execute else " (not executed)")
        title = page.splitlines()[0].lstrip("# ").strip()
        index.append(f"- [{title}]({path.stem}.md)")
        files.append(File.generated(config, f"tutorials/{path.stem}.md", content=page))
        for name, data in images:
            files.append(File.generated(config, f"tutorials/{name}", content=data))
    files.append(File.generated(config, "tutorials/index.md", content="\n".join(index) + "\n"))
    return files


def on_page_markdown(markdown: str, page: Any, config: Any, files: Any) -> str:
    """Fill the generated tables."""
    markdown = PLUGIN_TABLE.sub(lambda m: plugin_tables.TABLES[m.group(1)](), markdown)
    if API_INDEX in markdown:
        markdown = markdown.replace(API_INDEX, api_index(Path(config["docs_dir"])))
    return markdown


__all__ = ["api_index", "on_config", "on_files", "on_page_markdown", "render_tutorial",
           "run_cell"]
