"""3-D BPA throughput: voxel-pulses per second of a VolumeGrid beside a 2-D PlaneGrid of as many
pixels, the same raw product, the same kernel.

A volume is back-projected by the one BPA sum (:func:`mitsar.focus.backprojection
.backproject_drjit`) on flattened voxel positions, so the kernel rate per voxel-pulse is
expected to equal the 2-D rate per pixel-pulse (ratio ~1). Two rows:

* ``kernel``: the Dr.Jit kernel alone, every sweep on every pixel / voxel (the work is exactly
  pixels x sweeps): the volume (``nz = 16`` slices of ``side/4 x side/4``) around the paper's
  target against a ground plane of ``side x side`` pixels;
* ``focus``: :func:`mitsar.focus` end to end on those grids (range compression, the per-pixel
  sweep windows, normalisation and the noise variables included), rated per pixel (voxel) x
  sweep of the pass, the same count for both.

Each is the best of ``--repeats`` rounds after a warm-up (the kernel compiles once),
the two grids interleaved within a round. Not a test:
``python benchmarks/bench_volume.py [--sweeps N] [--pixels SIDE] [--repeats R]``.
"""

from __future__ import annotations

import argparse
import time
from collections.abc import Callable

import numpy as np
from paper_scene import TARGET, paper_target_raw

import mitsar
from mitsar.focus.backprojection import backproject_drjit
from mitsar.focus.compression import range_spectrum
from mitsar.focus.windows import window_coefficients

SLICES = 16
"""Slices of the volume along z; it has ``side/4 x side/4`` voxels in each, as many voxels as
the plane's ``side x side`` pixels."""


def _best(runs: dict[str, Callable[[], object]], repeats: int) -> dict[str, float]:
    """Best wall time [s] of each run over ``repeats`` rounds after one warm-up, the runs
    interleaved within a round (a load on a shared machine then hits both alike)."""
    for run in runs.values():
        run()
    best = dict.fromkeys(runs, float("inf"))
    for _ in range(repeats):
        for name, run in runs.items():
            start = time.perf_counter()
            run()
            best[name] = min(best[name], time.perf_counter() - start)
    return best


def _grids(side: int) -> tuple[mitsar.grid.PlaneGrid, mitsar.grid.VolumeGrid]:
    """A ground plane of side x side pixels over 2 m x 2 m around the target, and a volume of
    SLICES x (side/4)^2 voxels over 2 m x 2 m x 0.5 m around it."""
    x0, y0, z0 = TARGET
    step = 2.0 / side
    plane = mitsar.grid.PlaneGrid(origin=[0, 0, z0], axis_u=[1, 0, 0], axis_v=[0, 1, 0],
                                  u=x0 - 1.0 + step * np.arange(side),
                                  v=y0 - 1.0 + step * np.arange(side))
    quarter = side // 4
    coarse = 2.0 / quarter
    volume = mitsar.grid.VolumeGrid(x=x0 - 1.0 + coarse * np.arange(quarter),
                                    y=y0 - 1.0 + coarse * np.arange(quarter),
                                    z=z0 - 0.25 + 0.5 / SLICES * np.arange(SLICES))
    return plane, volume


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sweeps", type=int, default=500)
    parser.add_argument("--pixels", type=int, default=256, help="pixels per side of the plane "
                        "(a multiple of 4)")
    parser.add_argument("--repeats", type=int, default=7)
    args = parser.parse_args()
    side = args.pixels - args.pixels % 4

    radar = mitsar.Radar()
    raw = paper_target_raw(args.sweeps, radar)
    plane, volume = _grids(side)
    resolved = {name: grid.resolve(raw, radar, 0.01)["position"].reshape(-1, 3)
                for name, grid in (("2-D plane", plane), ("3-D volume", volume))}
    count = len(resolved["2-D plane"])
    assert count == len(resolved["3-D volume"])
    frequency, profile = range_spectrum(raw["raw"].values, radar, upsample=16)
    positions = raw["platform_position"].values
    velocities = raw["platform_velocity"].values
    centroid = raw["boresight"].values @ np.array([1.0, 0, 0])
    window = window_coefficients("rect")
    work = count * len(positions)

    print(f"BPA, {count} pixels (plane {side}x{side}; volume {SLICES}x{side // 4}x{side // 4}) "
          f"x {len(positions)} sweeps = {work:.3g} pixel-pulses")
    grids = {"2-D plane": plane, "3-D volume": volume}
    for row in ("kernel", "focus"):
        runs: dict[str, Callable[[], object]] = {}
        for name, grid in grids.items():
            runs[name] = ((lambda pixels=resolved[name]: backproject_drjit(
                profile, frequency, radar, pixels, positions, velocities, centroid, 1.0,
                window)) if row == "kernel"
                else (lambda grid=grid: mitsar.focus(raw, "bpa", grid)))
        best = _best(runs, args.repeats)
        for name, elapsed in best.items():
            print(f"  {row:6s} {name:10s} {elapsed:8.3f} s  {work / elapsed / 1e6:9.1f} "
                  "M pixel-pulses/s")
        print(f"  {row:6s} ratio 3-D / 2-D: {best['2-D plane'] / best['3-D volume']:.3f}")

if __name__ == "__main__":
    main()
