"""Monte Carlo over background realisations (paper Tables 4-5), resumable on disk.

Scene: the paper's §4.1 geometry (target T_p = [15, 8, 0] m, platform from y = 1.4 m, z = 4.5 m
along +x at 0.5 m/s), a shorter pass that still gives every pixel of a +-0.6 m slant grid its
whole 10 cm-resolution aperture, and a 0.8 m x 0.8 m fluctuating background redrawn every sweep
(paper eq. 4).
"""

from __future__ import annotations

import dataclasses
import json
import math

import numpy as np
import pytest

from mitsar.errors import MitsarError
from mitsar.experiment import montecarlo
from mitsar.experiment.loading import experiment_from_dict, load_experiment

SWEEP = 0.004


def _experiment(cell_rcs_db: float | None, speed: float = 0.5, size: float = 0.8) -> dict:
    start, length = 14.28, 1.44
    origin = start + speed * SWEEP / 2
    a0, r0 = 15.0 - origin, math.hypot(6.6, 4.5)
    data = {
        "name": "mc-test",
        "radar": {},
        "trajectory": {"kind": "linear", "start": [start, 1.4, 4.5], "velocity": [speed, 0, 0],
                       "duration": length / speed},
        "look": {"off_nadir_deg": math.degrees(math.atan2(6.6, 4.5))},
        "targets": [{"position": [15.0, 8.0, 0.0], "rcs": 1.0}],
        "simulation": {"seed": 11, "normalized": True},
        "focus": {"window": "rect", "azimuth_resolution": 0.1,
                  "grid": {"kind": "slant", "along_track": [a0 - 0.6, a0 + 0.6, 0.01],
                           "slant_range": [r0 - 0.6, r0 + 0.6, 0.01]}},
        "metrics": {"target": [15.0, 8.0, 0.0], "islr_extent": "paper"},
    }
    if cell_rcs_db is not None:
        data["background"] = {"center": [15.0, 8.0, 0.0], "size": [size, size],
                              "cell_rcs_db": cell_rcs_db, "mode": "pulse"}
    return data


def _toml(data: dict) -> str:
    """A minimal TOML writer for the nested dicts above."""
    def value(v):
        if isinstance(v, bool):
            return "true" if v else "false"
        if isinstance(v, str):
            return json.dumps(v)
        if isinstance(v, list | tuple):
            return "[" + ", ".join(value(x) for x in v) + "]"
        return repr(float(v)) if isinstance(v, float) else str(v)

    lines, tables = [], []
    for key, item in data.items():
        if isinstance(item, dict):
            tables.append((key, item))
        elif isinstance(item, list) and item and isinstance(item[0], dict):
            for entry in item:
                lines.append(f"[[{key}]]")
                lines += [f"{k} = {value(v)}" for k, v in entry.items()]
        else:
            lines.insert(0, f"{key} = {value(item)}")
    for key, table in tables:
        lines.append(f"[{key}]")
        nested = [(k, v) for k, v in table.items() if isinstance(v, dict)]
        lines += [f"{k} = {value(v)}" for k, v in table.items() if not isinstance(v, dict)]
        for sub, subtable in nested:
            lines.append(f"[{key}.{sub}]")
            lines += [f"{k} = {value(v)}" for k, v in subtable.items()]
    return "\n".join(lines) + "\n"


@pytest.fixture(scope="module")
def absorbing():
    """Metrics of the target on a completely absorbing background."""
    from mitsar.experiment.runs import run_focus, run_simulation

    experiment = experiment_from_dict(_experiment(None))
    options = dataclasses.replace(experiment.focus, algorithm="wda")
    image = run_focus(run_simulation(experiment), options)
    return montecarlo._measure(image, (15.0, 8.0, 0.0), "paper")


@pytest.fixture(scope="module")
def levels():
    return {db: montecarlo.run(experiment_from_dict(_experiment(db)), 3, ["wda"],
                               progress=False) for db in (-20.0, -10.0)}


def _mean(summary, direction, metric):
    return float(summary["mean"].sel(algorithm="wda", direction=direction, metric=metric))


def test_absorbing_background_gives_the_rect_closed_form(absorbing):
    assert absorbing["range_irw_cells"] == pytest.approx(0.886, abs=0.01)
    assert absorbing["range_pslr_db"] == pytest.approx(-13.26, abs=0.2)
    assert absorbing["azimuth_pslr_db"] == pytest.approx(-13.26, abs=0.2)


