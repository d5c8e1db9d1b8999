"""The bundled examples give the same raw data, image and metrics as when they were pinned.

The pins (``tests/pins/examples.json``) were written by ``tests/pins/pin_examples.py`` on the
commit before the layout work of issue 21 (behaviour and numbers unchanged by design). This is
a regression guard for refactors, not a physics test: the physics is asserted against closed
forms elsewhere. Digests are compared bit for bit when this machine reproduces them; the float
fingerprints everywhere with a relative tolerance of 1e-9 (a CPU with other vector units may
round Dr.Jit's LLVM kernels differently in the last bit; a real change moves them by far more).
"""

from __future__ import annotations

import json
import sys
from pathlib import Path

import numpy as np
import pytest

sys.path.insert(0, str(Path(__file__).parent / "pins"))
from pin_examples import CASES, pin  # noqa: E402

PINS = json.loads((Path(__file__).parent / "pins" / "examples.json").read_text())
RTOL = 1e-9


def _close(found: dict, expected: dict, rtol: float) -> None:
    assert found["shape"] == expected["shape"]
    assert found["energy"] == pytest.approx(expected["energy"], rel=rtol)
    scale = max(np.max(np.abs(expected["samples_re"])), np.max(np.abs(expected["samples_im"])))
    for part in ("samples_re", "samples_im"):
        np.testing.assert_allclose(found[part], expected[part], rtol=0, atol=rtol * scale)


@pytest.mark.slow
@pytest.mark.parametrize("name", sorted(CASES))
def test_example_reproduces_its_pin(name):
    found, expected = pin(name), PINS[name]
    _close(found["raw"], expected["raw"], RTOL)
    _close(found["image"], expected["image"], RTOL)
    assert set(found["metrics"]) == set(expected["metrics"])
    for key, value in expected["metrics"].items():
        assert found["metrics"][key] == pytest.approx(value, rel=1e-7, abs=1e-9), key
