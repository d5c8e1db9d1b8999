"""One report per run: a self-contained HTML page of a run folder (:mod:`mitsar.report.html`).

The run itself (what is simulated, focused, measured and drawn) is
:func:`mitsar.report.run.run_experiment`; it records everything in ``run.json``, from
which :func:`build_report` writes ``report.html`` (and ``mitsar report DIR`` writes it again).
"""

from __future__ import annotations

import importlib
from typing import TYPE_CHECKING, Any

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.report.html import RUN_RECORD, build_report, provenance

__all__ = ["RUN_RECORD", "build_report", "provenance"]

_EXPORTS = {
    "RUN_RECORD": "mitsar.report.html",
    "build_report": "mitsar.report.html",
    "provenance": "mitsar.report.html",
}
"""Public names -> the module that defines each, imported on first use (PEP 562)."""


def __getattr__(name: str) -> Any:
    """Import a public name on first use (PEP 562) and keep it in the package's namespace."""
    if name not in _EXPORTS:
        raise AttributeError(f"module {__name__!r} has no attribute {name!r}")
    value = globals()[name] = getattr(importlib.import_module(_EXPORTS[name]), name)
    return value


def __dir__() -> list[str]:
    return sorted(set(globals()) | set(__all__))
