"""Exact back-projection end to end: ``mitsar.focus(raw, "bpa", grid)`` against FastSAR 0.1.8.

The same sweeps of the paper's point target, the same N x N ground grid (2 m, centred on the
target), both tools timed alternately in one process, the best of ``--repeats`` calls each
after a warm-up call (compilation), and beside every speed the accuracy of the image against a
float64 reference:

* **mitsar** ``focus(raw, "bpa", PlaneGrid)`` at focus()'s defaults (4-tap Lagrange cubic
  interpolation of 8x zero-padded profiles, :mod:`mitsar.focus.interpolation`), whole beam,
  rect window: band selection, range compression, the Dr.Jit sum (by row segments,
  :mod:`mitsar.focus.bp_tiled`, neighbours sharing a cubic lookup), normalisation, the image
  product. ``--range-upsample`` and
  ``--interpolation`` time other choices (linear 16x, the old default, is -48 dB on this
  image). Accuracy against ``focus(..., backend="numpy")`` on a random subset of the pixels:
  at 32x cubic (float64; the cubic's error bound there is -113 dB, module eq. 2 of
  :mod:`mitsar.focus.interpolation`: the total error of the image, interpolation included),
  and the same sum in float64 at the same interpolation (the kernel's arithmetic alone).
* **FastSAR grid path** ``fastsar.form_image(S, ant, fmin, df, nx, ny, spx, spy,
  algorithm="bp", backend="cpu")``: its ``ExactFormer``, which its docs call "the fast path
  for exact backprojection" onto a regular grid (tile-centre distance in float64 once per tile
  and pulse, third-order expansion of the pixel offset in float32, cubic interpolation at 8x).
* **FastSAR points path** ``fastsar.backproject(S, ant, fmin, df, points, backend="cpu")``: its
  path for arbitrary points, bistatic geometry or a DEM (float64 per pixel and pulse).

FastSAR gets the same sweeps as a frequency-domain phase history: RVP removed, conjugated
(FastSAR's ``exp(-j 4 pi f dR / c)``) and referenced to the grid centre (``dR = |x - a| -
|a|``, antenna positions relative to the centre), ``window=False`` (mitsar runs rect). Its
accuracy is measured against the exact float64 sum ``sum_p sum_k S[p, k] exp(+j 4 pi f_k dR /
c)`` (no interpolation at all) on the same subset of pixels.

Measured on 27 November 2026 after the shared cubic lookups (mitsar.focus.bp_tiled step 5:
neighbouring pixels of a row or column read one packet), quiet 2-CPU machine (load 1.3-1.7),
best of 3: 1000 x 512^2: mitsar 0.203-0.216 s / 0.39-0.41 CPU-s, -71.1 dB; FastSAR grid
0.426-0.497 s / 0.84-0.92 CPU-s, -85.3 dB; points 3.11 s, -44.3 dB: **2.10x, 2.02x, 2.02x
and 2.35x (wall)** in four runs, 2.11-2.35x per CPU-s. 4096 x 1024^2: mitsar 1.02 s / 1.86
CPU-s, -65.8 dB; FastSAR grid 6.76 s / 13.4 CPU-s, -84.0 dB: **6.64x (wall), 7.22x per
CPU-s**. Before the shared lookups (one 32-byte packet per pixel and sweep): 1.20-1.23x and
3.62x (wall); docs/focusing.md, "Exact BPA by pixel groups", has the history. mitsar's
NumPy set-up (~35 ms) runs on one core: on more cores the 512^2 ratio would fall (not
measured).

Counts: pixel-pulses = pixels x sweeps for every tool (mitsar sums, per pixel, only the
sweeps whose line of sight lies in the beam; FastSAR every sweep). Wall time is what counts;
CPU time of all threads is printed beside it, and the load average before and after, since
the machine may be shared. FastSAR is optional (``pip install fastsar==0.1.8``, the ``bench``
extra; it compiles its C++ kernel on first use); without it its rows are skipped with the
reason. Not a test: ``python benchmarks/bench_fastsar.py [--sweeps N] [--pixels N]``
(the issue's two sizes: 1000 x 512 and 4096 x 1024).
"""

from __future__ import annotations

import argparse
import math
import os
import resource
import time
from collections.abc import Callable

import numpy as np
from paper_scene import TARGET, paper_target_raw

import mitsar
from mitsar.focus.grid import PlaneGrid, PointsGrid
from mitsar.focus.spectral import remove_rvp
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import fast_time

EXTENT = 2.0
"""Side of the square ground grid [m]."""


def error_db(values: np.ndarray, reference: np.ndarray) -> float:
    """``20 log10(||values - reference|| / ||reference||)`` [dB]."""
    return 20 * math.log10(np.linalg.norm(values - reference) / np.linalg.norm(reference))


