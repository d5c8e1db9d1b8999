"""One report per run: a self-contained HTML page of a run folder (:mod:`mitsar.report.html`).

The run itself (what is simulated, focused, measured and drawn) is
:func:`mitsar.report.run.run_experiment`; it records everything in ``run.json``, from
which :func:`build_report` writes ``report.html`` (and ``mitsar report DIR`` writes it again).
"""

from mitsar.report.html import RUN_RECORD, build_report, provenance

__all__ = ["RUN_RECORD", "build_report", "provenance"]
