"""Ray-tracing throughput and memory of the ``radar`` integrator (docs/design.md §7). Not a test.

In one run, on the same scene (default: the canned ``control_volume`` room at the default
density of 9 scatterers per resolution cell, ~0.97 M scatterers):

1. Mitsuba's own ``ray_intersect`` and ``ray_test`` on random rays from the antenna into the
   beam's half-space (rays/s), timed after reading a result;
2. the integrator (:func:`mitsar.raw.traced` on the loaded scene, warm: scatterers and kernels
   cached): scatterer x sweep pairs/s, and contributions/s (pairs that survive the beam cull:
   visibility + float64 phase + scatter-add; shadow rays are shared by blocks of sweeps, see
   ``bench_speed.py`` for the comparison with a ray per sweep and with Sionna RT);
3. memory (RSS after a warm-up trace, and the peak while tracing; each case in a fresh
   subprocess) of :func:`mitsar.simulate_scene` (streams histograms to raw) and of
   :func:`mitsar.raw.traced` (keeps the histogram product) as the number of sweeps doubles.

Run: ``python benchmarks/bench_trace.py [--scene NAME] [--sweeps N] [--density D]
[--memory-sweeps 64,128,256,512]``.
"""

from __future__ import annotations

import argparse
import json
import math
import resource
import subprocess
import sys
import time

import numpy as np

import mitsar

RADAR = mitsar.Radar()
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
START = [14.8, 1.4, 4.5]


def _trajectory(sweeps: int) -> mitsar.Trajectory:
    return mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], (sweeps + 0.5) / RADAR.prf)


def mitsuba_rays(scene: object, count: int) -> dict[str, float]:
    """Mitsuba's ray_intersect / ray_test rays/s on ``count`` random rays from the antenna."""
    import drjit as dr
    import mitsuba as mi

    rng = np.random.default_rng(0)
    direction = rng.normal(size=(count, 3)) + np.array([0.0, 1.5, -1.0])
    direction /= np.linalg.norm(direction, axis=1, keepdims=True)
    d = mi.Vector3f(*(mi.Float(np.ascontiguousarray(direction[:, i])) for i in range(3)))
    dr.eval(d)
    out = {}
    for name in ("ray_intersect", "ray_test"):
        best = math.inf
        for _ in range(3):
            ray = mi.Ray3f(mi.Point3f(*START), d)
            start = time.perf_counter()
            if name == "ray_intersect":
                si = scene.ray_intersect(ray)
                dr.eval(si.t, si.p, si.n)
                hits = dr.count(si.is_valid())
            else:
                hits = dr.count(scene.ray_test(ray))
            np.asarray(hits)  # read a result: the timing includes the kernel
            best = min(best, time.perf_counter() - start)
        out[name] = count / best
    return out


def integrator_rate(scene: object, sweeps: int, density: float | None) -> dict[str, float]:
    """Warm throughput of :func:`mitsar.raw.traced` on a loaded scene."""
    from mitsar.raw.traced import trace

    trajectory = _trajectory(sweeps)
    start = time.perf_counter()
    hist = trace(RADAR, trajectory, LOOK, scene, density=density, seed=0,
                 deterministic=False)  # all cores
    cold = time.perf_counter() - start
    best, best_cpu = math.inf, math.inf
    for _ in range(3):
        start, start_cpu = time.perf_counter(), _cpu()
        hist = trace(RADAR, trajectory, LOOK, scene, density=density, seed=0,
                     deterministic=False)
        best = min(best, time.perf_counter() - start)
        best_cpu = min(best_cpu, _cpu() - start_cpu)
    a = hist.attrs
    return {"seconds": best, "cpu_seconds": best_cpu, "cold_seconds": cold,
            "scatterers": a["scatterer_count"],
            "sweeps": hist.sizes["sweep"], "pairs": a["traced_pairs"],
            "candidate_pairs": a["traced_candidate_pairs"],
            "contributions": a["traced_shadow_rays"], "launches": a["traced_launches"],
            "visibility_rays": a["traced_visibility_rays"]}


