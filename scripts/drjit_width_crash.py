"""Minimal reproducer of a Dr.Jit 1.5.0 LLVM-backend crash (docs/reliability.md §5). Not a test.

A kernel ``sin(x) + 1`` over a Float64 array made from NumPy, evaluated and read back through
``np.asarray`` 20 times in a row (without the read-back it does not crash), crashes the process
(SIGSEGV inside a later ``dr.eval``; in most runs, not all) when the width is ``2^22 - d`` for ``3
<= d <= 14`` (also ``2^20 - 4`` and ``2^23 - 4``, one or two threads alike), and runs at ``2^22``,
``2^22 - 1``, ``2^22 - 2`` and ``2^22 - d`` for ``d >= 16``. Measured on this 2-core x86-64 machine
with drjit 1.5.0 / mitsuba 3.9.1 (no newer release on PyPI).

Run: ``python scripts/drjit_width_crash.py [WIDTH]`` (default 2^22 - 4); each width in a fresh
process: ``for d in 1 2 3 4 14 16; do python scripts/drjit_width_crash.py $((4194304 - d)); done``.
mitsar pads its kernels' lanes past such widths (:func:`mitsar.backend.safe_width`: the analytic
simulator, both back-projection kernels, FFBP's final stage). Back-projection crashed the same
way at 2^20 - 8 lanes (``tests/test_drjit_width.py``), 3 times in 3 with Dr.Jit imported before
NumPy and SciPy and 0 in 5 imported after them: whether a width in the band crashes depends on
the process's state, not on the kernel alone.
"""

from __future__ import annotations

import sys

import drjit as dr
import numpy as np
from drjit.llvm import Float64


def main() -> None:
    width = int(sys.argv[1]) if len(sys.argv) > 1 else 2**22 - 4
    source = np.arange(width, dtype=np.float64)
    for _ in range(20):
        result = dr.sin(Float64(source)) + 1.0
        dr.eval(result)
        float(np.asarray(result)[::1000].sum())  # read back through NumPy, as mitsar does
    print(f"width {width}: no crash", flush=True)


if __name__ == "__main__":
    main()
