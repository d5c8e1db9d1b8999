"""``report.html``: a run's configuration, figures, metrics and provenance in one page.

The page is self-contained (figures embedded as base64 PNG, no external style or script), so it
can be mailed or archived alone. It is built from the run record ``run.json`` of a run folder
(:data:`RUN_RECORD`, written by :func:`mitsar.report.run.run_experiment`):

``title``, ``experiment`` (the effective configuration), ``source``, ``kind``;
``steps`` (name -> seconds); ``products`` (list of file names); ``figures`` (list of
``{"file", "title", "caption"}``, and optionally ``"section"``: the figure is shown in that
section instead of "Figures"); ``metrics`` (algorithm -> the dict of
:func:`mitsar.measure_impulse_response`); ``tables`` (list of ``{"title", "header", "rows"}``);
``warnings`` (list of str); ``provenance`` (:func:`provenance`); ``interferometry``
(optional: ``summary``, :func:`mitsar.experiment.interferometry.interferometry_summary`, and
``points``, the point cloud's PLY file in the folder).

A small script in the page counts the figures that decoded (``#render-check``), so a headless
browser can confirm that nothing is missing (``tests/test_report.py``). The interferometry
section draws its point cloud in 3-D on a canvas with a few lines of inline script (no library,
no network: the points are embedded as JSON; drag to rotate); the script records the points it
drew in the canvas's ``data-drawn`` attribute.
"""

from __future__ import annotations

import base64
import html
import json
import math
import platform
import re
import sys
from collections.abc import Sequence
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import plyfile

