"""Tracer speed on the paper's room: the block kernel against the lane kernels, and Sionna RT.

In one run, alternated round by round on the canned ``control_volume`` (paper Table 3 room,
default density: 9 scatterers per resolution cell, ~0.97 M scatterers), direct backscatter:

* mitsar lane kernels (a lane per scatterer and sweep; ``block_kernel=False``), a shadow ray
  per sweep (``visibility_feature=0``: the tracer before the visibility reuse);
* mitsar lane kernels with shadow rays shared by blocks of sweeps (3 cm; docs/integrator.md
  §"Visibility reuse"), on all cores and on one thread (the deterministic default before the
  block kernel);
* mitsar block kernel (the default: a lane per scatterer and chunk of sweeps, float32 advance
  from the chunk's middle sweep, shared probe rays, packet deposits; docs/integrator.md
  §"Performance"), on all cores and deterministic (the default: integer packets on every core,
  the rest on one thread);
* Sionna RT's ``PathSolver`` on the same room, one aperture position per solve
  (``sionna_paper_room.py``, its docstring states the workload), in a subprocess: by default
  under this interpreter if it imports ``sionna.rt``, else under ``--sionna-python``; without
  Sionna RT its rows are skipped with the reason.

Definitions: a *contribution* is a (scatterer, sweep) pair inside the beam cull (±2 beamwidths)
and the histogram's range grid: the lanes that get a visibility decision, a phase and a deposit
(the histogram attribute ``traced_shadow_rays``, counted the same way by both kernels; the block
kernel's float32 bin test may differ by a few lanes at the grid's edge).
Contributions/s and ms per aperture position (= per sweep) are from the wall time of
:func:`mitsar.raw.traced.trace` on the loaded scene, warm (scatterers and kernels cached), best
of the rounds; CPU seconds (all threads) and the load average before and after are printed too,
as the 2-core machine is shared. Errors are ``20 log10(|raw - raw_ref| / |raw_ref|)`` against a
shadow ray per sweep.

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
PREVIOUS_SIONNA_SECONDS = 0.75
"""Sionna RT 2.2 PathSolver, 10^6 rays, per aperture position, in an earlier run of this script
on this machine (docs/integrator.md §"Determinism"): context when Sionna RT is not installed."""


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
    # (visibility_feature, deterministic, block_kernel): all cores unless said
    per_sweep_name = "lanes, a shadow ray per sweep"
    cases = {per_sweep_name: (0.0, False, False),
             "lanes, shadow-ray reuse (3 cm)": (None, False, False),
             "lanes, reuse, one thread (old default)": (None, True, False),
             "block kernel, all cores": (None, False, True),
             "block kernel, deterministic (default)": (None, True, True)}
    python, reason = _sionna_python(args.sionna_python)
    best: dict[str, dict] = {}
    products = {}
    load_before = os.getloadavg()
    for name, (feature, serial, blocks) in cases.items():  # cold: sampling, upload, compiling
        products[name] = trace(RADAR, track, LOOK, scene, density=args.density,
                               visibility_feature=feature, deterministic=serial,
                               block_kernel=blocks)
    sionna_runs = []
    for _ in range(args.rounds):
        for name, (feature, serial, blocks) in cases.items():
            start, start_cpu = time.perf_counter(), _cpu()
            hist = trace(RADAR, track, LOOK, scene, density=args.density,
                         visibility_feature=feature, deterministic=serial, block_kernel=blocks)
            wall, cpu = time.perf_counter() - start, _cpu() - start_cpu
            if name not in best or wall < best[name]["wall"]:
                best[name] = {"wall": wall, "cpu": cpu, "attrs": hist.attrs}
        if python:
            sionna_runs.append(_sionna(python, args.sionna_positions, args.sionna_samples))

    raw = {name: histogram_to_raw_product(product)["raw"].values
           for name, product in products.items()}
    reference = raw[per_sweep_name]
    attrs = next(iter(best.values()))["attrs"]
    print(f"paper room (control_volume): {attrs['scatterer_count']:,} scatterers, "
          f"{args.sweeps} sweeps, {args.rounds} alternated rounds, best of each; load average "
          f"{load_before[0]:.1f} before, {os.getloadavg()[0]:.1f} after, on {os.cpu_count()} "
          "cores (shared machine)")
    print(f"{'case':42s} {'contrib.':>11s} {'rays':>10s} {'wall s':>7s} {'CPU s':>6s} "
          f"{'M contrib/s':>11s} {'M/CPU-s':>8s} {'ms/pos':>7s} {'vs ray/sweep':>12s}")
    per_position = {}
    for name, row in best.items():
        a = row["attrs"]
        rays = a["traced_shadow_rays"] if cases[name][0] == 0.0 else a["traced_visibility_rays"]
        per_position[name] = row["wall"] / args.sweeps
        diff = np.linalg.norm(raw[name] - reference) / np.linalg.norm(reference)
        error = ("-" if name == per_sweep_name else "identical" if diff == 0
                 else f"{20 * math.log10(diff):.1f} dB")
        print(f"{name:42s} {a['traced_shadow_rays']:11,d} {rays:10,d} {row['wall']:7.3f} "
              f"{row['cpu']:6.2f} {a['traced_shadow_rays'] / row['wall'] / 1e6:11.1f} "
              f"{a['traced_shadow_rays'] / row['cpu'] / 1e6:8.1f} "
              f"{1e3 * per_position[name]:7.2f} {error:>12s}")
    old, new = (best["lanes, reuse, one thread (old default)"],
                best["block kernel, deterministic (default)"])
    old_all, new_all = best["lanes, shadow-ray reuse (3 cm)"], best["block kernel, all cores"]
    print(f"block kernel vs lane kernels (reuse): deterministic {old['wall'] / new['wall']:.2f}x "
          f"wall, {old['cpu'] / new['cpu']:.2f}x CPU; all cores "
          f"{old_all['wall'] / new_all['wall']:.2f}x wall, {old_all['cpu'] / new_all['cpu']:.2f}x "
          "CPU")
    if python:
        sionna = min(run["seconds_per_position"] for run in sionna_runs)
        print(f"{'Sionna RT PathSolver (1 position)':42s} {sionna_runs[-1]['paths']:11,d} "
              f"{sionna_runs[-1]['samples_per_src']:10,d} {sionna:7.3f} {'':6s} "
              f"{sionna_runs[-1]['paths'] / sionna / 1e6:11.1f} {'':8s} {1e3 * sionna:7.2f}")
        for name, seconds in per_position.items():
            print(f"ratio Sionna RT / {name}: {sionna / seconds:.0f}x per aperture position")
    else:
        print(f"Sionna RT: skipped: {reason}")
        seconds = per_position["block kernel, deterministic (default)"]
        print(f"context only, not measured in this run: Sionna RT took {PREVIOUS_SIONNA_SECONDS} "
              f"s per position in an earlier run, {PREVIOUS_SIONNA_SECONDS / seconds:.0f}x this "
              "run's default")


if __name__ == "__main__":
    main()
