"""Commands from one product file to the next: ``simulate``, ``range``, ``focus``, ``export``,
``metrics`` and ``plot`` (docs/cli.md)."""

from __future__ import annotations

import argparse
import dataclasses
import json
import time
from typing import Any

from mitsar.cli.common import log
from mitsar.errors import MitsarError
from mitsar.experiment.loading import load_experiment, load_grid
from mitsar.experiment.options import FocusOptions
from mitsar.experiment.parsers import MAX_SEED
from mitsar.experiment.runs import pass_path, run_focus, run_metrics, simulate_to
from mitsar.export import write_cphd, write_sicd
from mitsar.focus.compression import range_compress
from mitsar.io import check_writable, load, save, to_jsonable, write_json
from mitsar.plots.figures import plot_file
from mitsar.plots.footprint import scene_range_marks
from mitsar.products.requests import focus_request, scene_of
from mitsar.scene import load_scene

__all__ = ["cmd_export", "cmd_focus", "cmd_metrics", "cmd_plot", "cmd_range", "cmd_simulate",
           "format_metrics"]


def cmd_simulate(args: argparse.Namespace) -> int:
    """``mitsar simulate``: experiment file -> raw product, chunk by chunk of sweeps; an
    interrupted run resumes from its last finished chunk (docs/reliability.md §5)."""
    if args.chunk_sweeps < 1:
        raise MitsarError(f"--chunk-sweeps: expected an integer >= 1, found {args.chunk_sweeps}")
    experiment = load_experiment(args.experiment, args.set)
    if not experiment.passes:  # with [[passes]]: one file per pass, checked by simulate_to
        check_writable(args.output, args.overwrite)
    if args.seed is not None:
        if not 0 <= args.seed <= MAX_SEED:
            raise MitsarError(f"--seed: expected an integer in [0, {MAX_SEED}] (products "
                              f"record it as 64 bits), found {args.seed}")
        experiment.simulation = dataclasses.replace(experiment.simulation, seed=args.seed)
        experiment.config.setdefault("simulation", {})["seed"] = args.seed
    start = time.perf_counter()
    log(args, f"simulating {args.experiment} ...")
    sweeps = simulate_to(experiment, args.output, overwrite=args.overwrite,
                         progress=not args.quiet, chunk_sweeps=args.chunk_sweeps,
                         log=lambda message: log(args, message))
    written = (", ".join(str(pass_path(args.output, i)) for i in range(len(experiment.passes)))
               if experiment.passes else args.output)
    kind = f"{len(experiment.passes)} raw products (one per pass)" if experiment.passes else (
        "raw product")
    log(args, f"wrote {written}: {kind}, {sweeps} sweeps x "
              f"{experiment.radar.samples_per_sweep} samples "
              f"({time.perf_counter() - start:.1f} s)")
    return 0


def cmd_range(args: argparse.Namespace) -> int:
    """``mitsar range``: raw product -> range-compressed product."""
    check_writable(args.output, args.overwrite)
    raw = load(args.raw, product="raw")
    profile = range_compress(raw, window=args.window)
    save(profile, args.output, overwrite=args.overwrite)
    log(args, f"wrote {args.output}: range-compressed product, "
              f"{profile.sizes['sweep']} sweeps x {profile.sizes['range']} range bins")
    return 0


def _focus_options(args: argparse.Namespace, raw: Any) -> Any:
    """Focus options: command-line flags over ``--grid`` over the options the raw product
    records (:func:`mitsar.products.requests.focus_request`)."""
    options = FocusOptions(**focus_request(raw))
    changes: dict[str, Any] = {}
    if args.algorithm is not None:
        changes["algorithm"] = args.algorithm
    if args.window is not None:
        changes["window"] = args.window
    if args.azimuth_resolution is not None:
        if not args.azimuth_resolution > 0:
            raise MitsarError(f"--azimuth-resolution: expected a resolution > 0 m, found "
                              f"{args.azimuth_resolution}")
        changes["azimuth_resolution"] = args.azimuth_resolution
    if args.full_aperture:
        changes["azimuth_resolution"] = None
    if args.band_limit is not None:
        changes["band_limit"] = args.band_limit
    if args.autofocus is not None:
        changes["autofocus"] = None if args.autofocus == "none" else args.autofocus
    if args.grid is not None:
        changes["grid"] = load_grid(args.grid)
    if args.default_grid:
        changes["grid"] = None
    return dataclasses.replace(options, **changes)


