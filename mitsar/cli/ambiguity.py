"""``mitsar ambiguity``: resolution and ambiguity maps by the gradient method
(docs/ambiguity.md)."""

from __future__ import annotations

import argparse

from mitsar.ambiguity.run import run_ambiguity_experiment
from mitsar.cli.common import log

__all__ = ["cmd_ambiguity"]


def cmd_ambiguity(args: argparse.Namespace) -> int:
    """``mitsar ambiguity``: gradient-method maps of one or more trajectories."""
    log(args, f"ambiguity maps of {args.experiment} ...")
    summary = run_ambiguity_experiment(args.experiment, args.output, overwrite=args.overwrite,
                                       figures=False if args.no_figures else None,
                                       progress=not args.quiet,
                                       log=lambda message: log(args, message))
    if summary.get("comparison_table"):
        print(summary["comparison_table"])
    for name in summary.get("files", []):
        log(args, f"wrote {name}")
    return 0
