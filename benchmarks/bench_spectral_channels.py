"""Receive channels in RDA, WDA and FSA: what a second receiver costs. Not a test.

One point target on the paper's geometry (``--duration`` s of a 0.5 m/s straight track, 250 Hz),
focused at 0.1 m azimuth resolution onto a 1 m x 3 m slant grid of 2 cm pixels, by a monostatic
radar and by two receivers 5 cm apart vertically (docs/interferometry.md §8: each offset channel
is compensated onto the common monostatic reference, :func:`mitsar.focus.channels.
compensate_channel`, then focused). Best of ``--rounds``, the two cases alternated in one process
so that the machine's load hits both alike; prints the times and their ratio.

Run: ``python benchmarks/bench_spectral_channels.py [--duration S] [--rounds R]``.
"""

from __future__ import annotations

import argparse
import math
import time
import warnings

import mitsar
from mitsar.errors import MitsarWarning
from mitsar.focus.grid import SlantGrid


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("--duration", type=float, default=2.0)
    parser.add_argument("--rounds", type=int, default=3)
    args = parser.parse_args()
    track = mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0.0, 0.0], args.duration)
    look, target = mitsar.Look(55.7), [mitsar.PointTarget([15.3, 8.0, 0.0])]
    grid = SlantGrid(along_track=[0.0, 1.0, 0.02], slant_range=[7.0, 10.0, 0.02])
    with warnings.catch_warnings():
        warnings.simplefilter("ignore", MitsarWarning)
        raws = {name: mitsar.simulate_point_targets(radar, track, look, target, normalized=True)
                for name, radar in (("one", mitsar.Radar()), ("two", mitsar.Radar(
                    receivers=[(0.0, 0.0, 0.0), (0.0, 0.0, 0.05)])))}
    for algorithm in ("rda", "wda", "fsa"):
        best = dict.fromkeys(raws, math.inf)
        for _ in range(args.rounds):
            for name, raw in raws.items():
                start = time.perf_counter()
                mitsar.focus(raw, algorithm, grid, azimuth_resolution=0.1)
                best[name] = min(best[name], time.perf_counter() - start)
        print(f"{algorithm}: one receiver {best['one']:.3f} s, two {best['two']:.3f} s, "
              f"ratio {best['two'] / best['one']:.2f}")


if __name__ == "__main__":
    main()
