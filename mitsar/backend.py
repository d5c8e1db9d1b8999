"""The Dr.Jit compute backend: which one runs mitsar's kernels, and fail early when it cannot.

One choice for every Dr.Jit kernel of mitsar (the analytic simulator, BPA, FFBP; the tracer's
Mitsuba variant follows it too, :mod:`mitsar.plugins.variant`): :func:`backend_name` resolves,
in this order, an explicit argument, a :func:`use_backend` block, the environment variable
``MITSAR_BACKEND`` (``auto``, ``llvm`` or ``cuda``) and ``auto`` = CUDA where Dr.Jit finds a
CUDA device (:func:`cuda_available`), else LLVM (CPU). :func:`array_namespace` gives the
matching module of array types (``drjit.llvm`` or ``drjit.cuda``), checked to run; kernels
that receive arrays take their types from them (:func:`namespace_of`), so one call never mixes
backends (docs/gpu.md).

Dr.Jit's CPU (LLVM) backend needs libLLVM >= 16; Debian 12's default libLLVM 15 aborts the
process on some operations (``dr.maximum``: "LLVM ERROR: Cannot select fmaximum"). So the check
runs a tiny ``dr.maximum`` kernel in a subprocess, once per process, and :func:`require_llvm`
raises an error that names the fix.
"""

from __future__ import annotations

import contextlib
import functools
import importlib
import os
import subprocess
import sys
from collections.abc import Callable, Iterator
from types import ModuleType
from typing import Any

from mitsar.errors import MitsarError, ParameterError
from mitsar.lazy import LazyModule

drjit = LazyModule("drjit")
"""Dr.Jit, imported when a kernel first uses it (:class:`LazyModule`)."""


def syntax(function: Callable[..., Any]) -> Callable[..., Any]:
    """``@drjit.syntax`` applied on the function's first call rather than at its definition
    (which would import Dr.Jit with the module); the transformed function is kept.

    ``drjit.syntax`` rewrites the function from its source, so applying it later gives the
    same function.
    """
    transformed: list[Callable[..., Any]] = []

    @functools.wraps(function)
    def run(*args: Any, **kwargs: Any) -> Any:
        if not transformed:
            transformed.append(drjit.syntax(function))
        return transformed[0](*args, **kwargs)

    return run

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


BACKEND_ENV = "MITSAR_BACKEND"
"""Environment variable that picks the backend: ``auto`` (default), ``llvm`` or ``cuda``."""

BACKENDS = ("llvm", "cuda")
"""The Dr.Jit JIT backends mitsar's kernels run on."""

_override: list[str] = []
"""Backends chosen by the enclosing :func:`use_backend` blocks, innermost last."""


class BackendError(MitsarError, RuntimeError):
    """The chosen Dr.Jit backend cannot run on this machine."""


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


@functools.cache
def cuda_available() -> bool:
    """Whether Dr.Jit finds a CUDA device and driver (``dr.has_backend``), once per process."""
    try:
        import drjit as dr  # lazy: Dr.Jit is heavy and only needed by the kernels

        return bool(dr.has_backend(dr.JitBackend.CUDA))
    except Exception:  # noqa: BLE001 - no CUDA driver, or an old Dr.Jit
        return False


def backend_name(backend: str | None = None) -> str:
    """The backend a kernel runs on: ``"llvm"`` (CPU) or ``"cuda"`` (NVIDIA GPU).

    Parameters
    ----------
    backend : {"auto", "llvm", "cuda"}, optional
        Explicit choice. Default: the innermost :func:`use_backend` block, else the
        environment variable ``MITSAR_BACKEND``, else ``"auto"``: CUDA where
        :func:`cuda_available`, LLVM otherwise.

    Returns
    -------
    str
        ``"llvm"`` or ``"cuda"``.

    Raises
    ------
    ParameterError
        If the choice is none of ``auto``, ``llvm``, ``cuda``.
    """
    choice = backend or (_override[-1] if _override else None) or os.environ.get(BACKEND_ENV)
    choice = (choice or "auto").strip().lower()
    if choice == "auto":
        return "cuda" if cuda_available() else "llvm"
    if choice not in BACKENDS:
        raise ParameterError("mitsar.backend", BACKEND_ENV, "'auto', 'llvm' or 'cuda'", choice)
    return choice


def require_backend(backend: str | None = None) -> str:
    """Resolve :func:`backend_name` and check that it can run.

    Raises
    ------
    BackendError
        LLVM: libLLVM < 16 (:func:`require_llvm`); CUDA: no CUDA device or driver.
    """
    name = backend_name(backend)
    if name == "llvm":
        require_llvm()
    elif not cuda_available():
        raise BackendError("the CUDA backend was chosen (MITSAR_BACKEND or use_backend) but "
                           "Dr.Jit finds no CUDA device: no NVIDIA GPU, or no driver "
                           "(libcuda.so). Fix: MITSAR_BACKEND=llvm, or run on a GPU machine.")
    return name


def array_namespace(backend: str | None = None) -> ModuleType:
    """The Dr.Jit array types of the chosen backend, checked to run.

    Parameters
    ----------
    backend : {"auto", "llvm", "cuda"}, optional
        As :func:`backend_name`.

    Returns
    -------
    module
        ``drjit.llvm`` or ``drjit.cuda`` (``Float32``, ``Float64``, ``UInt32``, ...).
    """
    return importlib.import_module(f"drjit.{require_backend(backend)}")


def namespace_of(value: Any) -> ModuleType:
    """The array-type module (``drjit.llvm`` or ``drjit.cuda``) that Dr.Jit array ``value``
    belongs to: kernels build their temporaries on their inputs' backend."""
    import drjit as dr  # lazy: see cuda_available

    cuda = dr.backend_v(value) == dr.JitBackend.CUDA
    return importlib.import_module("drjit.cuda" if cuda else "drjit.llvm")


@contextlib.contextmanager
def use_backend(backend: str | None) -> Iterator[str]:
    """Run the kernels of the enclosed block on ``backend`` (``None``: no change).

    Parameters
    ----------
    backend : {"auto", "llvm", "cuda"} or None

    Yields
    ------
    str
        The resolved backend, ``"llvm"`` or ``"cuda"``.
    """
    if backend is None:
        yield backend_name()
        return
    name = backend_name(backend)
    _override.append(name)
    try:
        yield name
    finally:
        _override.pop()


UNSAFE_WIDTH_BAND = 16
"""Dr.Jit 1.5's LLVM backend crashes (SIGSEGV inside ``dr.eval``) on some kernels whose width
lies just below a power of two from 2^20 up: measured at ``2^22 - d`` for ``3 <= d <= 14``
(and at ``2^20 - 4``, ``2^20 - 8``, ``2^23 - 4``), never at ``2^k`` itself nor at ``d >= 16``
(docs/reliability.md §5, ``scripts/drjit_width_crash.py``)."""


def safe_width(width: int) -> int:
    """The kernel width to launch for ``width`` lanes: ``width`` itself, or the next power of
    two (from 2^20 up) when ``width`` lies in the band below it where Dr.Jit 1.5 crashes
    (:data:`UNSAFE_WIDTH_BAND`: 2^20 - 8 included, which crashed back-projection); callers
    pad their lanes to it (lanes that contribute nothing) and drop the extra results."""
    width = int(width)
    power = 1 << max(width - 1, 0).bit_length()  # the smallest power of two >= width
    if power >= 2**20 and 0 < power - width < UNSAFE_WIDTH_BAND:
        return power
    return width
