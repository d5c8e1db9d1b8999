"""``report.html`` read as a newcomer reads it (issue 26 item 5): one precision per column,
messages that span a row, the configuration in TOML (non-ASCII kept) folded away, the
autofocus results in their own table, the page check at the bottom, the paper's Table 4 beside
a plain run. The pages are built from small run records written here (no simulation), and
parsed with the standard library's HTML parser."""

from __future__ import annotations

import base64
import html
import json
import re
import tomllib
from html.parser import HTMLParser
from types import SimpleNamespace

import pytest

from mitsar.experiment.paper import PAPER_TABLES
from mitsar.report.html import RUN_RECORD, build_report, toml_text
from mitsar.report.run import paper_comparison, scene_label

# A 1 x 1 PNG (the smallest figure a page can embed).
PNG = base64.b64decode("iVBORw0KGgoAAAANSUhEUgAAAAEAAAABCAYAAAAfFcSJAAAADUlEQVR42mP8z8BQ"
                       "DwAEhQGAhKmMIQAAAABJRU5ErkJggg==")


class Page(HTMLParser):
    """The tables (with each cell's text and attributes), the headings and the order of the
    elements of a page."""

    def __init__(self, text: str) -> None:
        super().__init__()
        self.tables: list[list[list[tuple[str, dict]]]] = []
        self.order: list[tuple[str, dict]] = []
        self.text: dict[int, str] = {}
        self._cell: list[str] | None = None
        self._stack: list[int] = []
        self.feed(text)

    def handle_starttag(self, tag, attrs):
        attrs = dict(attrs)
        self.order.append((tag, attrs))
        self._stack.append(len(self.order) - 1)
        if tag == "table":
            self.tables.append([])
        elif tag == "tr":
            self.tables[-1].append([])
        elif tag in ("td", "th"):
            self._cell = []
            self.tables[-1][-1].append(("", attrs))

    def handle_endtag(self, tag):
        if tag in ("td", "th") and self._cell is not None:
            text, attrs = self.tables[-1][-1][-1]
            self.tables[-1][-1][-1] = ("".join(self._cell).strip(), attrs)
            self._cell = None

    def handle_data(self, data):
        if self._cell is not None:
            self._cell.append(data)
        if self._stack:
            index = self._stack[-1]
            self.text[index] = self.text.get(index, "") + data

    def table_after(self, heading: str) -> list[list[tuple[str, dict]]]:
        """The first table after the heading ``heading``."""
        names = [self.text.get(i, "").strip() for i in range(len(self.order))]
        start = next(i for i, (tag, _) in enumerate(self.order)
                     if tag == "h2" and names[i].startswith(heading))
        count = sum(1 for tag, _ in self.order[:start] if tag == "table")
        return self.tables[count]


def _metrics(irw: float, pslr: float) -> dict:
    cut = {"irw_cells": irw, "irw_m": 0.1 * irw, "pslr_db": pslr, "islr_db": pslr + 3.0}
    return {"range": dict(cut), "azimuth": dict(cut), "peak_offset_m": 0.0013763,
            "peak_index": [0, 0]}


def _page(tmp_path, **record) -> tuple[Page, str]:
    base = {"title": "t", "steps": {"simulate": 1.23456}, "products": ["raw.nc"],
            "figures": [], "metrics": {}, "tables": [], "warnings": []}
    base.update(record)
    for entry in base["figures"]:
        (tmp_path / entry["file"]).write_bytes(PNG)
    (tmp_path / RUN_RECORD).write_text(json.dumps(base))
    text = build_report(tmp_path).read_text(encoding="utf-8")
    return Page(text), text


def _decimals(text: str) -> int:
    return len(text.split(".")[1]) if "." in text else 0


