"""Azimuth lines through bright scatterers: phase histories and their line images, any track.

PGA's image-domain steps (Wahl et al. 1994: centre the brightest pixel of a range line, window,
transform back to the phase history) need an azimuth Fourier transform, which back-projection on
a curved track does not have. This module builds its equivalent from the BP geometry
(:mod:`mitsar.focus.autofocus.contributions`):

* the phase history of a scatterer at x_p is ``h_k = w_k c_k(x_p)`` over the sweeps whose beam
  holds it (``w_k``: 0/1 by default);
* the line is ``x_p + delta_q a_p`` along the scatterer's azimuth direction a_p
  (:func:`azimuth_directions`); moving a point by delta along a_p changes its two-way carrier
  phase by ``4 pi delta u_k / lambda`` to first order, ``u_k = a_p . l_k(x_p)`` the direction
  sine of sweep k's line of sight (the far-field, polar-format approximation PGA itself makes);
* so the line image is the non-uniform Fourier transform ``I_p(q) = sum_k D_kpq h_k`` with
  ``D_kpq = exp(-j 4 pi delta_q u_k(p) / lambda)``, sampled at ``rho / oversample``
  (``rho = lambda / (2 du)``, du the span of u_k) over the extent the sweep spacing resolves
  without aliasing, ``lambda / (2 max |du/dk|)``: one period, as PGA's azimuth FFT, and
  ``D^H D ~ Q`` (Q points) for the near-uniform u_k of a smooth track.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from numpy.typing import NDArray

from mitsar.focus.aperture import aperture_half_width
from mitsar.focus.autofocus.contributions import (
    PulseData,
    aperture_weights,
    azimuth_directions,
    contributions,
)

__all__ = ["AzimuthLines", "azimuth_lines"]


@dataclass(frozen=True)
class AzimuthLines:
    """Phase histories and line-image kernels of P scatterers (module docstring).

    Attributes
    ----------
    history : ndarray, shape (S, P), complex
        ``h_k = w_k c_k(x_p)``.
    kernel : ndarray, shape (S, P, Q), complex
        ``D_kpq``; the line images are ``einsum("kpq,kp->pq", kernel, history)``.
    covered : ndarray, shape (S, P)
        1 where sweep k holds scatterer p, else 0.
    offsets : ndarray, shape (P, Q)
        ``delta_q`` along each line [m].
    oversample : int
        Line points per resolution cell.
    """

    history: NDArray
    kernel: NDArray
    covered: NDArray
    offsets: NDArray
    oversample: int

    @property
    def coverage(self) -> NDArray:
        """1 for the sweeps that hold at least one scatterer, else 0, shape (S,)."""
        return self.covered.any(axis=1).astype(float)

    def images(self, phase: NDArray) -> NDArray:
        """Line images ``I_p(q)`` after correcting sweep k by ``exp(-j phase_k)``, (P, Q)."""
        return np.einsum("kpq,kp->pq", self.kernel, self.history * np.exp(-1j * phase)[:, None])


def direction_sines(data: PulseData, points: NDArray, direction: NDArray) -> NDArray:
    """``u_k(p) = a_p . l_k(x_p)``, shape (S, P); ``l_k``: unit vector antenna -> point."""
    sight = points[None, :, :] - data.positions[:, None, :]
    sight /= np.linalg.norm(sight, axis=-1, keepdims=True)
    return np.einsum("spi,pi->sp", sight, direction)


def azimuth_lines(data: PulseData, points: NDArray, *, aperture: str = "beam",
                  oversample: int = 2, line_cells: float | None = None,
                  max_elements: int = 1 << 23) -> AzimuthLines:
    """Build the lines through ``points`` (module docstring).

    Parameters
    ----------
    data : PulseData
    points : ndarray, shape (P, 3)
        Scatterer positions [m], brightest first; points no sweep holds are dropped, and the
        last ones when ``S P Q`` would exceed ``max_elements`` (memory: 16 bytes each).
    aperture : {"beam", "processed"}
        Sweeps of a phase history: all sweeps whose beam (to its first nulls) holds the point,
        or the focuser's processed aperture.
    oversample : int
        Line points per resolution cell.
    line_cells : float, optional
        Half length of the lines in resolution cells; default (and at most) half the alias-free
        extent.
    """
    points = np.asarray(points, dtype=float).reshape(-1, 3)
    beam = aperture_half_width(data.radar, None) if aperture == "beam" else None
    weight = aperture_weights(data, points, half_width=beam, window="rect")
    keep = weight.any(axis=0)
    points, weight = points[keep], weight[:, keep]
    direction = azimuth_directions(data, points, weight)
    sine = direction_sines(data, points, direction)
    wavelength = data.radar.wavelength
    used = weight > 0
    span = np.where(used, sine, -np.inf).max(axis=0) - np.where(used, sine, np.inf).min(axis=0)
    fine = wavelength / (2 * np.maximum(span, 1e-12)) / oversample
    step = np.abs(np.diff(sine, axis=0)).max(axis=0) if len(sine) > 1 else span
    alias_half = wavelength / (4 * np.maximum(step, 1e-12))
    if line_cells is None:
        half_points = int(np.ceil(np.max(alias_half / fine)))
    else:
        half_points = int(np.ceil(line_cells * oversample))
    spacing = np.minimum(fine, alias_half / half_points)
    offsets = spacing[:, None] * np.arange(-half_points, half_points + 1)[None, :]
    count = max(1, min(len(points), max_elements // (len(sine) * offsets.shape[1])))
    points, weight, sine, offsets = points[:count], weight[:, :count], sine[:, :count], \
        offsets[:count]
    kernel = np.exp(-4j * np.pi / wavelength * sine[:, :, None] * offsets[None, :, :])
    return AzimuthLines(contributions(data, points) * weight, kernel, used[:, :count].astype(
        float), offsets, oversample)
