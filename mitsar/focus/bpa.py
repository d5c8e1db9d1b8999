"""Back-projection (BPA) of dechirped FMCW data, with the continuous-motion range shift.

Steps of :func:`focus_bpa`:

1. choose how the processed azimuth band is selected (:mod:`mitsar.focus.aperture`):
   ``"doppler"`` on straight uniform tracks whose band is narrower than the beam, where every
   range bin is band-passed in azimuth frequency by the *echo's* Doppler, as RDA/WDA/FSA do, so
   a point focuses to a clean sinc with no phase curvature across the image; ``"pixel"``
   otherwise, where each sweep is weighted by the window at the *pixel's* direction sine (the
   point response then carries a quadratic phase ``2 pi d^2 / (lambda R)`` in the azimuth offset
   d, so the image must be sampled finely);
2. range-compress the sweeps on a zero-padded (``range_upsample``, 8x by default),
   sweep-centred FFT
   (:func:`mitsar.focus.compression.range_spectrum`; paper eq. 1) and keep the bins the pixels
   can be looked up in (:func:`crop_to_pixels`);
3. back-project (:mod:`mitsar.focus.backprojection`: the profile is read at the beat frequency
   ``K tau + f_c dtau/dt`` of every pixel, Meta 2007 §II-B, and de-rotated by
   ``exp(-j 2 pi f_c tau)``; the profile interpolated by ``range_interpolation``,
   :mod:`mitsar.focus.interpolation`: 4-tap Lagrange cubic by default), in pixel chunks,
   with the Dr.Jit kernel limited per pixel to the
   sweeps of its aperture (straight tracks: :func:`mitsar.focus.aperture.sweep_window`; any
   other track: :func:`curved_sweep_range`, a bound from a coarse search), or with the NumPy
   reference;
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

from mitsar.backend import backend_name
from mitsar.focus.aperture import (
    aspect_frames,
    median_sweep_interval,
    sweep_window,
    track_coordinates,
)
from mitsar.focus.backprojection import backproject_drjit, backproject_numpy, jit_array
from mitsar.focus.bp_setup import aperture_weights, beat_band, normalise, prepare
from mitsar.focus.bp_tiled import LANE_SIZES, backproject_tiled, column_order, nearest_range
from mitsar.focus.grid import track_frame
from mitsar.focus.interpolation import (
    DEFAULT_INTERPOLATION,
    check_interpolation,
    coefficient_table,
    jit_packets,
)
from mitsar.focus.reuse import reuse
from mitsar.model.geometry.bounds import bounding_box
from mitsar.model.radar import Radar

__all__ = ["crop_to_pixels", "curved_sweep_range", "focus_bpa"]


def crop_to_pixels(frequency: NDArray, profile: NDArray, radar: Radar, pixels: NDArray,
                   positions: NDArray, max_speed: float) -> tuple[NDArray, NDArray]:
    """Keep only the profile bins that the pixels can be looked up in.

    The band of :func:`mitsar.focus.bp_setup.beat_band` (a no-op on profiles that
    :func:`mitsar.focus.bp_setup.prepare` computed for these pixels already).
    """
    low, high = beat_band(radar, pixels, positions, max_speed)
    keep = np.flatnonzero((frequency >= low) & (frequency <= high))
    if len(keep) < 2:
        return frequency, profile
    return frequency[keep[0]:keep[-1] + 1], profile[:, keep[0]:keep[-1] + 1]


def _rows(pair: tuple[NDArray, NDArray] | None, rows: slice) -> tuple[NDArray, NDArray] | None:
    """The rows of a per-pixel pair of arrays (or None)."""
    return None if pair is None else (pair[0][rows], pair[1][rows])


def focus_bpa(raw: xr.Dataset, pixels: NDArray, *, half_width: float, window: str,
              range_window: str, remove_rvp: bool, motion_correction: bool, backend: str,
              range_upsample: int, pixel_chunk: int, band_selection: str | None = None,
              progress: bool = False, row_length: int | None = None,
              slab_rows: int | None = None,
              range_interpolation: str = DEFAULT_INTERPOLATION
              ) -> tuple[NDArray, NDArray, dict]:
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
    row_length : int, optional
        Pixels per row when ``pixels`` are a grid in row-major order (its fastest dim): the
        Dr.Jit sum then runs by row segments (:func:`mitsar.focus.bp_tiled.backproject_tiled`,
        float64 once per segment and sweep); None: groups of consecutive points.
    slab_rows : int, optional
        Rows per slab (a volume's z slices; None: one slab), for lanes along the columns
        (:func:`mitsar.focus.bp_tiled.column_order`).
    range_interpolation : {"cubic", "linear"}
        Interpolation of the range profiles (:mod:`mitsar.focus.interpolation`).

    Returns
    -------
    values : ndarray, shape (P,), complex
    coverage : ndarray, shape (P,)
    extra : dict
        Processing attributes for the image product (band selection, kernel,
        ``range_upsample`` and ``range_interpolation``).
    """
    check_interpolation("focus", range_interpolation)
    # 1.-2. band selection and range compression, cropped to the pixels
    bp = prepare(raw, half_width=half_width, window=window, range_window=range_window,
                 remove_rvp=remove_rvp, range_upsample=range_upsample,
                 band_selection=band_selection, points=pixels)
    radar, positions = bp.radar, bp.positions
    frequency, profile = bp.frequency, bp.profile  # the pixels' band (beat_band) already
    # 3. back-projection in pixel chunks
    origin, direction, _ = track_frame(raw)
    coordinates = track_coordinates(pixels, origin, direction)  # once for ranges and weights
    # curved tracks, band narrower than the beam: the window on each pixel's aspect angle
    # (aperture.aspect_frames); the whole beam keeps every sweep that sees the pixel
    aspect = None
    if bp.band_selection == "pixel" and not bp.straight and half_width < bp.beam_half_width:
        aspect = reuse("aspect_frames", (pixels, positions, bp.velocities, bp.centroid),
                       lambda: aspect_frames(pixels, positions, bp.velocities, bp.centroid))
    # by pixel groups (bp_tiled) on the CPU, a bistatic channel's too (its step 6); on a GPU
    # the exact kernel is the faster one (1.6-1.9x the groups on an H100, docs/gpu.md §6)
    by_groups = backend != "numpy" and backend_name() != "cuda"
    # lanes along the grid's columns (bp_tiled.column_order), decided once for all chunks
    columns = bool(by_groups and aspect is None and range_interpolation == "cubic"
                   and column_order(pixels, row_length, slab_rows, bp.velocities,
                                    bp.centroid, bp.kernel_half_width) is not None)
    chunks = tqdm(_chunks(len(pixels), pixel_chunk, row_length if backend != "numpy" else None,
                          slab_rows if columns else None),
                  disable=not progress, desc="back-projection", unit="chunk")
    arguments = (profile, frequency, radar)
    common = (positions, bp.velocities, bp.centroid, bp.kernel_half_width, bp.kernel_window,
              motion_correction)
    kernel = {"bp_kernel": "numpy" if backend == "numpy" else "exact"}
    weights = None
    how: dict = {"interpolation": range_interpolation}
    if len(chunks) > 1:  # the profile's coefficients made once for all the chunks
        how["table" if backend == "numpy" else "packets"] = (
            coefficient_table(profile, range_interpolation) if backend == "numpy"
            else jit_packets(profile, range_interpolation, jit_array))
    if backend == "numpy":
        results = [backproject_numpy(*arguments, pixels[c], *common, aspect=_rows(aspect, c),
                                     receivers=bp.receivers, **how)
                   for c in chunks]
    else:
        if bp.straight:
            ranges = sweep_window(pixels, origin, direction, bp.mean_speed / bp.sweep_rate,
                                  len(positions), bp.mean_centroid, bp.kernel_half_width,
                                  coordinates)
        else:  # any track: a safe bound from a coarse search (curved_sweep_range)
            ranges = reuse("curved_sweep_range", (pixels, positions, bp.velocities,
                                                  bp.centroid, bp.kernel_half_width, aspect),
                           lambda: curved_sweep_range(pixels, positions, bp.velocities,
                                                      bp.centroid, bp.kernel_half_width, aspect))
        if by_groups:
            # the whole grid's nearest range: every chunk shares lookups alike; the aperture
            # weights (host work) while the last chunk's kernel runs
            centres = positions if bp.receivers is None else np.concatenate(
                [positions, bp.receivers])   # a bistatic channel: the nearer phase centre
            nearest = nearest_range(centres, *bounding_box(pixels)) if len(pixels) else None
            tiled = [backproject_tiled(*arguments, pixels[c], *common,
                                       sweep_range=_rows(ranges, c), aspect=_rows(aspect, c),
                                       row_length=row_length, nearest=nearest,
                                       columns=columns, slab_rows=_slab_rows(
                                           c, row_length, slab_rows),
                                       receivers=bp.receivers, **how,
                                       while_running=None if c.stop < len(pixels) else
                                       lambda: aperture_weights(bp, raw, pixels, half_width,
                                                                coordinates))
                     for c in chunks]
            results = [t[:2] for t in tiled]
            weights = tiled[-1][2]["while_running"] if tiled else None
            exact = sum(t[2]["exact_pixels"] for t in tiled)
            kernel = {"bp_kernel": "tiled" if exact == 0 else "tiled+exact",
                      "bp_lane_pixels": max(t[2]["lane_pixels"] for t in tiled)}
        else:  # the exact kernel (a GPU)
            results = [backproject_drjit(*arguments, pixels[c], *common,
                                         sweep_range=_rows(ranges, c), aspect=_rows(aspect, c),
                                         receivers=bp.receivers, **how)
                       for c in chunks]
    # 4. normalisation by the full-aperture weight
    sums, totals = zip(*results, strict=True)
    values, coverage = normalise(bp, raw, pixels, np.concatenate(sums), np.concatenate(totals),
                                 half_width, weights or aperture_weights(bp, raw, pixels,
                                                                         half_width,
                                                                         coordinates))
    return values, coverage, {"band_selection": bp.band_selection, **kernel,
                              "range_upsample": int(range_upsample),
                              "range_interpolation": range_interpolation}


