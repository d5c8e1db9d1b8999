"""Interpolation of zero-padded range profiles, written once for NumPy and for Dr.Jit.

Every back-projection reads a range profile (the zero-padded range FFT,
:func:`mitsar.focus.compression.range_spectrum`) at a beat frequency that falls between two
bins ``i`` and ``i + 1``, at a fraction ``t`` in [0, 1). The value there is a polynomial in
``t`` whose coefficients depend on the bin only:

* ``"linear"``: ``p_i + t (p_{i+1} - p_i)`` (two taps);
* ``"cubic"``: the 4-tap Lagrange polynomial through ``p_{i-1} ... p_{i+2}`` (Lagrange
  interpolation as a filter: Schafer & Rabiner 1973, "A digital signal processing approach
  to interpolation", Proc. IEEE 61(6), 692-702, §IV), written as
  ``c_0 + t (c_1 + t (c_2 + t c_3))`` with

  ``c_0 = p_i``, ``c_1 = -p_{i-1} / 3 - p_i / 2 + p_{i+1} - p_{i+2} / 6``,
  ``c_2 = (p_{i-1} + p_{i+1}) / 2 - p_i``,
  ``c_3 = (p_{i+2} - p_{i-1}) / 6 + (p_i - p_{i+1}) / 2``.                             (1)

The coefficients are computed once per bin (:func:`coefficients`, a pure function of array
arithmetic, so the NumPy sum and the packets the Dr.Jit kernels load use the same formula) and
evaluated by Horner's rule (:func:`horner`, with the caller's fused multiply-add). The kernels
load a bin's coefficients as one packet of float32 (:func:`kernel_packets`, :func:`lookup`):
16 bytes (linear) or 32 bytes (cubic) per lookup.

Error (docs/focusing.md, "Error budget"): a profile zero-padded U times is sampled U times
finer than its resolution, so a component ``exp(j 2 pi nu x)`` (x in bins) has ``|nu| <=
1 / (2 U)``. The Lagrange remainder ``f^(n)(xi) / n! prod (t - x_j)`` (the
remainder of Lagrange interpolation, ibid.) bounds the relative error of such a component by

  linear: ``(pi / U)^2 / 8`` (``max t (1 - t) = 1/4``, ``(2 pi nu)^2 / 2``);
  cubic: ``(pi / U)^4 * 3 / 128`` (``max |(t + 1) t (t - 1) (t - 2)| = 9 / 16`` at
  ``t = 1/2``, ``(2 pi nu)^4 / 24``),                                                    (2)

that is -46 dB (linear, 16x), -58 dB (linear, 32x), -65 dB (cubic, 8x), -89 dB (cubic, 16x)
at the band edge; the windowed echo holds little energy there, so an image's error is a few dB
lower (measured: linear 16x -48 dB, cubic 8x -71 dB).

Taps beyond the profile's ends are extrapolated linearly (``p_{-1} = 2 p_0 - p_1``,
``p_F = 2 p_{F-1} - p_{F-2}``), so every interval ``[i, i + 1]``, ``0 <= i <= F - 2``, has a
polynomial (the cubic is then the linear one's neighbour at the two end intervals only, which
the beat band's margin keeps lookups away from, :func:`mitsar.focus.bp_setup.beat_band`); a
periodic profile wraps around instead.
"""

from __future__ import annotations

from collections.abc import Callable
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.backend import array_namespace, namespace_of
from mitsar.backend import drjit as dr  # imported when a kernel runs (LazyModule)
from mitsar.errors import ParameterError

__all__ = ["DEFAULT_INTERPOLATION", "INTERPOLATIONS", "check_interpolation", "coefficients",
           "coefficient_table", "error_bound", "evaluate", "horner", "jit_packets",
           "kernel_packets", "lookup", "packet",
           "numpy_fma"]

INTERPOLATIONS = ("linear", "cubic")
"""Interpolations of the range profiles (module docstring)."""

DEFAULT_INTERPOLATION = "cubic"
"""Interpolation of every back-projection by default (with focus()'s 8x zero-padding: -71 dB
against a float64 reference on the benchmark image, docs/focusing.md, error budget)."""

