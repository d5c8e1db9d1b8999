"""CFAR detection on 2-D and 3-D images: cell-averaging (CA) and ordered-statistic (OS).

Each cell under test (CUT) of the square-law detected power ``P = |x|^2`` is compared with a
threshold ``T = alpha Z`` set from the power of the *training cells* around it: a hollow box,
``guard`` cells on each side of the CUT left out (they hold the target's own main lobe) and
``training`` cells beyond them, in every dimension of the image. ``alpha`` follows from the
requested false-alarm probability ``pfa`` in closed form, under the assumption that the CUT and
the N training cells hold independent, identically distributed exponential powers (complex
Gaussian noise or clutter of one local mean power; docs/features.md §2):

* CA-CFAR: ``Z`` = sum of the training powers, ``Pfa = (1 + alpha/N)^-N``, so
  ``alpha = N (pfa^(-1/N) - 1)`` per mean training power (Finn & Johnson 1968; Richards 2005
  §6.5; docs/features.md eq. 2).
* OS-CFAR: ``Z`` = the k-th smallest training power, ``Pfa = k C(N,k) Gamma(alpha+N-k+1)
  Gamma(k) / Gamma(alpha+N+1)`` (Rohling 1983, docs/features.md eq. 3), solved for ``alpha``.

Near the image's edges a window holds fewer training cells: by default each cell is tested with
those inside the image, its own N (and for OS its own rank) in eqs. 2-3, so every cell keeps the
requested ``pfa``; ``edges="inside"`` tests only cells whose whole window fits. Everything is
vectorised: box sums by separable running filters (CA), a sliding rank with a footprint
(``scipy.ndimage.rank_filter``, OS).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray
from scipy import integrate, ndimage, optimize, special, stats

from mitsar import checks
from mitsar.errors import ParameterError

__all__ = ["DEFAULT_GUARD", "DEFAULT_TRAINING", "METHODS", "Window", "ca_threshold_factor",
           "cfar", "default_window", "detection_probability", "make_window", "os_false_alarm",
           "os_noise_scale", "os_threshold_factor", "os_threshold_factors"]

WHERE = "mitsar.detect"
METHODS = ("ca", "os")
EDGES = ("truncate", "inside")
DEFAULT_GUARD = 2
"""Guard cells on each side of the CUT, every dimension, when the image's resolution is not
known; otherwise the default guard is one resolution cell, ``ceil(rho_d / step_d)`` cells
(:func:`default_window`), so the target's main lobe stays out of the training cells."""
DEFAULT_TRAINING = 3
"""Fewest training cells beyond the guard on each side, every dimension (the default is the
larger of this and the guard: a training ring at least one resolution cell wide). With guard 2:
N = 11^2 - 5^2 = 96 cells in 2-D, 11^3 - 5^3 = 1206 in 3-D."""


@dataclass(frozen=True)
class Window:
    """The CFAR window: guard and training cells on each side of the CUT, per dimension.

    Parameters
    ----------
    guard, training : tuple of int
        Cells on each side of the CUT per image dimension (guard >= 0, training >= 0, and at
        least one training cell in all).
    """

    guard: tuple[int, ...]
    training: tuple[int, ...]

    @property
    def half(self) -> tuple[int, ...]:
        """Half-width of the whole window per dimension (guard + training), cells."""
        return tuple(g + t for g, t in zip(self.guard, self.training, strict=True))

    @property
    def footprint(self) -> NDArray[np.bool_]:
        """Boolean footprint of the training cells: the window less the guard box and CUT."""
        shape = tuple(2 * h + 1 for h in self.half)
        mask = np.ones(shape, dtype=bool)
        mask[tuple(slice(h - g, h + g + 1) for h, g in zip(self.half, self.guard,
                                                            strict=True))] = False
        return mask

    @property
    def cells(self) -> int:
        """Number N of training cells."""
        outer = math.prod(2 * h + 1 for h in self.half)
        return outer - math.prod(2 * g + 1 for g in self.guard)


def _per_dim(name: str, value: Any, ndim: int, minimum: int) -> tuple[int, ...]:
    values = np.atleast_1d(np.asarray(value, dtype=object))
    if values.size == 1:
        values = np.repeat(values, ndim)
    if values.ndim != 1 or values.size != ndim:
        raise ParameterError(WHERE, name, f"an integer >= {minimum} or {ndim} of them (one a "
                             "dimension)", value)
    expected = f"integers >= {minimum}, one a dimension or one for all"
    return tuple(checks.integer(WHERE, name, v, minimum, expected) for v in values)


