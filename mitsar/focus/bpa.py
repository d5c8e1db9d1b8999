"""Back-projection (BPA) of dechirped FMCW data, with the continuous-motion range shift.

Steps of :func:`focus_bpa`:

1. choose how the processed azimuth band is selected (:mod:`mitsar.focus.aperture`):
   ``"doppler"`` on straight uniform tracks whose band is narrower than the beam, where every
   range bin is band-passed in azimuth frequency by the *echo's* Doppler, as RDA/WDA/FSA do, so
   a point focuses to a clean sinc with no phase curvature across the image; ``"pixel"``
   otherwise, where each sweep is weighted by the window at the *pixel's* direction sine (the
   point response then carries a quadratic phase ``2 pi d^2 / (lambda R)`` in the azimuth offset
   d, so the image must be sampled finely);
2. range-compress the sweeps on a 16x zero-padded, sweep-centred FFT
   (:func:`mitsar.focus.compression.range_spectrum`; paper eq. 1) and keep the bins the pixels
   can be looked up in (:func:`crop_to_pixels`);
3. back-project (:mod:`mitsar.focus.backprojection`: the profile is read at the beat frequency
   ``K tau + f_c dtau/dt`` of every pixel, Meta 2007 §II-B, and de-rotated by
   ``exp(-j 2 pi f_c tau)``), in pixel chunks, with the Dr.Jit kernel limited per pixel to the
   sweeps of its aperture on straight tracks (:func:`mitsar.focus.aperture.sweep_window`), or
   with the NumPy reference;
4. normalise by the weight a full aperture would have
   (:func:`mitsar.focus.aperture.full_aperture_weight`), so a point of amplitude a focuses to a
   peak of about a, and pixels whose aperture runs off the end of the track fade instead of
   being amplified.
"""

from __future__ import annotations

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.focus.aperture import aspect_frames, sweep_window
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy
from mitsar.focus.bp_setup import normalise, prepare
from mitsar.focus.grid import track_frame
from mitsar.model.radar import Radar

__all__ = ["crop_to_pixels", "focus_bpa"]


def crop_to_pixels(frequency: NDArray, profile: NDArray, radar: Radar, pixels: NDArray,
                   positions: NDArray, max_speed: float) -> tuple[NDArray, NDArray]:
    """Keep only the profile bins that the pixels can be looked up in.

    Slant ranges between the pixels' bounding box and the antenna positions bound the beat
    frequencies (nearest point of the box, farthest corner), widened by the largest Doppler
    shift ``f_c v / K`` (in range) and half a metre.
    """
    low_corner, high_corner = pixels.min(axis=0), pixels.max(axis=0)
    nearest = np.clip(positions, low_corner, high_corner)
    corners = np.array(np.meshgrid(*zip(low_corner, high_corner, strict=True),
                                   indexing="ij")).reshape(3, -1).T
    low = np.linalg.norm(positions - nearest, axis=-1).min()
    high = np.linalg.norm(positions[:, None, :] - corners[None], axis=-1).max()
    margin = 0.5 + radar.carrier_frequency * max_speed / radar.chirp_rate
    keep = np.flatnonzero((frequency >= radar.beat_frequency(max(low - margin, 0.0)))
                          & (frequency <= radar.beat_frequency(high + margin)))
    if len(keep) < 2:
        return frequency, profile
    return frequency[keep[0]:keep[-1] + 1], profile[:, keep[0]:keep[-1] + 1]


def _rows(pair: tuple[NDArray, NDArray] | None, rows: slice) -> tuple[NDArray, NDArray] | None:
    """The rows of a per-pixel pair of arrays (or None)."""
    return None if pair is None else (pair[0][rows], pair[1][rows])


def focus_bpa(raw: xr.Dataset, pixels: NDArray, *, half_width: float, window: str,
              range_window: str, remove_rvp: bool, motion_correction: bool, backend: str,
              range_upsample: int, pixel_chunk: int, band_selection: str | None = None,
              progress: bool = False) -> tuple[NDArray, NDArray, dict]:
    """Back-project a raw product onto pixels (see the module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product.
    pixels : ndarray, shape (P, 3)
        Pixel world positions [m].
    half_width : float
        Processed half width in direction sine, ``lambda / (4 rho)``.
    band_selection : {"doppler", "pixel"} or None
        How the processed band is selected; default "doppler" for straight tracks with a
        processed band narrower than the beam, "pixel" otherwise.
    progress : bool
        Show a progress bar over pixel chunks.

    Returns
    -------
    values : ndarray, shape (P,), complex
    coverage : ndarray, shape (P,)
    extra : dict
        Processing attributes for the image product.
    """
    # 1.-2. band selection and range compression, cropped to the pixels
    bp = prepare(raw, half_width=half_width, window=window, range_window=range_window,
                 remove_rvp=remove_rvp, range_upsample=range_upsample,
                 band_selection=band_selection)
    radar, positions = bp.radar, bp.positions
    frequency, profile = crop_to_pixels(bp.frequency, bp.profile, radar, pixels, positions,
                                        float(bp.speed.max()))
    # 3. back-projection in pixel chunks
    origin, direction, _ = track_frame(raw)
    chunks = tqdm([slice(start, start + pixel_chunk)
                   for start in range(0, len(pixels), pixel_chunk)],
                  disable=not progress, desc="back-projection", unit="chunk")
    arguments = (profile, frequency, radar)
    common = (positions, bp.velocities, bp.centroid, bp.kernel_half_width, bp.kernel_window,
              motion_correction)
    # curved tracks, band narrower than the beam: the window on each pixel's aspect angle
    # (aperture.aspect_frames); the whole beam keeps every sweep that sees the pixel
    aspect = None
    if bp.band_selection == "pixel" and not bp.straight and half_width < bp.beam_half_width:
        aspect = aspect_frames(pixels, positions, bp.velocities, bp.centroid)
    if backend == "numpy":
        results = [backproject_numpy(*arguments, pixels[c], *common, aspect=_rows(aspect, c))
                   for c in chunks]
    else:
        ranges = None
        if bp.straight:
            ranges = sweep_window(pixels, origin, direction, bp.mean_speed / radar.prf,
                                  len(positions), bp.mean_centroid, bp.kernel_half_width)
        results = [backproject_drjit(*arguments, pixels[c], *common,
                                     sweep_range=_rows(ranges, c), aspect=_rows(aspect, c))
                   for c in chunks]
    # 4. normalisation by the full-aperture weight
    sums, totals = zip(*results, strict=True)
    values, coverage = normalise(bp, raw, pixels, np.concatenate(sums), np.concatenate(totals),
                                 half_width)
    return values, coverage, {"band_selection": bp.band_selection}
