"""Fast factorised back-projection (FFBP) of dechirped FMCW data, for any track and any grid.

After Ulander, Hellsten & Stenström, "Synthetic-aperture radar processing using fast factorized
back-projection", IEEE TAES 39(3):760-776, 2003. The track is cut into sub-apertures; a
sub-aperture of length L can only resolve angles to about ``lambda / (2 L)``, so its image is
held on a coarse *local polar grid* (range ``rho`` from the sub-aperture centre c by direction
cosine ``alpha = a . (x - c) / rho`` about its axis a), and sub-apertures are merged, a factor
at a time, onto the finer polar grids of their parents by interpolation.

Steps of :func:`focus_ffbp`:

1. band selection and range compression as :func:`mitsar.focus.bpa.focus_bpa`
   (``"doppler"`` band-pass on straight uniform tracks with a band narrower than the beam,
   ``"pixel"`` weighting otherwise; :func:`mitsar.focus.compression.range_spectrum`, here in
   single precision: the kernels read float32 profiles anyway);
2. first stage: every sub-aperture of ``first_subaperture`` sweeps is back-projected exactly,
   with BPA's per-pulse sum (:func:`mitsar.focus.backprojection.pixel_pulse`: beat frequency
   ``K tau + f_c dtau/dt``, Meta 2007 §II-B, and de-rotation by ``exp(-j 2 pi f_c tau)``),
   onto the nodes of its polar grid (:func:`mitsar.focus.ffbp_stages.first_stage`); the nodes
   are points of the image plane (the plane that holds the output pixels: least squares
   through them; :func:`mitsar.focus.ffbp_stages.polar_node`, evaluated by the kernels from
   the node's index), so the sub-aperture images are exact there for any track, bends
   included; each node also keeps the sum of its sweeps' azimuth weights (for the
   normalisation); the images stay in Dr.Jit memory until the pixels;
3. every polar image is *demodulated*, multiplied by ``exp(+j 2 pi f_c 2 rho / c)``: what is
   left varies slowly, in range as the compressed pulse (bandwidth ``2B/c`` cycles/m) and in
   angle as the residual phase ``2 pi (2/lambda) s (alpha - alpha_0)`` of the sweeps' offsets s
   (bandwidth ``2 L / lambda``), so it can be sampled at ``c / (2 B q_r)`` in range and
   ``lambda / (2 L q_a)`` in angle and interpolated (Keys cubic, 4 x 4 taps; the weight sums
   bilinearly);
4. merge stages: a parent node y takes, from each child j, the child's demodulated image
   interpolated at ``(|y - c_j|, alpha_j(y))``, re-modulated by ``exp(-j 2 pi f_c 2 rho_j / c)``
   and demodulated by the parent's ``exp(+j 2 pi f_c 2 rho_P / c)``, i.e. rotated by
   ``2 pi (2 f_c / c)(rho_P - rho_j)``, computed as ``(c_j - c_P).(2y - c_P - c_j) /
   (rho_P + rho_j)`` so that float32 keeps it (:func:`mitsar.focus.ffbp_stages.merge_nodes`):
   one lane per node and a symbolic loop over its children; each row of four taps is one
   packet load of (real, imag) float32 pairs; the sums of the weights only where the
   normalisation reads them ("pixel" band selection); merging stops before sub-apertures
   grow too long for the polar grids' range sampling (:func:`_longest_subaperture`);
5. final stage: the remaining sub-apertures are merged onto the output pixels the same way
   (:func:`mitsar.focus.ffbp_stages.merge_points`), re-modulated by the carrier of the
   range from a local origin (float64 range), and normalised as BPA
   (:func:`mitsar.focus.aperture.full_aperture_weight`, :func:`normalise_image`), so a unit
   point focuses to about 1.

A channel whose receiver is not its transmitter (one channel of a multi-channel product,
:func:`mitsar.focus.channels.channel_view`) is back-projected on half its exact path in every
stage, as BPA does (docs/focusing.md § FFBP, "Channels"): the polar grids stay the
transmitter's (centres c), each sub-aperture also keeps its receiver's centre d, the first stage
sums BPA's bistatic per-pulse terms, every image is demodulated by half the node's path
``(|x - c| + |x - d|) / 2`` instead of rho (step 3), and a merge rotates by half the change of
both ranges (step 4); a tapered window's shifted reads move in range too, so that half the
path stays (:func:`mitsar.focus.ffbp_band._receiver_read`).

The azimuth window, whole beam or a band on a straight uniform track (a Doppler band-pass
first, as BPA): each sweep is weighted at the first-stage nodes exactly as BPA weights it at a
pixel (the window at the node's direction sine), so bends of the track are handled (a sweep
past a turn that no longer sees a node gets weight 0).

A band narrower than the beam on a curved track or at a varying speed (``"pixel"`` band
selection, BPA's window on each pixel's aspect angle, :func:`mitsar.focus.aperture.
aspect_frames`): a hard cut per pixel and sweep, which no polar image can hold (it is known
to one angular cell there: -7 dB when it was tried at the nodes). Instead the sub-aperture
images hold every sweep unweighted, merging stops at the longest pixel band, every stage is
kept, and each pixel sums its own band of sweeps ``[k_1, k_2)`` (bisection on its aspect
offset) from the sub-apertures of any stage that lie wholly inside it, the largest first
(segment-tree fashion), and from single sweeps at its two edges through BPA's own per-pulse
sum and window test (:func:`mitsar.focus.ffbp_band.merge_band`): the cut is BPA's to the
sweep. A tapered (cosine-series) window weights a whole sub-aperture's sweeps by reading its
demodulated image at shifted direction cosines, one read per harmonic
(:func:`mitsar.focus.ffbp_band._windowed_piece`). The frames and sweep ranges are BPA's
(:func:`_band_setup`), on grids interpolated from a checked sub-grid (:func:`_grid_band_setup`).
Measured -46 to -50 dB from exact BPA at 5 and 10 cm on 20-degree turns, U-turns and an
accelerating pass (``tests/test_ffbp_turns.py``).

Options (``algorithm_options``), defaults and measured error (``docs/focusing.md`` § FFBP):
``factor`` 4 (sub-apertures merged per stage), ``first_subaperture`` 8 (sweeps per
first-stage sub-aperture), ``final_subapertures`` 8 (merging stops when at most this many are
left), ``angle_oversample`` 4.0 (``q_a``), ``first_angle_oversample`` 2.0 (extra angular
sampling of the first stage: finer window edges), ``range_oversample`` 4.0 (``q_r``),
``lookup_upsample`` 16 (cap on the range FFT's zero-padding for the first stage's linear
lookup: 8 gives -39 dB, 4 -32 dB). Only the range band of the first stage's polar grids is
compressed (zoom transform, :func:`mitsar.focus.bp_setup.beat_band`). At the defaults a point
target's image is -44 dB from exact BPA (straight track, Doppler band selection), -40 dB
(curved track, ground plane, whole beam); the error falls by ~19 dB from ``q_a`` = 2 to 4 and
~4 dB from 4 to 8, and is -31 dB at ``q_r`` = 2. Processing the whole beam with a rect window,
the hard cut of the target's echo at each far pixel's beam edge limits the agreement to about
-33 dB (-45 dB with a Hamming window).
"""

