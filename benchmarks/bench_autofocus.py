"""Autofocus cost against focusing alone, and what it restores, on the traced room of
tests/test_autofocus_traced.py.

A metal trihedral on a concrete floor before a wall, a curved flight of 300 sweeps with
navigation errors, BPA at 2.5 cm on a 1.2 m x 1.0 m ground grid (240 x 100 pixels). In one
process and alternately, ``--rounds`` times: ``focus(raw)`` (the default a user gets),
``focus(raw, band_limit=False)`` (the focus autofocus runs twice: it models the per-pixel
band selection), ``focus(raw, autofocus="pga")`` and ``focus(raw, autofocus="entropy")``,
each the whole call a user makes (range compression, the estimate and the refocus included).
Prints the times, the ratios to focusing alone per round (median and best times; issue 24
item 4 bounds entropy at 3x), the load average, and for each method the reflector's peak
offset, peak level and IRW against the error-free image (true track).

    .venv/bin/python benchmarks/bench_autofocus.py --rounds 7

Measured (2026-11-27, 2 shared cores, no GPU; single rounds scatter by up to 2x with the
load; focus = the band-limited default since 1fafd1f, while autofocus focuses with
band_limit=False, the per-pixel band it models):

* With the refocus reusing the first focus's geometry (mitsar.focus.reuse, e0c6092), 7 rounds
  at load 1.7-2.1: focus median 1.29 s, with band_limit=False 0.68 s; **entropy 1.14 s:
  0.92x the default focus, 1.68x the band_limit=False one** (per round 0.53-1.56 and
  best times 0.82 against the default); PGA 0.97 s (0.82x, 1.49x); estimate + refocus of the
  last entropy call 0.30 s.
* Before that reuse (refocus = a whole second focus), 7 rounds at load 4.2-4.6: entropy
  0.99x the default focus, 2.44x the band_limit=False one; PGA 1.19x, 2.50x. Before this
  work: entropy median 2.47x (load ~3, 30 iterations a stage).
* The estimate alone (range compression, lines, chips, L-BFGS; old and new code alternately
  in one process, 9 rounds at load 2.3-4.2): 0.19 s against 0.25 s before (0.30 instead of
  0.40 of a 0.62 s focus); L-BFGS 0.1 s of it (114-139 iterations).
* Restored against the error-free image (load 1.7-2.1 run): entropy peak -0.06 dB, offset
  (-0.83, -2.59) cm, azimuth IRW -0.1 %; PGA -0.05 dB, (+0.86, -2.55) cm, +0.1 %; the errors
  alone -7.23 dB. The -2.5 cm in ground range is the offset's cross-track part (a quarter of
  the 10.7 cm range cell); the azimuth offsets are the along-track part and the unobservable
  linear phase (docs/autofocus.md).
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
    """The test module and its traced raw data (true track, with errors, bare floor)."""
    path = Path(__file__).resolve().parents[1] / "tests" / "test_autofocus_traced.py"
    spec = importlib.util.spec_from_file_location("autofocus_room", path)
    module = importlib.util.module_from_spec(spec)
    spec.loader.exec_module(module)

    folder = Path(os.environ.get("TMPDIR", "/tmp")) / "bench_autofocus_room"
    folder.mkdir(parents=True, exist_ok=True)
    return module, module.trace_room(folder)


def _quality(module, image, reference):
    """Peak offset [cm], peak level [dB] and azimuth IRW [%] against the error-free image."""
    metrics = module._metrics(image)
    offset = 100 * np.subtract(metrics["peak_position"], reference["peak_position"])[:2]
    irw = metrics["azimuth"]["irw_m"] / reference["azimuth"]["irw_m"] - 1
    return (f"peak {metrics['peak_db'] - reference['peak_db']:+.2f} dB, offset "
            f"({offset[0]:+.2f}, {offset[1]:+.2f}) cm, azimuth IRW {100 * irw:+.1f} %, range "
            f"IRW {100 * (metrics['range']['irw_m'] / reference['range']['irw_m'] - 1):+.1f} %")


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--rounds", type=int, default=5)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    module, room = _room()
    raw = room["errors"]
    images = {}

    def focus(name, **options):
        start = time.perf_counter()
        images[name] = mitsar.focus(raw, "bpa", module.GRID, azimuth_resolution=module.RHO,
                                    **options)
        return time.perf_counter() - start

    cases = {"focus": {}, "focus, band_limit=False": {"band_limit": False},
             "pga": {"autofocus": "pga"}, "entropy": {"autofocus": "entropy"}}
    focus("focus")  # compile
    times = {name: [] for name in cases}
    loads = [os.getloadavg()[0]]
    for _ in range(args.rounds):
        for name, options in cases.items():
            times[name].append(focus(name, **options))
        loads.append(os.getloadavg()[0])
    print(f"load average (1 min) {min(loads):.1f}-{max(loads):.1f}, {os.cpu_count()} CPUs")
    for name, values in times.items():
        print(f"{name}: {np.round(values, 2).tolist()} s, median {np.median(values):.2f} s")
    for method in ("pga", "entropy"):
        ratio = np.array(times[method]) / np.array(times["focus"])
        plain = np.array(times[method]) / np.array(times["focus, band_limit=False"])
        print(f"{method} / focus: per round {np.round(ratio, 2).tolist()}, median "
              f"{np.median(ratio):.2f}, best times "
              f"{min(times[method]) / min(times['focus']):.2f}; / focus with band_limit=False: "
              f"median {np.median(plain):.2f}; last estimate + refocus "
              f"{images[method].attrs['autofocus_seconds']:.2f} s")
    reference = room["reference"]
    print("navigation errors, no autofocus:", _quality(module, images["focus"], reference))
    for method in ("pga", "entropy"):
        attrs = images[method].attrs
        print(f"{method}: {_quality(module, images[method], reference)}; converged "
              f"{attrs['autofocus_converged']}, warning {attrs['autofocus_warning'] or 'none'}")


if __name__ == "__main__":
    main()
