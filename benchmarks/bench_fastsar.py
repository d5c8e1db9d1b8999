"""Exact back-projection throughput: mitsar's Dr.Jit kernel against FastSAR 0.1.8's CPU kernel.

Both back-project the same sweeps onto the same N x N ground pixels, every pixel from every
sweep (pixel-pulses = pixels x sweeps), and each image is compared with a float64 NumPy
evaluation of its own sum on a random subset of pixels (error ``20 log10(||a - ref|| /
||ref||)``):

* mitsar: :func:`mitsar.focus.backprojection.backproject_drjit` on the 16x range spectrum
  (float64 range and phase, float32 elsewhere), against
  :func:`mitsar.focus.backprojection.backproject_numpy`;
* FastSAR: ``fastsar.backproject(..., backend="cpu")`` (C++/OpenMP, float64 arithmetic on
  float32 range profiles) on the same data written as a frequency-domain phase history
  motion-compensated to the scene centre (sample n at RF frequency ``f_c + K t_n``; a
  scatterer gives ``exp(-j 4 pi f dR / c)``, ``dR = |x - a| - |a|``), against a float64
  evaluation of that documented sum (``fastsar.bp`` module docstring).

FastSAR is optional (``pip install fastsar==0.1.8``, the ``bench`` extra); without it, or
without a C++ compiler for its CPU kernel, its rows are skipped with the reason printed.
Timings are taken after a warm-up call (kernel compilation) and include the copy back to
NumPy; both wall time and CPU time (all threads) are printed, since on a shared machine the
wall time depends on the other jobs. Not a test:
``python benchmarks/bench_fastsar.py [--sweeps N] [--pixels N]``.
"""

from __future__ import annotations

import argparse
import math
import resource
import time

import numpy as np
from paper_scene import paper_target_raw

import mitsar
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
from mitsar.focus.compression import range_spectrum
from mitsar.focus.windows import window_coefficients
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import fast_time

TARGET = np.array([15.0, 8.0, 0.0])


def error_db(values: np.ndarray, reference: np.ndarray) -> float:
    return 20 * math.log10(np.linalg.norm(values - reference) / np.linalg.norm(reference))


def cpu_seconds() -> float:
    """CPU time of this process, all threads (user + system) [s]."""
    usage = resource.getrusage(resource.RUSAGE_SELF)
    return usage.ru_utime + usage.ru_stime