def cmd_focus(args: argparse.Namespace) -> int:
    """``mitsar focus``: raw product -> image product."""
    check_writable(args.output, args.overwrite)
    raw = load(args.raw, product="raw")
    options = _focus_options(args, raw)
    start = time.perf_counter()
    log(args, f"focusing {args.raw} with {options.algorithm.upper()} ...")
    image = run_focus(raw, options, progress=not args.quiet)
    save(image, args.output, overwrite=args.overwrite)
    shape = " x ".join(f"{image.sizes[d]} {d}" for d in image["image"].dims)
    log(args, f"wrote {args.output}: image product, {shape} "
              f"({time.perf_counter() - start:.1f} s)")
    return 0


def cmd_export(args: argparse.Namespace) -> int:
    """``mitsar export``: image product -> SICD, raw product -> CPHD (docs/products.md)."""
    check_writable(args.output, args.overwrite)
    if args.format == "sicd":
        # the image carries the aperture it was formed from; --raw gives the same metadata
        written = write_sicd(load(args.product, product="image"), args.output,
                             raw=load(args.raw, product="raw") if args.raw else None,
                             overwrite=args.overwrite)
    else:
        written = write_cphd(load(args.product, product="raw"), args.output,
                             overwrite=args.overwrite)
    log(args, f"wrote {written}: {args.format.upper()}")
    return 0


def format_metrics(metrics: dict[str, Any]) -> str:
    """Impulse-response metrics as a small text table."""
    target = ", ".join(f"{v:.3f}" for v in metrics.get("target", []))
    extent = metrics.get("islr_extent")  # a name ('paper': ±5 cells) or cells either side
    extent = f"±{extent:g} cells" if isinstance(extent, int | float) else repr(extent)
    lines = [f"target [{target}] m, peak offset {metrics.get('peak_offset_m', float('nan')):.4f}"
             f" m, ISLR extent {extent}",
             f"{'':9}{'IRW [m]':>10}{'IRW [cells]':>13}{'PSLR [dB]':>11}{'ISLR [dB]':>11}"]
    for name in ("range", "azimuth"):
        m = metrics[name]
        lines.append(f"{name:9}{m['irw_m']:>10.4f}{m['irw_cells']:>13.3f}"
                     f"{m['pslr_db']:>11.2f}{m['islr_db']:>11.2f}")
    if "islr_2d_db" in metrics:
        lines.append(f"2-D ISLR {metrics['islr_2d_db']:.2f} dB")
    if "snr_db" in metrics:  # images of raw data with a noise figure (docs/metrics.md §Noise)
        lines.append(f"SNR {metrics['snr_db']:.2f} dB, NESZ {metrics['nesz_db']:.2f} dB")
    lines.extend(f"warning: {message}" for message in metrics.get("warnings", []))
    return "\n".join(lines)


def cmd_metrics(args: argparse.Namespace) -> int:
    """``mitsar metrics``: image product -> IRW, PSLR, ISLR."""
    if args.output is not None:
        check_writable(args.output, args.overwrite)
    image = load(args.image, product="image")
    extent: str | float | None = args.islr_extent
    if extent is not None:
        try:
            extent = float(extent)
        except ValueError:
            pass  # a named extent ("paper", "isce3", ...), checked by measure_impulse_response
    metrics = to_jsonable(run_metrics(image, target=args.target, islr_extent=extent))
    if args.output is not None:
        write_json(metrics, args.output, overwrite=args.overwrite)
        log(args, f"wrote {args.output}")
    print(json.dumps(metrics, indent=2) if args.json else format_metrics(metrics))
    return 0


def _scene_marks(path: str) -> dict[str, float] | None:
    """NR / CS / FR of an image of a scene experiment from the beam's hits in its scene."""
    product = load(path)
    scene = scene_of(product)
    if product.attrs.get("product") != "image" or not scene:
        return None
    return scene_range_marks(product, None, load_scene(scene)) or None


def cmd_plot(args: argparse.Namespace) -> int:
    """``mitsar plot``: product file -> figure."""
    if args.dynamic_range is not None and not args.dynamic_range > 0:
        raise MitsarError(f"--dynamic-range: expected a colour scale depth > 0 dB, found "
                          f"{args.dynamic_range}")
    plot_file(args.file, args.output, overwrite=args.overwrite,
              dynamic_range_db=args.dynamic_range, range_marks=_scene_marks(args.file))
    log(args, f"wrote {args.output}")
    return 0