def make_window(ndim: int, guard: Any = None, training: Any = None,
                default_guard: Any = DEFAULT_GUARD) -> Window:
    """A :class:`Window` from ``guard``/``training`` (int for every dimension or one per
    dimension). Defaults: ``default_guard`` (:func:`default_window`) and, per dimension, the
    larger of :data:`DEFAULT_TRAINING` and the guard."""
    guards = _per_dim("guard", default_guard if guard is None else guard, ndim, 0)
    trainings = (tuple(max(DEFAULT_TRAINING, g) for g in guards) if training is None
                 else _per_dim("training", training, ndim, 0))
    window = Window(guards, trainings)
    if window.cells < 1:
        raise ParameterError(WHERE, "training", "at least one training cell", training)
    return window


def default_window(resolution: NDArray[np.float64], spacing: NDArray[np.float64],
                   known: bool) -> tuple[int, ...] | int:
    """Default guard: one resolution cell each side, ``ceil(rho_d / step_d)`` cells (at least
    1), when the resolution is known; else :data:`DEFAULT_GUARD`."""
    if not known or not np.all(spacing > 0):
        return DEFAULT_GUARD
    return tuple(max(1, math.ceil(r / s - 1e-6)) for r, s in zip(resolution, spacing,
                                                                   strict=True))


def _check_pfa(pfa: Any) -> float:
    value = checks.finite(WHERE, "pfa", pfa, "a false-alarm probability in (0, 1)")
    if not 0.0 < value < 1.0:
        raise ParameterError(WHERE, "pfa", "a false-alarm probability in (0, 1)", pfa)
    return value


def ca_threshold_factor(pfa: float, cells: ArrayLike) -> NDArray[np.float64] | float:
    """CA-CFAR threshold factor per *mean* training power, docs/features.md eq. 2.

    ``alpha = N (pfa^(-1/N) - 1)`` from ``Pfa = (1 + alpha/N)^-N`` (Finn & Johnson 1968;
    Richards 2005 §6.5): iid exponential CUT and training powers.

    Parameters
    ----------
    pfa : float
        Requested false-alarm probability per cell, in (0, 1).
    cells : int or array_like of int
        Number N of training cells (per cell, where edges truncate the window).

    Returns
    -------
    float or ndarray
        ``alpha`` [1]: detect when ``P_CUT > alpha * mean(training powers)``.
    """
    cells = np.asarray(cells, dtype=float)
    alpha = cells * np.expm1(-math.log(pfa) / cells)
    return float(alpha) if alpha.ndim == 0 else alpha


def os_false_alarm(alpha: ArrayLike, cells: ArrayLike, rank: ArrayLike) -> NDArray[np.float64]:
    """OS-CFAR false-alarm probability, docs/features.md eq. 3 (Rohling 1983).

    ``Pfa = k C(N,k) Gamma(alpha+N-k+1) Gamma(k) / Gamma(alpha+N+1)`` for the threshold
    ``alpha X_(k)``, ``X_(k)`` the k-th smallest of N iid exponential training powers; in log
    form by ``gammaln``.

    Parameters
    ----------
    alpha : array_like
        Threshold factor(s) per k-th training power, >= 0.
    cells, rank : int or array_like of int
        N training cells and the rank k (1 <= k <= N), broadcast against ``alpha``.
    """
    alpha = np.asarray(alpha, dtype=float)
    n, k = np.asarray(cells, dtype=float), np.asarray(rank, dtype=float)
    log = (np.log(k) + special.gammaln(n + 1) - special.gammaln(k + 1)
           - special.gammaln(n - k + 1) + special.gammaln(alpha + n - k + 1)
           + special.gammaln(k) - special.gammaln(alpha + n + 1))
    return np.exp(log)


def os_threshold_factor(pfa: float, cells: int, rank: int) -> float:
    """The ``alpha`` of :func:`os_false_alarm` that gives ``pfa`` (Brent's method on the log).

    ``Pfa(alpha)`` falls monotonically from 1 at ``alpha = 0``; the bracket doubles until it
    holds the root.
    """
    def gap(alpha: float) -> float:
        return float(np.log(os_false_alarm(alpha, cells, rank)) - math.log(pfa))

    high = 1.0
    while gap(high) > 0.0:
        high *= 2.0
    return float(optimize.brentq(gap, 0.0, high, xtol=1e-12, rtol=1e-12))


