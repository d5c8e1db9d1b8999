"""``mitsar run`` (everything an experiment asks for, with an HTML report) and ``mitsar report``
(that report again, from a run folder)."""

from __future__ import annotations

import argparse
import json
import sys

from mitsar.cli.common import log
from mitsar.report.html import RUN_RECORD, build_report
from mitsar.report.run import run_experiment

__all__ = ["cmd_report", "cmd_run"]


def cmd_run(args: argparse.Namespace) -> int:
    """``mitsar run``: everything an experiment asks for, and its report."""
    log(args, f"running {args.experiment} into {args.output} ...")
    report = run_experiment(args.experiment, args.output, overrides=args.set,
                            algorithms=args.algorithms, realisations=args.realisations,
                            overwrite=args.overwrite, progress=not args.quiet)
    record = json.loads((report.parent / RUN_RECORD).read_text())
    for warning in record.get("warnings", []):
        print(f"warning: {warning}", file=sys.stderr)
    print(f"wrote {report}")
    return 0


def cmd_report(args: argparse.Namespace) -> int:
    """``mitsar report``: rebuild the report of a run folder."""
    print(f"wrote {build_report(args.folder)}")
    return 0
