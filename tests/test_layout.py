"""The house rules of docs/design.md §3, checked on the source: imports run down the pipeline,
no import circle, and no function-level import of mitsar's own modules."""

from __future__ import annotations

import ast
from pathlib import Path

import pytest

PACKAGE = Path(__file__).resolve().parents[1] / "mitsar"

# Stages from the ground up (docs/design.md §2). A module may import its own stage and the ones
# below; a higher rank importing a lower one is the pipeline's direction.
RANKS = {
    "mitsar.errors": 0, "mitsar.version": 0,
    "mitsar.checks": 1, "mitsar.budget": 1, "mitsar.backend": 1, "mitsar.io": 1,
    "mitsar.model": 2,
    "mitsar.products": 2.5,
    "mitsar.scene": 3,
    "mitsar.plugins": 4,
    "mitsar.raw": 5,
    "mitsar.focus": 6,
    "mitsar.quality": 7, "mitsar.interferometry": 7, "mitsar.plots": 7, "mitsar.export": 7,
    "mitsar.experiment": 8,
    "mitsar.ambiguity": 9,
    "mitsar.report": 9.5,
    "mitsar.cli": 10,
    "mitsar": 11,
}


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


def _imports(module: str) -> tuple[list[str], list[tuple[int, str]]]:
    """(mitsar modules imported at module level, (line, module) imported inside functions)."""
    tree = ast.parse(MODULES[module].read_text())
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
    for func in ast.walk(tree):
        if isinstance(func, ast.FunctionDef | ast.AsyncFunctionDef):
            for node in ast.walk(func):
                nested += [(node.lineno, t) for t in targets(node)]
    return top, nested


GRAPH = {module: _imports(module) for module in MODULES}


@pytest.mark.parametrize("module", sorted(MODULES))
def test_imports_run_down_the_pipeline(module):
    up = [t for t in GRAPH[module][0] if t != module and _rank(t) > _rank(module)]
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