from __future__ import annotations

import math

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.backend import require_backend, safe_width
from mitsar.budget import require_memory
from mitsar.errors import ParameterError
from mitsar.focus.aperture import aspect_frames, sweep_window, track_coordinates
from mitsar.focus.backprojection import kernel_tables
from mitsar.focus.bp_setup import Prepared, aperture_weights, normalise, prepare
from mitsar.focus.bpa import curved_sweep_range
from mitsar.focus.ffbp_band import merge_band
from mitsar.focus.ffbp_stages import (
    LANE_NODES,
    Stage,
    first_stage,
    merge_nodes,
    merge_points,
    node_frames,
    to_numpy,
)
from mitsar.focus.grid import track_frame
from mitsar.focus.interpolation import DEFAULT_INTERPOLATION, check_interpolation
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.products.raw import radar_of

__all__ = ["FFBP_DEFAULTS", "focus_ffbp"]

FFBP_DEFAULTS: dict[str, float | str] = {
    "factor": 4, "first_subaperture": 8, "final_subapertures": 8, "angle_oversample": 4.0,
    "range_oversample": 4.0, "first_angle_oversample": 2.0, "lookup_upsample": 16}
"""Default FFBP options (see the module docstring)."""

MAX_OVERSAMPLE = 1000.0
"""Largest oversampling option accepted (the error stops falling near 8, docs/focusing.md
§ FFBP); beyond it the products of the options could overflow the grid sizes."""

_MARGIN = 3
"""Polar-grid range nodes added beyond the pixels on every side, per remaining stage.

The range step is the same at every stage, so each stage needs its parent's margin plus the
cubic taps (one before, two after) and a node for the parallax between the centres."""

_ANGLE_MARGIN = 4
"""Polar-grid angle nodes added beyond the pixels on every side, at every stage.

A parent's angular step is ``factor`` times finer than its children's (the first stage's
twice finer again is ``first_angle_oversample``): a parent's margin of 4 of its own steps
lies within 2 of a child's, which with the cubic taps (2) gives 4 again. Measured against
the old margin (3 per remaining stage: 12 at the first stage of 4096 sweeps, a third fewer
first-stage nodes now): the error of all five checked cases the same to 0.01 dB (straight
0.1 m, 20 degree turn, whole beam rect and Hamming, 0.1 m at full size)."""


