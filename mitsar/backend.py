"""The Dr.Jit / Mitsuba compute backend: pick a variant and fail early with the fix.

Dr.Jit's CPU (LLVM) backend needs libLLVM >= 16; Debian 12's default libLLVM 15 crashes on
some operations (``dr.maximum``: "Cannot select fmaximum"). :func:`require_llvm` checks once per
process that a small kernel with ``dr.maximum`` compiles and runs, and otherwise raises an error
that names the fix.
"""

from __future__ import annotations

import functools
import os

from mitsar.errors import MitsarError

LLVM_FIX = ("install a newer LLVM (Debian 12: 'apt-get install libllvm19', or 'make setup'), "
            "or point DRJIT_LIBLLVM_PATH at libLLVM.so of version >= 16")


class BackendError(MitsarError, RuntimeError):
    """The Dr.Jit LLVM backend cannot run on this machine."""


@functools.cache
def require_llvm() -> None:
    """Check that Dr.Jit's LLVM backend works (libLLVM >= 16); raise BackendError if not."""
    try:
        import drjit as dr
        from drjit.llvm import Float32
    except ImportError as error:  # pragma: no cover - dependency missing
        raise BackendError(f"Dr.Jit is not installed ({error}); run 'make setup'") from error
    if not dr.has_backend(dr.JitBackend.LLVM):
        raise BackendError(
            "Dr.Jit found no usable LLVM library (DRJIT_LIBLLVM_PATH="
            f"{os.environ.get('DRJIT_LIBLLVM_PATH', 'unset')}): " + LLVM_FIX)
    try:
        probe = dr.maximum(Float32([1.0, 3.0]), Float32([2.0, 0.0]))
        values = list(probe)
    except Exception as error:  # pragma: no cover - depends on the system LLVM
        raise BackendError(f"Dr.Jit's LLVM backend failed a probe kernel ({error}): "
                           + LLVM_FIX) from error
    if values != [2.0, 3.0]:  # pragma: no cover
        raise BackendError(f"Dr.Jit's LLVM backend computed a wrong result {values}: " + LLVM_FIX)
