"""One report per run: a self-contained HTML page of a run folder (:mod:`mitsar.report.html`).

The run itself (what is simulated, focused, measured and drawn) is
:func:`mitsar.report.run.run_experiment`; it records everything in ``run.json``, from
which :func:`build_report` writes ``report.html`` (and ``mitsar report DIR`` writes it again).
"""

from __future__ import annotations

from typing import TYPE_CHECKING

from mitsar.lazy import lazy_exports

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.report.html import RUN_RECORD, build_report, provenance

__all__ = ["RUN_RECORD", "build_report", "provenance"]

_EXPORTS = {
    "RUN_RECORD": "mitsar.report.html",
    "build_report": "mitsar.report.html",
    "provenance": "mitsar.report.html",
}
"""Public names -> the module that defines each, imported on first use (PEP 562)."""


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), __all__)
