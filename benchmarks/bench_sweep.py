"""Campaign scaling: the wall time of one sweep on a local Dask cluster of 1 and of 2 workers.

A 3 x 3 sweep (off-nadir angle x speed) of a small point-target experiment on a -20 dB
background, ``--realisations`` each (18 runs by default), every run simulated, focused (BPA)
and measured. Each cluster is started and warmed up (every worker imports mitsar and compiles
its kernels on a first sweep into a scratch folder) before the timed sweep, so the times are of
the runs, not of the start; the start is printed apart. The load average is printed too: on a
shared machine the speed-up is that of the cores actually free. Usage:
``python benchmarks/bench_sweep.py [--realisations N] [--workers 1 2]``.
"""

from __future__ import annotations

import argparse
import os
import tempfile
import time
from pathlib import Path

from distributed import Client, LocalCluster

from mitsar.experiment.sweep import run_sweep

EXPERIMENT = Path(__file__).resolve().parents[1] / "examples" / "campaign_tiny.toml"

VARY = ["look.off_nadir_deg=54:57:1.5", "trajectory.speed=0.5,1.0,1.5"]


def main() -> None:
    parser = argparse.ArgumentParser(description=__doc__)
    parser.add_argument("--realisations", type=int, default=2)
    parser.add_argument("--workers", type=int, nargs="+", default=[1, 2])
    args = parser.parse_args()
    folder = Path(tempfile.mkdtemp(prefix="mitsar-bench-sweep-"))
    experiment = folder / "experiment.toml"
    experiment.write_text(EXPERIMENT.read_text(encoding="utf-8"), encoding="utf-8")
    times, tables = {}, {}
    for workers in args.workers:
        start = time.perf_counter()
        with LocalCluster(n_workers=workers, threads_per_worker=1, processes=True,
                          dashboard_address=":0") as cluster, Client(cluster) as client:
            client.wait_for_workers(workers)
            started = time.perf_counter() - start
            run_sweep(experiment, ["look.off_nadir_deg=55", f"trajectory.speed={workers}"],
                      folder / f"warm{workers}", client=client, progress=False,
                      realisations=workers, figures=False)
            start = time.perf_counter()
            tables[workers] = run_sweep(experiment, VARY, folder / f"sweep{workers}",
                                        realisations=args.realisations, client=client,
                                        progress=False, figures=False)
            times[workers] = time.perf_counter() - start
        runs = tables[workers].attrs["runs"]
        print(f"sweep: {workers} worker(s): {times[workers]:.2f} s for {runs} runs "
              f"({times[workers] / runs:.3f} s a run); cluster start {started:.1f} s",
              flush=True)
    first = args.workers[0]
    for workers in args.workers[1:]:
        same = tables[workers].drop_attrs().identical(tables[first].drop_attrs())
        print(f"sweep: speed-up {first} -> {workers} workers: "
              f"{times[first] / times[workers]:.2f}x; tables identical: {same}")
    print(f"sweep: {os.cpu_count()} CPUs, load average {os.getloadavg()[0]:.1f} "
          f"(1 min) at the end")


if __name__ == "__main__":
    main()
