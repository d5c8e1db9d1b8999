"""Tracer speed on the paper's room: shadow-ray reuse against a ray per sweep, and Sionna RT.

In one run, alternated round by round on the canned ``control_volume`` (paper Table 3 room,
default density: 9 scatterers per resolution cell, ~0.97 M scatterers), direct backscatter:

* mitsar, a shadow ray per sweep (``visibility_feature=0``: the tracer before the reuse);
* mitsar, shadow rays shared by blocks of sweeps (the default ``visibility_feature``, 3 cm;
  docs/integrator.md §"Visibility reuse");
* Sionna RT's ``PathSolver`` on the same room, one aperture position per solve
  (``sionna_paper_room.py``, its docstring states the workload), in a subprocess: by default
  under this interpreter if it imports ``sionna.rt``, else under ``--sionna-python``; without
  Sionna RT its rows are skipped with the reason.

Definitions: a *contribution* is a (scatterer, sweep) pair inside the beam cull (±2 beamwidths)
and the histogram's range grid: the lanes that get a visibility decision, a float64 phase and a
deposit (the histogram attribute ``traced_shadow_rays``, counted the same way before and after
the reuse). Contributions/s and ms per aperture position (= per sweep) are from the wall time
of :func:`mitsar.raw.traced.trace` on the loaded scene, warm (scatterers and kernels cached),
best of the rounds; CPU seconds (all threads) are printed too, as the 2-core machine is shared.
The mitsar-vs-mitsar error is ``20 log10(|raw_reuse - raw_per_sweep| / |raw_per_sweep|)``.

Run: ``python benchmarks/bench_speed.py [--sweeps 256] [--rounds 3] [--sionna-python PATH]``.
"""

from __future__ import annotations

import argparse
import json
import math
import os
import resource
import subprocess
import sys
import time
from pathlib import Path

import numpy as np

import mitsar
from mitsar.raw.traced import histogram_to_raw_product, trace
from mitsar.scene import load_scene

RADAR = mitsar.Radar()
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
START = [14.8, 1.4, 4.5]
HERE = Path(__file__).resolve().parent
PREVIOUS_SIONNA_RATIO = "34-48x (issue #13 notes, before the reuse; another machine state)"


def _cpu() -> float:
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _sionna_python(option: str | None) -> tuple[str | None, str]:
    """The interpreter that has Sionna RT, or None and why not."""
    option = option or os.environ.get("MITSAR_SIONNA_PYTHON")  # set by `make bench`
    candidates = [option] if option else [sys.executable]
    for python in candidates:
        probe = subprocess.run([python, "-c", "import sionna.rt"], capture_output=True,
                               text=True, check=False)
        if probe.returncode == 0:
            return python, ""
        reason = (probe.stderr.strip().splitlines() or ["failed"])[-1]
    return None, (f"Sionna RT not importable by {candidates[0]} ({reason}); install it with "
                  "'pip install sionna-rt==2.2.0' (pins mitsuba 3.9.1, drjit 1.5.0; `make bench` "
                  "puts it in .venv-sionna), or pass --sionna-python")


