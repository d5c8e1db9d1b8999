"""Zarr products: chunked stores read back by ``mitsar.load``, raw data streamed chunk by chunk
(the same samples as in memory), and a 20 000-sweep acquisition written in bounded memory that
focuses to the same image as the netCDF path.
"""

from __future__ import annotations

import json
import os
import subprocess
import sys
import textwrap
from pathlib import Path

import numpy as np
import pytest
import xarray as xr

import mitsar
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.montecarlo import _measure
from mitsar.experiment.runs import run_focus, run_simulation, simulate_to
from mitsar.io import OutputExistsError, ProductFileError, ZarrStream, save

TARGET = (15.0, 8.0, 0.0)
EXAMPLES = Path(__file__).resolve().parents[1] / "examples"


# 20 000 sweeps (80 s at 250 Hz) of 200 samples (fs 50 kHz, so max_range <= 10 m): 64 MB of
# complex samples, flown at 0.1 m/s past the target.
LONG = """
[radar]
sampling_frequency = 50000.0
max_range = 9.5
[trajectory]
kind = "linear"
start = [11.0, 1.4, 4.5]
velocity = [0.1, 0.0, 0.0]
duration = 80.0
[look]
off_nadir_deg = 55.71
[[targets]]
position = [15.0, 8.0, 0.0]
[simulation]
seed = 3
normalized = true
[focus]
algorithm = "bpa"
window = "rect"
azimuth_resolution = 0.1
[focus.grid]
kind = "slant"
along_track = [3.7, 4.3, 0.03]
slant_range = [7.69, 8.29, 0.03]
"""

PROBE = textwrap.dedent("""
    import json, sys, threading, time
    from pathlib import Path
    from mitsar.experiment.loading import load_experiment
    from mitsar.experiment.runs import simulate_to

    def anonymous():
        for line in Path("/proc/self/status").read_text().splitlines():
            if line.startswith("RssAnon:"):
                return int(line.split()[1]) * 1024

    path, out, chunk = sys.argv[1], Path(sys.argv[2]), int(sys.argv[3])
    warm = load_experiment(path, ["trajectory.duration=2.0"])
    simulate_to(warm, out.with_name("warm.zarr"), chunk_sweeps=chunk)  # imports, JIT
    base = anonymous()
    peak, done = [base], threading.Event()

    def watch():  # a chunk lives ~0.1 s: sampling every 2 ms sees its peak
        while not done.is_set():
            peak[0] = max(peak[0], anonymous())
            time.sleep(0.002)

    watcher = threading.Thread(target=watch)
    watcher.start()
    sweeps = simulate_to(load_experiment(path), out, chunk_sweeps=chunk)
    done.set()
    watcher.join()
    print(json.dumps({"base": base, "peak": max(peak[0], anonymous()), "sweeps": sweeps}))
""")


def _short():
    """examples/campaign_tiny.toml flown at 0.5 m/s: 300 sweeps."""
    return load_experiment(EXAMPLES / "campaign_tiny.toml",
                           ["trajectory.speed=0.5", "simulation.seed=5"])


def _experiment(tmp_path, text, name):
    path = tmp_path / f"{name}.toml"
    path.write_text(text, encoding="utf-8")
    return load_experiment(path), path


def test_streamed_raw_is_the_in_memory_product_and_loads_back(tmp_path):
    """Chunks of 70 sweeps (the last one 20) give the very samples of the one-piece simulation:
    the pulse-mode background is drawn in the same order."""
    experiment = _short()
    whole = run_simulation(experiment)
    store = tmp_path / "raw.zarr"
    assert simulate_to(experiment, store, chunk_sweeps=70) == whole.sizes["sweep"] == 300
    streamed = mitsar.load(store, product="raw")
    assert streamed["raw"].encoding["chunks"] == (70, whole.sizes["sample"])
    xr.testing.assert_identical(streamed.drop_attrs(), whole.drop_attrs())
    assert streamed.attrs["experiment"] == whole.attrs["experiment"]
    with pytest.raises(OutputExistsError, match="overwrite"):
        simulate_to(experiment, store)
    assert simulate_to(experiment, store, overwrite=True, chunk_sweeps=300) == 300
    assert not [p for p in tmp_path.iterdir() if p.name.startswith(".")]  # no temporaries