def os_threshold_factors(pfa: float, cells: ArrayLike, rank: ArrayLike) -> NDArray[np.float64]:
    """:func:`os_threshold_factor` for arrays of (N, k) at once (bisection on ``log Pfa``, which
    falls monotonically in ``alpha``): the factors of cells whose window the image edge
    truncates."""
    cells, rank = np.broadcast_arrays(np.asarray(cells, float), np.asarray(rank, float))
    target = math.log(pfa)
    low, high = np.zeros(cells.shape), np.ones(cells.shape)
    while np.any(above := np.log(os_false_alarm(high, cells, rank)) > target):
        high = np.where(above, 2.0 * high, high)
    for _ in range(64):
        middle = 0.5 * (low + high)
        above = np.log(os_false_alarm(middle, cells, rank)) > target
        low, high = np.where(above, middle, low), np.where(above, high, middle)
    return 0.5 * (low + high)


def os_noise_scale(cells: ArrayLike, rank: ArrayLike) -> NDArray[np.float64] | float:
    """Mean of the k-th smallest of N unit-mean exponentials, ``H_N - H_(N-k)`` (harmonic
    numbers, as ``psi(N+1) - psi(N-k+1)``; docs/features.md eq. 4): ``X_(k)`` over this is
    OS-CFAR's mean-power estimate."""
    cells, rank = np.asarray(cells, float), np.asarray(rank, float)
    scale = special.digamma(cells + 1.0) - special.digamma(cells - rank + 1.0)
    return float(scale) if scale.ndim == 0 else scale


def _default_rank(cells: int) -> int:
    """Rohling's choice k = 3N/4 (rounded, at least 1)."""
    return max(1, round(0.75 * cells))


def detection_probability(snr: ArrayLike, pfa: float, method: str = "ideal", cells: int = 0,
                          rank: int | None = None) -> NDArray[np.float64]:
    """Detection probability of a non-fluctuating (Swerling 0) target, docs/features.md §4.

    With known noise power the square-law detector with normalised threshold ``T = -ln pfa``
    detects with ``Pd = Q1(sqrt(2 SNR), sqrt(2 T))`` (Marcum Q; Richards 2005 ch. 6), evaluated
    as the survival function of a non-central chi-square with 2 degrees of freedom. A CFAR
    detector's threshold is random: ``Pd`` is that expression averaged over the distribution
    of the noise estimate (Gamma(N) sum for CA, the k-th order statistic for OS; Gandhi &
    Kassam 1988), integrated numerically.

    Parameters
    ----------
    snr : array_like
        Signal-to-noise power ratio of the target in its cell (linear).
    pfa : float
        False-alarm probability.
    method : {"ideal", "ca", "os"}
        Known noise, cell-averaging or ordered-statistic CFAR.
    cells : int
        N training cells (CA, OS).
    rank : int, optional
        k (OS); default ``round(3N/4)``.

    Returns
    -------
    ndarray
        Pd per SNR.
    """
    snr = np.atleast_1d(np.asarray(snr, dtype=float))

    def marcum(threshold: float) -> NDArray[np.float64]:  # threshold per unit noise power
        return stats.ncx2.sf(2.0 * threshold, 2, 2.0 * snr)

    if method == "ideal":
        return marcum(-math.log(pfa))
    if method == "ca":
        alpha = ca_threshold_factor(pfa, cells) / cells  # per summed training power
        density = stats.gamma(cells).pdf
    elif method == "os":
        rank = _default_rank(cells) if rank is None else rank
        alpha = os_threshold_factor(pfa, cells, rank)
        log_c = (math.log(rank) + special.gammaln(cells + 1) - special.gammaln(rank + 1)
                 - special.gammaln(cells - rank + 1))

        def density(z: float) -> float:  # pdf of the k-th of N unit exponentials
            return math.exp(log_c + (rank - 1) * math.log(-math.expm1(-z))
                            - z * (cells - rank + 1)) if z > 0 else 0.0
    else:
        raise ParameterError(WHERE, "method", "'ideal', 'ca' or 'os'", method)
    return np.array([integrate.quad(
        lambda z, s=s: density(z) * stats.ncx2.sf(2.0 * alpha * z, 2, 2.0 * s),
        0.0, np.inf, limit=200)[0] for s in snr])


