"""The house rules of docs/design.md §3, checked on the source: imports run down the pipeline,
no import circle, and no function-level import of mitsar's own modules. Imports by name
(``importlib.import_module("mitsar.…")``, ``__import__``, or a module that imports names it
computes, e.g. from a tuple of module names) count as imports for the first two rules."""

from __future__ import annotations

import ast
import re
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "mitsar"

# Stages from the ground up (docs/design.md §2). A module may import its own stage and the ones
# below; a higher rank importing a lower one is the pipeline's direction.
RANKS = {
    "mitsar.errors": 0, "mitsar.version": 0, "mitsar.lazy": 0,
    "mitsar.checks": 1, "mitsar.budget": 1, "mitsar.backend": 1, "mitsar.io": 1,
    "mitsar.model": 2,
    "mitsar.products": 3,
    "mitsar.plugins": 4,
    "mitsar.scene": 5,
    "mitsar.raw": 6,
    "mitsar.focus": 7,
    "mitsar.quality": 8, "mitsar.interferometry": 8, "mitsar.plots": 8, "mitsar.export": 8,
    "mitsar.features": 8.5,
    "mitsar.experiment": 9,
    "mitsar.ambiguity": 10,
    "mitsar.report": 11,
    "mitsar.cli": 12,
    "mitsar": 13,
}

MODULE_NAME = re.compile(r"mitsar(\.[A-Za-z_]\w*)*")
"""A string that names a mitsar module (an import by name when the module imports by name)."""


def _module_name(path: Path) -> str:
    parts = list(path.relative_to(PACKAGE.parent).with_suffix("").parts)
    if parts[-1] == "__init__":
        parts.pop()
    return ".".join(parts)


MODULES = {_module_name(p): p for p in sorted(PACKAGE.rglob("*.py"))}


def _rank(module: str) -> int:
    parts = module.split(".")
    for n in range(len(parts), 0, -1):
        if ".".join(parts[:n]) in RANKS:
            return RANKS[".".join(parts[:n])]
    raise KeyError(module)


def _resolve(base: str, name: str | None) -> str:
    """The mitsar module that ``from base import name`` (or ``import base``) reaches."""
    if name is not None and f"{base}.{name}" in MODULES:
        return f"{base}.{name}"
    return base


def _is_import_call(node: ast.AST) -> bool:
    """``importlib.import_module(...)``, ``import_module(...)``, ``__import__(...)`` or
    ``LazyModule(...)`` (:class:`mitsar.lazy.LazyModule`: imported on first use, an import all
    the same)."""
    if not isinstance(node, ast.Call):
        return False
    func = node.func
    name = func.attr if isinstance(func, ast.Attribute) else getattr(func, "id", None)
    return name in ("import_module", "__import__", "LazyModule")


def _by_name(tree: ast.Module) -> list[str]:
    """mitsar modules imported by name: string literals passed to an import call, and, where a
    module passes a computed name (a variable, a loop over a tuple of names), every string
    constant of the module that names a mitsar module."""
    calls = [node for node in ast.walk(tree) if _is_import_call(node)]
    literal = [c.args[0].value for c in calls if c.args and isinstance(c.args[0], ast.Constant)
               and isinstance(c.args[0].value, str)]
    if any(not c.args or not isinstance(c.args[0], ast.Constant) for c in calls):
        literal += [node.value for node in ast.walk(tree) if isinstance(node, ast.Constant)
                    and isinstance(node.value, str)]
    return sorted({name for name in literal if MODULE_NAME.fullmatch(name)})


def _imports_of(source: str) -> tuple[list[str], list[tuple[int, str]]]:
    """(mitsar modules imported at module level or by name, (line, module) imported by an
    ``import`` statement inside functions) of a module's source."""
    tree = ast.parse(source)
    top: list[str] = []
    nested: list[tuple[int, str]] = []

    def targets(node: ast.AST) -> list[str]:
        if isinstance(node, ast.Import):
            return [a.name for a in node.names if a.name.split(".")[0] == "mitsar"]
        if isinstance(node, ast.ImportFrom) and node.level == 0 and node.module \
                and node.module.split(".")[0] == "mitsar":
            return [_resolve(node.module, a.name) for a in node.names]
        return []

    for node in tree.body:
        top += targets(node)
    top += _by_name(tree)
    for func in ast.walk(tree):
        if isinstance(func, ast.FunctionDef | ast.AsyncFunctionDef):
            for node in ast.walk(func):
                nested += [(node.lineno, t) for t in targets(node)]
    return top, nested


