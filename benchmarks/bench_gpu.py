"""CPU (Dr.Jit LLVM) against GPU (Dr.Jit CUDA) throughput of mitsar's kernels, same run.

For every backend that runs here (``--backends``; one not available is reported and skipped)
and every kernel family:

- ``analytic``: the point-target simulator (:func:`mitsar.simulate_point_targets`) on a
  frozen background patch, in echo samples/s (sweeps x samples x scatterers);
- ``bpa``: the back-projection kernel (``backproject_drjit``) on a ground grid around the
  paper's target, in pixel-pulses/s (pixels x sweeps);
- ``bpa_tiled``: the same sum by pixel groups (:func:`mitsar.focus.bp_tiled.backproject_tiled`,
  the path of ``mitsar.focus(algorithm="bpa")`` on a grid), same size and unit;
- ``ffbp``: fast factorised back-projection end to end (``mitsar.focus(algorithm="ffbp")``,
  range compression and the normalisation included), in BPA-equivalent pixel-pulses/s;
- ``tracer``: the ``radar`` integrator on the canned ``control_volume`` room
  (:func:`mitsar.raw.traced.trace`, warm: scatterers and kernels cached), in contributions/s
  (scatterer x sweep pairs that survive the beam cull: visibility + phase + deposit) and
  scatterer x sweep pairs/s; the Mitsuba variant follows the backend. (``trace`` traces one
  receive channel; what a second receiver costs is ``benchmarks/bench_channels.py``'s.)

Every case is run once to compile (kernel caches), then timed best of ``--repeats``; the
functions return NumPy arrays or products, so the time includes the device synchronisation
and the copy back. Prints a table and the GPU/CPU ratios, and writes them as JSON
(``--json``). Sizes scale with ``--scale`` (work grows as its square for BPA, linearly
otherwise). Not a test: ``python benchmarks/bench_gpu.py [--scale 1] [--backends llvm,cuda]``.
"""

from __future__ import annotations

import argparse
import contextlib
import json
import math
import os
import platform
import subprocess
import time
from collections.abc import Callable

import numpy as np
from paper_scene import paper_target_raw

import mitsar
from mitsar import backend
from mitsar.backend import use_backend
from mitsar.focus.backprojection import backproject_drjit
from mitsar.focus.bp_tiled import backproject_tiled
from mitsar.focus.compression import range_spectrum
from mitsar.focus.grid import SlantGrid
from mitsar.focus.windows import window_coefficients

RADAR = mitsar.Radar()
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
VARIANTS = {"llvm": "llvm_ad_mono", "cuda": "cuda_ad_mono"}


def _best(function: Callable[[], object], repeats: int) -> tuple[float, float, object]:
    """(first call [s], best of ``repeats`` later calls [s], last result)."""
    start = time.perf_counter()
    result = function()
    cold = time.perf_counter() - start
    best = math.inf
    for _ in range(repeats):
        start = time.perf_counter()
        result = function()
        best = min(best, time.perf_counter() - start)
    return cold, best, result


def analytic_case(scale: float, repeats: int) -> dict:
    sweeps = max(8, int(round(400 * scale)))
    trajectory = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], sweeps / RADAR.prf)
    background = mitsar.Background([15.0, 8.0, 0.0], (0.8, 0.8), mode="frozen")

    def run() -> object:
        return mitsar.simulate_point_targets(RADAR, trajectory, LOOK,
                                             [mitsar.PointTarget([15.0, 8.0, 0.0])],
                                             background, seed=1)

    cold, best, raw = _best(run, repeats)
    scatterers = raw.attrs["background_scatterers"] + 1
    work = sweeps * RADAR.samples_per_sweep * scatterers
    return {"unit": "echo samples", "work": work, "seconds": best, "cold_seconds": cold,
            "size": f"{sweeps} sweeps x {RADAR.samples_per_sweep} samples x {scatterers} "
                    "scatterers"}


def bpa_case(scale: float, repeats: int, tiled: bool = False) -> dict:
    sweeps, side = 1000, max(16, int(round(256 * scale)))
    raw = paper_target_raw(sweeps, RADAR)
    frequency, profile = range_spectrum(raw["raw"].values, RADAR, upsample=16)
    axis = np.linspace(-1.0, 1.0, side)
    grid_x, grid_y = np.meshgrid(15.0 + axis, 8.0 + axis, indexing="ij")
    pixels = np.stack([grid_x, grid_y, np.zeros_like(grid_x)], -1).reshape(-1, 3)
    arguments = (profile, frequency, RADAR, pixels, raw["platform_position"].values,
                 raw["platform_velocity"].values,
                 raw["boresight"].values @ np.array([1.0, 0, 0]), 1.0,
                 window_coefficients("rect"))
    if tiled:  # the pixel groups of focus(algorithm="bpa") on a grid: rows of `side` pixels
        cold, best, _ = _best(lambda: backproject_tiled(*arguments, row_length=side), repeats)
    else:
        cold, best, _ = _best(lambda: backproject_drjit(*arguments), repeats)
    return {"unit": "pixel-pulses", "work": len(pixels) * sweeps, "seconds": best,
            "cold_seconds": cold, "size": f"{side}x{side} pixels x {sweeps} sweeps"}


def bpa_tiled_case(scale: float, repeats: int) -> dict:
    return bpa_case(scale, repeats, tiled=True)


