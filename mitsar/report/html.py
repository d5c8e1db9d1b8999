"""``report.html``: a run's configuration, figures, metrics and provenance in one page.

The page is self-contained (figures embedded as base64 PNG, no external style or script), so it
can be mailed or archived alone. It is built from the run record ``run.json`` of a run folder
(:data:`RUN_RECORD`, written by :func:`mitsar.report.run.run_experiment`):

``title``, ``experiment`` (the effective configuration), ``source``, ``kind``;
``steps`` (name -> seconds); ``products`` (list of file names); ``figures`` (list of
``{"file", "title", "caption"}``); ``metrics`` (algorithm -> the dict of
:func:`mitsar.measure_impulse_response`); ``tables`` (list of ``{"title", "header", "rows"}``);
``warnings`` (list of str); ``provenance`` (:func:`provenance`).

A small script in the page counts the figures that decoded (``#render-check``), so a headless
browser can confirm that nothing is missing (``tests/test_report.py``).
"""

from __future__ import annotations

import base64
import html
import json
import platform
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

from mitsar.errors import MitsarError
from mitsar.io import atomic_output, check_writable
from mitsar.version import __version__

__all__ = ["RUN_RECORD", "build_report", "provenance"]

RUN_RECORD = "run.json"
"""File name of the run record in a run folder."""

REPORT = "report.html"
"""File name of the report in a run folder."""

_PACKAGES = ("mitsuba", "drjit", "numpy", "scipy", "xarray", "matplotlib")

_STYLE = """
body { font-family: system-ui, sans-serif; margin: 2em auto; max-width: 1100px; color: #222; }
h1 { font-size: 1.6em; } h2 { border-bottom: 1px solid #ccc; padding-bottom: .2em; }
table { border-collapse: collapse; margin: .5em 0 1.5em; }
th, td { border: 1px solid #ccc; padding: .25em .6em; text-align: right; }
th { background: #f3f3f3; } td.name { text-align: left; }
figure { margin: 1em 0 2em; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { color: #555; font-size: .9em; }
pre { background: #f7f7f7; padding: 1em; overflow-x: auto; font-size: .85em; }
.warning { background: #fff4e5; border-left: 4px solid #f0a020; padding: .4em .8em; }
"""

_CHECK = """
window.addEventListener("load", function () {
  var images = document.querySelectorAll("figure img"), ok = 0, failed = [];
  images.forEach(function (img) {
    if (img.complete && img.naturalWidth > 0) { ok += 1; } else { failed.push(img.alt); }
  });
  var check = document.getElementById("render-check");
  check.setAttribute("data-loaded", String(ok));
  check.setAttribute("data-failed", String(failed.length));
  check.textContent = ok + " of " + images.length + " figures rendered"
    + (failed.length ? "; missing: " + failed.join(", ") : "");
});
"""


def provenance(seeds: dict[str, Any] | None = None) -> dict[str, Any]:
    """Versions of mitsar, Python and the numerical packages, the platform, and ``seeds``."""
    versions = {"mitsar": __version__, "python": sys.version.split()[0]}
    for name in _PACKAGES:
        try:
            versions[name] = metadata.version(name)
        except metadata.PackageNotFoundError:
            versions[name] = "not installed"
    return {"versions": versions, "platform": platform.platform(), "seeds": seeds or {}}