def focus_ffbp(raw: xr.Dataset, layout_or_pixels: dict | NDArray, *, half_width: float,
               window: str, range_window: str, remove_rvp: bool, motion_correction: bool,
               range_upsample: int, options: dict | None = None, band_selection: str | None = None,
               progress: bool = False, range_interpolation: str = DEFAULT_INTERPOLATION
               ) -> tuple[NDArray, NDArray, dict]:
    """Focus a raw product by fast factorised back-projection (see the module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product.
    layout_or_pixels : dict or ndarray
        A resolved grid layout (``position`` of shape (n0, n1, 3)) or pixel positions (P, 3) [m].
    half_width : float
        Processed half width in direction sine, ``lambda / (4 rho)``.
    window, range_window : str
        Azimuth and range windows.
    remove_rvp, motion_correction : bool
        As :func:`mitsar.focus.bpa.focus_bpa`.
    range_upsample : int
        Zero-padding factor of the range FFT (first-stage lookup, as BPA).
    options : dict, optional
        ``factor``, ``first_subaperture``, ``final_subapertures``, ``angle_oversample``,
        ``first_angle_oversample``, ``range_oversample``, ``lookup_upsample``
        (:data:`FFBP_DEFAULTS`; module
        docstring).
    band_selection : {"doppler", "pixel"} or None
        As :func:`mitsar.focus.bpa.focus_bpa`.
    progress : bool
        Show a progress bar over stages.
    range_interpolation : {"cubic", "linear"}
        Interpolation of the range profiles in the first stage and the band edges
        (:mod:`mitsar.focus.interpolation`).

    Returns
    -------
    values : ndarray, shape (P,), complex
    coverage : ndarray, shape (P,)
    extra : dict
        Processing attributes (band selection, options, stage count).
    """
    require_backend()  # LLVM (libLLVM >= 16) or CUDA (a device), docs/gpu.md
    check_interpolation("focus", range_interpolation)
    settings = _options(options)
    pixels = _pixel_array(layout_or_pixels)
    sweeps = raw.sizes["sweep"]
    rho_step = radar_of(raw).range_resolution / settings["range_oversample"]
    track = raw["platform_position"].values
    longest = _longest_subaperture(track, _pixel_sample(layout_or_pixels), radar_of(raw),
                                   settings)
    stages = _plan(sweeps, settings, longest)
    # The first stage's polar grids reach (margin + 1) range steps and half a sub-aperture
    # past the pixels' ranges (_make_stage): compress only that band (bp_setup.beat_band).
    reach = ((_MARGIN * len(stages) + 1) * rho_step
             + settings["first_subaperture"]
             * float(np.linalg.norm(np.diff(track, axis=0), axis=-1).max(initial=0.0))
             + 0.5 * _baseline(raw))  # a bistatic channel's half path departs from the range
    bp = prepare(raw, half_width=half_width, window=window, range_window=range_window,
                 remove_rvp=remove_rvp,
                 range_upsample=min(range_upsample, settings["lookup_upsample"]),
                 band_selection=band_selection, points=_pixel_sample(layout_or_pixels),
                 range_margin=reach, profile_dtype=np.complex64)
    radar, positions, velocities = bp.radar, bp.positions, bp.velocities
    frequency, profile = bp.frequency, bp.profile
    mean_speed, mean_centroid = bp.mean_speed, bp.mean_centroid
    kernel_half_width, kernel_window = bp.kernel_half_width, bp.kernel_window
    # A band narrower than the beam cut per pixel and sweep ("pixel" band selection: curved
    # tracks, varying speed): the sub-aperture images hold every sweep, unweighted, and each
    # pixel sums its own band at the end (_band_setup, ffbp_band.merge_band).
    band = None
    if bp.band_selection == "pixel" and half_width < bp.beam_half_width:
        band = _band_setup(bp, layout_or_pixels, pixels, half_width)
        # (no more stages than the range margins and the compressed band were sized for)
        stages = _plan(sweeps, settings, longest, cap=band["longest"])[:len(stages)]
        kernel_half_width, kernel_window = _UNWINDOWED, np.array([1.0])

    # Geometry relative to a local origin near the pixels (float32 kernels; docs/focusing.md).
    origin_local = pixels.mean(axis=0)
    sample = _pixel_sample(layout_or_pixels) - origin_local
    local_positions = positions - origin_local
    # a bistatic channel: half its path in every stage (steps 2-5), the grids the transmitter's
    local_receivers = None if bp.receivers is None else bp.receivers - origin_local
    normal, plane_point = _image_plane(sample, local_positions)
    wavenumber = 2 * radar.carrier_frequency / SPEED_OF_LIGHT  # two-way, cycles per metre
    window_support = (mean_centroid - kernel_half_width, mean_centroid + kernel_half_width)
    if band is not None:  # every pixel's band lies in the beam (its aspect frame's crossing)
        window_support = (float(bp.centroid.min()) - bp.beam_half_width,
                          float(bp.centroid.max()) + bp.beam_half_width)
    bar = tqdm(total=len(stages) + 1, disable=not progress, desc="FFBP", unit="stage")

    # First stage: exact back-projection onto the nodes of every sub-aperture's polar grid
    # (nodes generated in the kernel; images stay in Dr.Jit memory until the pixels).
    stage = _make_stage(stages[0], local_positions, velocities, sample, normal, plane_point,
                        rho_step, radar.wavelength,
                        settings["angle_oversample"] * settings["first_angle_oversample"],
                        _MARGIN * len(stages), window_support, LANE_NODES, local_receivers)
    _check_nodes(stage, first=True)
    tables = kernel_tables(profile, frequency, radar, local_positions, velocities, bp.centroid,
                           kernel_half_width, kernel_window, motion_correction,
                           receivers=local_receivers, interpolation=range_interpolation)
    first_stage(stage, node_frames(stage, normal, plane_point), tables, wavenumber)
    bar.update()

    # Merge stages (the sums of the weights only where the normalisation reads them).
    with_totals = bp.band_selection != "doppler" and band is None
    kept = [stage]
    for index, groups in enumerate(stages[1:], start=1):
        parent = _make_stage(groups, local_positions, velocities, sample, normal, plane_point,
                             rho_step, radar.wavelength, settings["angle_oversample"],
                             _MARGIN * (len(stages) - index), window_support,
                             receivers=local_receivers)
        _check_nodes(parent, first=False)
        merge_nodes(stage, parent, node_frames(parent, normal, plane_point),
                    _children_of(stage, parent), wavenumber, with_totals)
        stage = parent
        if band is not None:
            kept.append(stage)
        bar.update()

    # Final stage: onto the pixels, with the azimuth window per sub-aperture; one lane a pixel,
    # padded past Dr.Jit 1.5's crashing widths (_pad_lanes).
    coordinates = None
    count = len(pixels)
    width = safe_width(count)
    if band is not None:  # every pixel's own band, from the sub-apertures of all stages
        local, direction, centre, band_first, band_end = _pad_lanes(
            width, pixels - origin_local, *band["frame"], *band["range"])
        launched = merge_band(kept, local, (direction, centre), (band_first, band_end),
                              tables, half_width, bp.coefficients, wavenumber, normal)
    elif bp.straight:
        origin, direction, _ = track_frame(raw)
        coordinates = track_coordinates(pixels, origin, direction)
        first, end = sweep_window(pixels, origin, direction, mean_speed / bp.sweep_rate,
                                  len(positions), mean_centroid, kernel_half_width, coordinates)
        first_child = np.searchsorted(stage.end, first, side="right").astype(np.uint32)
        end_child = np.searchsorted(stage.first, end, side="left").astype(np.uint32)
    else:
        first_child = np.zeros(len(pixels), dtype=np.uint32)
        end_child = np.full(len(pixels), len(stage.first), dtype=np.uint32)
    if band is None:
        launched = merge_points(stage, *_pad_lanes(width, pixels - origin_local, first_child,
                                                   end_child), wavenumber, with_totals)
    weights = aperture_weights(bp, raw, pixels, half_width, coordinates)  # while it runs
    merged, total = (part[:count] for part in to_numpy(*launched))
    bar.update()
    bar.close()

    values, coverage = normalise(bp, raw, pixels, merged, total, half_width, weights)
    extra = {"band_selection": bp.band_selection, "ffbp_stages": len(stages),
             "ffbp_final": "pixel band" if band is not None else "sub-apertures",
             **{f"ffbp_{key}": value for key, value in settings.items()},
             "range_upsample": int(min(range_upsample, settings["lookup_upsample"])),
             "range_interpolation": range_interpolation}
    return values, coverage, extra


