"""Regression pins of the bundled examples: raw data, image and metrics of each (issue 21).

A refactor that changes no physics must leave these unchanged. ``python tests/pins/pin_examples.py
OUT.json`` writes them (run once on the commit before a refactor, on the machine that compares);
``tests/test_example_pins.py`` recomputes them and compares. Each pin holds the SHA-256 of the
raw samples and of the focused image (bit-for-bit on the machine that wrote them) and float
fingerprints (energy and samples at fixed indices, IRW/PSLR/ISLR) compared with a relative
tolerance of 1e-9: another CPU may round the LLVM kernels differently in the last bit, never more.
"""

from __future__ import annotations

import hashlib
import json
import sys
import warnings
from pathlib import Path
from typing import Any

import numpy as np

from mitsar.experiment import load_experiment
from mitsar.experiment.runs import run_focus, run_metrics, run_simulation

EXAMPLES = Path(__file__).resolve().parents[2] / "examples"

# (example, overrides): shortened flights so that all pins run in about a minute.
CASES: dict[str, tuple[str, list[str]]] = {
    "paper_point_target": ("paper_point_target.toml", ["trajectory.duration=0.8"]),
    "scene_point_target": ("scene_point_target.toml", []),
    "dihedral_3d": ("dihedral_3d.toml", []),
    "trihedral_3d": ("trihedral_3d.toml", []),
    "walking_person": ("walking_person.toml", []),
}


def _digest(values: np.ndarray) -> str:
    return hashlib.sha256(np.ascontiguousarray(values).tobytes()).hexdigest()


def _fingerprint(values: np.ndarray) -> dict[str, Any]:
    flat = np.ravel(values)
    picks = np.linspace(0, flat.size - 1, 16).astype(np.int64)
    return {"energy": float(np.sum(np.abs(flat) ** 2)),
            "samples_re": [float(v) for v in flat[picks].real],
            "samples_im": [float(v) for v in flat[picks].imag],
            "shape": list(values.shape)}


def _numbers(tree: Any, prefix: str = "") -> dict[str, float]:
    """The finite numbers of a nested metrics dict, flattened to ``a.b`` keys."""
    found: dict[str, float] = {}
    if isinstance(tree, dict):
        for key, value in tree.items():
            found.update(_numbers(value, f"{prefix}{key}."))
    elif isinstance(tree, int | float | np.floating | np.integer) and not isinstance(tree, bool):
        if np.isfinite(tree):
            found[prefix[:-1]] = float(tree)
    return found


def pin(name: str) -> dict[str, Any]:
    """The pin of one example: digests, fingerprints and metrics."""
    file, overrides = CASES[name]
    experiment = load_experiment(EXAMPLES / file, overrides)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        raw = run_simulation(experiment)
        image = run_focus(raw, experiment.focus)
        try:
            metrics = run_metrics(image)
        except Exception as error:  # noqa: BLE001 - an example without a measurable target
            metrics = {"error": type(error).__name__}
    keep = _numbers(metrics)
    return {"raw_sha256": _digest(raw["raw"].values), "raw": _fingerprint(raw["raw"].values),
            "image_sha256": _digest(image["image"].values),
            "image": _fingerprint(image["image"].values), "metrics": keep}


if __name__ == "__main__":
    out = {name: pin(name) for name in CASES}
    Path(sys.argv[1]).write_text(json.dumps(out, indent=1, sort_keys=True))
