"""BPA throughput: the Dr.Jit kernel against a plain NumPy back-projection in the same run.

Prints pixel-pulses per second for both and their ratio. Not a test: run it with
``python benchmarks/bench_bpa.py [--sweeps N] [--pixels N]``.
"""

from __future__ import annotations

import argparse
import time

import numpy as np
from paper_scene import paper_target_raw

import mitsar
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
from mitsar.focus.compression import range_spectrum
from mitsar.focus.windows import window_coefficients


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sweeps", type=int, default=500)
    parser.add_argument("--pixels", type=int, default=256, help="pixels per side")
    args = parser.parse_args()

    radar = mitsar.Radar()
    raw = paper_target_raw(args.sweeps, radar)
    frequency, profile = range_spectrum(raw["raw"].values, radar, upsample=16)
    side = np.linspace(-1.0, 1.0, args.pixels)
    grid_x, grid_y = np.meshgrid(15.0 + side, 8.0 + side, indexing="ij")
    pixels = np.stack([grid_x, grid_y, np.zeros_like(grid_x)], -1).reshape(-1, 3)
    positions = raw["platform_position"].values
    velocities = raw["platform_velocity"].values
    centroid = raw["boresight"].values @ np.array([1.0, 0, 0])
    window = window_coefficients("rect")
    arguments = (profile, frequency, radar, pixels, positions, velocities, centroid, 1.0, window)
    work = len(pixels) * len(positions)

    backproject_drjit(*arguments)  # compile once (cached afterwards)
    rows = []
    for name, kernel, repeats in (("drjit", backproject_drjit, 3),
                                  ("numpy", backproject_numpy, 1)):
        start = time.perf_counter()
        for _ in range(repeats):
            result, _ = kernel(*arguments)  # returns NumPy: the timing includes the sync
        elapsed = (time.perf_counter() - start) / repeats
        rows.append((name, elapsed, work / elapsed, result))
    print(f"BPA {args.pixels}x{args.pixels} pixels x {len(positions)} sweeps "
          f"= {work:.3g} pixel-pulses")
    for name, elapsed, rate, _ in rows:
        print(f"  {name:6s} {elapsed:8.3f} s  {rate / 1e6:9.1f} M pixel-pulses/s")
    print(f"  speed-up drjit / numpy: {rows[1][1] / rows[0][1]:.1f}x; max |difference| / peak: "
          f"{np.abs(rows[0][3] - rows[1][3]).max() / np.abs(rows[1][3]).max():.2e}")


if __name__ == "__main__":
    main()