def test_image_and_raw_round_trip_through_both_formats(tmp_path):
    experiment = _short()
    raw = run_simulation(experiment)
    image = run_focus(raw, experiment.focus)
    for product in (raw, image):
        kind = product.attrs["product"]
        netcdf = mitsar.load(save(product, tmp_path / f"{kind}.nc"))
        zarr = mitsar.load(save(product, tmp_path / f"{kind}.zarr"))
        xr.testing.assert_identical(zarr, netcdf)
    with pytest.raises(ProductFileError, match="expected a product of type 'raw'"):
        mitsar.load(tmp_path / "image.zarr", product="raw")
    (tmp_path / "plain.zarr").mkdir()  # a folder that is not a store is never replaced
    with pytest.raises(ProductFileError, match="not a Zarr store"):
        save(raw, tmp_path / "plain.zarr", overwrite=True)
    with pytest.raises(ProductFileError, match="suffix .zarr"):
        ZarrStream(tmp_path / "plain.nc")


def test_a_failed_stream_leaves_nothing(tmp_path):
    experiment = _short()
    chunk = run_simulation(experiment).isel(sweep=slice(0, 10))
    with pytest.raises(RuntimeError, match="stop"), ZarrStream(tmp_path / "x.zarr") as out:
        out.append(chunk)
        raise RuntimeError("stop")
    assert list(tmp_path.glob("*.zarr")) == [] and list(tmp_path.glob(".x.zarr*")) == []


@pytest.mark.skipif(not os.path.exists("/proc/self/status"), reason="needs Linux /proc")
def test_a_20000_sweep_zarr_raw_streams_in_bounded_memory_and_focuses_like_netcdf(tmp_path):
    experiment, path = _experiment(tmp_path, LONG, "long")
    size = 20_000 * experiment.radar.samples_per_sweep * 16  # complex128 samples [bytes]
    store = tmp_path / "raw.zarr"
    # Measured: the anonymous resident memory (heap, NumPy, Dr.Jit, zarr buffers), not file
    # pages (shared libraries paged in again on a loaded machine add up to 14 MB of noise). glibc
    # gives each thread (zarr's codec pool, Dr.Jit's workers) its own malloc arena and keeps
    # freed chunks resident in each; one arena keeps the measurement about the data path
    # (measured here: +6 to +11.5 MB with one arena, +16 to +20 MB with glibc's default).
    env = {**os.environ, "MALLOC_ARENA_MAX": "1", "MITSAR_SKIP_BACKEND_PROBE": "1"}
    result = subprocess.run([sys.executable, "-c", PROBE, str(path), str(store), "250"],
                            capture_output=True, text=True, env=env, timeout=600, check=True)
    probe = json.loads(result.stdout.strip().splitlines()[-1])
    assert probe["sweeps"] == 20_000
    grown = probe["peak"] - probe["base"]
    # The bound of the issue: less than a quarter of the product (16 MB of 64 MB). A chunk of
    # 250 sweeps is 0.8 MB of samples; what it holds besides is kernel lanes and buffers.
    assert grown < size / 4, f"peak memory grew by {grown / 2**20:.1f} MB"
    streamed = mitsar.load(store, product="raw")
    whole = run_simulation(experiment)
    save(whole, tmp_path / "raw.nc")
    netcdf = mitsar.load(tmp_path / "raw.nc", product="raw")
    np.testing.assert_array_equal(streamed["raw"].values, netcdf["raw"].values)
    image_zarr = run_focus(streamed, experiment.focus)
    image_netcdf = run_focus(netcdf, experiment.focus)
    np.testing.assert_array_equal(image_zarr["image"].values, image_netcdf["image"].values)
    # And it is a focused point target: rect-window IRW 0.886 cells (closed form); 0.01 for
    # the 32x upsampled cut's sampling.
    metrics = _measure(image_zarr, TARGET, 2)
    assert metrics["range_irw_cells"] == pytest.approx(0.886, abs=0.01)
    assert metrics["azimuth_irw_cells"] == pytest.approx(0.886, abs=0.01)
