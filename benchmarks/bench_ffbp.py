"""FFBP against exact BPA: speed-up and image error on the same grid, in the same run.

A straight track at 0.5 m/s past a point 8 m away (``--turn``: a 20-degree turn of radius
10 m, ``mitsar.Trajectory.flight``, centred where the point is broadside; the aperture then
follows the pixels' aspect angles, docs/focusing.md "Curved tracks"), a ground-plane grid of
N x N pixels around it, the whole beam processed (rect window) unless
``--window``/``--resolution`` say otherwise; both images come from :func:`mitsar.focus`
(``algorithm="bpa"`` with the Dr.Jit kernel, and ``algorithm="ffbp"``), timed end to end
(range compression included) after a warm-up run that compiles the kernels; with
``--repeat N`` the methods run in turn N times in this one process (BPA, then every FFBP
option set, then BPA again...) and the fastest run of each is kept, so both see the same load.
The error is ``20 log10(||ffbp - bpa|| / ||bpa||)``. Speed-ups are given per wall second and
per CPU-second (all threads): on a shared machine the wall time depends on the other jobs.
Not a test: run it with
``python benchmarks/bench_ffbp.py [--full] [--turn] [--resolution M] [--sweeps N]
[--pixels N] [--extent M]``: by default a reduced case (1024 sweeps x 256^2 pixels,
seconds), ``--full`` the size of the issue's requirement (4096 sweeps x 1024^2 pixels, about a
minute). The load average is printed before and after (the speed-ups mean little on a busy
machine); ``--stages`` prints the time of every FFBP step of the last run (kernels
synchronised after each, so the sum is a little more than the run, whose kernels overlap the
NumPy work).
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import time

import drjit as dr
import numpy as np
import xarray as xr
from paper_scene import paper_target_raw

import mitsar
from mitsar.focus import ffbp as ffbp_module
from mitsar.focus.grid import PlaneGrid

TARGET = np.array([15.0, 8.0, 0.0])


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--full", action="store_true",
                        help="4096 sweeps x 1024^2 pixels (the issue's size)")
    parser.add_argument("--sweeps", type=int, default=1024)
    parser.add_argument("--pixels", type=int, default=256, help="pixels per side")
    parser.add_argument("--extent", type=float, default=2.0, help="grid side [m]")
    parser.add_argument("--window", default="rect", help="azimuth (and range) window")
    parser.add_argument("--resolution", type=float, default=None,
                        help="azimuth resolution [m] (default: the whole beam)")
    parser.add_argument("--options", type=str, default="",
                        help="FFBP option sets to compare, e.g. 'angle_oversample=2;factor=2'")
    parser.add_argument("--repeat", type=int, default=1,
                        help="runs of each method; the fastest is reported")
    parser.add_argument("--stages", action="store_true",
                        help="time every FFBP step of the last run")
    parser.add_argument("--turn", nargs="?", const="right", choices=("left", "right"),
                        help="a 20-degree turn (radius 10 m) at the target's broadside, away "
                             "from the look side (right, the default) or towards it (left)")
    args = parser.parse_args()
    if args.full:
        args.sweeps, args.pixels = 4096, 1024

    radar = mitsar.Radar()
    raw = (turn_raw(args.sweeps, radar, args.turn) if args.turn
           else paper_target_raw(args.sweeps, radar))
    args.sweeps = raw.sizes["sweep"]
    half = args.extent / 2
    step = args.extent / args.pixels
    axis = [-half, half - step / 2, step]
    grid = PlaneGrid(origin=TARGET, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=axis, v=axis)
    work = args.pixels**2 * args.sweeps

    option_sets = [{}] + [dict(_parse(item) for item in chunk.split(","))
                          for chunk in args.options.split(";") if chunk.strip()]
    small = PlaneGrid(origin=TARGET, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=[-0.1, 0.1, 0.05],
                      v=[-0.1, 0.1, 0.05])
    mitsar.focus(raw, grid=small)  # compile the kernels once (cached afterwards)
    mitsar.focus(raw, algorithm="ffbp", grid=small)

    settings = {"window": args.window, "azimuth_resolution": args.resolution}
    mitsar.focus(raw, grid=small, **settings)  # and the band kernels (turn, resolution)
    mitsar.focus(raw, algorithm="ffbp", grid=small, **settings)
    steps: dict[str, list[float]] = {}
    if args.stages:
        _time_steps(steps)
    runs = [lambda: mitsar.focus(raw, grid=grid, **settings)] + [
        lambda options=options: mitsar.focus(raw, algorithm="ffbp", grid=grid,
                                             algorithm_options=options, **settings)
        for options in option_sets]
    load_before = os.getloadavg()
    timings, images = _alternate(args.repeat, runs)
    (bpa_time, bpa_cpu), reference = timings[0], images[0]["image"].values
    track = f"20-degree {args.turn} turn (radius 10 m)" if args.turn else "straight track"
    print(f"FFBP vs BPA: {args.pixels}x{args.pixels} pixels ({args.extent:g} m square, ground) "
          f"x {args.sweeps} sweeps = {work:.3g} pixel-sweeps, {track}, "
          f"{'whole beam' if args.resolution is None else f'{args.resolution:g} m'}, "
          f"{args.window} window, fastest of {max(1, args.repeat)} alternating runs; load "
          f"average {load_before[0]:.1f} (1 min) / {load_before[1]:.1f} (5 min) on "
          f"{os.cpu_count()} CPUs")
    print(f"  {'method':40s} {'time [s]':>9s} {'M px-sweeps/s':>14s} {'speed-up':>9s} "
          f"{'cpu [s]':>8s} {'speed-up (cpu)':>15s} {'error [dB]':>11s}")
    print(f"  {'bpa (exact, Dr.Jit)':40s} {bpa_time:9.2f} {work / bpa_time / 1e6:14.1f} "
          f"{1.0:9.1f} {bpa_cpu:8.2f} {1.0:15.1f} {'-':>11s}")
    for options, (elapsed, cpu), image in zip(option_sets, timings[1:], images[1:],
                                              strict=True):
        values = image["image"].values
        error = 20 * math.log10(np.linalg.norm(values - reference) / np.linalg.norm(reference))
        label = "ffbp " + (", ".join(f"{k}={v}" for k, v in options.items()) or "defaults")
        print(f"  {label:40s} {elapsed:9.2f} {work / elapsed / 1e6:14.1f} "
              f"{bpa_time / elapsed:9.1f} {cpu:8.2f} {bpa_cpu / cpu:15.1f} {error:11.1f}")
    if args.stages:
        print("  steps of the last FFBP run [s]: " + ", ".join(
            f"{name} {' + '.join(f'{t:.3f}' for t in times)}" for name, times in steps.items()))
    print(f"  load average after: {os.getloadavg()[0]:.1f}")


def turn_raw(sweeps: int, radar: mitsar.Radar, side: str = "right") -> xr.Dataset:
    """The paper's target seen from a 20-degree turn of radius 10 m at 0.5 m/s whose middle is
    at the target's broadside (x = 15 m), about ``sweeps`` sweeps long. The radar looks left:
    a right turn swings the beam forward over the scene, a left one back (then part of a 2 m
    patch beyond the target never crosses the beam centre on the track)."""
    leg = 0.5 * sweeps / radar.prf / 2 + 0.018  # the arc is 0.035 m shorter than the legs
    turn = math.radians(20.0) * (1 if side == "left" else -1)
    points = [[15.0 - leg, 1.4, 4.5], [15.0, 1.4, 4.5],
              [15.0 + leg * math.cos(turn), 1.4 + leg * math.sin(turn), 4.5]]
    track = mitsar.Trajectory.flight(points, 0.5, turn_radius=10.0)
    look = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
    return mitsar.simulate_point_targets(radar, track, look, [mitsar.PointTarget(TARGET)],
                                         normalized=True)


def _alternate(repeat: int, runs: list) -> tuple[list, list]:
    """(wall, CPU) seconds of the fastest of ``repeat`` calls of every run, called in turn
    (all runs once, then again), and the results of the last calls."""
    best = [(math.inf, math.inf)] * len(runs)
    results: list = [None] * len(runs)
    for _ in range(max(1, repeat)):
        for index, run in enumerate(runs):
            start, cpu = time.perf_counter(), _cpu_seconds()
            results[index] = run()
            elapsed = (time.perf_counter() - start, _cpu_seconds() - cpu)
            best[index] = min(best[index], elapsed)
    return best, results


def _time_steps(steps: dict[str, list[float]]) -> None:
    """Wrap FFBP's steps (names in :mod:`mitsar.focus.ffbp`) to record their wall time,
    synchronising the Dr.Jit kernels before and after each (of the last run only: the
    caller clears ``steps`` before every option set, repeats overwrite)."""
    for name in ("prepare", "_band_setup", "_make_stage", "kernel_tables", "first_stage",
                 "merge_nodes", "sweep_window", "merge_points", "merge_band", "normalise"):
        function = getattr(ffbp_module, name)

        def timed(*args, _function=function, _name=name, **kwargs):
            if _name == "prepare":
                steps.clear()  # a new run
            dr.sync_thread()
            start = time.perf_counter()
            result = _function(*args, **kwargs)
            dr.sync_thread()
            steps.setdefault(_name, []).append(time.perf_counter() - start)
            return result

        setattr(ffbp_module, name, timed)


def _cpu_seconds() -> float:
    """CPU time of this process, all threads [s]."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _parse(item: str) -> tuple[str, float | int]:
    key, value = item.split("=")
    number = float(value)
    return key.strip(), int(number) if number.is_integer() and "." not in value else number


if __name__ == "__main__":
    main()