def test_one_precision_per_column_and_messages_span_the_row(tmp_path):
    """0.892 and 0.8951 were side by side, and a peak offset of 0.001376 m: now each column
    has one format (IRW to 0.001 cells, dB to 0.01, the offset in mm), and a metrics failure is
    one wrapped cell spanning the row, not text squeezed into the first number's cell."""
    edge = ("target too close to the image edge: the measurement needs 8.0 cells around the "
            "peak, found 4.99 cells")
    page, _ = _page(tmp_path, metrics={"bpa": _metrics(0.892, -13.0), "wda": _metrics(0.8951,
                                                                                   -12.6148),
                                       "rda": edge},
                    tables=[{"title": "mixed", "header": ["name", "value"],
                             "rows": [["a", 0.5], ["b", 12.25], ["c", 0.0625]]}])
    table = page.table_after("Image quality")
    header = [text for text, _ in table[0]]
    assert header[-1] == "peak offset [mm]"
    rows = {row[0][0]: row for row in table[1:]}
    for column in range(1, len(header)):
        places = {_decimals(rows[name][column][0]) for name in ("bpa", "wda")}
        assert len(places) == 1, (header[column], [rows[n][column][0] for n in rows])
    assert rows["bpa"][1][0] == "0.892" and rows["wda"][1][0] == "0.895"
    assert rows["wda"][2][0] == "-12.61" and rows["bpa"][-1][0] == "1.4"
    message = rows["rda"]
    assert len(message) == 2 and message[1][1]["colspan"] == str(len(header) - 1)
    assert message[1][1]["class"] == "message" and "4.99 cells" in message[1][0]
    mixed = page.table_after("mixed")
    assert {_decimals(row[1][0]) for row in mixed[1:]} == {2}  # 4 digits for the largest
    assert page.table_after("Timings")[1][1][0] == "1.23"


def test_configuration_is_folded_toml_with_its_own_characters(tmp_path):
    experiment = {"name": "x", "description": "paper §4.1, 94 GHz → 3.2 mm",
                  "radar": {"bandwidth": 1.5e9, "prf": 250.0, "antenna_width": 0.01},
                  "targets": [{"position": [15.0, 8.0, 0.0], "rcs": 1.0},
                              {"position": [15.5, 8.0, 0.0], "rcs": 0.5}],
                  "focus": {"algorithm": "bpa", "autofocus": None,
                            "grid": {"kind": "slant", "along_track": [-0.4, 0.8, 0.01]}},
                  "metrics": {"target": [15.0, 8.0, 0.0], "islr_extent": "paper"}}
    page, text = _page(tmp_path, experiment=experiment, source="/somewhere/x.toml")
    assert "\\u00a7" not in text and "§4.1" in text and "→" in text
    details = [attrs for tag, attrs in page.order if tag == "details"]
    assert details and details[0]["id"] == "configuration" and "open" not in details[0]
    shown = re.search(r'<details id="configuration">.*?<pre>(.*?)</pre>', text, re.S).group(1)
    parsed = tomllib.loads(html.unescape(shown))
    expected = json.loads(json.dumps(experiment))
    del expected["focus"]["autofocus"]  # not set: the default applies, TOML has no null
    assert parsed == expected
    assert "[focus.grid]" in shown and shown.count("[[targets]]") == 2
    assert tomllib.loads("\n".join(toml_text({"a": 1e-7, "b": 94e9})))["a"] == 1e-7