_UNWINDOWED = 4.0
"""Half width in direction sine of the first stage's window when each pixel's band is cut at
the end: larger than any offset ``|v . l - u_c| <= 2``, so every sweep has weight 1."""


def _pad_lanes(width: int, *arrays: NDArray) -> list[NDArray]:
    """Per-pixel arrays padded to ``width`` rows by repeating their last row.

    The final stage's kernels run one independent lane a pixel (no sum across lanes), so the
    extra lanes, which take the kernel width past the band where Dr.Jit 1.5's LLVM backend
    crashes (:func:`mitsar.backend.safe_width`, at most 15 of them), change no other pixel's
    value; theirs are dropped. ``width`` equal to the rows: the arrays as they are.
    """
    return [np.concatenate([a, np.repeat(a[-1:], width - len(a), axis=0)]) if width > len(a)
            else a for a in arrays]


def _band_setup(bp: Prepared, layout_or_pixels: dict | NDArray, pixels: NDArray,
                half_width: float) -> dict:
    """Aspect frames, safe sweep ranges and the longest band of the pixels (band mode).

    The frames are BPA's (:func:`mitsar.focus.aperture.aspect_frames` on a track that is not
    straight and uniform; on one that is, the track direction and the centroid, the window
    BPA applies there), as are the sweep ranges that bracket each band
    (:func:`mitsar.focus.bpa.curved_sweep_range`), so FFBP cuts the same band. On a grid of
    pixels both are computed on a sub-grid and interpolated (:func:`_grid_band_setup`);
    scattered pixels get them one by one.
    """
    if bp.straight:
        speed = max(float(np.linalg.norm(bp.velocities[0])), 1e-12)
        frame = (np.broadcast_to(bp.velocities[0] / speed, pixels.shape).copy(),
                 np.full(len(pixels), bp.mean_centroid))
        first, end = curved_sweep_range(pixels, bp.positions, bp.velocities, bp.centroid,
                                        half_width, frame)
    else:
        grid = (np.asarray(layout_or_pixels["position"], dtype=float)
                if isinstance(layout_or_pixels, dict) else None)
        if grid is not None and grid.ndim == 3 and min(grid.shape[:2]) > 4 * _FRAME_STRIDE:
            frame, (first, end) = _grid_band_setup(bp, grid, half_width)
        else:
            frame = aspect_frames(pixels, bp.positions, bp.velocities, bp.centroid)
            first, end = curved_sweep_range(pixels, bp.positions, bp.velocities, bp.centroid,
                                            half_width, frame)
    longest = int(np.max(end.astype(np.int64) - first, initial=1))
    return {"frame": frame, "range": (first, end), "longest": max(longest, 1)}


