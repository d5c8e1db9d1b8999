"""Pictures of a scene experiment: ``rays`` (ray geometry and echoes of one sweep, paper Figs. 6,
10, 11) and ``preview`` (the scene, the flight and the beam, before simulating)."""

from __future__ import annotations

import argparse

from mitsar.cli.common import log
from mitsar.experiment.loading import load_experiment
from mitsar.experiment.rays import run_rays
from mitsar.report.preview import preview

__all__ = ["cmd_preview", "cmd_rays"]


def cmd_rays(args: argparse.Namespace) -> int:
    """``mitsar rays``: ray geometry and echo figures of a scene experiment."""
    log(args, f"tracing rays of {args.experiment} (sweep {args.sweep}) ...")
    summary = run_rays(load_experiment(args.experiment, args.set), args.output, args.rays,
                       args.sweep, overwrite=args.overwrite)
    ratio = summary.get("reflections_over_backscatter_amplitude")
    print(f"captured reflected rays: {summary['captures']}; reflections / backscatter peak "
          f"amplitude after the range FFT: {'none' if not ratio else f'{ratio:.3g}'}")
    for name in summary["figures"].values():
        log(args, f"wrote {name}")
    return 0


def cmd_preview(args: argparse.Namespace) -> int:
    """``mitsar preview``: the scene, the flight and the beam, before simulating."""
    print(f"wrote {preview(args.experiment, args.output, overwrite=args.overwrite)}")
    return 0
