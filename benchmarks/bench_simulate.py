"""Analytic simulator throughput: the Dr.Jit kernel against the NumPy reference, same run.

Prints echo-samples per second (sweeps x samples x scatterers) for both backends on the
paper's point target with a fluctuating background. Usage:
``python benchmarks/bench_simulate.py [--sweeps N] [--patch M]``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np

import mitsar


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sweeps", type=int, default=200)
    parser.add_argument("--patch", type=float, default=0.8, help="background patch side [m]")
    args = parser.parse_args()

    radar = mitsar.Radar()
    trajectory = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], args.sweeps / radar.prf)
    look = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
    target = mitsar.PointTarget([15.0, 8.0, 0.0])
    background = mitsar.Background([15.0, 8.0, 0.0], (args.patch, args.patch), mode="frozen")
    run = {}
    for backend in ("drjit", "numpy"):
        mitsar.simulate_point_targets(radar, trajectory, look, [target], background, seed=1,
                                      backend=backend)  # warm-up (kernel compilation)
        start = time.perf_counter()
        raw = mitsar.simulate_point_targets(radar, trajectory, look, [target], background,
                                            seed=1, backend=backend)
        run[backend] = (time.perf_counter() - start, raw)
    scatterers = run["drjit"][1].attrs["background_scatterers"] + 1
    work = args.sweeps * radar.samples_per_sweep * scatterers
    print(f"simulate: {args.sweeps} sweeps x {radar.samples_per_sweep} samples x "
          f"{scatterers} scatterers = {work:.3g} echo samples")
    for backend, (elapsed, _) in run.items():
        print(f"  {backend:6s} {elapsed:8.3f} s  {work / elapsed / 1e6:9.1f} M echo-samples/s")
    fast, reference = run["drjit"][1]["raw"].values, run["numpy"][1]["raw"].values
    print(f"  speed-up drjit / numpy: {run['numpy'][0] / run['drjit'][0]:.1f}x; "
          f"max |difference| / max |sample|: "
          f"{np.abs(fast - reference).max() / np.abs(reference).max():.1e}")


if __name__ == "__main__":
    main()
