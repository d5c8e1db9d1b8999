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
import sys
from importlib import metadata
from pathlib import Path
from typing import Any

import numpy as np
import plyfile

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
        rows.append([key, value])
    parts = ["<h2>Interferometry</h2>", _table(["quantity", "value"], rows)]
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
    if record.get("interferometry"):
        parts.extend(_interferometry(folder, record))
    general = [entry for entry in record.get("figures", []) if not entry.get("section")]
    if general:
        parts.append("<h2>Figures</h2>")
        parts.extend(_figure(folder, entry) for entry in general)
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
