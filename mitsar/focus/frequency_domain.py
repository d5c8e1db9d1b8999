"""Frequency-domain focusing (RDA, WDA, FSA) of a straight-track raw product onto a slant grid.

Steps of :func:`focus_frequency_domain`:

1. check the algorithm's options (:data:`ALGORITHM_OPTIONS`);
2. the common front end (:func:`mitsar.focus.spectral.prepare_spectrum`: RVP removal, azimuth
   chirp-z transform, continuous-motion correction ``H_cm``, azimuth weighting);
3. the algorithm's own matched filter (:mod:`mitsar.focus.rda`, :mod:`mitsar.focus.wda`,
   :mod:`mitsar.focus.fsa`);
4. the aperture coverage of every pixel (:func:`aperture_coverage`), with which the image fades
   where a pixel's aperture runs off the track, as back-projection's does.
"""

from __future__ import annotations

from collections.abc import Callable

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.focus.fsa import focus_fsa
from mitsar.focus.rda import focus_rda
from mitsar.focus.spectral import Spectrum, prepare_spectrum
from mitsar.focus.wda import focus_wda
from mitsar.products.raw import radar_of

__all__ = ["ALGORITHM_OPTIONS", "FOCUSERS", "aperture_coverage", "focus_frequency_domain"]

FOCUSERS: dict[str, Callable[..., tuple[NDArray[np.complex128], dict]]] = {
    "rda": focus_rda, "wda": focus_wda, "fsa": focus_fsa}
"""The frequency-domain algorithms, each ``f(spectrum, **options) -> (image, extra)``."""

ALGORITHM_OPTIONS: dict[str, tuple[str, ...]] = {
    "rda": ("src",),
    "wda": ("gate_cells",),
    "fsa": ("upsample", "check_aliasing", "src", "chunk_elements"),
}
"""Keyword options of every algorithm (``algorithm_options`` of :func:`mitsar.focus.focus`)."""


def focus_frequency_domain(raw: xr.Dataset, algorithm: str, layout: dict, *, half_width: float,
                           window: str, range_window: str, remove_rvp_flag: bool,
                           motion_correction: bool, options: dict | None = None
                           ) -> tuple[NDArray[np.complex128], NDArray[np.float64], dict]:
    """Focus with RDA, WDA or FSA onto a resolved slant grid.

    Returns the image (shape of the grid), the aperture coverage of every pixel
    (:func:`aperture_coverage`) and extra processing attributes.

    Raises
    ------
    ParameterError
        For ``options`` the algorithm does not take (:data:`ALGORITHM_OPTIONS`).
    """
    options = dict(options or {})
    allowed = ALGORITHM_OPTIONS[algorithm]
    unknown = sorted(set(options) - set(allowed))
    if unknown:
        raise ParameterError(algorithm, "algorithm_options", f"keys among {list(allowed)}",
                             unknown)
    radar = radar_of(raw)
    spectrum = prepare_spectrum(raw, radar, layout, half_width=half_width, window=window,
                                range_window=range_window, remove_rvp_flag=remove_rvp_flag,
                                motion_correction=motion_correction, where=algorithm)
    image, extra = FOCUSERS[algorithm](spectrum, **options)
    return image, aperture_coverage(spectrum, half_width), extra


def aperture_coverage(spectrum: Spectrum, half_width: float) -> NDArray[np.float64]:
    """Fraction of every pixel's processed aperture that lies on the recorded track.

    The aperture of pixel (a, r) spans the along-track positions ``a - r g(u)`` for direction
    sines ``u`` within ``u_c +- h`` (``g(u) = u / sqrt(1 - u^2)``); the image fades where it
    runs off the track (no renormalisation), shape (len(azimuth), len(slant_range)).
    """
    track = spectrum.track
    u_c = track.centroid_sine
    low, high = u_c - half_width, u_c + half_width
    a = spectrum.azimuth[:, None]
    r = spectrum.slant_range[None, :]
    start = a - r * high / np.sqrt(1 - high**2)
    stop = a - r * low / np.sqrt(1 - low**2)
    end = (track.sweeps - 1) * track.spacing
    inside = np.clip(np.minimum(stop, end) - np.maximum(start, 0.0), 0.0, None)
    return np.clip(inside / np.maximum(stop - start, 1e-12), 0.0, 1.0)
