"""The fuzz campaign's cases for issue 27 (scripts/fuzz.py): every section validated at load
whatever the command, Trajectory's bounds, wrong argument classes at the public API, files that
are not text, two surfaces of one name, a rendering integrator, reception per channel and per
pass. Each is invalid by construction and must be refused (or warned about) naming the key,
the parameter or the target: CLEAN (docs/reliability.md §4)."""

from __future__ import annotations

import random
import sys
from pathlib import Path

import pytest

sys.path.insert(0, str(Path(__file__).resolve().parent.parent / "scripts"))
import fuzz  # noqa: E402


def _cases() -> list[fuzz.Case]:
    documents = fuzz.base_documents()
    cases = []
    for family, keys in fuzz.LOAD_CASES.items():
        generated = fuzz._toml_cases(family, documents[family], random.Random(0),
                                     len(fuzz.MEMORY_CASES[family]) + len(keys), True)
        cases += [c for c in generated if c.name.startswith("load ")]
    cases += [fuzz.Case("api", name, True, tokens, action)
              for name, action, tokens in fuzz._issue27_api_cases()]
    cases += [c for c in fuzz._xml_cases(random.Random(0), 9, True) if "integrator" in c.name]
    return cases


CASES = {f"{case.family} {case.name}": case for case in _cases()}


def test_every_family_has_its_load_cases() -> None:
    assert len(CASES) == sum(map(len, fuzz.LOAD_CASES.values())) + 9
    assert any("metrics.target" in name for name in CASES)
    assert any("slab_width" in name for name in CASES)


@pytest.mark.parametrize("name", sorted(CASES))
def test_issue27_case_is_clean(name: str, tmp_path: Path, monkeypatch) -> None:
    monkeypatch.setenv("MITSAR_MEMORY_LIMIT", "2G")
    case = CASES[name]
    outcome = fuzz.run_case(case, tmp_path)
    assert fuzz.classify(case, outcome) == "CLEAN", outcome.message