def _ring_sum(values: NDArray[np.float64], window: Window) -> NDArray[np.float64]:
    """Sum of ``values`` over each cell's training cells, zero outside the array: the window's
    box sum less the guard box's (separable running sums, ``scipy.ndimage.uniform_filter``)."""
    outer = tuple(2 * h + 1 for h in window.half)
    core = tuple(2 * g + 1 for g in window.guard)
    return (ndimage.uniform_filter(values, outer, mode="constant") * math.prod(outer)
            - ndimage.uniform_filter(values, core, mode="constant") * math.prod(core))


GOLDEN = (math.sqrt(5.0) - 1.0) / 2.0


def _ordered_statistic(power: NDArray[np.float64], window: Window, rank: int) -> tuple[
        NDArray[np.float64], NDArray[np.float64], NDArray[np.float64]]:
    """k-th smallest training power of every cell, with the image's edges truncating windows.

    The image is padded by the window's half-width; a fraction ``k/N`` of the padding cells
    (a low-discrepancy pattern) holds ``-inf`` and the rest ``+inf``. A cell with ``n`` training
    cells inside the image and ``m`` ``-inf`` ones in its window gets from one
    ``rank_filter(k)`` the ``(k - m)``-th smallest of its ``n`` real training powers, about
    ``k n / N``: OS-CFAR with its own (n, k - m) (docs/features.md §3).

    Returns
    -------
    tuple of ndarray
        The order statistic (``±inf`` where k - m is outside 1..n), n and k - m per cell.
    """
    pad = [(h, h) for h in window.half]
    outside = np.pad(np.zeros(power.shape, dtype=bool), pad, constant_values=True)
    low = outside & ((np.arange(outside.size).reshape(outside.shape) * GOLDEN) % 1.0
                     < rank / window.cells)
    padded = np.where(low, -np.inf, np.where(outside, np.inf, np.pad(power, pad)))
    inner = tuple(slice(h, h + size) for h, size in zip(window.half, power.shape, strict=True))
    ordered = ndimage.rank_filter(padded, rank - 1, footprint=window.footprint,
                                  mode="nearest")[inner]
    below = np.rint(_ring_sum(low.astype(float), window))[inner]
    counts = np.rint(_ring_sum(np.ones(power.shape), window))
    return ordered, counts, rank - below


def _spatial_dims(image: xr.Dataset) -> tuple[str, ...]:
    if "image" not in image.variables:
        raise ParameterError(WHERE, "image", "an image product (variable 'image') or an array",
                             f"variables {sorted(map(str, image.variables))}")
    dims = tuple(str(d) for d in image["image"].dims)
    extra = [d for d in dims if d in ("channel", "pass")]
    if extra:
        raise ParameterError(WHERE, "image", "one complex image per detection: select a "
                             f"channel or pass first (e.g. image.isel({extra[0]}=0))",
                             f"dims {dims}")
    if len(dims) not in (2, 3):
        raise ParameterError(WHERE, "image", "a 2-D or 3-D image", f"dims {dims}")
    return dims


def _positions(image: xr.Dataset, dims: tuple[str, ...]) -> NDArray[np.float64]:
    """World position of every pixel [m], shape image + (3,): the ``position`` variable, or the
    coordinates of dims named x, y, z (a volume), or index coordinates."""
    if "position" in image.variables:
        return np.asarray(image["position"].transpose(*dims, "xyz").values, dtype=float)
    shape = image["image"].shape
    out = np.zeros(shape + (3,))
    world = dict(zip("xyz", range(3), strict=True))
    for axis, dim in enumerate(dims):
        values = (np.asarray(image[dim].values, dtype=float) if dim in image.coords
                  else np.arange(shape[axis], dtype=float))
        column = world.get(dim, axis)
        out[..., column] += values.reshape([-1 if a == axis else 1 for a in range(len(dims))])
    return out


def _axes(position: NDArray[np.float64]) -> tuple[NDArray[np.float64], NDArray[np.float64]]:
    """Mean world step vector per image dim (rows, [m]) and its length [m]."""
    steps = np.array([np.diff(position, axis=a).reshape(-1, 3).mean(axis=0)
                      for a in range(position.ndim - 1)])
    return steps, np.linalg.norm(steps, axis=1)


