"""Receive channels: what a second receiver costs the tracer, the simulator and BPA. Not a test.

In one run, on the same acquisition (default: the canned ``control_volume`` room at the default
density, 256 sweeps of the paper's geometry), each case warm (scatterers and kernels cached) and
best of ``--rounds``:

1. the tracer (:func:`mitsar.simulate_scene`): one monostatic receiver against two receivers
   5 cm apart vertically (docs/interferometry.md) — channels x sweeps per second and the ratio
   of the two walls (issue 22 asks < 1.3: rays shared by the receivers), and apart from it
   the time of the tracer's own Dr.Jit kernels (rays, visibility, deposits: Dr.Jit's kernel
   history) — the rest of the wall is the histogram -> raw synthesis (one inverse FFT per
   sweep and channel, NumPy) that every channel needs for its own raw data;
2. the analytic simulator (:func:`mitsar.simulate_point_targets`, one point target): the same;
3. back-projection of every channel onto one grid (:func:`mitsar.focus`, 256^2 pixels):
   channel-pixel-pulses per second and the ratio.

Run: ``python benchmarks/bench_channels.py [--scene NAME] [--sweeps N] [--rounds R]``.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings
from collections.abc import Callable
from typing import Any

import drjit as dr

import mitsar
from mitsar.scene import load_scene

LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
START = [14.8, 1.4, 4.5]
RECEIVERS = [(0.0, 0.0, 0.0), (0.0, 0.0, 0.05)]


def _best(run: Callable[[], Any], rounds: int) -> tuple[float, Any]:
    best, result = math.inf, None
    for _ in range(rounds):
        start = time.perf_counter()
        result = run()
        best = min(best, time.perf_counter() - start)
    return best, result


def _kernel_seconds(run: Callable[[], Any], rounds: int) -> float:
    """Best of ``rounds`` of the summed execution time of the Dr.Jit kernels ``run`` launches
    (Dr.Jit's kernel history) [s]."""
    dr.set_flag(dr.JitFlag.KernelHistory, True)
    best = math.inf
    try:
        for _ in range(rounds):
            dr.kernel_history()  # clear
            run()
            best = min(best, sum(entry.get("execution_time", 0.0)
                                 for entry in dr.kernel_history()) / 1e3)
    finally:
        dr.set_flag(dr.JitFlag.KernelHistory, False)
    return best


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--scene", default="control_volume")
    parser.add_argument("--sweeps", type=int, default=256)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    warnings.simplefilter("ignore")
    radars = {"1 receiver": mitsar.Radar(), "2 receivers": mitsar.Radar(receivers=RECEIVERS)}
    track = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], (args.sweeps + 0.5) / 250.0)
    scene = load_scene(args.scene)
    target = [mitsar.PointTarget([15.0, 8.0, 0.0])]
    grid = mitsar.grid.SlantGrid(along_track=[-0.2, 0.31, 0.002],
                                 slant_range=[7.3, 8.32, 0.004])
    rows = []
    walls: dict[str, dict[str, float]] = {}
    for name, radar in radars.items():
        channels = radar.channel_count
        traced_wall, _ = _best(lambda r=radar: mitsar.simulate_scene(r, track, LOOK, scene),
                               args.rounds)
        kernels = _kernel_seconds(lambda r=radar: mitsar.simulate_scene(r, track, LOOK, scene),
                                  args.rounds)
        analytic_wall, raw = _best(lambda r=radar: mitsar.simulate_point_targets(
            r, track, LOOK, target), args.rounds)
        focus_wall, image = _best(lambda r=raw: mitsar.focus(r, "bpa", grid), args.rounds)
        pixels = image["position"].shape[0] * image["position"].shape[1]
        walls[name] = {"trace": traced_wall, "tracer kernels": kernels,
                       "analytic": analytic_wall, "bpa": focus_wall}
        rows.append((name, channels * args.sweeps / traced_wall,
                     channels * args.sweeps / analytic_wall,
                     channels * pixels * raw.sizes["sweep"] / focus_wall / 1e6))
    print(f"scene {args.scene}, {args.sweeps} sweeps, best of {args.rounds}")
    print(f"{'case':<14}{'trace ch*sweeps/s':>20}{'analytic ch*sweeps/s':>23}"
          f"{'BPA M ch*pixel-pulses/s':>26}")
    for name, traced, analytic, bpa in rows:
        print(f"{name:<14}{traced:>20.1f}{analytic:>23.1f}{bpa:>26.1f}")
    one, two = walls["1 receiver"], walls["2 receivers"]
    print("wall of 2 receivers / 1 receiver: " + ", ".join(
        f"{key} {two[key] / one[key]:.2f}x" for key in one) + " (issue 22 target for the "
        "tracer: < 1.3x)")
    print("tracer kernels [ms]: " + ", ".join(f"{name} {wall['tracer kernels'] * 1e3:.1f}"
                                              for name, wall in walls.items()))


if __name__ == "__main__":
    main()