def test_page_check_sits_at_the_bottom_and_autofocus_has_its_table(tmp_path):
    autofocus = {"method": "pga", "iterations": 7, "converged": False, "scatterers": 12,
                 "entropy_before": 9.87654, "entropy_after": 9.5, "applied": True,
                 "seconds": 0.4321,
                 "warning": "autofocus 'pga' did not converge: the last update was 0.02 rad"}
    figures = [{"file": "image_bpa.png", "title": "Image, BPA"},
               {"file": "autofocus_bpa.png", "title": "Autofocus phase, BPA",
                "section": "Autofocus"}]
    page, text = _page(tmp_path, autofocus={"bpa": autofocus}, figures=figures)
    tags = [tag for tag, _ in page.order]
    check = next(i for i, (_, attrs) in enumerate(page.order)
                 if attrs.get("id") == "render-check")
    assert check > max(i for i, tag in enumerate(tags) if tag in ("h2", "table", "figure"))
    table = page.table_after("Autofocus")
    header = [cell for cell, _ in table[0]]
    row = dict(zip(header, [cell for cell, _ in table[1]], strict=True))
    assert row["method"] == "pga" and row["iterations"] == "7" and row["converged"] == "no"
    assert row["entropy before [nats]"] == "9.8765" and row["applied"] == "yes"
    assert row["time [s]"] == "0.43"
    assert table[2][1][1]["class"] == "message" and "did not converge" in table[2][1][0]
    autofocus_at = text.index("<h2>Autofocus</h2>")
    assert autofocus_at < text.index('alt="autofocus_bpa.png"') < text.index("<h2>Figures</h2>")
    assert text.count("<figure>") == 2


def test_paper_table_beside_a_plain_run():
    """A run on the paper's -20 dB background shows Table 4 beside its own values (mean +-
    sqrt(variance)); another background or an algorithm the paper did not use shows none."""
    background = SimpleNamespace(cell_rcs_db=-20.0)
    paper = PAPER_TABLES[-20.0]["bpa"]
    mean, variance = paper["azimuth"]["islr_db"]
    far = _metrics(0.87, -13.0)
    far["azimuth"]["islr_db"] = mean + 2.5 * variance ** 0.5  # outside two deviations
    table = paper_comparison({"bpa": far, "ffbp": _metrics(0.9, -13.0), "wda": "edge"},
                             background)
    assert "Table 4" in table["title"] and [r[0] for r in table["rows"]] == ["BPA range",
                                                                          "BPA azimuth"]
    header = table["header"]
    azimuth = dict(zip(header, table["rows"][1], strict=True))
    assert azimuth["ISLR [dB], paper"] == f"{mean:.2f} ± {variance ** 0.5:.2f}"
    assert azimuth["IRW [cells], this run"] == 0.87
    assert "5 of 6 values" in table["note"]
    assert "Table 5" in paper_comparison({"bpa": far}, SimpleNamespace(cell_rcs_db=-10.0))[
        "title"]
    assert paper_comparison({"bpa": far}, SimpleNamespace(cell_rcs_db=-15.0)) is None
    assert paper_comparison({"bpa": far}, None) is None


@pytest.mark.parametrize(("scene", "expected"), [("dihedral", "dihedral"),
                                                 ("/data/exp/scenes/room.xml", "scenes/room.xml"),
                                                 ("/elsewhere/room.xml", "room.xml")])
def test_scene_label_is_never_an_absolute_path(scene, expected, tmp_path):
    experiment = SimpleNamespace(scene=scene, source="/data/exp/run.toml")
    assert scene_label(experiment) == expected


AUTOFOCUS_EXPERIMENT = """
name = "autofocus-tiny"
[radar]
[trajectory]
kind = "linear"
start = [14.8, 1.4, 4.5]
velocity = [0.5, 0.0, 0.0]
duration = 0.6
[trajectory.errors]
seed = 11
position_random_walk = [0.0, 2e-3, 1e-3]
[look]
off_nadir_deg = 55.71
[[targets]]
position = [15.0, 8.0, 0.0]
rcs = 1.0
[simulation]
seed = 7
normalized = true
[focus]
algorithm = "bpa"
azimuth_resolution = 0.1
autofocus = "pga"
[focus.grid]
kind = "slant"
along_track = [-0.1, 0.5, 0.02]
slant_range = [7.69, 8.29, 0.02]
[metrics]
target = [15.0, 8.0, 0.0]
islr_extent = 2
"""