def _resolution(image: xr.Dataset, ndim: int, steps: NDArray[np.float64],
                resolution: Any) -> tuple[NDArray[np.float64], str]:
    """Resolution cell along each image dim [m] and where it came from (docs/features.md §5).

    Given; or a ``resolution`` attribute (one value a dim); or the image's ``{p}_resolution``
    along ``{p}_axis`` for p in range, azimuth (axes in the image's dim order, as
    ``mitsar.focus`` writes them) and elevation (``elevation_axis`` in world xyz, as a
    multi-pass volume writes it): ``rho_d = sqrt(sum_p (rho_p (w_p . e_d))^2)`` with ``w_p``
    the world direction of axis p and ``e_d`` the world unit step of dim d; else the pixel
    step. ``steps`` holds the world step vector of each dim (rows, [m]).
    """
    spacing = np.linalg.norm(steps, axis=1)
    if resolution is not None:
        values = np.atleast_1d(np.asarray(resolution, dtype=float))
        if values.size == 1:
            values = np.repeat(values, ndim)
        if values.shape != (ndim,) or not np.all(np.isfinite(values) & (values > 0)):
            raise ParameterError(WHERE, "resolution", f"a resolution > 0 m, or {ndim} of them",
                                 resolution)
        return values, "given"
    attrs = image.attrs
    if "resolution" in attrs and np.size(attrs["resolution"]) == ndim:
        return np.asarray(attrs["resolution"], dtype=float).reshape(ndim), "image attrs"
    units = steps / np.where(spacing > 0, spacing, 1.0)[:, None]
    cells, names = [], []
    for name in ("range", "azimuth", "elevation"):
        if f"{name}_resolution" not in attrs or f"{name}_axis" not in attrs:
            continue
        axis = np.ravel(np.asarray(attrs[f"{name}_axis"], dtype=float))
        world = axis @ units if name != "elevation" and axis.size == ndim else axis
        if world.size == 3 and np.linalg.norm(world) > 0:
            cells.append(float(attrs[f"{name}_resolution"]) * (units @ world)
                         / np.linalg.norm(world))
            names.append(name)
    if len(cells) >= 2:
        return (np.sqrt(np.sum(np.square(cells), axis=0)),
                "image " + "/".join(names) + " resolution")
    return np.where(spacing > 0, spacing, 1.0), "pixel step"


def _as_dataset(image: Any) -> xr.Dataset:
    if isinstance(image, xr.Dataset):
        return image
    if isinstance(image, xr.DataArray):
        return xr.Dataset({"image": image})
    array = np.asarray(image)
    if not np.issubdtype(array.dtype, np.number):
        raise ParameterError(WHERE, "image", "an image product or a numeric array",
                             type(image).__name__)
    return xr.Dataset({"image": ([f"dim_{a}" for a in range(array.ndim)], array)})