def _cpu() -> float:
    """CPU time of this process, all threads [s] (robust against other jobs on the machine)."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def _vm(field: str) -> float:
    """A /proc/self/status memory field in MiB (Linux)."""
    with open("/proc/self/status") as status:
        for line in status:
            if line.startswith(field + ":"):
                return int(line.split()[1]) / 1024
    return float("nan")


def child(kind: str, scene_name: str, sweeps: int, density: float | None) -> None:
    """Run one memory case and print JSON: RSS before and peak RSS during [MiB].

    The scene is loaded and traced for 8 sweeps first (imports, kernels, scatterers), then the
    peak counter is reset (``/proc/self/clear_refs``) and the case runs.
    """
    from mitsar.raw.traced import simulate_scene, trace
    from mitsar.scene import load_scene

    scene = load_scene(scene_name)
    function = simulate_scene if kind == "simulate_scene" else trace
    function(RADAR, _trajectory(8), LOOK, scene, density=density, seed=0)
    before = _vm("VmRSS")
    try:
        with open("/proc/self/clear_refs", "w") as refs:
            refs.write("5")
    except OSError:
        pass  # not Linux, or not allowed: peak RSS then counts from process start
    start = time.perf_counter()
    product = function(RADAR, _trajectory(sweeps), LOOK, scene, density=density, seed=0)
    elapsed = time.perf_counter() - start
    print(json.dumps({"before_mib": before, "peak_mib": _vm("VmHWM"), "seconds": elapsed,
                      "product_mib": product.nbytes / 2**20}))


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--scene", default="control_volume")
    parser.add_argument("--sweeps", type=int, default=256)
    parser.add_argument("--density", type=float, default=None, help="scatterers per m²")
    parser.add_argument("--rays", type=int, default=2**22)
    parser.add_argument("--memory-sweeps", default="64,128,256,512,1024")
    parser.add_argument("--child", nargs=2, metavar=("KIND", "SWEEPS"), help=argparse.SUPPRESS)
    args = parser.parse_args()
    if args.child:
        child(args.child[0], args.scene, int(args.child[1]), args.density)
        return

    from mitsar.scene import load_scene

    scene = load_scene(args.scene)
    rays = mitsuba_rays(scene, args.rays)
    rate = integrator_rate(scene, args.sweeps, args.density)
    print(f"scene {args.scene}: {rate['scatterers']:,} scatterers, {rate['sweeps']} sweeps, "
          f"{rate['launches']} launches")
    print(f"{'what':46s} {'count':>12s} {'seconds':>8s} {'M/s':>8s}")
    for name, value in rays.items():
        print(f"{'Mitsuba ' + name + ' (random rays)':46s} {args.rays:12,d} "
              f"{args.rays / value:8.3f} {value / 1e6:8.1f}")
    seconds = rate["seconds"]
    for label, key in (("integrator: scatterer x sweep pairs", "pairs"),
                       ("  left by the chunk-level beam cull", "candidate_pairs"),
                       ("  contributions (visibility + deposit)", "contributions"),
                       ("  shadow rays shared by blocks of sweeps", "visibility_rays")):
        print(f"{label:46s} {rate[key]:12,d} {seconds:8.3f} {rate[key] / seconds / 1e6:8.1f}")
    print(f"first call (scatterer sampling, upload, compile): {rate['cold_seconds']:.2f} s; "
          f"contributions/s : ray_test rays/s = "
          f"{rate['contributions'] / seconds / rays['ray_test']:.2f}; integrator CPU time "
          f"{rate['cpu_seconds']:.2f} s (all threads) for {seconds:.2f} s wall")

    print("\nmemory per fresh process: RSS after a warm-up trace / peak while tracing [MiB]")
    print(f"{'sweeps':>7s} {'simulate_scene':>17s} {'s':>6s} {'trace':>17s} {'s':>6s} "
          f"{'histogram MiB':>14s}")
    for sweeps in (int(s) for s in args.memory_sweeps.split(",")):
        row = []
        for kind in ("simulate_scene", "trace"):
            command = [sys.executable, __file__, "--scene", args.scene, "--child", kind,
                       str(sweeps)] + (["--density", str(args.density)] if args.density else [])
            result = subprocess.run(command, capture_output=True, text=True, check=True)
            row.append(json.loads(result.stdout.strip().splitlines()[-1]))
        print(f"{sweeps:7d} {row[0]['before_mib']:8.0f} /{row[0]['peak_mib']:7.0f} "
              f"{row[0]['seconds']:6.2f} {row[1]['before_mib']:8.0f} /{row[1]['peak_mib']:7.0f} "
              f"{row[1]['seconds']:6.2f} {row[1]['product_mib']:14.1f}")


if __name__ == "__main__":
    main()
