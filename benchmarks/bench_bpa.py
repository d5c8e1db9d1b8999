"""BPA throughput: the Dr.Jit kernel against a plain NumPy back-projection in the same run.

Prints pixel-pulses per second for both (per wall second and per CPU-second of all threads: on
a shared machine the wall time depends on the other jobs), their ratio, and the kernel's error
against the float64 NumPy sum, ``20 log10(||drjit - numpy|| / ||numpy||)``; then
``mitsar.focus`` end to end against the kernel time inside it. Not a test: run it with
``python benchmarks/bench_bpa.py [--sweeps N] [--pixels N]``.
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np
from paper_scene import paper_target_raw

import mitsar
from mitsar.focus import bpa as bpa_module
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
from mitsar.focus.compression import range_spectrum
from mitsar.focus.grid import PlaneGrid
from mitsar.focus.windows import window_coefficients


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sweeps", type=int, default=500)
    parser.add_argument("--pixels", type=int, default=256, help="pixels per side")
    args = parser.parse_args()

    radar = mitsar.Radar()
    raw = paper_target_raw(args.sweeps, radar)
    # focus()'s default profiles: 8x zero-padding, read by the cubic interpolation
    frequency, profile = range_spectrum(raw["raw"].values, radar, upsample=8)
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
        start, cpu = time.perf_counter(), _cpu_seconds()
        for _ in range(repeats):
            result, _ = kernel(*arguments)  # returns NumPy: the timing includes the sync
        elapsed = (time.perf_counter() - start) / repeats
        cpu = (_cpu_seconds() - cpu) / repeats
        rows.append((name, elapsed, cpu, result))
    print(f"BPA {args.pixels}x{args.pixels} pixels x {len(positions)} sweeps "
          f"= {work:.3g} pixel-pulses")
    for name, elapsed, cpu, _ in rows:
        print(f"  {name:6s} {elapsed:8.3f} s  {work / elapsed / 1e6:9.1f} M pixel-pulses/s  "
              f"{cpu:8.3f} cpu-s  {work / cpu / 1e6:9.1f} M pixel-pulses/cpu-s")
    difference = np.linalg.norm(rows[0][3] - rows[1][3]) / np.linalg.norm(rows[1][3])
    print(f"  speed-up drjit / numpy: {rows[1][1] / rows[0][1]:.1f}x (wall), "
          f"{rows[1][2] / rows[0][2]:.1f}x (cpu); error vs float64 NumPy: "
          f"{20 * math.log10(difference):.1f} dB")
    _focus_overhead(raw, args.pixels)


def _focus_overhead(raw, side: int) -> None:  # noqa: ANN001
    """``mitsar.focus`` end to end against the kernel calls inside it (timed by wrapping the
    kernels that :mod:`mitsar.focus.bpa` calls): whole beam on a ground grid."""
    extent = 2.0
    step = extent / side
    axis = [-extent / 2, extent / 2 - step / 2, step]
    grid = PlaneGrid(origin=[15.0, 8.0, 0.0], axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=axis,
                     v=axis)
    inside = []
    kernels = {"backproject_drjit": bpa_module.backproject_drjit,
               "backproject_tiled": bpa_module.backproject_tiled}  # focus() calls the latter

    def timed(kernel):  # noqa: ANN001, ANN202
        def call(*arguments, **keywords):  # noqa: ANN002, ANN003, ANN202
            start = time.perf_counter()
            result = kernel(*arguments, **keywords)
            inside.append(time.perf_counter() - start)
            return result
        return call

    for name, kernel in kernels.items():
        setattr(bpa_module, name, timed(kernel))
    try:
        mitsar.focus(raw, grid=grid)  # warm-up
        inside.clear()
        start = time.perf_counter()
        mitsar.focus(raw, grid=grid)
        total = time.perf_counter() - start
    finally:
        for name, kernel in kernels.items():
            setattr(bpa_module, name, kernel)
    print(f"  focus() end to end, {side}x{side} ground pixels, whole beam: {total:.3f} s, "
          f"kernel {sum(inside):.3f} s: {total / sum(inside):.2f}x the kernel")


def _cpu_seconds() -> float:
    """CPU time of this process, all threads [s]."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


if __name__ == "__main__":
    main()