TERMS = {"linear": 2, "cubic": 4}
"""Polynomial coefficients per bin (complex)."""


def check_interpolation(caller: str, interpolation: str) -> str:
    """``interpolation`` if it is one of :data:`INTERPOLATIONS`, else a ParameterError."""
    if interpolation not in INTERPOLATIONS:
        raise ParameterError(caller, "range_interpolation", f"one of {INTERPOLATIONS}",
                             interpolation)
    return interpolation


def numpy_fma(a: Any, b: Any, c: Any) -> Any:
    """``a b + c`` (NumPy's side of the fused multiply-add of :func:`horner`)."""
    return a * b + c


def coefficients(before: Any, low: Any, high: Any, after: Any, interpolation: str
                 ) -> tuple[Any, ...]:
    """Polynomial coefficients in the fraction t of the interval between ``low`` (t = 0) and
    ``high`` (t = 1), from the taps at t = -1, 0, 1, 2 (module eq. 1; linear uses two)."""
    if interpolation == "linear":
        return low, high - low
    return (low,
            high - before / 3 - low / 2 - after / 6,
            (before + high) / 2 - low,
            (after - before) / 6 + (low - high) / 2)


def horner(terms: tuple[Any, ...], fraction: Any, fma: Callable[[Any, Any, Any], Any]) -> Any:
    """``sum_n terms[n] fraction^n`` by Horner's rule (``fma(a, b, c) = a b + c``)."""
    value = terms[-1]
    for term in terms[-2::-1]:
        value = fma(value, fraction, term)
    return value


def error_bound(upsample: float, interpolation: str, shared: bool = False) -> float:
    """Largest relative error (module eq. 2) of a component at the band edge ``1 / (2 U)``.

    ``shared``: a cubic evaluated on ``t`` in [-1/2, 3/2) instead of [0, 1) (a lookup shared
    by neighbouring pixels, :mod:`mitsar.focus.bp_tiled`), where ``|(t + 1) t (t - 1) (t - 2)|
    <= 15 / 16`` (at both ends) instead of ``9 / 16``: 5/3 of the bound (+4.4 dB)."""
    x = np.pi / upsample
    if interpolation == "linear":
        return x ** 2 / 8
    return (5 if shared else 3) * x ** 4 / 128


def coefficient_table(profile: NDArray, interpolation: str, periodic: bool = False) -> NDArray:
    """Coefficients of every bin's interval, shape (..., F, terms), the profile's precision.

    Bin ``i`` holds the polynomial on ``[i, i + 1]`` along the last axis of ``profile``; taps
    past the ends extrapolated linearly, or wrapped when ``periodic`` (module docstring). The
    last bin of a non-periodic profile holds its extrapolated interval (never read).
    """
    profile = np.asarray(profile)
    if periodic:
        before, after = np.roll(profile, 1, -1), np.roll(profile, -2, -1)
        high = np.roll(profile, -1, -1)
    else:
        first = 2 * profile[..., :1] - profile[..., 1:2]
        last = 2 * profile[..., -1:] - profile[..., -2:-1]
        extended = np.concatenate([first, profile, last, 2 * last - profile[..., -1:]], -1)
        before, high, after = extended[..., :-3], extended[..., 2:-1], extended[..., 3:]
    return np.stack(coefficients(before, profile, high, after, interpolation), axis=-1)


