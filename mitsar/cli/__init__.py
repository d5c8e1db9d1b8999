"""The ``mitsar`` command line: simulate, focus, measure and plot; ``mitsar demo`` for the paper.

::

    mitsar simulate EXPERIMENT.toml -o raw.nc [--overwrite]
    mitsar range raw.nc -o profile.nc [--window W]
    mitsar focus raw.nc -o image.nc [-a bpa] [--window W] [--azimuth-resolution M]
                 [--grid GRID.toml]
    mitsar export image.nc -f sicd --raw raw.nc -o image.nitf   (or raw.nc -f cphd -o raw.cphd)
    mitsar metrics image.nc [--target X Y Z] [--islr-extent paper] [--json] [-o metrics.json]
    mitsar plot FILE -o FIG.png
    mitsar run EXPERIMENT.toml -o DIR        (everything, with report.html; mitsar report DIR)
    mitsar preview EXPERIMENT.toml -o PREVIEW.png
    mitsar demo [-o DIR] [--overwrite]
    mitsar montecarlo EXPERIMENT.toml -o DIR [-n N]
    mitsar sweep EXPERIMENT.toml --vary KEY=A:B:STEP [--vary ...] [-n N] -o DIR
    mitsar interferogram | rays | ambiguity ...

Errors in the input (bad files, invalid parameters) print one message on stderr and exit with
status 2; ``--debug`` shows the traceback instead. See ``docs/cli.md``.

The commands live in one module a group: :mod:`~mitsar.cli.stages` (one product file to the
next), :mod:`~mitsar.cli.demo`, :mod:`~mitsar.cli.campaigns` (``montecarlo``, ``sweep``),
:mod:`~mitsar.cli.scene` (``rays``, ``preview``), :mod:`~mitsar.cli.report` (``run``,
``report``), :mod:`~mitsar.cli.ambiguity`; their options in :mod:`~mitsar.cli.parser`.
"""

from __future__ import annotations

import sys
from collections.abc import Sequence
from typing import TYPE_CHECKING

from mitsar.budget import set_memory_limit
from mitsar.cli.parser import build_parser
from mitsar.errors import MitsarError
from mitsar.lazy import lazy_exports

if TYPE_CHECKING:  # the same names for type checkers and the API docs (griffe reads these)
    from mitsar.cli.demo import (
        DEMO_FILES,
        PAPER_TABLE4_BPA,
        demo_examples,
        demo_summary,
        run_demo,
    )
    from mitsar.cli.stages import format_metrics

# The demo's and the metrics table's helpers stay importable from here, as before the split.
__all__ = ["DEMO_FILES", "PAPER_TABLE4_BPA", "build_parser", "demo_examples", "demo_summary",
           "format_metrics", "main", "run_demo"]

_EXPORTS = {
    "DEMO_FILES": "mitsar.cli.demo", "PAPER_TABLE4_BPA": "mitsar.cli.demo",
    "demo_examples": "mitsar.cli.demo", "demo_summary": "mitsar.cli.demo",
    "format_metrics": "mitsar.cli.stages", "run_demo": "mitsar.cli.demo",
}
"""Public names -> the module that defines each, imported on first use (PEP 562): a command
imports only what it runs (:mod:`mitsar.cli.parser` imports each command's module when it
runs)."""

EXIT_USAGE = 2
"""Exit status for bad input (same as argparse's usage errors)."""


def main(argv: Sequence[str] | None = None) -> int:
    """Run the ``mitsar`` command line.

    Parameters
    ----------
    argv : sequence of str, optional
        Arguments (default ``sys.argv[1:]``).

    Returns
    -------
    int
        Exit status: 0 on success, 2 for bad input (message on stderr), 130 if interrupted.
    """
    parser = build_parser()
    args = parser.parse_args(argv)
    try:
        set_memory_limit(args.memory_limit)
        return int(args.func(args) or 0)
    except KeyboardInterrupt:
        print("mitsar: interrupted", file=sys.stderr)
        return 130
    except (MitsarError, ValueError, OSError) as error:
        if args.debug:
            raise
        print(f"mitsar {args.command}: error: {error}", file=sys.stderr)
        return EXIT_USAGE


__getattr__, __dir__ = lazy_exports(__name__, _EXPORTS, globals(), __all__)