def cfar(image: Any, pfa: float = 1e-6, method: str = "ca", guard: Any = None,
         training: Any = None, rank: int | None = None, resolution: Any = None,
         edges: str = "truncate") -> xr.Dataset:
    """CFAR test of every cell of a 2-D or 3-D image (module docstring).

    Parameters
    ----------
    image : xarray.Dataset, xarray.DataArray or array_like
        An image product of :func:`mitsar.focus` (variable ``image``, complex, 2 or 3 dims; world
        positions from its ``position`` variable, or from coordinates named x, y, z), or a plain
        complex (or real amplitude) array, whose positions are then its indices.
    pfa : float
        False-alarm probability per tested cell, in (0, 1).
    method : {"ca", "os"}
        Cell-averaging or ordered-statistic CFAR.
    guard, training : int or sequence of int, optional
        Guard and training cells on each side of the CUT, one for all dims or one a dim.
        Default guard: one resolution cell, ``ceil(rho_d / step_d)``, where the image says its
        resolution, else :data:`DEFAULT_GUARD`; default training: the larger of
        :data:`DEFAULT_TRAINING` and the guard (docs/features.md §2).
    rank : int, optional
        OS-CFAR's k (1..N): the k-th smallest training power sets the threshold; default
        ``round(3N/4)`` (Rohling 1983).
    resolution : float or sequence of float, optional
        Resolution cell along each image dim [m], for the position uncertainty; default from the
        image (:func:`_resolution`).
    edges : {"truncate", "inside"}
        Near the image's edges: test with the training cells inside the image (N and, for OS,
        k per cell, thresholds from eqs. 2-3 for them; docs/features.md §2), or test only cells
        whose whole window fits.

    Returns
    -------
    xarray.Dataset
        On the image's dims: ``power`` (``|x|^2``), ``noise`` (mean noise power estimated from
        the training cells; NaN where untested), ``threshold``, ``detected`` and ``tested``
        (bool), ``training_cells`` (N of each cell), ``position`` (dims + xyz) [m]; attributes:
        the parameters, ``cells`` and ``alpha`` (N and the factor of a whole window),
        ``resolution`` and ``axes`` (world unit vector of each dim).

    Raises
    ------
    ParameterError
        ``pfa`` outside (0, 1), an unknown ``method``, a bad window or ``rank``, an image with
        neither 2 nor 3 spatial dims, or a window larger than the image.
    """
    pfa = _check_pfa(pfa)
    if method not in METHODS:
        raise ParameterError(WHERE, "method", "'ca' (cell-averaging) or 'os' (ordered-statistic)",
                             method)
    if edges not in EDGES:
        raise ParameterError(WHERE, "edges", "'truncate' or 'inside'", edges)
    data = _as_dataset(image)
    dims = _spatial_dims(data)
    values = np.asarray(data["image"].transpose(*dims).values)
    power = np.square(np.abs(values)).astype(float)
    finite = np.isfinite(power)  # NaN/inf pixels: not tested, zero power as training cells
    power = np.where(finite, power, 0.0)
    position = _positions(data, dims)
    steps, spacing = _axes(position)
    cell, source = _resolution(data, len(dims), steps, resolution)
    window = make_window(len(dims), guard, training,
                         default_window(cell, spacing, source != "pixel step"))
    if any(2 * h + 1 > s for h, s in zip(window.half, power.shape, strict=True)):
        raise ParameterError(WHERE, "guard/training", f"a window (2 (guard + training) + 1 = "
                             f"{tuple(2 * h + 1 for h in window.half)} cells) no larger than "
                             "the image", f"image shape {power.shape}")
    n = window.cells
    if method == "ca":
        rank_used = None
        counts = np.rint(_ring_sum(np.ones(power.shape), window))
        tested = counts >= (n if edges == "inside" else 1)
        counts = np.where(tested, counts, n)
        noise = np.maximum(_ring_sum(power, window), 0.0) / counts
        threshold = ca_threshold_factor(pfa, counts) * noise
    else:
        rank_used = _default_rank(n) if rank is None else checks.integer(
            WHERE, "rank", rank, 1, f"an integer in [1, N = {n}]")
        if rank_used > n:
            raise ParameterError(WHERE, "rank", f"an integer in [1, N = {n}]", rank)
        ordered, counts, ranks = _ordered_statistic(power, window, rank_used)
        tested = (ranks >= 1) & (ranks <= counts) & ((counts == n) | (edges == "truncate"))
        counts, ranks = np.where(tested, counts, n), np.where(tested, ranks, rank_used)
        pairs, inverse = np.unique(np.stack([counts.ravel(), ranks.ravel()]), axis=1,
                                   return_inverse=True)
        alphas = os_threshold_factors(pfa, pairs[0], pairs[1])[inverse.ravel()]
        threshold = alphas.reshape(power.shape) * np.where(tested, ordered, 0.0)
        noise = np.where(tested, ordered, 0.0) / os_noise_scale(counts, ranks)
    alpha = (ca_threshold_factor(pfa, n) if method == "ca"
             else os_threshold_factor(pfa, n, rank_used))
    tested &= finite
    noise = np.where(tested, noise, np.nan)
    threshold = np.where(tested, threshold, np.nan)
    detected = tested & (power > threshold)
    axes = steps / np.where(spacing > 0, spacing, 1.0)[:, None]
    coords = {d: data[d] for d in dims if d in data.coords}
    out = xr.Dataset(
        {"power": (dims, power, {"units": "1", "long_name": "square-law detected power |x|^2"}),
         "noise": (dims, noise, {"units": "1", "long_name":
                                 "mean noise power estimated from the training cells"}),
         "threshold": (dims, threshold, {"units": "1", "long_name": "CFAR threshold on power"}),
         "detected": (dims, detected, {"long_name": "cell above the CFAR threshold"}),
         "tested": (dims, tested, {"long_name": "cell tested (its training cells suffice)"}),
         "training_cells": (dims, np.where(tested, counts, 0).astype(int), {
             "units": "1", "long_name": "training cells inside the image"}),
         "position": (dims + ("xyz",), position, {"units": "m", "long_name":
                                                  "world position of the cell"})},
        coords={**coords, "xyz": ["x", "y", "z"]})
    out.attrs.update(
        product="cfar", method=method, pfa=pfa, guard=list(window.guard),
        training=list(window.training), cells=n, alpha=alpha, edges=edges,
        rank=-1 if rank_used is None else rank_used, resolution=cell.tolist(),
        resolution_source=source, axes=axes.ravel().tolist(), dims=list(dims))
    return out