@pytest.mark.slow  # about 10 s: a simulation, BPA and PGA
def test_an_autofocused_run_reports_its_autofocus(tmp_path):
    """A run with navigation errors and PGA: the autofocus results in the record and in their
    own table (they were only in the configuration dump), the estimated phase per sweep as a
    figure of that section, and no Table 4 (no background)."""
    from mitsar.report.run import run_experiment

    source = tmp_path / "autofocus.toml"
    source.write_text(AUTOFOCUS_EXPERIMENT)
    report = run_experiment(source, tmp_path / "run")
    record = json.loads((tmp_path / "run" / RUN_RECORD).read_text())
    entry = record["autofocus"]["bpa"]
    assert entry["method"] == "pga" and isinstance(entry["applied"], bool)
    assert entry["iterations"] >= 1 and entry["entropy_after"] > 0
    figure = next(f for f in record["figures"] if f.get("section") == "Autofocus")
    assert figure["file"] == "autofocus_bpa.png"
    assert (tmp_path / "run" / figure["file"]).stat().st_size > 10_000
    assert not any(t["title"].startswith("Comparison") for t in record["tables"])
    text = report.read_text(encoding="utf-8")
    page = Page(text)
    row = page.table_after("Autofocus")[1]
    assert [cell for cell, _ in row[:2]] == ["bpa", "pga"]
    assert text.index("<h2>Autofocus</h2>") < text.index('alt="autofocus_bpa.png"')


def test_ambiguity_table_and_figures_read_in_words():
    """The ambiguity run's table had raw keys (``fraction_outside_beam``) at five different
    precisions and a title "(0.15, 0.1)"; its figures were titled by their file stems."""
    from mitsar.report.run import (
        _ambiguity_figure,
        _ambiguity_heading,
        _ambiguity_value,
        _resolution_text,
    )

    assert _resolution_text([0.15, 0.1]) == "0.15 m (range) x 0.1 m (azimuth)"
    assert _resolution_text(0.1) == "0.1 m" and _resolution_text([0.1, 0.1]) == "0.1 m"
    assert _ambiguity_heading("fraction_outside_beam") == "outside the beam [%]"
    assert _ambiguity_heading("fraction_only_ambiguous") == "only ambiguous [%]"
    assert _ambiguity_heading("surface_area") == "surface area [m²]"
    assert _ambiguity_value("fraction_resolved", 0.1234) == pytest.approx(12.34)
    assert _ambiguity_value("surface_area", 307.0) == 307.0
    assert _ambiguity_figure("ambiguity_paper_side_3d")[0] == "Ambiguity, paper_side: 3-D view"
    assert _ambiguity_figure("comparison")[0] == "Trajectories compared"


def test_interferometry_summary_reads_in_words(tmp_path):
    """The summary's keys (``perpendicular_baseline_m``) become "perpendicular baseline [m]";
    each row keeps its own precision (one quantity per row)."""
    summary = {"perpendicular_baseline_m": 0.041114, "median_coherence": 0.98765,
               "points": 17061}
    page, _ = _page(tmp_path, interferometry={"summary": summary})
    rows = {row[0][0]: row[1][0] for row in page.table_after("Interferometry")[1:]}
    assert rows == {"perpendicular baseline [m]": "0.04111", "median coherence": "0.9877",
                    "points": "17061"}


def test_a_small_variance_is_not_shown_as_zero():
    """Two realisations gave an IRW variance of 1.4e-6 cells², shown as 0.0000 beside the
    paper's 0.006: variances in cells² are written in exponent form, one format a column."""
    from mitsar.report.html import _table

    page = Page(_table(["source", "IRW variance [cells²]", "PSLR variance [dB²]"],
                       [["mitsar", 1.4e-6, 0.015], ["paper", 0.006, 0.269]]))
    cells = [[text for text, _ in row[1:]] for row in page.tables[0][1:]]
    assert cells == [["1.4e-06", "0.015"], ["6.0e-03", "0.269"]]
