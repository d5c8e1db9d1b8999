"""Phase unwrapping with SNAPHU, and tying the relative result to the reference surface.

SNAPHU (Chen & Zebker 2001: statistical-cost network-flow unwrapping; PyPI ``snaphu``,
isce-framework's wrapper) returns an unwrapped phase defined up to a multiple of 2 pi per
connected component. :func:`tie_to_reference` fixes that multiple so that the unwrapped phase
equals the wrapped phase at one reference pixel of each component: the scatterer there is taken
to lie within half an ambiguity height of the reference surface (flat phase in (-pi, pi]).
docs/interferometry.md §5.
"""

from __future__ import annotations

from collections.abc import Mapping
from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import MitsarError, ParameterError

try:  # a declared dependency; without it only unwrap=False works, with a clear error otherwise
    import snaphu
except ImportError:  # pragma: no cover - depends on the environment
    snaphu = None

__all__ = ["UnwrappingError", "tie_to_reference", "unwrap"]

_COSTS = ("smooth", "defo")
_INITS = ("mcf", "mst")


class UnwrappingError(MitsarError):
    """SNAPHU is not installed, or it failed on the interferogram."""


def unwrap(interferogram: ArrayLike, coherence: ArrayLike, looks: float, *,
           mask: ArrayLike | None = None, cost: str = "smooth", init: str = "mcf",
           options: Mapping[str, Any] | None = None
           ) -> tuple[NDArray[np.float64], NDArray[np.int64]]:
    """Unwrap a 2-D interferogram with SNAPHU (Chen & Zebker 2001).

    Parameters
    ----------
    interferogram : array_like of complex, shape (M, N)
        Interferogram (its phase is unwrapped) [1]; NaN is taken as masked.
    coherence : array_like, shape (M, N)
        Coherence magnitude in [0, 1] [1]; NaN is taken as 0.
    looks : float
        Equivalent number of independent looks of the coherence estimate [1].
    mask : array_like of bool, shape (M, N), optional
        True where a pixel is invalid (SNAPHU's mask is the opposite: valid pixels).
    cost : {"smooth", "defo"}
        SNAPHU's statistical cost mode ("smooth": topography without deformation).
    init : {"mcf", "mst"}
        SNAPHU's initialisation.
    options : mapping, optional
        Further keywords of ``snaphu.unwrap``, passed through: tiling (``ntiles``,
        ``tile_overlap``, ``nproc``, ``tile_cost_thresh``, ``min_region_size``, ...),
        ``min_conncomp_frac``, ``phase_grad_window``, ``scratchdir``.

    Returns
    -------
    unwrapped : ndarray, shape (M, N)
        Unwrapped phase [rad], NaN where masked; relative (:func:`tie_to_reference`);
        congruent to the wrapped phase in float64 (SNAPHU's cycle counts, its float32 phase
        not kept).
    components : ndarray of int, shape (M, N)
        SNAPHU's connected-component labels (0: in no component).

    Raises
    ------
    UnwrappingError
        If ``snaphu`` is not installed or fails.
    """
    if snaphu is None:
        raise UnwrappingError("interferometry.unwrap: the 'snaphu' package is not installed; "
                              "install it (pip install 'snaphu>=0.4') or call "
                              "interferogram(..., unwrap=False)")
    igram = np.asarray(interferogram)
    corr = np.asarray(coherence, float)
    if igram.ndim != 2 or corr.shape != igram.shape:
        raise ParameterError("unwrap", "coherence", f"2-D arrays of one shape {igram.shape}",
                             corr.shape)
    if cost not in _COSTS:
        raise ParameterError("unwrap", "cost", f"one of {_COSTS}", cost)
    if init not in _INITS:
        raise ParameterError("unwrap", "init", f"one of {_INITS}", init)
    if not np.isfinite(looks) or looks < 1:
        raise ParameterError("unwrap", "looks", "a number of looks >= 1", looks)
    invalid = ~np.isfinite(igram) | ~np.isfinite(corr)
    if mask is not None:
        invalid |= np.asarray(mask, bool)
    if invalid.all():
        raise UnwrappingError("interferometry.unwrap: every pixel is masked (zero amplitude, "
                              "NaN or the given mask); nothing to unwrap")
    igram = np.where(invalid, 0, igram).astype(np.complex64)
    corr = np.where(invalid, 0, np.clip(np.nan_to_num(corr), 0, 1)).astype(np.float32)
    try:
        unw, comp = snaphu.unwrap(igram, corr, nlooks=float(looks), cost=cost, init=init,
                                  mask=(~invalid).astype(np.uint8), **dict(options or {}))
    except Exception as exc:  # noqa: BLE001 - SNAPHU reports failures of many kinds
        raise UnwrappingError(f"interferometry.unwrap: SNAPHU failed on a {igram.shape} "
                              f"interferogram ({type(exc).__name__}: {exc}); check the mask "
                              "and coherence, or pass tiling options (options={'ntiles': "
                              "(2, 2), 'tile_overlap': 16})") from exc
    # SNAPHU works in float32: keep its cycle count, take the phase itself in float64
    wrapped = np.angle(np.asarray(interferogram))
    cycles = np.round((np.asarray(unw, float) - wrapped) / (2 * np.pi))
    unwrapped = np.where(invalid, np.nan, wrapped + 2 * np.pi * cycles)
    return unwrapped, np.asarray(comp, np.int64)


def tie_to_reference(unwrapped: ArrayLike, wrapped: ArrayLike, components: ArrayLike,
                     quality: ArrayLike, reference: tuple[int, int] | None = None
                     ) -> NDArray[np.float64]:
    """Shift each connected component by 2 pi k so it equals the wrapped phase at its reference.

    The reference pixel of a component is ``reference`` for the component holding it, otherwise
    the component's pixel of highest ``quality`` (coherence). Pixels in no component (label 0)
    are tied together as one more component.

    Parameters
    ----------
    unwrapped : array_like, shape (M, N)
        Relative unwrapped phase [rad].
    wrapped : array_like, shape (M, N)
        Wrapped phase in (-pi, pi] [rad].
    components : array_like of int, shape (M, N)
        Connected-component labels.
    quality : array_like, shape (M, N)
        Coherence [1] (NaN: never a reference).
    reference : (int, int), optional
        A reference pixel (row, col) of the grid.

    Returns
    -------
    ndarray, shape (M, N)
        The unwrapped phase tied to the reference surface [rad].
    """
    unw = np.array(unwrapped, float)
    wrap = np.asarray(wrapped, float)
    labels = np.asarray(components)
    score = np.where(np.isfinite(unw) & np.isfinite(wrap),
                     np.nan_to_num(np.asarray(quality, float), nan=-1.0), -np.inf)
    if reference is not None:
        row, col = (int(i) for i in reference)
        if not (0 <= row < unw.shape[0] and 0 <= col < unw.shape[1]) \
                or not np.isfinite(unw[row, col]):
            raise ParameterError("interferogram", "reference_pixel",
                                 f"a valid (row, col) pixel of the {unw.shape} grid", reference)
        score = score.copy()
        score[row, col] = np.inf
    for label in np.unique(labels):  # one shift per component (a handful), not per pixel
        inside = labels == label
        best = np.argmax(np.where(inside, score, -np.inf))
        if not np.isfinite(unw.flat[best]):
            continue
        cycles = np.round((unw.flat[best] - wrap.flat[best]) / (2 * np.pi))
        unw[inside] -= 2 * np.pi * cycles
    return unw
