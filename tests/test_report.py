"""``mitsar run`` and ``report.html``: every bundled experiment runs to a report that a real
headless browser renders with no missing figure."""

from __future__ import annotations

import json
import re
import shutil
import subprocess

import pytest

from mitsar.cli import main
from mitsar.errors import MitsarError
from mitsar.experiment.examples import example_path, examples_dir
from mitsar.report.html import RUN_RECORD, build_report
from mitsar.report.run import run_experiment

BROWSER = shutil.which("chromium-headless-shell") or shutil.which("chromium")
EXAMPLES = sorted(p.stem for p in examples_dir().glob("*.toml"))


def _rendered(report):
    """(figures decoded, figures missing) as the page's own check reports them in a browser."""
    dom = subprocess.run([BROWSER, "--headless", "--no-sandbox", "--disable-gpu",
                          "--dump-dom", report.resolve().as_uri()],
                         capture_output=True, text=True, timeout=120, check=True).stdout
    found = re.search(r'id="render-check" data-loaded="(\d+)" data-failed="(-?\d+)"', dom)
    assert found, "the page's render check did not run"
    return int(found.group(1)), int(found.group(2))


@pytest.mark.slow
@pytest.mark.parametrize("name", EXAMPLES)
def test_every_bundled_experiment_runs_to_a_report_that_renders(name, tmp_path):
    report = run_experiment(example_path(name), tmp_path / name)
    record = json.loads((tmp_path / name / RUN_RECORD).read_text())
    assert record["figures"], "a run draws figures"
    assert record["provenance"]["versions"]["mitsar"]
    assert record["steps"] and all(seconds >= 0 for seconds in record["steps"].values())
    if record["kind"] != "ambiguity":  # one raw product, or one per pass ([[passes]])
        assert "raw.nc" in record["products"] or "raw_pass0.nc" in record["products"]
        assert record["provenance"]["seeds"]["simulation"] is not None
    if "mapping" in record:  # [mapping]: the map's products, scores and features
        assert {"mapping/detections.nc", "mapping/map_scores.nc"} <= set(record["products"])
        scores = {row[0]: row[1] for row in record["mapping"]["scores"]}
        assert 0.0 <= scores["precision"] <= 1.0 and 0.0 <= scores["f_score"] <= 1.0
        assert record["mapping"]["features"], "the scene's corner features are scored"
    if BROWSER is None:
        pytest.skip("no headless browser (chromium-headless-shell or chromium): install "
                    "Debian's chromium-headless-shell, as scripts/setup.sh does")
    loaded, failed = _rendered(report)
    assert (loaded, failed) == (len(record["figures"]), 0)


def test_report_of_a_run_folder_and_its_errors(tmp_path):
    """The paper's point target with two algorithms: metrics of both in the record and the page;
    ``mitsar report`` rebuilds it; a run never replaces a folder's record unless asked; a
    missing figure or record is a clear error."""
    out = tmp_path / "run"
    assert main(["run", str(example_path("paper_point_target")), "-o", str(out), "-q",
                 "-a", "bpa", "wda", "-n", "2", "--set", "trajectory.duration=0.8"]) == 0
    record = json.loads((out / RUN_RECORD).read_text())
    assert set(record["metrics"]) == {"bpa", "wda"}
    titles = [table["title"] for table in record["tables"]]
    assert titles[0].startswith("Comparison with the paper's Table 4")  # one realisation
    table = record["tables"][1]
    assert table["title"].startswith("Monte Carlo over 2")
    assert [row[0] for row in table["rows"]][-1] == "paper Table 4: WDA azimuth"  # beside ours
    assert "IRW mean [cells]" in table["header"] and "PSLR variance [dB²]" in table["header"]
    assert {"background.png", "montecarlo/cuts_wda.png"} <= {f["file"]
                                                             for f in record["figures"]}
    page = (out / "report.html").read_text()
    assert "Image quality" in page and page.count("<figure>") == len(record["figures"])
    assert record["experiment"]["trajectory"]["duration"] == 0.8
    assert main(["run", str(example_path("paper_point_target")), "-o", str(out), "-q"]) == 2
    (out / "report.html").unlink()
    assert main(["report", str(out), "-q"]) == 0 and (out / "report.html").is_file()
    (out / record["figures"][0]["file"]).unlink()
    with pytest.raises(MitsarError, match="missing"):
        build_report(out)
    with pytest.raises(MitsarError, match="run.json"):
        build_report(tmp_path)
