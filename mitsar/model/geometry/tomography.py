"""Elevation (tomographic) resolution of a stack of passes: closed forms and the array factor.

Passes flown at different positions across the line of sight form an aperture in *elevation*,
the direction ``e`` normal to the track and to the line of sight. Back-projecting every pass onto
the same voxels and summing them coherently (tomographic back-projection) focuses that aperture:
a voxel displaced by ``s`` along ``e`` from a point target sees, in pass ``n`` with
perpendicular position ``b_n`` (its offset along ``e``), the two-way phase
``4 pi b_n s / (lambda R)`` (first order in ``b_n / R`` and ``s / R``), so the response along
``e`` is the *array factor*

``AF(s) = (1/N) sum_n exp(-j 4 pi b_n s / (lambda R))``                                 (T1)

(Reigber & Moreira 2000, "First demonstration of airborne SAR tomography using multibaseline
L-band data", IEEE TGRS 38(5):2142-2152, eq. 3 and §II). A continuous aperture of length
``L_perp`` gives ``|AF| = |sinc(2 L_perp s / (lambda R))|``, whose Rayleigh resolution (first
null) is

``rho_e = lambda R / (2 L_perp)``                                                         (T2)

(Reigber & Moreira 2000, eq. 4) and whose -3 dB impulse-response width (the IRW of
:mod:`mitsar.quality.cuts`) is ``0.8859 rho_e``. A uniform stack of ``N`` passes spaced ``d``
across the line of sight samples that aperture: each pass stands for one cell ``d`` of it, so
``L_perp = N d`` (the span ``(N - 1) d`` plus one spacing), the first null of the Dirichlet
kernel ``sin(N x) / (N sin x)`` lies exactly at ``rho_e``, its -3 dB width tends to
``0.8859 rho_e`` (0.892 at N = 8, 0.8866 at N = 32) and grating lobes repeat every

``s_amb = lambda R / (2 d)``                                                              (T3)

(the stack's height of ambiguity; Reigber & Moreira 2000 §II). :func:`elevation_irw` evaluates
(T1) for any stack and returns its exact -3 dB width.
"""

from __future__ import annotations

import math

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError

__all__ = ["RECT_IRW_CELLS", "array_factor", "effective_aperture", "elevation_ambiguity",
           "elevation_irw", "elevation_resolution", "perpendicular_baselines"]

RECT_IRW_CELLS = 0.8859
"""-3 dB width of ``|sinc|`` in Rayleigh cells (continuous rect aperture; Cumming & Wong 2005
§2.6, as :mod:`mitsar.quality.cuts`)."""


def _positive(where: str, name: str, value: float, unit: str) -> float:
    value = float(value)
    if not (math.isfinite(value) and value > 0):
        raise ParameterError(where, name, f"a finite value > 0 {unit}", value)
    return value


def elevation_resolution(wavelength: float, slant_range: float,
                         perpendicular_baseline_span: float) -> float:
    """Rayleigh elevation resolution ``rho_e = lambda R / (2 L_perp)`` [m] (eq. T2).

    Parameters
    ----------
    wavelength : float
        Carrier wavelength ``lambda`` [m].
    slant_range : float
        Range ``R`` from the stack to the target [m].
    perpendicular_baseline_span : float
        Extent ``L_perp`` of the aperture across the line of sight [m]; for a uniform stack of
        N passes spaced d, ``N d`` (:func:`effective_aperture`; module docstring).

    Returns
    -------
    float
        ``rho_e`` [m]: first null of the elevation response; its -3 dB width is
        ``0.8859 rho_e`` for a continuous aperture (Reigber & Moreira 2000, eq. 4).
    """
    where = "elevation_resolution"
    wavelength = _positive(where, "wavelength", wavelength, "m")
    slant_range = _positive(where, "slant_range", slant_range, "m")
    span = _positive(where, "perpendicular_baseline_span", perpendicular_baseline_span, "m")
    return wavelength * slant_range / (2.0 * span)


def elevation_ambiguity(wavelength: float, slant_range: float, spacing: float) -> float:
    """Spacing of the elevation grating lobes ``lambda R / (2 d)`` [m] of a stack spaced
    ``d`` across the line of sight (eq. T3): the volume must be shorter than this along the
    elevation axis for the stack to be unambiguous."""
    where = "elevation_ambiguity"
    return (_positive(where, "wavelength", wavelength, "m")
            * _positive(where, "slant_range", slant_range, "m")
            / (2.0 * _positive(where, "spacing", spacing, "m")))


def _baselines(where: str, baselines: ArrayLike) -> NDArray[np.float64]:
    values = np.asarray(baselines, dtype=float)
    if values.ndim != 1 or values.size < 2 or not np.all(np.isfinite(values)) \
            or np.ptp(values) <= 0:
        raise ParameterError(where, "baselines", "perpendicular positions of >= 2 passes [m], "
                             "finite, not all equal", np.asarray(baselines).tolist())
    return values