def _sionna(python: str, positions: int, samples: int) -> dict:
    result = subprocess.run([python, str(HERE / "sionna_paper_room.py"), "--positions",
                             str(positions), "--samples", str(samples)],
                            capture_output=True, text=True, check=True)
    return json.loads(result.stdout.strip().splitlines()[-1])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sweeps", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=3)
    parser.add_argument("--density", type=float, default=None, help="scatterers per m²")
    parser.add_argument("--sionna-python", default=None)
    parser.add_argument("--sionna-positions", type=int, default=3)
    parser.add_argument("--sionna-samples", type=int, default=10**6)
    args = parser.parse_args()

    scene = load_scene("control_volume")
    track = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], (args.sweeps + 0.5) / RADAR.prf)
    # (visibility_feature, deterministic): all cores unless said; the default is one thread
    cases = {"mitsar, a shadow ray per sweep": (0.0, False),
             "mitsar, shadow-ray reuse (3 cm)": (None, False),
             "mitsar, reuse, one thread (deterministic default)": (None, True)}
    python, reason = _sionna_python(args.sionna_python)
    best: dict[str, dict] = {}
    products = {}
    for name, (feature, serial) in cases.items():  # cold calls: sampling, upload, compilation
        products[name] = trace(RADAR, track, LOOK, scene, density=args.density,
                               visibility_feature=feature, deterministic=serial)
    sionna_runs = []
    for _ in range(args.rounds):
        for name, (feature, serial) in cases.items():
            start, start_cpu = time.perf_counter(), _cpu()
            hist = trace(RADAR, track, LOOK, scene, density=args.density,
                         visibility_feature=feature, deterministic=serial)
            wall, cpu = time.perf_counter() - start, _cpu() - start_cpu
            if name not in best or wall < best[name]["wall"]:
                best[name] = {"wall": wall, "cpu": cpu, "attrs": hist.attrs}
        if python:
            sionna_runs.append(_sionna(python, args.sionna_positions, args.sionna_samples))

    raw = [histogram_to_raw_product(products[name])["raw"].values for name in cases]
    error = 20 * math.log10(np.linalg.norm(raw[1] - raw[0]) / np.linalg.norm(raw[0]))
    attrs = next(iter(best.values()))["attrs"]
    print(f"paper room (control_volume): {attrs['scatterer_count']:,} scatterers, "
          f"{args.sweeps} sweeps, {args.rounds} alternated rounds, best of each; load average "
          f"{os.getloadavg()[0]:.1f} on {os.cpu_count()} cores (shared machine)")
    print(f"{'case':50s} {'contrib.':>11s} {'shadow rays':>11s} {'wall s':>7s} {'CPU s':>6s} "
          f"{'M contrib/s':>11s} {'ms/pos':>7s}")
    per_position = {}
    for name, row in best.items():
        a = row["attrs"]
        rays = a["traced_shadow_rays"] if cases[name][0] == 0.0 else a["traced_visibility_rays"]
        per_position[name] = row["wall"] / args.sweeps
        print(f"{name:50s} {a['traced_shadow_rays']:11,d} {rays:11,d} {row['wall']:7.3f} "
              f"{row['cpu']:6.2f} {a['traced_shadow_rays'] / row['wall'] / 1e6:11.1f} "
              f"{1e3 * per_position[name]:7.2f}")
    reuse = best["mitsar, shadow-ray reuse (3 cm)"]["attrs"]
    print(f"reuse: {reuse['traced_visibility_split']:,} (candidate, block) pairs re-tested per "
          f"sweep; raw data vs a ray per sweep: {error:.1f} dB; speed-up "
          f"{best['mitsar, a shadow ray per sweep']['wall'] / best['mitsar, shadow-ray reuse (3 cm)']['wall']:.2f}x wall, "  # noqa: E501
          f"{best['mitsar, a shadow ray per sweep']['cpu'] / best['mitsar, shadow-ray reuse (3 cm)']['cpu']:.2f}x CPU")  # noqa: E501
    if python:
        sionna = min(run["seconds_per_position"] for run in sionna_runs)
        print(f"{'Sionna RT PathSolver (1 position)':50s} {sionna_runs[-1]['paths']:11,d} "
              f"{sionna_runs[-1]['samples_per_src']:11,d} {sionna:7.3f} {'':6s} "
              f"{sionna_runs[-1]['paths'] / sionna / 1e6:11.1f} {1e3 * sionna:7.2f}")
        for name, seconds in per_position.items():
            print(f"ratio Sionna RT / {name}: {sionna / seconds:.0f}x per aperture position")
    else:
        print(f"Sionna RT: skipped: {reason}")
        print(f"context only, not measured in this run: previous ratio {PREVIOUS_SIONNA_RATIO}")


if __name__ == "__main__":
    main()