from mitsar.errors import MitsarError
from mitsar.io import atomic_output, check_writable
from mitsar.plots.labels import quantity_label
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
th { background: #f3f3f3; } td.name, th:first-child { text-align: left; }
figure { margin: 1em 0 2em; } figure img { max-width: 100%; border: 1px solid #ddd; }
figcaption { color: #555; font-size: .9em; }
pre { background: #f7f7f7; padding: 1em; overflow-x: auto; font-size: .85em; }
.warning { background: #fff4e5; border-left: 4px solid #f0a020; padding: .4em .8em; }
div.table { overflow-x: auto; }
td.text { text-align: left; } td.message { text-align: left; white-space: normal;
  max-width: 60em; color: #7a4a00; background: #fffaf2; }
p.note { color: #555; font-size: .9em; max-width: 60em; }
details { margin: .5em 0 1.5em; } summary { cursor: pointer; color: #333; }
#render-check { color: #777; font-size: .85em; border-top: 1px solid #ddd; padding-top: .5em; }
#render-check.failed { color: #a00; }
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
  check.textContent = "Page check: " + ok + " of " + images.length
    + " embedded figures decoded by this browser"
    + (failed.length ? "; missing: " + failed.join(", ") : "") + ".";
  if (failed.length) {
    check.className = "failed";
    var note = document.createElement("p");
    note.className = "warning";
    note.textContent = failed.length + " figure(s) of this page did not decode: "
      + failed.join(", ") + " (see the page check at the bottom).";
    var title = document.querySelector("h1");
    title.parentNode.insertBefore(note, title.nextSibling);
  }
});
"""


CLOUD_POINTS = 3000
"""Most points of a point cloud drawn in the report (the brightest)."""

CLOUD_DYNAMIC_RANGE_DB = 40.0
"""Points fainter than this [dB] below the brightest are not drawn (as in the maps)."""

_CLOUD_SCRIPT = """
window.addEventListener("load", function () {
  var canvas = document.getElementById("point-cloud");
  if (!canvas || !canvas.getContext) { return; }
  var d = JSON.parse(document.getElementById("point-cloud-data").textContent);
  var ctx = canvas.getContext("2d"), n = d.x.length, yaw = -0.7, pitch = 0.45;
  function span(v) {
    var lo = Infinity, hi = -Infinity;
    for (var i = 0; i < v.length; i++) { lo = Math.min(lo, v[i]); hi = Math.max(hi, v[i]); }
    return [lo, hi];
  }
  var sx = span(d.x), sy = span(d.y), sz = span(d.z);
  var c = [(sx[0] + sx[1]) / 2, (sy[0] + sy[1]) / 2, (sz[0] + sz[1]) / 2];
  var flat = Math.max(sx[1] - sx[0], sy[1] - sy[0], 1e-6), tall = Math.max(sz[1] - sz[0], 1e-9);
  var ex = Math.max(1, Math.round(0.5 * flat / tall)), size = Math.max(flat, tall * ex);
  function project(x, y, z) {
    var u = (x - c[0]) / size, w = (y - c[1]) / size, h = (z - c[2]) * ex / size;
    var X = u * Math.cos(yaw) - w * Math.sin(yaw), Y = u * Math.sin(yaw) + w * Math.cos(yaw);
    var s = 0.75 * Math.min(canvas.width, canvas.height);
    return [canvas.width / 2 + X * s,
            canvas.height / 2 - (h * Math.cos(pitch) + Y * Math.sin(pitch)) * s,
            Y * Math.cos(pitch) - h * Math.sin(pitch)];
  }
  function colour(z) {
    var t = (z - sz[0]) / tall;
    return "hsl(" + Math.round(240 * (1 - t)) + ", 85%, 45%)";
  }
  function line(a, b, label) {
    var p = project(a[0], a[1], a[2]), q = project(b[0], b[1], b[2]);
    ctx.strokeStyle = "#555"; ctx.beginPath(); ctx.moveTo(p[0], p[1]); ctx.lineTo(q[0], q[1]);
    ctx.stroke(); ctx.fillStyle = "#222"; ctx.fillText(label, q[0] + 4, q[1] - 4);
  }
  function draw() {
    ctx.clearRect(0, 0, canvas.width, canvas.height);
    ctx.font = "12px sans-serif";
    var o = [sx[0], sy[0], sz[0]];
    line(o, [sx[1], sy[0], sz[0]], "x " + sx[1].toFixed(2) + " m");
    line(o, [sx[0], sy[1], sz[0]], "y " + sy[1].toFixed(2) + " m");
    line(o, [sx[0], sy[0], sz[1]], "z " + sz[1].toFixed(3) + " m");
    var order = [], drawn = 0;
    for (var i = 0; i < n; i++) { order.push([project(d.x[i], d.y[i], d.z[i]), i]); }
    order.sort(function (a, b) { return b[0][2] - a[0][2]; });
    for (var k = 0; k < order.length; k++) {
      var p = order[k][0], j = order[k][1];
      ctx.globalAlpha = 0.25 + 0.75 * d.a[j];
      ctx.fillStyle = colour(d.z[j]);
      ctx.fillRect(p[0] - 2, p[1] - 2, 4, 4);
      drawn += 1;
    }
    ctx.globalAlpha = 1; ctx.fillStyle = "#222";
    ctx.fillText("colour: height z from " + sz[0].toFixed(3) + " m (blue) to " + sz[1].toFixed(3)
                 + " m (red); z exaggerated x" + ex + "; drag to rotate", 8, canvas.height - 8);
    canvas.setAttribute("data-drawn", String(drawn));
  }
  var last = null;
  canvas.addEventListener("mousedown", function (e) { last = [e.clientX, e.clientY]; });
  window.addEventListener("mouseup", function () { last = null; });
  canvas.addEventListener("mousemove", function (e) {
    if (!last) { return; }
    yaw += 0.01 * (e.clientX - last[0]);
    pitch = Math.max(-1.5, Math.min(1.5, pitch + 0.01 * (e.clientY - last[1])));
    last = [e.clientX, e.clientY]; draw();
  });
  draw();
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


_UNIT_FORMATS = {"cells": ".3f", "dB": ".2f", "m": ".3f", "mm": ".1f", "cm": ".2f",
                 "deg": ".2f", "s": ".2f", "rad": ".3f", "nats": ".4f", "%": ".1f",
                 "cells²": ".1e", "dB²": ".3f", "m/s": ".3f", "m²": ".1f"}
"""Format of a table column by the unit in its heading (``"range IRW [cells]"``): one
precision per quantity, about a thousandth of its natural scale (IRW in cells to 0.001, levels
in dB to 0.01, lengths in m to a millimetre); variances of IRW (cells²) in exponent form, as
they span 1e-5 (a few realisations) to 1e-1 (the paper's Table 5)."""


def _unit(heading: str) -> str | None:
    """The unit in a column heading's last ``[...]``, or None."""
    found = re.findall(r"\[([^\]]+)\]", heading)
    return found[-1].strip() if found else None


def _numbers(value: Any) -> list[float]:
    """The finite floats in a cell (a number or a list of numbers)."""
    values = value if isinstance(value, list | tuple) else [value]
    return [float(v) for v in values
            if isinstance(v, float) and not isinstance(v, bool) and math.isfinite(v)]


def _column_format(heading: str, column: Sequence[Any]) -> str:
    """The one format of a column's numbers: by the unit of its heading
    (:data:`_UNIT_FORMATS`), else fixed decimals giving four significant digits to the
    column's largest magnitude (so ``0.892`` and ``0.8951`` are never side by side)."""
    unit = _unit(heading)
    if unit in _UNIT_FORMATS:
        return _UNIT_FORMATS[unit]
    numbers = [abs(v) for cell in column for v in _numbers(cell)]
    if not numbers or max(numbers) == 0:
        return ".4g"
    largest = max(numbers)
    if largest >= 1e6 or largest < 1e-3:
        return ".3e"
    return f".{max(0, 3 - math.floor(math.log10(largest)))}f"


def _cell(value: Any, spec: str) -> str:
    """The text of one cell: floats with the column's format, lists element by element,
    booleans as yes / no, NaN and None as n/a."""
    if isinstance(value, bool):
        return "yes" if value else "no"
    if value is None:
        return "n/a"
    if isinstance(value, float):
        return format(value, spec) if math.isfinite(value) else "n/a"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_cell(v, spec) for v in value) + "]"
    return str(value)


def _table(header: Sequence[str], rows: Sequence[Sequence[Any]],
           formats: Sequence[str | None] | None = None) -> str:
    """An HTML table; the first column names the row (left-aligned), numbers are right-aligned
    with one format per column (``formats``, else :func:`_column_format`), text left-aligned.
    A row ``[name, {"message": text}]`` is a message spanning the other columns (a step that
    could not run), wrapped and readable instead of squeezed into one cell."""
    head = "".join(f"<th>{html.escape(str(h))}</th>" for h in header)
    plain = [row for row in rows if not (len(row) == 2 and isinstance(row[1], dict))]
    specs = [(formats[i] if formats and i < len(formats) and formats[i] else None)
             or _column_format(str(heading), [row[i] for row in plain if i < len(row)])
             for i, heading in enumerate(header)]
    body = []
    for row in rows:
        cells = [f'<td class="name">{html.escape(str(row[0]))}</td>']
        if len(row) == 2 and isinstance(row[1], dict) and "message" in row[1]:
            cells.append(f'<td class="message" colspan="{max(len(header) - 1, 1)}">'
                         f"{html.escape(str(row[1]['message']))}</td>")
        else:
            for i, value in enumerate(row[1:], start=1):
                text = _cell(value, specs[i] if i < len(specs) else ".4g")
                numeric = (isinstance(value, int | float) and not isinstance(value, bool)
                           or bool(_numbers(value))
                           or isinstance(value, str) and re.match(r"[-+−]?\d", value))
                kind = "" if numeric else ' class="text"'
                cells.append(f"<td{kind}>{html.escape(text)}</td>")
        body.append("<tr>" + "".join(cells) + "</tr>")
    return f'<div class="table"><table><tr>{head}</tr>{"".join(body)}</table></div>'


METRICS_HEADER = ["algorithm", "range IRW [cells]", "range PSLR [dB]", "range ISLR [dB]",
                  "azimuth IRW [cells]", "azimuth PSLR [dB]", "azimuth ISLR [dB]",
                  "peak offset [mm]"]
"""Columns of the report's image-quality table (peak offset from the metrics target)."""


def _metrics_rows(metrics: dict[str, Any]) -> list[list[Any]]:
    rows: list[list[Any]] = []
    for algorithm, result in metrics.items():
        if not isinstance(result, dict) or "range" not in result:
            rows.append([algorithm, {"message": "not measurable: " + str(result)}])
            continue
        offset = result.get("peak_offset_m")
        rows.append([algorithm] + [float(result[d][k]) for d in ("range", "azimuth")
                                   for k in ("irw_cells", "pslr_db", "islr_db")]
                    + [float("nan") if offset is None else 1e3 * float(offset)])
    return rows


def _toml_value(value: Any) -> str:
    """A value as TOML writes it: strings quoted with their own characters (``§``, not
    ``\\u00a7``), floats in their shortest exact form, lists and dicts inline."""
    if isinstance(value, bool):
        return "true" if value else "false"
    if isinstance(value, float):
        if not math.isfinite(value):
            return "nan" if math.isnan(value) else ("inf" if value > 0 else "-inf")
        if value != 0 and not 1e-3 <= abs(value) < 1e6:
            return np.format_float_scientific(value, trim="-", exp_digits=1)
        return repr(value)
    if isinstance(value, int):
        return str(value)
    if isinstance(value, str):
        return json.dumps(value, ensure_ascii=False)
    if isinstance(value, dict):
        return "{" + ", ".join(f"{_toml_key(k)} = {_toml_value(v)}" for k, v in value.items()
                               if v is not None) + "}"
    if isinstance(value, list | tuple):
        return "[" + ", ".join(_toml_value(v) for v in value) + "]"
    return json.dumps(value, ensure_ascii=False)


def _toml_key(key: str) -> str:
    return key if re.fullmatch(r"[A-Za-z0-9_-]+", key) else json.dumps(key, ensure_ascii=False)


def toml_text(document: dict[str, Any], prefix: str = "") -> list[str]:
    """The lines of a configuration written in TOML's layout: keys before sub-tables,
    ``[table]`` and ``[[array of tables]]`` headers (docs/experiments.md). Keys whose value is
    None (not set: the default applies) are left out, as TOML has no null."""
    lines: list[str] = []
    scalars = {k: v for k, v in document.items() if v is not None and not isinstance(v, dict)
               and not (isinstance(v, list) and v and all(isinstance(x, dict) for x in v))}
    lines += [f"{_toml_key(k)} = {_toml_value(v)}" for k, v in scalars.items()]
    for key, value in document.items():
        name = f"{prefix}.{_toml_key(key)}" if prefix else _toml_key(key)
        if isinstance(value, dict):
            body = toml_text(value, name)
            if not body or not body[0].startswith("["):
                body = [f"[{name}]"] + body
            lines += [""] + body
        elif key not in scalars and isinstance(value, list) and value:
            for entry in value:
                lines += ["", f"[[{name}]]"] + toml_text(entry, name)
    return lines


def _configuration(record: dict[str, Any]) -> list[str]:
    """The Configuration section: the effective experiment in TOML's layout, folded in a
    ``<details>`` (the page stays short; a click shows it)."""
    experiment = record.get("experiment") or {}
    if not experiment:
        return []
    text = "\n".join(toml_text(experiment)).strip()
    source = record.get("source")
    where = f" of {html.escape(Path(source).name)}" if source else ""
    return ["<h2>Configuration</h2>",
            f'<details id="configuration"><summary>The effective experiment{where} in TOML '
            f"({len(text.splitlines())} lines; keys not set, whose defaults apply, are left "
            "out) &mdash; click to show</summary>"
            f"<pre>{html.escape(text)}</pre></details>"]


def _provenance(entry: dict[str, Any]) -> list[str]:
    """The Provenance section: package versions and platform as a table, seeds below."""
    if not entry:
        return []
    rows = [[name, str(version)] for name, version in entry.get("versions", {}).items()]
    if entry.get("platform"):
        rows.append(["platform", str(entry["platform"])])
    parts = ["<h2>Provenance</h2>", _table(["package", "version"], rows)]
    seeds = {k: v for k, v in entry.get("seeds", {}).items() if v is not None}
    if seeds:
        parts.append("<p>Seeds: " + html.escape(", ".join(
            f"{k} = {_toml_value(v)}" for k, v in seeds.items())) + "</p>")
    return parts


AUTOFOCUS_HEADER = ["algorithm", "method", "iterations", "converged", "scatterers",
                    "entropy before [nats]", "entropy after [nats]", "applied", "time [s]"]
"""Columns of the report's autofocus table (``record["autofocus"]``; the image attributes
``autofocus_*`` of :func:`mitsar.focus.autofocus.driver.run_autofocus`)."""


def _autofocus(folder: Path, record: dict[str, Any]) -> list[str]:
    """The Autofocus section: per image the method, its iterations and convergence, the whole
    image's entropy before and after, whether the correction was applied, its time, and its
    warning in full below the row; then the figures of the section (estimated phase error)."""
    rows: list[list[Any]] = []
    for algorithm, entry in record["autofocus"].items():
        rows.append([algorithm, entry.get("method", "?"), entry.get("iterations", "n/a"),
                     bool(entry.get("converged", True)), entry.get("scatterers", "n/a"),
                     entry.get("entropy_before"), entry.get("entropy_after"),
                     bool(entry.get("applied", True)), entry.get("seconds")])
        if entry.get("warning"):
            rows.append([f"{algorithm}: warning", {"message": entry["warning"]}])
    parts = ["<h2>Autofocus</h2>", _table(AUTOFOCUS_HEADER, rows),
             '<p class="note">Entropy of the whole image (lower is sharper; docs/autofocus.md). '
             "A correction that raised it is not applied: the uncorrected image is kept.</p>"]
    parts.extend(_figure(folder, figure) for figure in record.get("figures", [])
                 if figure.get("section") == "Autofocus")
    return parts


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


def _cloud_points(folder: Path, file: str) -> tuple[dict[str, list[float]], int]:
    """The brightest points of a PLY point cloud (at most :data:`CLOUD_POINTS`, within
    :data:`CLOUD_DYNAMIC_RANGE_DB` of the brightest) as JSON-ready columns ``x``, ``y``, ``z``
    [m] and ``a`` (amplitude mapped to [0, 1] over that range); and the cloud's size."""
    path = folder / file
    if not path.is_file():
        raise MitsarError(f"{folder / RUN_RECORD}: point cloud {file!r} is missing from the run "
                          "folder (run the experiment again)")
    vertex = plyfile.PlyData.read(str(path))["vertex"].data
    total = len(vertex)
    amplitude = np.asarray(vertex["amplitude"], float) if total else np.zeros(0)
    with np.errstate(divide="ignore", invalid="ignore"):
        level = 20 * np.log10(amplitude / np.max(amplitude, initial=0.0))
    keep = np.flatnonzero(np.isfinite(level) & (level >= -CLOUD_DYNAMIC_RANGE_DB)
                          & np.isfinite(np.asarray(vertex["z"], float)) if total else [])
    keep = keep[np.argsort(-amplitude[keep], kind="stable")[:CLOUD_POINTS]]
    columns = {name: [round(float(v), 5) for v in np.asarray(vertex[name], float)[keep]]
               for name in ("x", "y", "z")}
    columns["a"] = [round(float(1 + v / CLOUD_DYNAMIC_RANGE_DB), 3) for v in level[keep]]
    return columns, total


def _interferometry(folder: Path, record: dict[str, Any]) -> list[str]:
    """The interferometry section: the summary, its maps and the 3-D point cloud."""
    entry = record["interferometry"]
    summary = entry.get("summary", {})
    rows = []
    for key, value in summary.items():
        if isinstance(value, list):
            value = ", ".join(f"{v:.4g}" if isinstance(v, float) else str(v) for v in value)
        elif isinstance(value, float) and not math.isfinite(value):
            value = "nan"
        rows.append([quantity_label(key), value])
    parts = ["<h2>Interferometry</h2>", _table(["quantity", "value"], rows, [None, ".4g"])]
    parts.extend(_figure(folder, figure) for figure in record.get("figures", [])
                 if figure.get("section") == "Interferometry")
    if entry.get("points"):
        columns, total = _cloud_points(folder, entry["points"])
        data = json.dumps(columns).replace("</", "<\\/")
        parts.append(
            '<figure class="cloud"><canvas id="point-cloud" width="900" height="600" '
            'data-drawn="0" style="border: 1px solid #ddd; max-width: 100%"></canvas>'
            f'<script type="application/json" id="point-cloud-data">{data}</script>'
            f"<figcaption><b>Point cloud, 3-D.</b> The {len(columns['x'])} brightest of "
            f"{total} points of {html.escape(entry['points'])} (within "
            f"{CLOUD_DYNAMIC_RANGE_DB:g} dB of the brightest; fainter ones paler), world x, y, "
            "z [m], coloured by height; drag to rotate. Drawn by the page itself (inline "
            f"script, no network).</figcaption></figure><script>{_CLOUD_SCRIPT}</script>")
    return parts


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
             f"<p>{html.escape(record.get('description', ''))}</p>"]
    for warning in record.get("warnings", []):
        parts.append(f'<p class="warning">{html.escape(str(warning))}</p>')
    if record.get("metrics"):
        parts.append("<h2>Image quality</h2>")
        parts.append(_table(METRICS_HEADER, _metrics_rows(record["metrics"])))
        parts.append('<p class="note">Measured at the metrics target (IRW: -3 dB width in '
                     "resolution cells; PSLR, ISLR: peak and integrated sidelobe ratios; peak "
                     "offset: distance of the interpolated peak from the target; "
                     "docs/metrics.md).</p>")
    for table in record.get("tables", []):
        parts.append(f"<h2>{html.escape(table['title'])}</h2>")
        parts.append(_table(table["header"], table["rows"], table.get("formats")))
        if table.get("note"):
            parts.append(f'<p class="note">{html.escape(table["note"])}</p>')
    if record.get("autofocus"):
        parts.extend(_autofocus(folder, record))
    if record.get("interferometry"):
        parts.extend(_interferometry(folder, record))
    general = [entry for entry in record.get("figures", []) if not entry.get("section")]
    if general:
        parts.append("<h2>Figures</h2>")
        parts.extend(_figure(folder, entry) for entry in general)
    steps = record.get("steps", {})
    if steps:
        parts.append("<h2>Timings</h2>")
        parts.append(_table(["step", "wall time [s]"],
                            [[k, float(v)] for k, v in steps.items()]))
    parts.append("<h2>Products</h2><ul>" + "".join(
        f"<li>{html.escape(p)}</li>" for p in record.get("products", [])) + "</ul>")
    parts.extend(_configuration(record))
    parts.extend(_provenance(record.get("provenance", {})))
    parts.append('<p id="render-check" data-loaded="0" data-failed="-1">Page check: figures '
                 "not checked (the page's script did not run)</p>")
    page = ("<!DOCTYPE html><html lang=\"en\"><head><meta charset=\"utf-8\">"
            f"<title>{title}</title><style>{_STYLE}</style><script>{_CHECK}</script></head>"
            f"<body>{''.join(parts)}</body></html>")
    target = folder / REPORT
    check_writable(target, overwrite)
    with atomic_output(target, overwrite) as tmp:
        tmp.write_text(page, encoding="utf-8")
    return target
