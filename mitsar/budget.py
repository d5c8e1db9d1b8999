"""Memory budget: refuse, before any work, a request that does not fit the machine.

Every entry point that allocates in proportion to its inputs (background cells, surface
scatterers, samples x sweeps, ambiguity points x states, focus grid pixels, histogram bins)
estimates its peak memory from the parameters alone and calls :func:`require_memory` first.
The available memory is, in order: :func:`set_memory_limit` (the CLI's ``--memory-limit``), the
environment variable ``MITSAR_MEMORY_LIMIT`` (e.g. ``"4G"``, ``"512M"``, ``"2e9"``), else
``MemAvailable`` of ``/proc/meminfo`` (``os.sysconf`` physical pages elsewhere). See
``docs/reliability.md §2``.

Also here: :func:`require_count`, a sane bound on counts (sweeps, states, rays) independent of
the memory, for loops whose cost is time rather than space.
"""

from __future__ import annotations

import contextlib
import math
import os
import re
from pathlib import Path

from mitsar.errors import MemoryBudgetError, ParameterError

__all__ = ["MAX_SWEEPS", "MEMORY_LIMIT_ENV", "available_memory", "parse_size", "require_count",
           "require_memory", "set_memory_limit"]

MEMORY_LIMIT_ENV = "MITSAR_MEMORY_LIMIT"
"""Environment variable holding a memory limit (bytes, or a size with a K/M/G/T suffix)."""

MAX_SWEEPS = 10**9
"""Sane bound on the sweeps of one acquisition: 46 days of flight at 250 Hz."""

_LIMIT: int | None = None
"""Limit set by :func:`set_memory_limit` (the CLI's ``--memory-limit``); None: not set."""

_UNITS = {"": 1, "B": 1, "K": 2**10, "M": 2**20, "G": 2**30, "T": 2**40, "P": 2**50}


def parse_size(text: str | int | float, where: str = "memory limit",
               name: str = MEMORY_LIMIT_ENV) -> int:
    """A memory size in bytes from ``"4G"``, ``"512MiB"``, ``"2e9"`` or a number.

    Raises
    ------
    ParameterError
        If the text is not a size > 0.
    """
    expected = "a memory size > 0: bytes or a number with K, M, G or T (binary), e.g. '4G'"
    if isinstance(text, bool):
        raise ParameterError(where, name, expected, text)
    if isinstance(text, int | float):
        value, unit = float(text), ""
    else:
        match = re.fullmatch(r"\s*([0-9.eE+-]+)\s*([KMGTP]?)(?:i?B)?\s*", str(text),
                             re.IGNORECASE)
        if match is None:
            raise ParameterError(where, name, expected, text)
        try:
            value = float(match.group(1))
        except ValueError:
            raise ParameterError(where, name, expected, text) from None
        unit = match.group(2).upper()
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(where, name, expected, text)
    return int(value * _UNITS[unit])


def set_memory_limit(limit: str | int | float | None) -> None:
    """Set (or with None clear) the memory limit that :func:`available_memory` reports."""
    global _LIMIT
    _LIMIT = None if limit is None else parse_size(limit, "--memory-limit", "memory_limit")


def _machine_available() -> int:
    """Memory the machine can give now [bytes]: MemAvailable, else physical memory."""
    with contextlib.suppress(OSError, ValueError, IndexError):  # no /proc: physical memory
        for line in Path("/proc/meminfo").read_text().splitlines():
            if line.startswith("MemAvailable:"):
                return int(line.split()[1]) * 1024
    try:
        return int(os.sysconf("SC_PAGE_SIZE") * os.sysconf("SC_PHYS_PAGES"))
    except (ValueError, OSError, AttributeError):
        return 2**34  # 16 GiB: a laptop, when the platform reports nothing


def available_memory() -> tuple[int, str]:
    """The memory a request may use [bytes] and where that figure comes from."""
    if _LIMIT is not None:
        return _LIMIT, "--memory-limit"
    env = os.environ.get(MEMORY_LIMIT_ENV)
    if env:
        return parse_size(env), MEMORY_LIMIT_ENV
    return _machine_available(), "MemAvailable of this machine"


def require_memory(where: str, parameter: str, nbytes: float, hint: str = "") -> None:
    """Refuse a request whose estimated peak memory ``nbytes`` exceeds what is available.

    Parameters
    ----------
    where : str
        The function, file or command asking.
    parameter : str
        The parameter (or key path) that drives the size, e.g. ``"background.size"``.
    nbytes : float
        Estimated peak memory of the request [bytes] (may be ``inf``).
    hint : str
        What to change, e.g. the chunked or streamed path when one exists.

    Raises
    ------
    MemoryBudgetError
        Naming ``where``, ``parameter``, the need and what is available.
    """
    limit, source = available_memory()
    if not nbytes <= limit:  # NaN and inf refused too
        raise MemoryBudgetError(where, parameter, nbytes if math.isfinite(nbytes) else 2**70,
                                limit, source, hint)


def require_count(where: str, parameter: str, count: float, limit: float,
                  what: str = "items") -> None:
    """Refuse a count above a sane ``limit`` (a loop that would run for days, not a memory
    question), naming the parameter.

    Raises
    ------
    ParameterError
    """
    if not count <= limit:
        raise ParameterError(where, parameter, f"at most {limit:.3g} {what}", count)