def kernel_packets(profile: NDArray, interpolation: str) -> NDArray[np.float32]:
    """The coefficient table as float32, one packet of ``2 * terms`` floats per bin
    ((real, imaginary) of each coefficient in turn), flat: what :func:`lookup` reads.

    Computed in the profile's precision, rounded once."""
    profile = np.asarray(profile, dtype=np.complex64)
    *rows, bins = profile.shape
    if bins < 6:  # too short for the interior/ends split below
        table = coefficient_table(profile, interpolation)
        return np.ascontiguousarray(table, dtype=np.complex64).view(np.float32).ravel()
    out = np.empty((*rows, bins, TERMS[interpolation]), dtype=np.complex64)
    out[..., 0] = profile
    if interpolation == "linear":
        np.subtract(profile[..., 1:], profile[..., :-1], out=out[..., :-1, 1])
        out[..., -1, 1] = out[..., -2, 1]   # the extrapolated last interval (never read)
        return out.view(np.float32).ravel()
    # eq. (1) in single precision (rounding ~1e-7 of the profile) without full temporaries:
    # the interior bins 1 ... F-3 from slices, the two end intervals from coefficient_table
    before, low, high, after = (profile[..., :-3], profile[..., 1:-2], profile[..., 2:-1],
                                profile[..., 3:])
    inner = out[..., 1:-2, :]
    np.subtract(high, low * np.float32(0.5), out=inner[..., 1])
    inner[..., 1] -= before * np.float32(1 / 3)
    inner[..., 1] -= after * np.float32(1 / 6)
    np.add(before, high, out=inner[..., 2])
    inner[..., 2] *= np.float32(0.5)
    inner[..., 2] -= low
    np.subtract(after, before, out=inner[..., 3])
    inner[..., 3] *= np.float32(1 / 6)
    inner[..., 3] += (low - high) * np.float32(0.5)
    ends = coefficient_table(np.concatenate([profile[..., :3], profile[..., -3:]], -1),
                             interpolation)
    out[..., 0, :], out[..., -2:, :] = ends[..., 0, :], ends[..., -2:, :]
    return out.view(np.float32).ravel()


def jit_packets(profile: NDArray, interpolation: str, array: Callable) -> Any:
    """:func:`kernel_packets` as the Dr.Jit array :func:`lookup` reads: float32 (linear,
    one ``Array4f`` packet a bin), or 64-bit words of (real, imaginary) float32 (cubic, one
    ``Array4u64`` packet a bin). ``array(kind, values, dtype)`` makes an aligned Dr.Jit array
    (:func:`mitsar.focus.backprojection.jit_array`)."""
    packets = kernel_packets(profile, interpolation)
    jit = array_namespace()
    if interpolation == "linear":
        return array(jit.Float32, packets, np.float32)
    return array(jit.UInt64, packets.view(np.uint64), np.uint64)


def lookup(packets: Any, flat: Any, fraction: Any, active: Any, interpolation: str
           ) -> tuple[Any, Any]:
    """Real and imaginary parts of the profile at bin ``flat`` (a row-major index into the
    (sweep, bin) table of :func:`kernel_packets`) plus ``fraction`` (Dr.Jit, float32): one
    packet load (:func:`packet`), masked by ``active``, and :func:`evaluate`."""
    return evaluate(packet(packets, flat, active, interpolation), fraction)


def packet(packets: Any, flat: Any, active: Any, interpolation: str
           ) -> tuple[tuple[Any, ...], tuple[Any, ...]]:
    """The coefficients of bin ``flat`` (Dr.Jit): real parts and imaginary parts, each a tuple
    of ``TERMS[interpolation]`` float32 arrays; one 16-byte (linear) or 32-byte (cubic)
    packet load, zeros where ``active`` is false."""
    jit = namespace_of(packets)
    index = jit.UInt32(flat)
    if interpolation == "linear":
        taps = dr.gather(jit.Array4f, packets, index, active)
        return (taps[0], taps[2]), (taps[1], taps[3])
    words = dr.gather(jit.Array4u64, packets, index, active)   # one 32-byte packet
    real = [dr.reinterpret_array(jit.Float32, jit.UInt32(w)) for w in words]
    imag = [dr.reinterpret_array(jit.Float32, jit.UInt32(w >> 32)) for w in words]
    return tuple(real), tuple(imag)


def evaluate(coefficients: tuple[tuple[Any, ...], tuple[Any, ...]], fraction: Any
             ) -> tuple[Any, Any]:
    """Real and imaginary parts of a :func:`packet`'s polynomial at ``fraction`` (module eq. 1,
    :func:`horner`)."""
    real, imag = coefficients
    return horner(real, fraction, dr.fma), horner(imag, fraction, dr.fma)