def timed(function, repeats: int = 1):  # noqa: ANN001, ANN201
    """Result, wall seconds and CPU seconds per call, after a warm-up call. On a shared
    machine the wall time depends on the other jobs; the CPU time much less."""
    function()  # warm-up: compilation, caches
    start, cpu = time.perf_counter(), cpu_seconds()
    for _ in range(repeats):
        result = function()
    return (result, (time.perf_counter() - start) / repeats,
            (cpu_seconds() - cpu) / repeats)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sweeps", type=int, default=1000)
    parser.add_argument("--pixels", type=int, default=512, help="pixels per side")
    parser.add_argument("--check", type=int, default=2048, help="pixels in the float64 check")
    args = parser.parse_args()

    radar = mitsar.Radar()
    raw = paper_target_raw(args.sweeps, radar)
    side = np.linspace(-1.0, 1.0, args.pixels)
    grid_x, grid_y = np.meshgrid(15.0 + side, 8.0 + side, indexing="ij")
    pixels = np.stack([grid_x, grid_y, np.zeros_like(grid_x)], -1).reshape(-1, 3)
    positions = raw["platform_position"].values
    velocities = raw["platform_velocity"].values
    work = len(pixels) * len(positions)
    check = np.random.default_rng(1).choice(len(pixels), min(args.check, len(pixels)),
                                            replace=False)
    print(f"exact back-projection: {args.pixels}x{args.pixels} pixels x {len(positions)} "
          f"sweeps = {work:.3g} pixel-pulses (every pixel from every sweep)")
    print(f"  {'kernel':34s} {'time [s]':>9s} {'M px-pulses/s':>14s} {'cpu [s]':>8s} "
          f"{'M px-pulses/cpu-s':>18s} {'error vs f64 [dB]':>18s}")

    # mitsar
    frequency, profile = range_spectrum(raw["raw"].values, radar, upsample=16)
    centroid = raw["boresight"].values @ np.array([1.0, 0, 0])
    arguments = (profile, frequency, radar)
    common = (positions, velocities, centroid, 1.0, window_coefficients("rect"))
    reference, _ = backproject_numpy(*arguments, pixels[check], *common)
    (values, _), elapsed, cpu = timed(lambda: backproject_drjit(*arguments, pixels, *common),
                                      2)
    rate, cpu_rate = work / elapsed, work / cpu
    print(f"  {'mitsar Dr.Jit':34s} {elapsed:9.2f} {rate / 1e6:14.1f} {cpu:8.2f} "
          f"{cpu_rate / 1e6:18.1f} {error_db(values[check], reference):18.1f}")

    # FastSAR
    try:
        import fastsar  # optional: the bench extra
    except ImportError as error:
        print(f"  FastSAR skipped: {error} (pip install fastsar==0.1.8)")
        return
    centre = pixels.mean(axis=0)
    antenna = positions - centre
    points = pixels - centre
    rf = radar.carrier_frequency + radar.chirp_rate * fast_time(radar)
    history = np.conj(raw["raw"].values) * np.exp(
        4j * np.pi * rf[None, :] * np.linalg.norm(antenna, axis=-1)[:, None] / SPEED_OF_LIGHT)
    df = radar.chirp_rate / radar.sampling_frequency
    try:
        fast, elapsed, cpu = timed(lambda: fastsar.backproject(history, antenna, float(rf[0]), df,
                                                          points, backend="cpu",
                                                          window=False))
    except Exception as error:  # noqa: BLE001  (a missing compiler, an API change: say why)
        print(f"  FastSAR skipped: {type(error).__name__}: {error}")
        return
    fast_reference = _fastsar_reference(history, antenna, float(rf[0]), df, points[check])
    fast_rate, fast_cpu_rate = work / elapsed, work / cpu
    print(f"  {'FastSAR ' + fastsar.__version__ + ' exact, cpu':34s} {elapsed:9.2f} "
          f"{fast_rate / 1e6:14.1f} {cpu:8.2f} {fast_cpu_rate / 1e6:18.1f} "
          f"{error_db(fast[check], fast_reference):18.1f}")
    print(f"  mitsar / FastSAR throughput: {rate / fast_rate:.2f}x (wall), "
          f"{cpu_rate / fast_cpu_rate:.2f}x (per CPU-second)")


def _fastsar_reference(history: np.ndarray, antenna: np.ndarray, fmin: float, df: float,
                       points: np.ndarray, upsample: int = 8) -> np.ndarray:
    """float64 evaluation of FastSAR's documented exact sum (``fastsar.bp`` docstring): the
    pulse's zero-padded inverse FFT (zero delay at the centre bin), read linearly at
    ``dR`` and rotated by ``exp(+j 2 pi k dR)``, k the two-way wavenumber at the centre
    frequency."""
    pulses, samples = history.shape
    size = 1 << int(np.ceil(np.log2(upsample * samples)))
    half = samples // 2
    padded = np.zeros((pulses, size), dtype=complex)
    padded[:, :samples - half] = history[:, half:]
    padded[:, size - half:] = history[:, :half]
    compressed = np.fft.fftshift(np.fft.ifft(padded, axis=1), axes=1) * size
    bins_per_metre = 2.0 * df * size / SPEED_OF_LIGHT
    wavenumber = 2.0 * (fmin + half * df) / SPEED_OF_LIGHT
    out = np.zeros(len(points), dtype=complex)
    for start in range(0, pulses, 64):
        block = slice(start, start + 64)
        delta = (np.linalg.norm(points[None] - antenna[block, None], axis=-1)
                 - np.linalg.norm(antenna[block], axis=-1)[:, None])
        position = delta * bins_per_metre + size // 2
        lower = np.floor(position)
        fraction = position - lower
        lower = lower.astype(np.int64) % size
        rows = np.arange(start, min(start + 64, pulses))[:, None]
        value = (compressed[rows, lower] * (1 - fraction)
                 + compressed[rows, (lower + 1) % size] * fraction)
        out += (value * np.exp(2j * np.pi * wavenumber * delta)).sum(axis=0)
    return out


if __name__ == "__main__":
    main()
