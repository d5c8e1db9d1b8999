"""The Dr.Jit / Mitsuba compute backend: fail early, with the fix, when it cannot run.

Dr.Jit's CPU (LLVM) backend needs libLLVM >= 16; Debian 12's default libLLVM 15 aborts the
process on some operations (``dr.maximum``: "LLVM ERROR: Cannot select fmaximum"). So the check
runs a tiny ``dr.maximum`` kernel in a subprocess, once per process, and :func:`require_llvm`
raises an error that names the fix.
"""

from __future__ import annotations

import functools
import os
import subprocess
import sys

from mitsar.errors import MitsarError

LLVM_FIX = ("install a newer LLVM (Debian 12: 'apt-get install libllvm19', or 'make setup'), "
            "or point DRJIT_LIBLLVM_PATH at libLLVM.so of version >= 16")

SKIP_PROBE_ENV = "MITSAR_SKIP_BACKEND_PROBE"
"""Set to 1 to skip the subprocess probe (e.g. when it is known to pass)."""

_PROBE_SOURCE = """
import drjit as dr
from drjit.llvm import Float
x = dr.maximum(Float([1.0, -2.0, 3.0]), 0.0)
dr.eval(x)
assert list(x) == [1.0, 0.0, 3.0], list(x)
"""


class BackendError(MitsarError, RuntimeError):
    """The Dr.Jit LLVM backend cannot run on this machine."""


@functools.cache
def llvm_probe() -> tuple[bool, str]:
    """Run a ``dr.maximum`` kernel on the LLVM backend in a subprocess, once per process.

    Returns
    -------
    ok : bool
    detail : str
        The probe's output (last 1500 characters) when it failed.
    """
    if os.environ.get(SKIP_PROBE_ENV, "") not in ("", "0"):
        return True, ""
    try:
        proc = subprocess.run([sys.executable, "-c", _PROBE_SOURCE], capture_output=True,
                              text=True, timeout=300, check=False)
    except (OSError, subprocess.TimeoutExpired) as error:  # pragma: no cover - no subprocess
        return True, f"probe not run: {error}"
    detail = (proc.stderr or proc.stdout).strip()
    return proc.returncode == 0, detail[-1500:]


def require_llvm() -> None:
    """Raise :class:`BackendError` naming the fix unless Dr.Jit's LLVM backend works."""
    ok, detail = llvm_probe()
    if not ok:
        raise BackendError("Dr.Jit's LLVM backend failed a smoke test (dr.maximum); it needs "
                           f"libLLVM >= 16. Fix: {LLVM_FIX}. Probe output: {detail}")
