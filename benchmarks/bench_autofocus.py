"""Autofocus cost against focusing alone on the traced room of tests/test_autofocus_traced.py.

A metal trihedral on a concrete floor before a wall, a curved flight of 300 sweeps with
navigation errors, BPA at 2.5 cm on a 1.2 m x 1.0 m ground grid (240 x 100 pixels). In one
process and alternately, ``--rounds`` times: ``focus(raw)``, ``focus(raw, autofocus="pga")``,
``focus(raw, autofocus="entropy")`` (each call the whole thing a user runs: range compression,
the estimate and the refocus included). Prints the ratio per round, the ratio of the best
times and the load average (the ratio is what issue 24 item 4 bounds: entropy <= 3x).

    .venv/bin/python benchmarks/bench_autofocus.py --rounds 5
"""

from __future__ import annotations

import argparse
import importlib.util
import os
import time
import warnings
from pathlib import Path

import numpy as np

import mitsar


def _room():
    """The raw data with navigation errors, traced as the test does."""
    path = Path(__file__).resolve().parents[1] / "tests" / "test_autofocus_traced.py"
    spec = importlib.util.spec_from_file_location("autofocus_room", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    folder = Path(os.environ.get("TMPDIR", "/tmp")) / "bench_autofocus_room"
    folder.mkdir(parents=True, exist_ok=True)
    return module, module.trace_room(folder)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    module, room = _room()
    raw = room["errors"]

    def focus(**options):
        start = time.perf_counter()
        mitsar.focus(raw, "bpa", module.GRID, azimuth_resolution=module.RHO, **options)
        return time.perf_counter() - start

    focus()  # compile
    times = {"focus": [], "pga": [], "entropy": []}
    for _ in range(args.rounds):
        times["focus"].append(focus())
        for method in ("pga", "entropy"):
            times[method].append(focus(autofocus=method))
    print(f"load average {os.getloadavg()}, {os.cpu_count()} CPUs")
    print("seconds:", {k: np.round(v, 2).tolist() for k, v in times.items()})
    for method in ("pga", "entropy"):
        ratio = np.array(times[method]) / np.array(times["focus"])
        print(f"{method}: ratio per round {np.round(ratio, 2).tolist()}, median "
              f"{np.median(ratio):.2f}, best times {min(times[method]) / min(times['focus']):.2f}")


if __name__ == "__main__":
    main()
