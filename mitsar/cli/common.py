"""What every ``mitsar`` command shares: progress messages on stderr."""

from __future__ import annotations

import argparse
import sys

__all__ = ["log"]


def log(args: argparse.Namespace, message: str) -> None:
    """A progress message on stderr (silenced by ``--quiet``)."""
    if not getattr(args, "quiet", False):
        print(message, file=sys.stderr, flush=True)