_FRAME_STRIDE = 8
"""Pixels between the sub-grid nodes of :func:`_grid_band_setup` (twice that on grids of
1024 pixels a side or more: at least 64 cells a side)."""

_FRAME_TOLERANCE = 2e-6
"""Largest error of interpolated aspect frames, ``|d - d_exact| + |u - u_exact|`` (a bound on
the error of the window offset ``g``), accepted at a cell's check pixels: one sweep moves
``g`` by about its spacing over the range (2.5e-4 at 2 mm and 8 m), so a band edge moves by
less than 1 % of a sweep. Measured on the 0.6 m patch of the 20-degree turn towards the look
side at 10 cm: 1e-5 left -48 dB between the images with interpolated and exact frames (the
image -45.4 dB from BPA instead of -48.5 dB), 3e-6 none."""

_RANGE_MARGIN = 4
"""Sweeps added on each side of the interpolated sweep ranges (which bracket each band by
some ten sweeps more already, :func:`mitsar.focus.bpa.curved_sweep_range`)."""


def _grid_band_setup(bp: Prepared, grid: NDArray, half_width: float
                     ) -> tuple[tuple[NDArray, NDArray], tuple[NDArray, NDArray]]:
    """Aspect frames and sweep ranges of a grid of pixels (n0, n1, 3), from a sub-grid.

    The frame of a pixel (the track direction at its beam-centre crossing, and the sine of
    its line of sight there) varies smoothly across the grid, except along the line where
    pixels stop crossing the beam centre on the track (their frame is then at the closest
    approach): it is computed every :data:`_FRAME_STRIDE` pixels (and at the last row and
    column) and interpolated bilinearly (the direction renormalised), and the sweep range
    of a pixel is the union of those of its cell's four corners, widened by
    :data:`_RANGE_MARGIN`. Every cell is checked at its centre and the middles of two edges
    (where bilinear interpolation errs most) against the exact frame and range; the cells
    whose frame errs by more than :data:`_FRAME_TOLERANCE` or whose exact range is not inside
    the interpolated one, and their neighbours, are computed pixel by pixel. Measured on the
    20-degree turn: the error falls 4x per halving of the cell (median 2.5e-6 at 6 cm
    cells). Each function costs pixels x 256 sweeps in NumPy (seconds per 10^5 pixels); here
    about 4 / stride^2 of that, plus the cells computed pixel by pixel.
    """
    n0, n1 = grid.shape[:2]
    pixels = grid.reshape(-1, 3)
    track = (bp.positions, bp.velocities, bp.centroid)
    sweeps = len(bp.positions)
    stride = int(np.clip(min(n0, n1) // 64, _FRAME_STRIDE, 2 * _FRAME_STRIDE))
    rows, cols = _sub_grid(n0, stride), _sub_grid(n1, stride)
    nodes = grid[np.ix_(rows, cols)].reshape(-1, 3)
    direction, centre = aspect_frames(nodes, *track)
    first, end = curved_sweep_range(nodes, *track, half_width, (direction, centre))
    cell0, weight0 = _cells(rows, n0)
    cell1, weight1 = _cells(cols, n1)
    shape = (len(rows), len(cols))
    frame = _bilinear(np.column_stack([direction, centre]).reshape(*shape, 4),
                      cell0, weight0, cell1, weight1).reshape(-1, 4)
    frame[:, :3] /= np.linalg.norm(frame[:, :3], axis=-1, keepdims=True)
    low = np.clip(_corners(first.reshape(shape).astype(np.int64), cell0, cell1, np.minimum)
                  .ravel() - _RANGE_MARGIN, 0, sweeps)
    high = np.clip(_corners(end.reshape(shape).astype(np.int64), cell0, cell1, np.maximum)
                   .ravel() + _RANGE_MARGIN, 0, sweeps)
    # Check every cell at its centre and the middles of its first two edges (a direction
    # cosine from a fixed sweep, the frame where the beam centre never crosses, has
    # f_xx = -f_yy nearly: bilinear errs at the edge middles, not at the centre).
    middle0 = (rows[:-1] + rows[1:]) // 2
    middle1 = (cols[:-1] + cols[1:]) // 2
    check = np.stack([(a[:, None] * n1 + b[None, :]).ravel() for a, b in (
        (middle0, middle1), (middle0, cols[:-1]), (rows[:-1], middle1))])
    exact_direction, exact_centre = aspect_frames(pixels[check.ravel()], *track)
    exact_first, exact_end = curved_sweep_range(pixels[check.ravel()], *track, half_width,
                                                (exact_direction, exact_centre))
    at = check.ravel()
    error = (np.abs(frame[at, :3] - exact_direction).sum(axis=-1)
             + np.abs(frame[at, 3] - exact_centre))
    failed = ((error > _FRAME_TOLERANCE) | (low[at] > exact_first) | (high[at] < exact_end)
              ).reshape(3, len(middle0), len(middle1)).any(axis=0)
    padded = np.pad(failed, 1)
    failed = np.zeros_like(failed)
    for shift0 in range(3):  # the failed cells and their neighbours
        for shift1 in range(3):
            failed |= padded[shift0:shift0 + len(middle0), shift1:shift1 + len(middle1)]
    redo = np.flatnonzero(failed[cell0[:, None], cell1[None, :]].ravel())
    if len(redo):
        exact_direction, exact_centre = aspect_frames(pixels[redo], *track)
        frame[redo, :3], frame[redo, 3] = exact_direction, exact_centre
        low[redo], high[redo] = curved_sweep_range(pixels[redo], *track, half_width,
                                                   (exact_direction, exact_centre))
    return ((frame[:, :3], frame[:, 3].copy()),
            (low.astype(np.uint32), high.astype(np.uint32)))


def _sub_grid(count: int, stride: int) -> NDArray:
    """Every ``stride``-th index of ``count`` and the last one."""
    return np.unique(np.append(np.arange(0, count, stride), count - 1))


def _cells(nodes: NDArray, count: int) -> tuple[NDArray, NDArray]:
    """Cell (lower sub-grid node) and fraction towards the next of every index < count."""
    index = np.arange(count)
    cell = np.clip(np.searchsorted(nodes, index, side="right") - 1, 0, len(nodes) - 2)
    return cell, (index - nodes[cell]) / (nodes[cell + 1] - nodes[cell])


def _bilinear(values: NDArray, cell0: NDArray, weight0: NDArray, cell1: NDArray,
              weight1: NDArray) -> NDArray:
    """Values (m0, m1, ...) on a sub-grid, interpolated to the full grid (n0, n1, ...)."""
    along = (values[cell0] * (1 - weight0)[:, None, None]
             + values[cell0 + 1] * weight0[:, None, None])
    return (along[:, cell1] * (1 - weight1)[None, :, None]
            + along[:, cell1 + 1] * weight1[None, :, None])


def _corners(values: NDArray, cell0: NDArray, cell1: NDArray, pick: np.ufunc) -> NDArray:
    """``pick`` (minimum or maximum) of a sub-grid's values over every pixel's cell corners."""
    edge0 = pick(values[cell0], values[cell0 + 1])
    return pick(edge0[:, cell1], edge0[:, cell1 + 1])


# --------------------------------------------------------------------------------------------
# Options, pixels and the image plane
# --------------------------------------------------------------------------------------------
def _options(options: dict | None) -> dict:
    """Defaults completed and checked (:data:`FFBP_DEFAULTS`)."""
    settings = dict(FFBP_DEFAULTS)
    for key, value in (options or {}).items():
        if key not in FFBP_DEFAULTS:
            raise ParameterError("focus", "algorithm_options",
                                 f"FFBP options among {sorted(FFBP_DEFAULTS)}", key)
        settings[key] = value
    for key in ("factor", "first_subaperture", "final_subapertures", "lookup_upsample"):
        value = settings[key]
        low = 2 if key in ("factor", "first_subaperture") else 1
        if isinstance(value, bool) or not (isinstance(value, int | np.integer) and value >= low):
            raise ParameterError("focus", f"algorithm_options['{key}']", f"an integer >= {low}",
                                 value)
    for key in ("angle_oversample", "range_oversample", "first_angle_oversample"):
        value = settings[key]
        if (isinstance(value, bool) or not isinstance(value, int | float)
                or not 1 <= value <= MAX_OVERSAMPLE):
            raise ParameterError("focus", f"algorithm_options['{key}']",
                                 f"a number from 1 to {MAX_OVERSAMPLE:g}", value)
        settings[key] = float(value)
    return settings


def _pixel_array(layout_or_pixels: dict | NDArray) -> NDArray:
    if isinstance(layout_or_pixels, dict):
        return np.asarray(layout_or_pixels["position"], dtype=float).reshape(-1, 3)
    pixels = np.asarray(layout_or_pixels, dtype=float)
    if pixels.ndim != 2 or pixels.shape[1] != 3:
        raise ParameterError("focus_ffbp", "layout_or_pixels", "a layout or pixels (P, 3)",
                             pixels.shape)
    return pixels


def _pixel_sample(layout_or_pixels: dict | NDArray, count: int = 4096,
                  border_count: int = 1024) -> NDArray:
    """Pixels that bound the extent of the image: a grid's border and a strided interior.

    On a grid the extremes of range and direction cosine from a point off the plane lie on
    the border (range is convex along each border line, the cones of constant direction cosine
    cut the plane in conics), so the border is kept at ``border_count`` points and the interior
    at ``count / 16``; for scattered pixels ``count`` of them and their extremes.
    """
    if isinstance(layout_or_pixels, dict):
        grid = np.asarray(layout_or_pixels["position"], dtype=float)
        stride = max(1, (2 * (grid.shape[0] + grid.shape[1])) // border_count)
        border = np.concatenate([grid[0, ::stride], grid[-1, ::stride], grid[::stride, 0],
                                 grid[::stride, -1], grid[[0, 0, -1, -1], [0, -1, 0, -1]]])
        count = max(1, count // 16)
        step = max(1, int(math.ceil(math.sqrt(grid.shape[0] * grid.shape[1] / count))))
        return np.concatenate([border, grid[::step, ::step].reshape(-1, 3)])
    pixels = np.asarray(layout_or_pixels, dtype=float)
    step = max(1, len(pixels) // count)
    centred = pixels - pixels.mean(axis=0)
    extremes = np.concatenate([np.argmin(centred, axis=0), np.argmax(centred, axis=0)])
    return np.concatenate([pixels[::step], pixels[extremes]])


def _image_plane(sample: NDArray, positions: NDArray) -> tuple[NDArray, NDArray]:
    """Unit normal and a point of the plane that holds the pixels.

    The least-squares plane of the pixels; for pixels on a line or at one point, the plane
    through them that holds the track's mean direction (a slant plane).
    """
    centre = sample.mean(axis=0)
    _, singular, basis = np.linalg.svd(sample - centre, full_matrices=False)
    scale = max(float(singular[0]), 1e-12)
    if len(singular) == 3 and singular[1] > 1e-6 * scale:
        return basis[2], centre
    track = positions[-1] - positions[0]
    look = centre - positions.mean(axis=0)
    line = basis[0] if singular[0] > 1e-9 else track
    normal = np.cross(line, look) if singular[0] > 1e-9 else np.cross(track, look)
    return normal / np.linalg.norm(normal), centre


# --------------------------------------------------------------------------------------------
# Sub-apertures and their polar grids
# --------------------------------------------------------------------------------------------
def _plan(sweeps: int, settings: dict, longest: int, cap: int | None = None
          ) -> list[NDArray]:
    """Sweep boundaries of every stage's sub-apertures: a list of (J_s + 1,) arrays.

    Merging stops at ``final_subapertures`` or before a stage whose sub-apertures would hold
    more than ``longest`` sweeps (:func:`_longest_subaperture`) or more than ``cap`` (the
    longest pixel band: a sub-aperture longer than every band is never a piece of one,
    :func:`mitsar.focus.ffbp_band.merge_band`).
    """
    size = settings["first_subaperture"]
    if size > longest:
        raise ParameterError(
            "focus", "algorithm_options['first_subaperture']",
            f"at most {longest} sweeps at this geometry (a polar grid's range sampling holds "
            "the range curvature of a sub-aperture only up to a length, docs/focusing.md "
            "§ FFBP)", size)
    bounds = np.unique(np.append(np.arange(0, sweeps, size), sweeps))
    stages = [bounds]
    while ((len(bounds) - 1 > settings["final_subapertures"] or cap is not None)
           and size * settings["factor"] <= min(longest, cap or longest)):
        size *= settings["factor"]
        bounds = np.unique(np.append(bounds[::settings["factor"]], sweeps))
        stages.append(bounds)
    return stages


_CURVATURE_SHARE = 0.15
"""Range bandwidth a sub-aperture's range curvature may add to its polar image, as a share
of the range Nyquist frequency ``q_r B / c`` (:func:`_longest_subaperture`)."""


def _longest_subaperture(track: NDArray, sample: NDArray, radar: Radar, settings: dict) -> int:
    """Most sweeps a sub-aperture may hold for its polar image to stay sampled in range.

    Seen from a sub-aperture's centre, a sweep at offset s along it reaches a point at range
    rho by ``rho - s alpha + s^2 (1 - alpha^2) / (2 rho)`` (second order in s/rho): after
    demodulation the last term varies with rho at up to ``L^2 / (4 lambda rho^2)`` cycles per
    metre (two-way, |s| <= L/2) on top of the compressed pulse's ``B / c``. With range
    steps ``c / (2 B q_r)`` the polar image stays interpolable while that stays below
    :data:`_CURVATURE_SHARE` of ``q_r B / c``: ``L <= 2 rho_min sqrt(share q_r lambda B /
    c)``. Measured on the paper geometry (8 m, 4096 sweeps, ``q_r`` = 4): sub-apertures of
    1 m (the default plan) -32.5 dB from exact BPA, 2.7 m -19.7 dB, 4.1 m -6.9 dB; this
    bound allows 1.57 m there (docs/focusing.md § FFBP).
    """
    step = max(1, len(track) // 64)
    offsets = track[::step, None, :] - sample[None, :, :]
    rho_min = float(np.sqrt((offsets**2).sum(axis=-1)).min())
    limit = 2 * rho_min * math.sqrt(_CURVATURE_SHARE * settings["range_oversample"]
                                    * radar.wavelength * radar.bandwidth / SPEED_OF_LIGHT)
    spacing = float(np.linalg.norm(np.diff(track, axis=0), axis=-1).max(initial=0.0))
    return max(1, int(limit / spacing)) if spacing > 0 else len(track)


def _make_stage(bounds: NDArray, positions: NDArray, velocities: NDArray, sample: NDArray,
                normal: NDArray, plane_point: NDArray, rho_step: float, wavelength: float,
                angle_oversample: float, margin: int, support: tuple[float, float],
                alpha_multiple: int = 1, receivers: NDArray | None = None) -> Stage:
    """Centres, axes and polar-grid extents of the sub-apertures between ``bounds``.

    ``margin``: range nodes added beyond the pixels on every side (:data:`_MARGIN`; in angle
    at most :data:`_ANGLE_MARGIN`). ``N_alpha`` is
    rounded up to a multiple of ``alpha_multiple`` (lanes of the first stage). ``receivers``:
    a bistatic channel's receiver per sweep [m] (``positions``: its transmitter's), whose
    centre each sub-aperture keeps for the demodulation (step 3); the polar grids stay the
    transmitter's.
    """
    first, end = bounds[:-1], bounds[1:]
    last = end - 1
    middle_low, middle_high = (first + last) // 2, (first + last + 1) // 2
    centre = 0.5 * (positions[middle_low] + positions[middle_high])
    receiver = receiver_axis = None
    if receivers is not None:
        receiver = 0.5 * (receivers[middle_low] + receivers[middle_high])
    chord = positions[last] - positions[first]
    mean_velocity = np.add.reduceat(velocities, first, axis=0)
    fallback = mean_velocity / np.maximum(np.linalg.norm(mean_velocity, axis=-1), 1e-12)[:, None]
    length = np.linalg.norm(chord, axis=-1)
    axis = np.where(length[:, None] > 1e-9, chord / np.maximum(length, 1e-12)[:, None], fallback)
    if receivers is not None:  # the receiver's chord per unit of the transmitter's
        receiver_axis = np.where(length[:, None] > 1e-9, (receivers[last] - receivers[first])
                                 / np.maximum(length, 1e-12)[:, None], fallback)
    longest = float(length.max()) + _spacing(positions)
    alpha_step = wavelength / (2 * longest * angle_oversample)
    # |x - c| and a.(x - c) by products (no (J, Q, 3) temporary; local frame, ranges ~10 m:
    # the expansion of |x - c|^2 loses ~1e-14 m^2).
    square = ((sample**2).sum(axis=-1)[None, :] - 2.0 * (centre @ sample.T)
              + (centre**2).sum(axis=-1)[:, None])
    rho = np.sqrt(np.maximum(square, 0.0))
    alpha = (axis @ sample.T - np.einsum("ji,ji->j", axis, centre)[:, None]) / rho
    parallax = longest / rho.min()
    low = np.maximum(alpha.min(axis=1), support[0] - parallax)
    high = np.minimum(alpha.max(axis=1), support[1] + parallax)
    high = np.maximum(high, low)
    rho0 = rho.min(axis=1) - margin * rho_step
    angle_margin = min(margin, _ANGLE_MARGIN)
    alpha0 = np.maximum(low - angle_margin * alpha_step, -1.0)
    n_rho = int(np.ceil((rho.max(axis=1) - rho.min(axis=1)).max() / rho_step)) + 2 * margin + 1
    n_alpha = int(np.ceil((high - low).max() / alpha_step)) + 2 * angle_margin + 1
    n_alpha = -(-n_alpha // alpha_multiple) * alpha_multiple
    return Stage(first, end, centre, axis, rho0, alpha0, rho_step, alpha_step,
                 (n_rho, n_alpha), length, receiver, receiver_axis)


NODE_BYTES = 56
"""Peak bytes per polar-grid node: its (real, imag) float32 word and weight sum, the four-tap
rows its parent reads (4 words), and the parent's own word and sum while both live."""


def _check_nodes(stage: Stage, first: bool) -> None:
    """Refuse polar grids that Dr.Jit cannot index or memory cannot hold, before any kernel.

    A Dr.Jit array holds at most 2^32 - 1 entries, and the tap rows hold four per node.
    """
    nodes = len(stage.first) * stage.shape[0] * stage.shape[1]
    keys = ("'angle_oversample', 'first_angle_oversample', 'range_oversample'" if first
            else "'angle_oversample', 'range_oversample'")
    parameter = f"algorithm_options[{keys}]"
    if 4 * nodes >= 2**32:
        raise ParameterError(
            "focus", parameter, "polar grids of fewer than 2^30 nodes a stage (lower the "
            "oversampling, or focus a smaller grid)",
            f"{nodes:.3g} nodes ({len(stage.first)} sub-apertures of {stage.shape[0]} ranges x "
            f"{stage.shape[1]} angles)")
    require_memory("focus", parameter, float(nodes) * NODE_BYTES,
                   "lower the FFBP oversampling or focus a smaller grid")


def _baseline(raw: xr.Dataset) -> float:
    """Distance [m] between the transmitter and the receiver of a one-channel view
    (:func:`mitsar.focus.channels.channel_view`; 0: monostatic)."""
    if "transmitter_offset" not in raw.variables:
        return 0.0
    return float(np.linalg.norm(np.asarray(raw["receiver_offset"].values, dtype=float)
                                - np.asarray(raw["transmitter_offset"].values, dtype=float)))


def _spacing(positions: NDArray) -> float:
    """Mean distance between consecutive sweeps [m]."""
    return float(np.linalg.norm(np.diff(positions, axis=0), axis=-1).mean())


def _children_of(child: Stage, parent: Stage) -> tuple[NDArray, NDArray]:
    """First and end child index of every parent sub-aperture."""
    return (np.searchsorted(child.first, parent.first).astype(np.uint32),
            np.searchsorted(child.first, parent.end).astype(np.uint32))
