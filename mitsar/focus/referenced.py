"""Focusing of recorded data referenced to a scene point (from :mod:`mitsar.raw.recorded`).

Such a product (it has ``reference_range``) holds, per row k, samples of the scene's frequency
response motion-compensated to a reference range ``R_ref,k``, stop-and-go. Steps of
:func:`focus_referenced`:

1. choose the rows: all of them, or, for an azimuth resolution rho, those whose line of sight
   from the grid centre lies within ``+- lambda / (4 rho)`` of the middle row's;
2. resolve the grid with the nominal resolution ``lambda / (2 dtheta)`` of the rows used
   (:func:`mitsar.focus.aperture.aperture_resolution`);
3. range-compress without RVP removal (the recording has none) on a zero-padded FFT;
4. back-project at ``tau = 2 (R - R_ref,k) / c`` with the azimuth window over the rows
   (:func:`mitsar.focus.backprojection.backproject_referenced`), normalised by the sum of
   weights, so a point of amplitude A focuses to about A.
"""

from __future__ import annotations

from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.focus.aperture import aperture_resolution
from mitsar.focus.backprojection import backproject_referenced
from mitsar.focus.compression import range_spectrum
from mitsar.focus.interpolation import DEFAULT_INTERPOLATION
from mitsar.focus.windows import evaluate_window, window_coefficients
from mitsar.products.raw import radar_of

__all__ = ["focus_referenced"]


def focus_referenced(raw: xr.Dataset, grid: Any, *, azimuth_resolution: float | None,
                     window: str, range_window: str, range_upsample: int = 8,
                     range_interpolation: str = DEFAULT_INTERPOLATION
                     ) -> tuple[NDArray, dict, dict]:
    """Back-project a referenced raw product (:func:`raw_from_arrays`) onto a grid.

    The aperture is the recorded one, or, with ``azimuth_resolution`` rho, the rows whose line
    of sight from the grid centre lies within ``+- lambda / (4 rho)`` of the middle row's; the
    azimuth ``window`` runs over the rows used, and the image is normalised by the sum of
    weights, so a point of amplitude A focuses to about A. The nominal azimuth resolution of
    the image (its azimuth cell) is ``lambda / (2 dtheta)`` of the rows used.

    Returns
    -------
    image : ndarray (grid shape)
    layout : dict
        The resolved grid.
    processing : dict
        Extra attributes of the image product.
    """
    radar = radar_of(raw)
    positions = np.asarray(raw["platform_position"].values, float)
    sweeps = len(positions)
    centre = grid.resolve(raw, radar, 1.0)["position"]
    centre = centre.reshape(-1, 3).mean(axis=0)
    rows = np.arange(sweeps)
    if azimuth_resolution is not None:
        sight = positions - centre
        sight /= np.linalg.norm(sight, axis=1, keepdims=True)
        angle = np.arccos(np.clip(sight @ sight[sweeps // 2], -1.0, 1.0))
        rows = np.flatnonzero(angle <= radar.wavelength / (4 * azimuth_resolution))
        if len(rows) < 2:
            raise ParameterError("focus", "azimuth_resolution",
                                 "a resolution the recorded aperture can reach",
                                 azimuth_resolution)
    used = raw.isel(sweep=rows)
    layout = grid.resolve(raw, radar, aperture_resolution(used, centre))
    _, profile = range_spectrum(used["raw"].values, radar, window=range_window,
                                remove_rvp=False, upsample=range_upsample, rvp_present=False)
    frequency = np.sort(np.fft.fftfreq(profile.shape[1], 1.0 / radar.sampling_frequency))
    weight = evaluate_window(window_coefficients(window), (np.arange(len(rows)) + 0.5)
                             / len(rows))
    pixels = layout["position"].reshape(-1, 3)
    values, total = backproject_referenced(
        profile, frequency, radar, pixels, positions[rows],
        np.asarray(used["reference_range"].values, float), weight,
        interpolation=range_interpolation)
    image = (values / total).reshape(layout["position"].shape[:2])
    return image, layout, {"backend": "numpy", "referenced": 1, "rows_used": int(len(rows)),
                           "range_upsample": int(range_upsample),
                           "range_interpolation": range_interpolation}