def cpu_seconds() -> float:
    """CPU time of this process, all threads (user + system) [s]."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def alternate(calls: dict[str, Callable[[], object]], repeats: dict[str, int],
              warm_up: dict[str, Callable[[], object]]) -> dict[str, tuple[object, float, float]]:
    """Warm every call up once (``warm_up``: a smaller call that compiles the same kernels),
    then run them in turn, ``repeats`` rounds; per call the last result and the best wall and
    CPU seconds."""
    best: dict[str, tuple[object, float, float]] = {}
    for name, call in calls.items():
        best[name] = (warm_up.get(name, call)(), math.inf, math.inf)
    for round_ in range(max(repeats.values())):
        for name, call in calls.items():
            if round_ >= repeats[name]:
                continue
            start, cpu = time.perf_counter(), cpu_seconds()
            result = call()
            wall, cpu = time.perf_counter() - start, cpu_seconds() - cpu
            best[name] = (result, min(best[name][1], wall), min(best[name][2], cpu))
    return best


def fastsar_history(raw, radar: mitsar.Radar, centre: np.ndarray
                    ) -> tuple[np.ndarray, np.ndarray, float, float]:
    """The sweeps as FastSAR's phase history: samples (complex64), antenna positions relative
    to ``centre`` [m], first frequency and frequency step [Hz] (module docstring)."""
    antenna = raw["platform_position"].values - centre
    rf = radar.carrier_frequency + radar.chirp_rate * fast_time(radar)
    history = np.conj(remove_rvp(raw["raw"].values, radar)) * np.exp(
        4j * np.pi * rf[None] * np.linalg.norm(antenna, axis=-1)[:, None] / SPEED_OF_LIGHT)
    return (history.astype(np.complex64), antenna, float(rf[0]),
            radar.chirp_rate / radar.sampling_frequency)


def fastsar_reference(history: np.ndarray, antenna: np.ndarray, fmin: float, df: float,
                      points: np.ndarray) -> np.ndarray:
    """The exact float64 sum ``sum_p sum_k S[p, k] exp(+j 4 pi (f_min + k df) dR_p / c)``,
    ``dR_p = |x - a_p| - |a_p|``, by Horner's rule over k (vectorised over pulses and
    points)."""
    history = history.astype(np.complex128)
    out = np.zeros(len(points), dtype=complex)
    for start in range(0, len(history), 512):
        block = slice(start, start + 512)
        delta = (np.linalg.norm(points[None] - antenna[block, None], axis=-1)
                 - np.linalg.norm(antenna[block], axis=-1)[:, None])      # (p, x)
        step = np.exp(4j * np.pi * df * delta / SPEED_OF_LIGHT)
        total = np.zeros_like(step)
        for k in range(history.shape[1] - 1, -1, -1):
            total = total * step + history[block, k, None]
        out += (total * np.exp(4j * np.pi * fmin * delta / SPEED_OF_LIGHT)).sum(axis=0)
    return out


def load() -> str:
    """The 1-minute load average, and the number of CPUs."""
    return f"{os.getloadavg()[0]:.2f} on {os.cpu_count()} CPUs"


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__,
                                     formatter_class=argparse.RawDescriptionHelpFormatter)
    parser.add_argument("--sweeps", type=int, default=1000)
    parser.add_argument("--pixels", type=int, default=512, help="pixels per side")
    parser.add_argument("--repeats", type=int, default=3, help="timed calls per tool (best)")
    parser.add_argument("--points-repeats", type=int, default=None,
                        help="timed calls of FastSAR's points path (default: --repeats up to "
                        "1e9 pixel-pulses, else 1; 0 skips it)")
    parser.add_argument("--check", type=int, default=512, help="pixels in the float64 checks")
    parser.add_argument("--range-upsample", type=int, default=None,
                        help="mitsar's range_upsample (default: focus()'s, 8)")
    parser.add_argument("--interpolation", choices=("cubic", "linear"), default=None,
                        help="mitsar's range_interpolation (default: focus()'s, cubic)")
    args = parser.parse_args()

    radar = mitsar.Radar()
    raw = paper_target_raw(args.sweeps, radar)
    n = args.pixels
    step = EXTENT / n
    centre = np.asarray(TARGET, dtype=float)
    # FastSAR's grid: x_i = (i - n/2) step about the centre along e1 (x), y_j along e2 (y);
    # mitsar's PlaneGrid (dims v, u) holds the same points, transposed.
    axis = [-n / 2 * step, (n / 2 - 0.5) * step, step]
    grid = PlaneGrid(origin=centre, axis_u=[1, 0, 0], axis_v=[0, 1, 0], u=axis, v=axis)
    work = n * n * args.sweeps
    rng = np.random.default_rng(1)
    check = rng.choice(n * n, min(args.check, n * n), replace=False)
    print(f"exact back-projection, {args.sweeps} sweeps x {n}x{n} ground pixels over "
          f"{EXTENT:g} m = {work:.3g} pixel-pulses; load {load()}")

    chosen = {key: value for key, value in (("range_upsample", args.range_upsample),
                                            ("range_interpolation", args.interpolation))
              if value is not None}   # focus()'s defaults unless given
    calls: dict[str, Callable[[], object]] = {
        "mitsar focus(bpa)": lambda: mitsar.focus(raw, "bpa", grid, **chosen)["image"].values}
    repeats = {"mitsar focus(bpa)": args.repeats}
    warm_up: dict[str, Callable[[], object]] = {}
    notes: list[str] = []
    try:
        import fastsar  # optional: the bench extra
    except ImportError as error:
        fastsar = None
        notes.append(f"FastSAR skipped: {error} (pip install fastsar==0.1.8)")
    if fastsar is not None:
        history, antenna, fmin, df = fastsar_history(raw, radar, centre)
        calls["FastSAR form_image(bp) [grid]"] = lambda: fastsar.form_image(
            history, antenna, fmin, df, n, n, step, step, algorithm="bp", backend="cpu",
            window=False)
        repeats["FastSAR form_image(bp) [grid]"] = args.repeats
        points_repeats = (args.points_repeats if args.points_repeats is not None
                          else args.repeats if work <= 1e9 else 1)
        if points_repeats > 0:
            ii, jj = np.meshgrid(np.arange(n), np.arange(n), indexing="ij")
            points = np.stack([(ii - n / 2) * step, (jj - n / 2) * step, 0 * ii], -1)
            calls["FastSAR backproject [points]"] = lambda: fastsar.backproject(
                history, antenna, fmin, df, points.reshape(-1, 3), backend="cpu",
                window=False).reshape(n, n)
            repeats["FastSAR backproject [points]"] = points_repeats
            warm_up["FastSAR backproject [points]"] = lambda: fastsar.backproject(
                history, antenna, fmin, df, points.reshape(-1, 3)[:64], backend="cpu",
                window=False)
    print(f"  mitsar at {chosen or 'focus() defaults (cubic, 8x)'}")
    try:
        results = alternate(calls, repeats, warm_up)
    except Exception as error:  # noqa: BLE001  (a missing compiler, an API change: say why)
        print(f"  failed: {type(error).__name__}: {error}")
        raise
    print(f"  load after the runs: {load()}")

    # accuracy: the same random pixels, each tool against its float64 reference
    v_index, u_index = np.unravel_index(check, (n, n))
    pixels = grid.resolve(raw, radar, 0.1)["position"][v_index, u_index]
    accuracy: dict[str, str] = {}
    image = results["mitsar focus(bpa)"][0][v_index, u_index]
    same = mitsar.focus(raw, "bpa", PointsGrid(pixels), backend="numpy", **chosen)
    fine = mitsar.focus(raw, "bpa", PointsGrid(pixels), backend="numpy",
                        range_upsample=32, range_interpolation="cubic")["image"].values
    accuracy["mitsar focus(bpa)"] = (
        f"{error_db(image, fine.ravel()):.1f} dB (same sum in f64, "
        f"{same.attrs['range_interpolation']} {same.attrs['range_upsample']}x: "
        f"{error_db(image, same['image'].values.ravel()):.1f} dB)")
    if fastsar is not None:
        # FastSAR's pixel (i, j) is x = (i - n/2) step, y = (j - n/2) step: mitsar's (v=j, u=i)
        reference = fastsar_reference(history, antenna, fmin, df, pixels - centre)
        for name in calls:
            if name.startswith("FastSAR"):
                values = np.asarray(results[name][0])[u_index, v_index]
                accuracy[name] = f"{error_db(values, reference):.1f} dB"

    print(f"  {'tool [path]':32s} {'wall [s]':>9s} {'M px-pulses/s':>14s} {'cpu [s]':>8s} "
          f"{'M px-pulses/cpu-s':>18s}  error vs interpolation-free float64")
    for name, (_, wall, cpu) in results.items():
        print(f"  {name:32s} {wall:9.3f} {work / wall / 1e6:14.0f} {cpu:8.2f} "
              f"{work / cpu / 1e6:18.0f}  {accuracy[name]}")
    mitsar_wall = results["mitsar focus(bpa)"][1]
    for name in results:
        if name.startswith("FastSAR"):
            print(f"  mitsar / {name}: {results[name][1] / mitsar_wall:.2f}x (wall), "
                  f"{results[name][2] / results['mitsar focus(bpa)'][2]:.2f}x (per CPU-s)")
    for note in notes:
        print(f"  {note}")


if __name__ == "__main__":
    main()
