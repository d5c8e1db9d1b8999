"""Real drone flight: navigation errors, autofocus, and the ray-traced room (docs/navigation.md).

1. The paper's point target (§4.1 geometry) flown with navigation errors of several radians of
   phase (2 mm/sqrt(s) cross-track random walk, 1.5 mm vibration at 7 Hz): true against
   navigation track; the BPA image without autofocus, after PGA and after minimum entropy; the
   injected phase against both estimates; metrics of each, beside the error-free image and the
   *oracle* (the navigation data corrected with the true phase error at the target: the same
   track and band selection as the autofocused images, perfect phase).
2. The ray-traced control volume (``control_volume`` canned scene) flown with the same errors:
   BPA images without autofocus, with each method and with the oracle correction; image
   entropy of each.

Usage: ``python examples/real_flight.py -o docs/figures/real_flight [--overwrite]``; prints a
table of the metrics (also written to ``metrics.json``).
"""

from __future__ import annotations

import argparse
import json
import math
import time
from pathlib import Path

import matplotlib

matplotlib.use("Agg")
import matplotlib.pyplot as plt  # noqa: E402
import numpy as np  # noqa: E402
import xarray as xr  # noqa: E402

import mitsar  # noqa: E402
from mitsar.focus.autofocus import correct_raw, image_entropy  # noqa: E402
from mitsar.focus.grid import SlantGrid, equivalent_position  # noqa: E402
from mitsar.io import write_json  # noqa: E402
from mitsar.plots import navigation as plots_navigation  # noqa: E402
from mitsar.plots.figures import plot_image, save_figure  # noqa: E402

RADAR = mitsar.Radar()
START = np.array([14.8, 1.4, 4.5])
TARGET = np.array([15.0, 8.0, 0.0])
LOOK = mitsar.Look(math.degrees(math.atan2(6.6, 4.5)))
TRACK = mitsar.Trajectory.linear(START, [0.5, 0.0, 0.0], 0.8)
ERRORS = mitsar.NavigationErrors(
    seed=11, position_random_walk=(0.0, 2e-3, 1e-3),
    vibration=(mitsar.Vibration((0.0, 1.5e-3, 0.0), 7.0, 0.5),))
METHODS = (None, "pga", "entropy")


def _metrics(image: xr.Dataset) -> dict:
    measured = mitsar.measure_impulse_response(image, equivalent_position(image, TARGET))
    return {d: {k: round(float(measured[d][k]), 4) for k in ("irw_cells", "pslr_db", "islr_db")}
            for d in ("range", "azimuth")} | {"peak_db": round(float(measured["peak_db"]), 3)}


def point_target(out: Path, overwrite: bool) -> dict:
    raw = mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                        normalized=True, navigation=ERRORS)
    ideal = mitsar.simulate_point_targets(RADAR, TRACK, LOOK, [mitsar.PointTarget(TARGET)],
                                          normalized=True)
    grid = SlantGrid(along_track=[-0.4, 0.8, 0.01], slant_range=[7.4, 8.6, 0.01])
    images, results = {}, {}
    reference = mitsar.focus(ideal, grid=grid, azimuth_resolution=0.1)
    results["error-free"] = _metrics(reference)
    oracle = correct_raw(raw, plots_navigation.navigation_phase(raw, TARGET))
    results["oracle"] = _metrics(mitsar.focus(oracle, grid=grid, azimuth_resolution=0.1))
    for method in METHODS:
        start = time.perf_counter()
        image = mitsar.focus(raw, grid=grid, azimuth_resolution=0.1, autofocus=method)
        name = method or "no autofocus"
        images[name] = image
        results[name] = _metrics(image) | {"seconds": round(time.perf_counter() - start, 2)}
    axes = plots_navigation.plot_tracks(raw)
    save_figure(axes[0].figure, out / "tracks.png", overwrite=overwrite, dpi=120)
    figure, axes = plt.subplots(1, 3, figsize=(13, 4), layout="constrained")
    for ax, (name, image) in zip(axes, images.items(), strict=True):
        plot_image(image, ax=ax, dynamic_range_db=40.0)
        ax.set_title(name)
    save_figure(figure, out / "point_target_autofocus.png", overwrite=overwrite, dpi=120)
    estimates = {name: image["autofocus_phase"].values for name, image in images.items()
                 if "autofocus_phase" in image}
    ax = plots_navigation.plot_phase(raw, TARGET, estimates)
    save_figure(ax.figure, out / "phase.png", overwrite=overwrite, dpi=120)
    plt.close("all")
    return results


def room(out: Path, overwrite: bool) -> dict:
    raw = mitsar.simulate_scene(RADAR, TRACK, LOOK, "control_volume", navigation=ERRORS)
    ideal = mitsar.simulate_scene(RADAR, TRACK, LOOK, "control_volume")
    oracle = correct_raw(raw, plots_navigation.navigation_phase(raw, TARGET))
    grid = SlantGrid(along_track=[-0.6, 1.0, 0.02], slant_range=[6.0, 10.0, 0.02])
    cases = {"error-free": (ideal, None), "no autofocus": (raw, None), "pga": (raw, "pga"),
             "entropy": (raw, "entropy"), "oracle": (oracle, None)}
    figure, axes = plt.subplots(1, len(cases), figsize=(4.2 * len(cases), 4.2),
                                layout="constrained")
    entropy = {}
    for ax, (name, (data, method)) in zip(axes, cases.items(), strict=True):
        image = mitsar.focus(data, grid=grid, azimuth_resolution=0.1, autofocus=method)
        plot_image(image, ax=ax, dynamic_range_db=40.0)
        ax.set_title(f"control volume, {name}")
        entropy[name] = round(float(image_entropy(image["image"].values)), 4)
    save_figure(figure, out / "room_autofocus.png", overwrite=overwrite, dpi=110)
    plt.close("all")
    return {"image_entropy": entropy}


def main() -> int:
    parser = argparse.ArgumentParser(description=__doc__.splitlines()[0])
    parser.add_argument("-o", "--output", required=True)
    parser.add_argument("--overwrite", action="store_true")
    args = parser.parse_args()
    out = Path(args.output)
    out.mkdir(parents=True, exist_ok=True)
    results = {"point_target": point_target(out, args.overwrite),
               "room": room(out, args.overwrite)}
    write_json(results, out / "metrics.json", overwrite=args.overwrite)
    print(json.dumps(results, indent=2))
    return 0


if __name__ == "__main__":
    raise SystemExit(main())
