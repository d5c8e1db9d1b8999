"""Dr.Jit's thread count for deterministic traces (docs/integrator.md §"Determinism").

Float64 atomic scatter-adds (the lane kernels' deposit, multipath, physical optics) sum in an
order that changes from run to run on several threads, so a deterministic trace runs them on
one Dr.Jit thread (:func:`deterministic_threads`). Kernels whose results do not depend on the
order of their lanes (integer sums, per-lane results such as shadow rays) may still use every
core inside it (:func:`order_independent`).
"""

from __future__ import annotations

from collections.abc import Iterator
from contextlib import contextmanager

__all__ = ["deterministic", "deterministic_threads", "order_independent"]

_outer: list[int] = []
"""Thread counts in force when the enclosing :func:`deterministic_threads` blocks began."""


def deterministic() -> bool:
    """Whether a :func:`deterministic_threads` block is active (kernels that can sum in an
    order-independent way choose to then)."""
    return bool(_outer)


@contextmanager
def deterministic_threads(enabled: bool) -> Iterator[None]:
    """One Dr.Jit thread inside the block when ``enabled`` (restored afterwards)."""
    if not enabled:
        yield
        return
    # lazy: Dr.Jit is loaded once a variant is set (register_plugins), never on import
    import drjit as dr

    previous = dr.thread_count()
    _outer.append(previous)
    dr.set_thread_count(1)
    try:
        yield
    finally:
        _outer.pop()
        dr.set_thread_count(previous)


@contextmanager
def order_independent() -> Iterator[None]:
    """Inside :func:`deterministic_threads`, the thread count from before it (every core by
    default) for kernels whose results do not depend on the order of their lanes."""
    if not _outer or _outer[-1] <= 1:
        yield
        return
    # lazy: as above
    import drjit as dr

    dr.set_thread_count(_outer[-1])
    try:
        yield
    finally:
        dr.sync_thread()  # the LLVM backend launches asynchronously: finish on every core
        dr.set_thread_count(1)