def _chunks(count: int, size: int, row_length: int | None, slab_rows: int | None
            ) -> list[slice]:
    """Pixel chunks of about ``size`` pixels that keep the pixel-group lanes where they are on
    the whole grid: whole rows (lanes along the rows), or with ``slab_rows`` (lanes along
    the columns of each slab) whole slabs, or blocks of ``LANE_SIZES[0]`` rows of a slab
    larger than ``size`` with its last rows joined to the block before. None: any cut (the
    NumPy sum, points)."""
    if not row_length:
        return [slice(start, start + size) for start in range(0, count, size)]
    if not slab_rows:
        size = max(row_length, size // row_length * row_length)
        return [slice(start, start + size) for start in range(0, count, size)]
    slab = slab_rows * row_length
    if size >= slab:
        size = size // slab * slab
        return [slice(start, start + size) for start in range(0, count, size)]
    block = LANE_SIZES[0] * row_length
    size = max(block, size // block * block)
    out = []
    for first in range(0, count, slab):
        cuts = list(range(first, first + slab, size))
        if len(cuts) > 1 and first + slab - cuts[-1] < block:
            cuts.pop()   # too few rows for a lane: joined to the block before
        out += [slice(a, b) for a, b in zip(cuts, [*cuts[1:], first + slab], strict=True)]
    return out


def _slab_rows(chunk: slice, row_length: int | None, slab_rows: int | None) -> int | None:
    """A chunk's rows per slab: the slab's, or the chunk's own when it is a block of one
    slab (:func:`_chunks`)."""
    if not row_length or not slab_rows:
        return slab_rows
    return min(slab_rows, (chunk.stop - chunk.start) // row_length)


def curved_sweep_range(pixels: NDArray, positions: NDArray, velocities: NDArray,
                       centroid_sine: NDArray, half_width: float,
                       aspect: tuple[NDArray, NDArray] | None = None, *, samples: int = 256,
                       chunk: int = 16384, slack: float = 1e-4) -> tuple[NDArray, NDArray]:
    """Per-pixel first and end sweep that can fall inside the window, on any track.

    The window offset of sweep k at pixel x is ``g_k = d . l_k - u`` (aspect frame
    ``(d, u)`` of :func:`mitsar.focus.aperture.aspect_frames`) or ``g_k = v_k . l_k - u_c,k``
    (whole beam: own velocity direction v_k and centroid sine u_c,k), with ``l_k`` the unit
    line of sight from the antenna to x; sweep k contributes only if ``|g_k| <= h``
    (docs/focusing.md, "Curved tracks", sweep ranges). ``g`` is evaluated on ``samples``
    evenly spaced sweeps ``c_i``; between ``c_i`` and ``c_{i+1}`` it changes by at most

    ``m_i = L_i / R_i + V_i + C_i`` (whole beam; ``L_i / R_i`` with an aspect frame),

    where ``L_i`` is the path length of the interval (the antenna's polyline), ``R_i =
    min(R(c_i), R(c_{i+1})) - L_i / 2`` a lower bound of the pixel's range along it (so the
    line of sight turns by at most ``L_i / R_i`` radians, a chord of the unit sphere no longer
    than that), ``V_i`` the summed changes ``|v_{k+1} - v_k|`` of the unit velocity and
    ``C_i`` those of the centroid sine. A sweep contributes while ``|g_k| < h + delta_k / 2``
    (its edge fraction, :func:`mitsar.focus.backprojection.edge_fraction`; ``delta_k <=
    |v_k| T / R``, T the sweep interval), so an interval can hold a contributing sweep only if
    ``|g(c_i)| <= h + m_i + e_i / 2 + slack``, ``e_i = max |v_k| T / R_i`` over the interval
    (``slack`` covers the kernel's float32 offsets), and a pixel's range runs from the first
    such interval's start to the last one's end: no contributing sweep is dropped (an interval
    with ``R_i <= 0`` always qualifies).

    Parameters
    ----------
    pixels : ndarray, shape (P, 3)
        Pixel positions [m].
    positions, velocities : ndarray, shape (S, 3)
        Mid-sweep antenna positions [m] and velocities [m/s].
    centroid_sine : ndarray, shape (S,)
        Doppler-centroid direction sine of every sweep.
    half_width : float
        Window half width h in direction sine.
    aspect : (ndarray (P, 3), ndarray (P,)), optional
        Per-pixel aspect frames; None for the window on each sweep's own velocity.
    samples : int
        Sweeps sampled (at least 2).
    chunk : int
        Pixels per NumPy block (memory ~ 50 bytes x samples x chunk).
    slack : float
        Added to every bound (direction sine).

    Returns
    -------
    first, end : ndarray, shape (P,), uint32
        Sweep range ``first <= k < end`` of every pixel (empty if none can contribute).
    """
    sweeps = len(positions)
    coarse = np.unique(np.linspace(0, sweeps - 1, max(min(samples, sweeps), 2))
                       .round().astype(int))
    first = np.zeros(len(pixels), dtype=np.uint32)
    end = np.zeros(len(pixels), dtype=np.uint32)
    if sweeps < 2 or len(pixels) == 0:
        end[:] = sweeps
        return first, end

    def per_interval(steps: NDArray) -> NDArray:
        """Sums of per-sweep steps over the coarse intervals [c_i, c_{i+1})."""
        total = np.concatenate([[0.0], np.cumsum(steps)])
        return total[coarse[1:]] - total[coarse[:-1]]

    path = per_interval(np.linalg.norm(np.diff(positions, axis=0), axis=-1))
    # the longest stretch |v_k| T a sweep of the interval stands for (its edge fraction)
    spacing = (np.linalg.norm(velocities, axis=-1)
               * median_sweep_interval(positions, velocities))
    stretch = np.maximum(np.maximum.reduceat(spacing, coarse[:-1]), spacing[coarse[1:]])
    turning = np.zeros(len(path))
    if aspect is None:
        speed = np.linalg.norm(velocities, axis=-1, keepdims=True)
        unit = velocities / np.where(speed > 0, speed, 1.0)
        turning = (per_interval(np.linalg.norm(np.diff(unit, axis=0), axis=-1))
                   + per_interval(np.abs(np.diff(centroid_sine))))
    anchors = positions[coarse]                                  # (M, 3)
    anchor_norm = np.einsum("mi,mi->m", anchors, anchors)
    if aspect is None:
        along = unit[coarse]
        along_anchor = np.einsum("mi,mi->m", anchors, along)
    for start in range(0, len(pixels), chunk):
        block = pixels[start:start + chunk]
        # |x - p_m| and (x - p_m) . d by matrix products (float64: no harmful cancellation
        # at room scale, and slack covers far more than the rounding)
        distance = np.sqrt(np.maximum(np.einsum("pi,pi->p", block, block)[:, None]
                                      - 2.0 * block @ anchors.T + anchor_norm[None], 0.0))
        if aspect is None:
            offset = ((block @ along.T - along_anchor[None]) / distance
                      - centroid_sine[coarse][None])
        else:
            frame, centre = aspect[0][start:start + chunk], aspect[1][start:start + chunk]
            offset = ((np.einsum("pi,pi->p", block, frame)[:, None] - frame @ anchors.T)
                      / distance - centre[:, None])
        nearest = np.minimum(distance[:, :-1], distance[:, 1:]) - 0.5 * path[None]
        reach = np.where(nearest > 0, (path + 0.5 * stretch)[None]
                         / np.where(nearest > 0, nearest, 1.0), np.inf)
        hit = np.abs(offset[:, :-1]) <= half_width + reach + turning[None] + slack  # (P, M-1)
        any_hit = hit.any(axis=1)
        low = hit.argmax(axis=1)
        high = hit.shape[1] - 1 - hit[:, ::-1].argmax(axis=1)
        first[start:start + chunk] = np.where(any_hit, coarse[:-1][low], 0)
        end[start:start + chunk] = np.where(any_hit, coarse[1:][high] + 1, 0)
    return first, end
