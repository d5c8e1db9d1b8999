"""CPHD that other readers trust (issue 25 item 2): TOASaved, TOA1/TOA2, aFRR1/aFRR2 and
SceneCoordinates/ImageGrid consistent for short and long collections, judged by sarkit's
``cphdcheck --thorough`` (exit 0) and its consistency checker (no failure at all), and by
sarpy's ``CphdConsistency`` where sarpy is installed (NGA.STND.0068-1 CPHD 1.0.1 §4, §5, §6)."""

from __future__ import annotations

import subprocess
import sys
from pathlib import Path

import numpy as np
import pytest

import mitsar
from mitsar.export import write_cphd
from mitsar.model.radar import SPEED_OF_LIGHT as C

skcphd = pytest.importorskip("sarkit.cphd", reason="needs sarkit (pip install mitsar[nga])")
skver = pytest.importorskip("sarkit.verification")

TARGET = [15.0, 8.0, 0.0]


def _raw(sweeps: int):
    """An analytic point-target run of ``sweeps`` sweeps along a straight 0.5 m/s track."""
    radar = mitsar.Radar()
    duration = sweeps / radar.prf
    track = mitsar.Trajectory.linear([14.8 - 0.25 * duration, 1.4, 4.5], [0.5, 0, 0],
                                     duration)
    return mitsar.simulate_point_targets(radar, track, mitsar.Look(55.7),
                                         [mitsar.PointTarget(TARGET)], normalized=True)


@pytest.fixture(scope="module", params=[600, 4096])
def cphd(request, tmp_path_factory):
    raw = _raw(request.param)
    assert raw.sizes["sweep"] == request.param
    return raw, write_cphd(raw, tmp_path_factory.mktemp("cphd") / "run.cphd", srp=TARGET)


def test_sarkit_checker_finds_nothing(cphd):
    _, path = cphd
    with path.open("rb") as handle:
        consistency = skver.CphdConsistency.from_file(handle, thorough=True)
        consistency.check()
    failed = {name: [d["details"] for d in result["details"] if not d["passed"]]
              for name, result in consistency.failures().items()}
    assert failed == {}


CHECKER_DIR = Path(sys.executable).parent


@pytest.mark.skipif(not (CHECKER_DIR / "cphdcheck").exists(),
                    reason="sarkit's cphdcheck script not installed beside this Python")
def test_cphdcheck_thorough_exits_0(cphd):
    _, path = cphd
    result = subprocess.run([str(CHECKER_DIR / "cphdcheck"), "--thorough", str(path)],
                            capture_output=True, check=False, text=True)
    assert result.returncode == 0, result.stdout[-2000:]


def test_toa_and_afrr_as_cphd_defines_them(cphd):
    raw, path = cphd
    with path.open("rb") as handle, skcphd.Reader(handle) as reader:
        xml = reader.metadata.xmltree
        pvp = reader.read_pvps(xml.findtext("{*}Data/{*}Channel/{*}Identifier"))
    saved = float(xml.findtext("{*}Channel/{*}Parameters/{*}TOASaved"))
    assert saved == pytest.approx(pvp["TOA2"].max() - pvp["TOA1"].min(), rel=1e-12)
    assert np.ptp(pvp["TOA1"]) > 0  # the drift the old TOASaved missed
    chirp_rate = mitsar.Radar.from_attrs(raw.attrs).chirp_rate
    fx_c = (pvp["FX1"] + pvp["FX2"]) / 2
    np.testing.assert_allclose(pvp["aFRR1"], 2 * fx_c / (C * chirp_rate), rtol=1e-12)
    np.testing.assert_allclose(pvp["aFRR2"], 2 / (C * chirp_rate), rtol=1e-12)
    assert xml.find("{*}SceneCoordinates/{*}ImageGrid") is not None


def test_sarpy_cphd_consistency_no_error(cphd):
    """sarpy 2.1's CphdConsistency (schema, PVPs, TOASaved, aFRR, ImageGrid, signal data):
    no Error on 600 and 4096 sweeps (measured: none of its 65 checks fails at all)."""
    pytest.importorskip("sarpy", reason="needs sarpy 2.1 (pip install mitsar[test])")
    from sarpy.consistency.cphd_consistency import CphdConsistency

    _, path = cphd
    checker = CphdConsistency.from_file(str(path), check_signal_data=True)
    checker.check()
    ran = checker.all()
    assert len(ran) >= 60 and "check_channel_toasaved_1" in ran  # the Error, checked
    errors = {name: result for name, result in checker.failures().items()
              if any(not d["passed"] and d["severity"] == "Error"
                     for d in result["details"])}
    assert errors == {}