def _table(header: list[str], rows: list[list[Any]]) -> str:
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    body = []
    for row in rows:
        cells = [f'<td class="name">{html.escape(str(row[0]))}</td>']
        for value in row[1:]:
            text = f"{value:.4g}" if isinstance(value, float) else str(value)
            cells.append(f"<td>{html.escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f"<table><tr>{head}</tr>{''.join(body)}</table>"


def _metrics_rows(metrics: dict[str, Any]) -> list[list[Any]]:
    rows = []
    for algorithm, result in metrics.items():
        if not isinstance(result, dict) or "range" not in result:
            rows.append([algorithm, "not measurable: " + str(result), "", "", "", "", "", ""])
            continue
        rows.append([algorithm] + [result[d][k] for d in ("range", "azimuth")
                                   for k in ("irw_cells", "pslr_db", "islr_db")]
                    + [result.get("peak_offset_m", float("nan"))])
    return rows


def _figure(folder: Path, entry: dict[str, Any]) -> str:
    path = folder / entry["file"]
    if not path.is_file():
        raise MitsarError(f"{folder / RUN_RECORD}: figure {entry['file']!r} is missing from the "
                          "run folder (run the experiment again)")
    data = base64.b64encode(path.read_bytes()).decode("ascii")
    title = html.escape(entry.get("title", entry["file"]))
    caption = html.escape(entry.get("caption", ""))
    return (f'<figure><img alt="{html.escape(entry["file"])}" '
            f'src="data:image/png;base64,{data}"><figcaption><b>{title}.</b> {caption}'
            "</figcaption></figure>")


def build_report(folder: str | Path, overwrite: bool = True) -> Path:
    """Write ``report.html`` of a run folder from its ``run.json``.

    Parameters
    ----------
    folder : path-like
        A run folder (:func:`mitsar.report.run.run_experiment`).
    overwrite : bool
        Replace an existing report (the default: the report is derived data).

    Returns
    -------
    Path
        The report.

    Raises
    ------
    MitsarError
        If the folder has no run record or a figure it names is missing.
    """
    folder = Path(folder)
    record_path = folder / RUN_RECORD
    if not record_path.is_file():
        raise MitsarError(f"{folder}: no {RUN_RECORD} (not a run folder of 'mitsar run')")
    try:
        record = json.loads(record_path.read_text())
    except json.JSONDecodeError as error:
        raise MitsarError(f"{record_path}: not a valid run record: {error}") from error
    title = html.escape(record.get("title") or "mitsar run")
    parts = [f"<h1>{title}</h1>",
             f"<p>{html.escape(record.get('description', ''))}</p>",
             '<p id="render-check" data-loaded="0" data-failed="-1">figures not checked</p>']
    for warning in record.get("warnings", []):
        parts.append(f'<p class="warning">{html.escape(str(warning))}</p>')
    if record.get("metrics"):
        parts.append("<h2>Image quality</h2>")
        parts.append(_table(["algorithm", "range IRW [cells]", "range PSLR [dB]",
                             "range ISLR [dB]", "azimuth IRW [cells]", "azimuth PSLR [dB]",
                             "azimuth ISLR [dB]", "peak offset [m]"],
                            _metrics_rows(record["metrics"])))
    for table in record.get("tables", []):
        parts.append(f"<h2>{html.escape(table['title'])}</h2>")
        parts.append(_table(table["header"], table["rows"]))
    if record.get("figures"):
        parts.append("<h2>Figures</h2>")
        parts.extend(_figure(folder, entry) for entry in record["figures"])
    steps = record.get("steps", {})
    if steps:
        parts.append("<h2>Timings</h2>")
        parts.append(_table(["step", "seconds"], [[k, float(v)] for k, v in steps.items()]))
    parts.append("<h2>Products</h2><ul>" + "".join(
        f"<li>{html.escape(p)}</li>" for p in record.get("products", [])) + "</ul>")
    parts.append("<h2>Configuration</h2><pre>"
                 + html.escape(json.dumps(record.get("experiment", {}), indent=2)) + "</pre>")
    parts.append("<h2>Provenance</h2><pre>"
                 + html.escape(json.dumps(record.get("provenance", {}), indent=2)) + "</pre>")
    page = ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{title}</title><style>{_STYLE}</style><script>{_CHECK}</script></head>"
            f"<body>{''.join(parts)}</body></html>")
    target = folder / REPORT
    check_writable(target, overwrite)
    with atomic_output(target, overwrite) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return target
