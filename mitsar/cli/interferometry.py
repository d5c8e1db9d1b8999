"""``mitsar interferogram``: a multi-channel image product -> interferogram product, point cloud
and maps in a folder, with a summary on stdout (docs/cli.md, docs/interferometry.md)."""

from __future__ import annotations

import argparse
import copy
import dataclasses
import json
import time
from pathlib import Path
from typing import Any

from mitsar.cli.common import log
from mitsar.errors import ParameterError
from mitsar.experiment.interferometry import (
    INTERFEROMETRY_FILES,
    check_multichannel,
    format_interferometry_summary,
    interferometry_summary,
    run_interferometry,
    write_interferometry,
)
from mitsar.experiment.options import InterferometryOptions
from mitsar.experiment.parsers import parse_interferometry
from mitsar.experiment.table import Table
from mitsar.io import ProductFileError, check_writable, load
from mitsar.products.requests import scene_of

__all__ = ["cmd_interferogram", "interferometry_options"]

WHERE = "mitsar interferogram"


def _recorded_options(image: Any, channels: int) -> InterferometryOptions:
    """The ``[interferometry]`` table of the experiment the image records, else defaults."""
    try:
        config = json.loads(image.attrs.get("experiment") or "{}")
    except (TypeError, json.JSONDecodeError):
        config = {}
    table = config.get("interferometry") if isinstance(config, dict) else None
    if not isinstance(table, dict):
        return InterferometryOptions()
    return parse_interferometry(Table(copy.deepcopy(table), "interferometry",
                                      "the image's experiment", Path.cwd()), channels)


def interferometry_options(args: argparse.Namespace, image: Any) -> InterferometryOptions:
    """Options: the command line over the image's recorded ``[interferometry]`` table over the
    defaults; the command line's values checked against the image's channels."""
    channels = int(image.sizes["channel"])
    options = _recorded_options(image, channels)
    changes: dict[str, Any] = {}
    if args.pair is not None:
        first, second = args.pair
        if first == second or not (0 <= first < channels and 0 <= second < channels):
            raise ParameterError(WHERE, "--pair", f"two different channels in 0..{channels - 1} "
                                 f"(the image has {channels}), e.g. --pair 0 1", args.pair)
        changes["pair"] = (first, second)
    if args.looks is not None:
        if min(args.looks) < 1:
            raise ParameterError(WHERE, "--looks", "two integers >= 1 [pixels] (rows, cols), "
                                 "e.g. --looks 5 5", args.looks)
        changes["looks"] = tuple(args.looks)
    if args.no_unwrap:
        changes["unwrap"] = False
    if args.min_coherence is not None:
        if not 0.0 <= args.min_coherence <= 1.0:
            raise ParameterError(WHERE, "--min-coherence", "a coherence in [0, 1], e.g. 0.3",
                                 args.min_coherence)
        changes["min_coherence"] = float(args.min_coherence)
    return dataclasses.replace(options, **changes)


def cmd_interferogram(args: argparse.Namespace) -> int:
    """``mitsar interferogram``: multi-channel image -> interferogram, points and maps."""
    out = Path(args.output)
    if out.exists() and not out.is_dir():
        raise ProductFileError(f"{out}: exists and is not a folder (-o names the output folder)")
    if out.is_dir():
        for name in INTERFEROMETRY_FILES.values():
            check_writable(out / name, args.overwrite)
    image = load(args.image, product="image")
    check_multichannel(image, args.image)
    options = interferometry_options(args, image)
    start = time.perf_counter()
    log(args, f"interferogram of channels {options.pair[0]}-{options.pair[1]} of {args.image} "
              f"({options.looks[0]} x {options.looks[1]} looks) ...")
    scene = None if args.no_masks else (args.scene or scene_of(image))
    if scene is not None:
        log(args, f"layover and shadow masks from the scene {scene} ...")
    result = run_interferometry(image, options, where=args.image, quiet=args.quiet,
                                scene=scene)
    paths = write_interferometry(out, result, overwrite=args.overwrite)
    log(args, f"wrote {', '.join(str(p) for p in paths.values())} "
              f"({time.perf_counter() - start:.1f} s)")
    print(format_interferometry_summary(interferometry_summary(result)))
    return 0