def effective_aperture(baselines: ArrayLike) -> float:
    """Aperture length ``L_perp`` [m] a stack of passes samples: its span times ``N / (N-1)``.

    For a uniform stack of N passes spaced d this is ``N d``, the length whose rect aperture the
    stack samples (module docstring): eq. T2 with it puts the first null of the array factor
    exactly at ``rho_e``.

    Parameters
    ----------
    baselines : array_like, shape (N,)
        Perpendicular positions ``b_n`` of the passes [m] (:func:`perpendicular_baselines`).
    """
    values = _baselines("effective_aperture", baselines)
    return float(np.ptp(values) * values.size / (values.size - 1))


def array_factor(baselines: ArrayLike, wavelength: float, slant_range: float,
                 offsets: ArrayLike) -> NDArray[np.complex128]:
    """Normalised elevation response (eq. T1) of a stack at elevation offsets ``s`` [m].

    Parameters
    ----------
    baselines : array_like, shape (N,)
        Perpendicular positions ``b_n`` [m].
    wavelength, slant_range : float
        ``lambda`` and ``R`` [m].
    offsets : array_like
        Elevation offsets ``s`` from the target [m].

    Returns
    -------
    ndarray, complex, shape of ``offsets``
        ``(1/N) sum_n exp(-j 4 pi b_n s / (lambda R))`` (1 at ``s = 0``).
    """
    b = _baselines("array_factor", baselines)
    b = b - b.mean()
    s = np.asarray(offsets, dtype=float)
    scale = 4.0 * np.pi / (_positive("array_factor", "wavelength", wavelength, "m")
                           * _positive("array_factor", "slant_range", slant_range, "m"))
    return np.exp(-1j * scale * s[..., None] * b).mean(axis=-1)


def elevation_irw(baselines: ArrayLike, wavelength: float, slant_range: float) -> float:
    """Exact -3 dB width [m] of the stack's elevation response |AF|^2 (eq. T1).

    The half-power crossings either side of ``s = 0`` are bracketed on a grid of 1/64 of
    ``rho_e`` and refined by bisection to 1e-9 of ``rho_e``.

    Parameters
    ----------
    baselines : array_like, shape (N,)
        Perpendicular positions ``b_n`` [m].
    wavelength, slant_range : float
        ``lambda`` and ``R`` [m].

    Returns
    -------
    float
        IRW along the elevation axis [m]; ``0.8859 lambda R / (2 L_perp)`` for a continuous
        aperture, ``0.892`` of it for 8 uniform passes.
    """
    b = _baselines("elevation_irw", baselines)
    rho = elevation_resolution(wavelength, slant_range, effective_aperture(b))

    def power(s: NDArray) -> NDArray:
        return np.abs(array_factor(b, wavelength, slant_range, s)) ** 2

    widths = []
    for sign in (-1.0, 1.0):
        grid = sign * rho * np.arange(0, 4 * 64 + 1) / 64
        below = np.flatnonzero(power(grid) < 0.5)
        if below.size == 0:
            raise ParameterError("elevation_irw", "baselines", "a stack whose elevation "
                                 "response falls to half power within 4 cells", b.tolist())
        low, high = grid[below[0] - 1], grid[below[0]]
        for _ in range(60):
            middle = 0.5 * (low + high)
            if power(np.array([middle]))[0] >= 0.5:
                low = middle
            else:
                high = middle
        widths.append(abs(0.5 * (low + high)))
    return float(sum(widths))


def perpendicular_baselines(pass_positions: ArrayLike, target: ArrayLike,
                            along_track: ArrayLike) -> tuple[NDArray[np.float64],
                                                             NDArray[np.float64], float]:
    """Perpendicular positions of passes seen from a target, and the elevation axis.

    Parameters
    ----------
    pass_positions : array_like, shape (N, 3)
        Each pass's antenna position at its aperture centre for ``target`` [m].
    target : array_like, shape (3,)
        The point (e.g. the volume's centre) [m].
    along_track : array_like, shape (3,)
        The passes' common track direction.

    Returns
    -------
    baselines : ndarray, shape (N,)
        ``b_n = (p_n - p_mean) . e`` [m].
    elevation_axis : ndarray, shape (3,)
        ``e = (a x l) / |a x l|`` for the unit track direction ``a`` and the unit line of sight
        ``l`` from the mean pass position to the target, signed so that ``e_z >= 0``.
    slant_range : float
        ``|target - p_mean|`` [m].
    """
    positions = np.asarray(pass_positions, dtype=float)
    target = np.asarray(target, dtype=float)
    along = np.asarray(along_track, dtype=float)
    if positions.ndim != 2 or positions.shape[1] != 3 or not np.all(np.isfinite(positions)):
        raise ParameterError("perpendicular_baselines", "pass_positions", "shape (N, 3), finite",
                             positions.shape)
    mean = positions.mean(axis=0)
    sight = target - mean
    slant_range = float(np.linalg.norm(sight))
    axis = np.cross(along, sight / max(slant_range, 1e-12))
    norm = float(np.linalg.norm(axis))
    if not norm > 1e-9:
        raise ParameterError("perpendicular_baselines", "along_track", "a track direction not "
                             "along the line of sight", along.tolist())
    axis /= norm
    if axis[2] < 0 or (axis[2] == 0 and axis[1] < 0):
        axis = -axis
    return (positions - mean) @ axis, axis, slant_range