def ffbp_case(scale: float, repeats: int) -> dict:
    sweeps = 4000
    raw = paper_target_raw(sweeps, RADAR)
    half = min(2.0, max(0.2, 0.5 * scale))  # slant grid half side [m], 401 x 401 at most
    origin = raw["platform_position"].values[0]
    along = 15.0 - origin[0]
    grid = SlantGrid(along_track=[along - half, along + half, 0.01],
                     slant_range=[8.0 - half, 8.0 + half, 0.01])

    def run() -> object:
        return mitsar.focus(raw, algorithm="ffbp", grid=grid, azimuth_resolution=0.1)

    cold, best, image = _best(run, repeats)
    pixels = image["image"].size
    return {"unit": "BPA-equivalent pixel-pulses", "work": pixels * sweeps, "seconds": best,
            "cold_seconds": cold, "size": f"{pixels} pixels x {sweeps} sweeps"}


def tracer_case(name: str, scale: float, repeats: int) -> dict:
    from mitsar.plugins.variant import register_plugins
    from mitsar.raw.traced import trace
    from mitsar.scene import load_scene

    register_plugins(VARIANTS[name])
    scene = load_scene("control_volume")
    sweeps = max(8, int(round(512 * scale)))
    trajectory = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0],
                                          (sweeps + 0.5) / RADAR.prf)
    cold, best, hist = _best(lambda: trace(RADAR, trajectory, LOOK, scene, seed=0,
                                           deterministic=False), repeats)
    attrs = hist.attrs
    return {"unit": "contributions", "work": int(attrs["traced_shadow_rays"]),
            "pairs": int(attrs["traced_pairs"]), "seconds": best, "cold_seconds": cold,
            "size": f"{attrs['scatterer_count']:,} scatterers x {hist.sizes['sweep']} sweeps"}


CASES = ("analytic", "bpa", "bpa_tiled", "ffbp", "tracer")


def run_backend(name: str, cases: list[str], scale: float, repeats: int) -> dict:
    """Every case on one backend: {case: result or {"error": ...}}."""
    results = {}
    with use_backend(name):
        for case in cases:
            start = time.perf_counter()
            try:
                if case == "tracer":
                    result = tracer_case(name, scale, repeats)
                else:
                    result = globals()[f"{case}_case"](scale, repeats)
            except Exception as error:  # noqa: BLE001 - report, go on with the others
                result = {"error": f"{type(error).__name__}: {error}"[:400]}
            result["wall_seconds"] = time.perf_counter() - start
            results[case] = result
            _print_row(name, case, result)
    return results


def _print_row(name: str, case: str, result: dict) -> None:
    if "error" in result:
        print(f"{name:5s} {case:9s} FAILED {result['error']}", flush=True)
        return
    rate = result["work"] / result["seconds"]
    extra = ""
    if "pairs" in result:
        extra = f"; {result['pairs'] / result['seconds'] / 1e6:.1f} M pairs/s"
    print(f"{name:5s} {case:9s} {rate / 1e6:10.1f} M {result['unit']}/s  "
          f"({result['seconds']:.3f} s warm, {result['cold_seconds']:.2f} s first; "
          f"{result['size']}{extra})", flush=True)


def _device_names() -> dict:
    names = {"cpu": platform.processor() or platform.machine(), "cpu_count": os.cpu_count()}
    with contextlib.suppress(OSError), open("/proc/cpuinfo") as info:  # no /proc: the generic
        for line in info:                                                   # name stays
            if line.startswith("model name"):
                names["cpu"] = line.split(":", 1)[1].strip()
                break
    try:
        names["gpu"] = subprocess.run(
            ["nvidia-smi", "--query-gpu=name,driver_version,memory.total", "--format=csv,noheader"],
            capture_output=True, text=True, timeout=30, check=True).stdout.strip()
    except (OSError, subprocess.SubprocessError):
        names["gpu"] = None
    return names


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--backends", default="llvm,cuda")
    parser.add_argument("--cases", default=",".join(CASES))
    parser.add_argument("--scale", type=float, default=1.0)
    parser.add_argument("--repeats", type=int, default=3)
    parser.add_argument("--json", default=None, help="write the results here")
    args = parser.parse_args()

    import drjit as dr
    import mitsuba as mi

    cases = [c for c in args.cases.split(",") if c]
    report = {"devices": _device_names(), "versions": {
        "mitsar": mitsar.__version__, "drjit": dr.__version__, "mitsuba": mi.__version__,
        "numpy": np.__version__}, "scale": args.scale, "results": {}}
    print(f"devices: {report['devices']}; versions: {report['versions']}", flush=True)
    for name in args.backends.split(","):
        if name == "cuda" and not backend.cuda_available():
            print("cuda  skipped: no CUDA device", flush=True)
            continue
        if name == "llvm" and not backend.llvm_probe()[0]:
            print("llvm  skipped: Dr.Jit's LLVM backend cannot run (libLLVM >= 16 missing)",
                  flush=True)
            continue
        report["results"][name] = run_backend(name, cases, args.scale, args.repeats)
    results = report["results"]
    if "llvm" in results and "cuda" in results:
        print("GPU/CPU ratios (CUDA rate / LLVM rate, warm):")
        ratios = {}
        for case in cases:
            cpu, gpu = results["llvm"].get(case, {}), results["cuda"].get(case, {})
            if "error" in cpu or "error" in gpu or not cpu or not gpu:
                continue
            ratios[case] = (gpu["work"] / gpu["seconds"]) / (cpu["work"] / cpu["seconds"])
            print(f"  {case:9s} {ratios[case]:8.1f}x")
        report["ratios"] = ratios

    if args.json:
        with open(args.json, "w") as out:
            json.dump(report, out, indent=1)


if __name__ == "__main__":
    main()