def test_weak_background_stays_close_to_the_absorbing_one(levels, absorbing):
    summary = levels[-20.0]
    assert list(summary["seed"].values) == [11, 12, 13]
    for direction in ("range", "azimuth"):
        assert _mean(summary, direction, "irw_cells") == pytest.approx(
            absorbing[f"{direction}_irw_cells"], abs=0.02)
        assert abs(_mean(summary, direction, "pslr_db")
                   - absorbing[f"{direction}_pslr_db"]) < 1.5


def test_strong_background_raises_the_sidelobes(levels, absorbing):
    """Paper Table 5: about 3 dB higher PSLR and ISLR on a -10 dB background."""
    weak, strong = levels[-20.0], levels[-10.0]
    raise_db = np.mean([_mean(strong, d, "pslr_db") - absorbing[f"{d}_pslr_db"]
                        for d in ("range", "azimuth")])
    assert raise_db > 1.5
    for direction in ("range", "azimuth"):
        assert _mean(strong, direction, "pslr_db") > _mean(weak, direction, "pslr_db")
        assert _mean(strong, direction, "islr_db") > absorbing[f"{direction}_islr_db"] + 1.0
    table = montecarlo.format_table(strong)
    assert "WDA" in table and "azimuth" in table


def test_runs_resume_from_disk_and_refuse_a_changed_configuration(tmp_path, monkeypatch):
    path = tmp_path / "experiment.toml"
    path.write_text(_toml(_experiment(-20.0, speed=1.0, size=0.3)), encoding="utf-8")
    load_experiment(path)  # the file is a valid experiment
    out = tmp_path / "mc"
    calls = []
    import mitsar.experiment.runs as experiment_module

    original = experiment_module.run_simulation

    def counting(experiment, *args, **kwargs):
        calls.append(experiment.simulation.seed)
        if len(calls) == 2 and fail[0]:
            raise KeyboardInterrupt  # interrupted during the second realisation
        return original(experiment, *args, **kwargs)

    fail = [True]
    monkeypatch.setattr(experiment_module, "run_simulation", counting)
    with pytest.raises(KeyboardInterrupt):
        montecarlo.run_montecarlo(path, 3, ["rda", "fsa"], out)
    record = json.loads((out / montecarlo.RECORD_FILE).read_text())
    assert [r["seed"] for r in record["records"]] == [11]  # the finished one survived
    fail[0] = False
    summary = montecarlo.run_montecarlo(path, 3, ["rda", "fsa"], out)
    assert calls == [11, 12, 12, 13]  # seed 11 was not simulated again
    assert list(summary["seed"].values) == [11, 12, 13]
    assert int(summary["count"].sel(algorithm="fsa", direction="range",
                                    metric="pslr_db")) == 3
    assert (out / montecarlo.SUMMARY_FILE).is_file()
    assert "RDA" in (out / montecarlo.TABLE_FILE).read_text()
    # RDA and FSA see the same realisations: nearly the same metrics.
    values = summary["value"]
    np.testing.assert_allclose(values.sel(algorithm="rda"), values.sel(algorithm="fsa"),
                               atol=0.05)
    with pytest.raises(MitsarError, match="another configuration"):
        montecarlo.run_montecarlo(path, 3, ["rda"], out)
    fresh = montecarlo.run_montecarlo(path, 1, ["rda"], out, resume=False)
    assert list(fresh["seed"].values) == [11]


def test_tables_print_the_papers_values_beside_ours(levels):
    """The -20 and -10 dB runs print paper Tables 4 and 5 (the WDA rows) below ours; the bundled
    -10 dB experiment is the -20 dB one with the stronger background."""
    from mitsar.experiment.examples import example_path
    from mitsar.experiment.loading import load_experiment
    from mitsar.experiment.paper import PAPER_TABLES, paper_table

    for level, number in ((-20.0, 4), (-10.0, 5)):
        table = montecarlo.format_table(levels[level])
        assert f"paper Table {number}" in table
        wda = PAPER_TABLES[level]["wda"]["azimuth"]["pslr_db"][0]
        assert f"{wda:11.3f}" in table
    assert paper_table(-15.0) is None
    strong = load_experiment(example_path("paper_point_target_10db"))
    weak = load_experiment(example_path("paper_point_target"))
    assert strong.background.cell_rcs_db == -10.0 and weak.background.cell_rcs_db == -20.0
    assert strong.trajectory.describe() == weak.trajectory.describe()
    assert strong.targets == weak.targets
