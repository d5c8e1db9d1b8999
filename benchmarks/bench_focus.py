"""Focusing speed on the paper's scene: each algorithm against its FFT floor, BPA throughput.

Scene (paper §4.1): platform from [14.8, 1.4, 4.5] m along +x at 0.5 m/s, 2,350 sweeps (9.4 s,
4.7 m), point targets along the track at 8 m, focused at 10 cm azimuth resolution on a slant
grid of 1200 (along track, 4 mm) x 200 (slant range, 1 cm) pixels: 5.6e8 pixel-pulses.

For every algorithm: the warm wall time (best of ``--repeat``), the same data's FFT floor
(one 2-D FFT of the raw matrix, i.e. a range FFT of every sweep and an azimuth FFT of every
sample, timed in the same run) and their ratio; for the frequency-domain algorithms also the
front end (RVP removal, azimuth chirp-z transform, H_cm, weighting) on its own. BPA is also
given in pixel-pulses per second. Not a test: ``python benchmarks/bench_focus.py``.
"""

from __future__ import annotations

import argparse
import math
import time

import numpy as np
from scipy import fft as sp_fft

import mitsar
from mitsar.focus.aperture import aperture_half_width
from mitsar.focus.grid import SlantGrid
from mitsar.focus.spectral import prepare_spectrum
from mitsar.products.raw import radar_of


def best_time(function, repeat: int) -> float:
    times = []
    for _ in range(repeat):
        start = time.perf_counter()
        function()
        times.append(time.perf_counter() - start)
    return min(times)


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--sweeps", type=int, default=2350)
    parser.add_argument("--along", type=int, default=1200, help="pixels along track")
    parser.add_argument("--range", type=int, default=200, help="pixels in slant range")
    parser.add_argument("--repeat", type=int, default=2)
    parser.add_argument("--algorithms", default="bpa,rda,wda,fsa")
    args = parser.parse_args()

    radar = mitsar.Radar()
    duration = args.sweeps / radar.prf
    trajectory = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], duration)
    look = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
    targets = [mitsar.PointTarget([x, 8.0, 0.0]) for x in np.linspace(15.0, 18.0, 7)]
    raw = mitsar.simulate_point_targets(radar, trajectory, look, targets, normalized=True)
    grid = SlantGrid(along_track=0.004 * np.arange(args.along),
                     slant_range=7.0 + 0.01 * np.arange(args.range))
    pixels = args.along * args.range
    samples = raw["raw"].values

    floor = best_time(lambda: sp_fft.fft2(samples), args.repeat + 1)
    rho = 0.10
    half_width = aperture_half_width(radar_of(raw), rho)
    layout = grid.resolve(raw, radar, rho)
    front = best_time(lambda: prepare_spectrum(
        raw, radar, layout, half_width=half_width, window="rect", range_window="rect",
        remove_rvp_flag=True, motion_correction=True, where="bench"), args.repeat)

    print(f"scene: {args.sweeps} sweeps x {samples.shape[1]} samples, grid {args.along} x "
          f"{args.range} = {pixels} pixels ({pixels * args.sweeps:.3g} pixel-pulses)")
    print(f"FFT floor (2-D FFT of the raw matrix): {floor * 1e3:.1f} ms; FD front end "
          f"(RVP, azimuth chirp-z, H_cm, weights): {front * 1e3:.1f} ms")
    print(f"{'algorithm':>10s} {'time [s]':>10s} {'x FFT floor':>12s} {'pixel-pulses/s':>16s}"
          f"  notes")
    for algorithm in args.algorithms.split(","):
        mitsar.focus(raw, algorithm=algorithm, grid=grid, azimuth_resolution=rho)  # warm-up
        image = {}

        def run(algorithm=algorithm, image=image):
            image["last"] = mitsar.focus(raw, algorithm=algorithm, grid=grid,
                                         azimuth_resolution=rho)

        seconds = best_time(run, args.repeat)
        rate = pixels * args.sweeps / seconds
        notes = ""
        attrs = image["last"].attrs
        if algorithm == "fsa":
            notes = f"upsample {attrs.get('fsa_upsample')}"
        elif algorithm == "wda":
            notes = f"Stolt upsample {attrs.get('wda_upsample')}"
        elif algorithm == "bpa":
            notes = f"band selection {attrs.get('band_selection', '?')}"
        print(f"{algorithm:>10s} {seconds:10.3f} {seconds / floor:12.1f} {rate:16.3g}  {notes}")


if __name__ == "__main__":
    main()