def _imports(module: str) -> tuple[list[str], list[tuple[int, str]]]:
    """:func:`_imports_of` of a module of the package."""
    return _imports_of(MODULES[module].read_text())


def _upward(module: str, imported: list[str]) -> list[str]:
    """The imports of ``module`` that run back up the stages."""
    return [t for t in imported if t != module and _rank(t) > _rank(module)]


GRAPH = {module: _imports(module) for module in MODULES}


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_run_down_the_pipeline(module):
    up = _upward(module, GRAPH[module][0])
    assert not up, f"{module} (stage rank {_rank(module)}) imports higher stages: {up}"


@pytest.mark.parametrize("module", sorted(MODULES))
def test_no_function_level_import_of_mitsar(module):
    assert not GRAPH[module][1], f"{module}: imports inside functions {GRAPH[module][1]}"


def _find_cycle(edges: dict[str, set[str]]) -> list[str] | None:
    """A loop of the directed graph ``edges`` (depth-first search), or None."""
    state: dict[str, int] = {}
    stack: list[str] = []

    def visit(node: str) -> list[str] | None:
        state[node] = 1
        stack.append(node)
        for nxt in sorted(edges.get(node, ())):
            if state.get(nxt) == 1:
                return stack[stack.index(nxt):] + [nxt]
            if nxt not in state and (found := visit(nxt)):
                return found
        stack.pop()
        state[node] = 2
        return None

    for node in sorted(edges):
        if node not in state and (found := visit(node)):
            return found
    return None


def test_no_import_circle():
    edges = {m: {t for t in GRAPH[m][0] if t in MODULES and t != m} for m in MODULES}
    cycle = _find_cycle(edges)
    assert cycle is None, "import circle: " + " -> ".join(cycle or [])


def test_the_checks_can_fail():
    """The helpers find a made-up loop and rank an upward import as such."""
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": {"a"}}) == ["a", "b", "c", "a"]
    assert _find_cycle({"a": {"b"}, "b": {"c"}, "c": set()}) is None
    assert _rank("mitsar.model.signal") < _rank("mitsar.raw.analytic")
    assert _resolve("mitsar.model", "histogram") == "mitsar.model.histogram"
    assert _resolve("mitsar.model.histogram", "bin_grid") == "mitsar.model.histogram"


UPWARD_BY_NAME = {
    "literal": 'import importlib\n\n'
               'def load():\n    return importlib.import_module("mitsar.raw.traced")\n',
    "from importlib": 'from importlib import import_module\n\n'
                      'def load():\n    return import_module("mitsar.focus")\n',
    "dunder": 'def load():\n    return __import__("mitsar.cli")\n',
    "lazy module": 'from mitsar.lazy import LazyModule\n\nfocus = LazyModule("mitsar.focus")\n',
    "tuple of names": 'import importlib\n\nNAMES = ("mitsar.model.radar", "mitsar.raw.traced")\n\n'
                      'def load():\n    return [importlib.import_module(n) for n in NAMES]\n',
}


@pytest.mark.parametrize("form", sorted(UPWARD_BY_NAME))
def test_an_upward_import_by_name_is_caught(form):
    """A string import from the scene stage up to ``raw``/``focus``/``cli`` is an upward import
    (the loop the issue found: the scene imported the plugins above it by name)."""
    top, nested = _imports_of(UPWARD_BY_NAME[form])
    assert _upward("mitsar.scene.loading", top), top
    assert not nested
    assert not _upward("mitsar.cli.parser", top)  # the same imports from the top stage


def test_by_name_imports_are_in_the_graph():
    """The plugin registry's imports by name are edges of the real graph (inside ``plugins``)."""
    assert "mitsar.plugins.integrators.radar.integrator" in GRAPH["mitsar.plugins.variant"][0]
    assert _imports_of('import importlib\nimportlib.import_module("drjit.llvm")\n')[0] == []
