"""Fast factorised back-projection (FFBP) of dechirped FMCW data, for any track and any grid.

After Ulander, Hellsten & Stenström, "Synthetic-aperture radar processing using fast factorized
back-projection", IEEE TAES 39(3):760-776, 2003. The track is cut into sub-apertures; a
sub-aperture of length L can only resolve angles to about ``lambda / (2 L)``, so its image is
held on a coarse *local polar grid* (range ``rho`` from the sub-aperture centre c by direction
cosine ``alpha = a . (x - c) / rho`` about its axis a), and sub-apertures are merged, a factor
at a time, onto the finer polar grids of their parents by interpolation.

Steps of :func:`focus_ffbp`:

1. band selection and range compression exactly as :func:`mitsar.focus.bpa.focus_bpa`
   (``"doppler"`` band-pass on straight uniform tracks with a band narrower than the beam,
   ``"pixel"`` weighting otherwise; :func:`mitsar.focus.compression.range_spectrum`);
2. first stage: every sub-aperture of ``first_subaperture`` sweeps is back-projected exactly,
   with the BPA kernel (:func:`mitsar.focus.backprojection.backproject_drjit`: beat frequency
   ``K tau + f_c dtau/dt``, Meta 2007 §II-B, and de-rotation by ``exp(-j 2 pi f_c tau)``),
   onto the nodes of its polar grid; the nodes are points of the image plane (the plane that
   holds the output pixels: least squares through them), so the sub-aperture images are exact
   there for any track, bends included; each node also keeps the sum of its sweeps' azimuth
   weights (for the normalisation);
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
   (rho_P + rho_j)`` so that float32 keeps it (a Dr.Jit kernel):
   one lane per node and a symbolic loop over its children; each tap is one 64-bit gather of
   a (real, imag) float32 pair; the sums of the weights only where the normalisation reads
   them ("pixel" band selection);
5. final stage: the remaining sub-apertures are merged onto the output pixels the same way,
   re-modulated in float64 by the range from a local origin, and normalised as BPA
   (:func:`mitsar.focus.aperture.full_aperture_weight`, :func:`normalise_image`), so a unit
   point focuses to about 1.

The azimuth window: each sweep is weighted at the first-stage nodes exactly as BPA weights it
at a pixel (the window at the node's direction sine), so bends of the track are handled (a
sweep past a turn that no longer sees a node gets weight 0); the window is then known to one
first-stage angular cell, which is why ``"pixel"`` band selection with a band narrower than the
beam (a hard cut per pixel and sweep) is refused: polar sub-aperture images cannot hold it
(measured -7 dB on the curved test track; use BPA there).

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
from dataclasses import dataclass
from typing import Any

import drjit as dr
import numpy as np
import xarray as xr
from drjit.llvm import Float32, UInt32, UInt64
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.backend import require_llvm
from mitsar.errors import ParameterError
from mitsar.focus.aperture import (
    sweep_window,
)
from mitsar.focus.backprojection import (
    backproject_drjit,
    carrier_turns,
    derotate,
    interpolate,
    jit_array,
)
from mitsar.focus.bp_setup import normalise, prepare
from mitsar.focus.grid import track_frame
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.raw.product import radar_of

__all__ = ["FFBP_DEFAULTS", "focus_ffbp"]

FFBP_DEFAULTS: dict[str, float | str] = {
    "factor": 4, "first_subaperture": 8, "final_subapertures": 8, "angle_oversample": 4.0,
    "range_oversample": 4.0, "first_angle_oversample": 2.0, "lookup_upsample": 16}
"""Default FFBP options (see the module docstring)."""

_MARGIN = 3
"""Polar-grid nodes added beyond the pixels on every side, per remaining stage (cubic taps)."""


@dataclass
class _Stage:
    """Sub-apertures of one stage and their polar images (arrays over sub-apertures j)."""

    first: NDArray           # (J,) first sweep
    end: NDArray             # (J,) end sweep
    centre: NDArray          # (J, 3) [m], relative to the local origin
    axis: NDArray            # (J, 3) unit
    rho0: NDArray            # (J,) first range node [m]
    alpha0: NDArray          # (J,) first direction-cosine node
    rho_step: float
    alpha_step: float
    shape: tuple[int, int]   # (N_rho, N_alpha)
    values: NDArray | None = None  # (J, N_rho, N_alpha) demodulated images
    totals: NDArray | None = None  # (J, N_rho, N_alpha) sums of the sweeps' weights


def focus_ffbp(raw: xr.Dataset, layout_or_pixels: dict | NDArray, *, half_width: float,
               window: str, range_window: str, remove_rvp: bool, motion_correction: bool,
               range_upsample: int, options: dict | None = None, band_selection: str | None = None,
               progress: bool = False) -> tuple[NDArray, NDArray, dict]:
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

    Returns
    -------
    values : ndarray, shape (P,), complex
    coverage : ndarray, shape (P,)
    extra : dict
        Processing attributes (band selection, options, stage count).
    """
    require_llvm()
    settings = _options(options)
    pixels = _pixel_array(layout_or_pixels)
    sweeps = raw.sizes["sweep"]
    stages = _plan(sweeps, settings)
    rho_step = radar_of(raw).range_resolution / settings["range_oversample"]
    # The first stage's polar grids reach (margin + 1) range steps and half a sub-aperture
    # past the pixels' ranges (_make_stage): compress only that band (bp_setup.beat_band).
    track = raw["platform_position"].values
    reach = ((_MARGIN * len(stages) + 1) * rho_step
             + settings["first_subaperture"]
             * float(np.linalg.norm(np.diff(track, axis=0), axis=-1).max(initial=0.0)))
    bp = prepare(raw, half_width=half_width, window=window, range_window=range_window,
                 remove_rvp=remove_rvp,
                 range_upsample=min(range_upsample, settings["lookup_upsample"]),
                 band_selection=band_selection, points=_pixel_sample(layout_or_pixels),
                 range_margin=reach)
    if bp.band_selection == "pixel" and half_width < bp.beam_half_width:
        raise ParameterError(
            "focus", "azimuth_resolution",
            "the whole beam (None) for FFBP on a curved track or a varying speed: a narrower "
            "band is cut per pixel and sweep, which polar sub-aperture images cannot hold "
            "(use algorithm='bpa')", f"a half width of {half_width:.4g} in direction sine")
    radar, positions, velocities = bp.radar, bp.positions, bp.velocities
    frequency, profile = bp.frequency, bp.profile
    mean_speed, mean_centroid = bp.mean_speed, bp.mean_centroid
    kernel_half_width, kernel_window = bp.kernel_half_width, bp.kernel_window

    # Geometry relative to a local origin near the pixels (float32 kernels; docs/focusing.md).
    origin_local = pixels.mean(axis=0)
    sample = _pixel_sample(layout_or_pixels) - origin_local
    local_positions = positions - origin_local
    normal, plane_point = _image_plane(sample, local_positions)
    wavenumber = 2 * radar.carrier_frequency / SPEED_OF_LIGHT  # two-way, cycles per metre
    window_support = (mean_centroid - kernel_half_width, mean_centroid + kernel_half_width)
    bar = tqdm(total=len(stages) + 1, disable=not progress, desc="FFBP", unit="stage")

    # First stage: exact back-projection onto the nodes of every sub-aperture's polar grid.
    stage = _make_stage(stages[0], local_positions, velocities, sample, normal, plane_point,
                        rho_step, radar.wavelength,
                        settings["angle_oversample"] * settings["first_angle_oversample"],
                        _MARGIN * len(stages), window_support)
    nodes = _node_positions(stage, normal, plane_point)
    flat_nodes = nodes.reshape(-1, 3) + origin_local
    node_count = stage.shape[0] * stage.shape[1]
    sweep_range = (np.repeat(stage.first, node_count).astype(np.uint32),
                   np.repeat(stage.end, node_count).astype(np.uint32))
    sums, totals = backproject_drjit(profile, frequency, radar, flat_nodes, positions,
                                     velocities, bp.centroid, kernel_half_width, kernel_window,
                                     motion_correction, sweep_range=sweep_range)
    # The nodes lie at the grid's ranges from their centre (by construction).
    rho = (stage.rho0[:, None] + stage.rho_step * np.arange(stage.shape[0]))[:, :, None]
    stage.values = (sums.reshape(nodes.shape[:3])
                    * np.exp(2j * np.pi * carrier_turns(rho, wavenumber, np.floor)))
    stage.totals = totals.reshape(nodes.shape[:3])
    bar.update()

    # Merge stages (the sums of the weights only where the normalisation reads them).
    with_totals = bp.band_selection != "doppler"
    for index, groups in enumerate(stages[1:], start=1):
        parent = _make_stage(groups, local_positions, velocities, sample, normal, plane_point,
                             rho_step, radar.wavelength, settings["angle_oversample"],
                             _MARGIN * (len(stages) - index), window_support)
        nodes = _node_positions(parent, normal, plane_point)
        per_node = nodes.shape[1] * nodes.shape[2]
        children = _children_of(stage, parent)
        first_child = np.repeat(children[0], per_node)
        end_child = np.repeat(children[1], per_node)
        reference = np.repeat(parent.centre, per_node, axis=0)
        merged, totals = _merge(stage, nodes.reshape(-1, 3), reference, first_child,
                                end_child, wavenumber, with_totals)
        parent.values = merged.reshape(nodes.shape[:3])
        parent.totals = totals.reshape(nodes.shape[:3])
        stage = parent
        bar.update()

    # Final stage: onto the pixels, with the azimuth window per sub-aperture.
    local_pixels = pixels - origin_local
    if bp.straight:
        origin, direction, _ = track_frame(raw)
        first, end = sweep_window(pixels, origin, direction, mean_speed / radar.prf,
                                  len(positions), mean_centroid, kernel_half_width)
        first_child = np.searchsorted(stage.end, first, side="right").astype(np.uint32)
        end_child = np.searchsorted(stage.first, end, side="left").astype(np.uint32)
    else:
        first_child = np.zeros(len(pixels), dtype=np.uint32)
        end_child = np.full(len(pixels), len(stage.first), dtype=np.uint32)
    merged, total = _merge(stage, local_pixels, np.zeros((1, 3)), first_child, end_child,
                           wavenumber, with_totals)
    # Re-modulate by the carrier of the range from the local origin, in float64.
    merged *= np.exp(-2j * np.pi * carrier_turns(np.linalg.norm(local_pixels, axis=-1),
                                                 wavenumber, np.floor))
    bar.update()
    bar.close()

    values, coverage = normalise(bp, raw, pixels, merged, total, half_width)
    extra = {"band_selection": bp.band_selection, "ffbp_stages": len(stages),
             **{f"ffbp_{key}": value for key, value in settings.items()}}
    return values, coverage, extra


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
        if not (isinstance(value, int | np.integer) and value >= low):
            raise ParameterError("focus", f"algorithm_options['{key}']", f"an integer >= {low}",
                                 value)
    for key in ("angle_oversample", "range_oversample", "first_angle_oversample"):
        value = settings[key]
        if not (isinstance(value, int | float) and math.isfinite(value) and value >= 1):
            raise ParameterError("focus", f"algorithm_options['{key}']", "a number >= 1",
                                 value)
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
def _plan(sweeps: int, settings: dict) -> list[NDArray]:
    """Sweep boundaries of every stage's sub-apertures: a list of (J_s + 1,) arrays."""
    bounds = np.unique(np.append(np.arange(0, sweeps, settings["first_subaperture"]), sweeps))
    stages = [bounds]
    while len(bounds) - 1 > settings["final_subapertures"]:
        bounds = np.unique(np.append(bounds[::settings["factor"]], sweeps))
        stages.append(bounds)
    return stages


def _make_stage(bounds: NDArray, positions: NDArray, velocities: NDArray, sample: NDArray,
                normal: NDArray, plane_point: NDArray, rho_step: float, wavelength: float,
                angle_oversample: float, margin: int, support: tuple[float, float]) -> _Stage:
    """Centres, axes and polar-grid extents of the sub-apertures between ``bounds``."""
    first, end = bounds[:-1], bounds[1:]
    last = end - 1
    middle_low, middle_high = (first + last) // 2, (first + last + 1) // 2
    centre = 0.5 * (positions[middle_low] + positions[middle_high])
    chord = positions[last] - positions[first]
    mean_velocity = np.add.reduceat(velocities, first, axis=0)
    fallback = mean_velocity / np.maximum(np.linalg.norm(mean_velocity, axis=-1), 1e-12)[:, None]
    length = np.linalg.norm(chord, axis=-1)
    axis = np.where(length[:, None] > 1e-9, chord / np.maximum(length, 1e-12)[:, None], fallback)
    longest = float(length.max()) + _spacing(positions)
    alpha_step = wavelength / (2 * longest * angle_oversample)
    offset = sample[None, :, :] - centre[:, None, :]
    rho = np.linalg.norm(offset, axis=-1)
    alpha = np.einsum("jpi,ji->jp", offset, axis) / rho
    parallax = longest / rho.min()
    low = np.maximum(alpha.min(axis=1), support[0] - parallax)
    high = np.minimum(alpha.max(axis=1), support[1] + parallax)
    high = np.maximum(high, low)
    rho0 = rho.min(axis=1) - margin * rho_step
    alpha0 = np.maximum(low - margin * alpha_step, -1.0)
    n_rho = int(np.ceil((rho.max(axis=1) - rho.min(axis=1)).max() / rho_step)) + 2 * margin + 1
    n_alpha = int(np.ceil((high - low).max() / alpha_step)) + 2 * margin + 1
    return _Stage(first, end, centre, axis, rho0, alpha0, rho_step, alpha_step,
                  (n_rho, n_alpha))


def _spacing(positions: NDArray) -> float:
    """Mean distance between consecutive sweeps [m]."""
    return float(np.linalg.norm(np.diff(positions, axis=0), axis=-1).mean())


def _node_positions(stage: _Stage, normal: NDArray, plane_point: NDArray) -> NDArray:
    """World positions (local frame) of the polar-grid nodes, shape (J, N_rho, N_alpha, 3).

    Node (rho, alpha) of sub-aperture j is where the sphere ``|x - c| = rho``, the cone
    ``a . (x - c) = rho alpha`` and the image plane meet, on the side of the pixels:
    ``x = c + rho (alpha a + s (cos phi b1 + sin phi b2))``, ``s = sqrt(1 - alpha^2)``, with
    ``A cos phi + B sin phi = C`` from the plane equation: ``A = rho s (b1 . n)``,
    ``B = rho s (b2 . n)``, so ``phi = beta +- gamma`` with ``beta = atan2(b2 . n, b1 . n)``
    (per sub-aperture) and ``cos gamma = C / sqrt(A^2 + B^2)``; the sign is the one that puts
    the node on the pixels' side, ``sign((x - c) . (n x a))`` of the plane centre. Written with
    ``cos gamma`` and ``sin gamma = sqrt(1 - cos^2 gamma)`` only (no inverse trigonometry),
    on (J, N_rho, N_alpha) arrays.
    """
    rho = (stage.rho0[:, None] + stage.rho_step * np.arange(stage.shape[0]))[:, :, None]
    alpha = np.clip(stage.alpha0[:, None] + stage.alpha_step * np.arange(stage.shape[1]),
                    -1.0, 1.0)[:, None, :]
    sine = np.sqrt(1 - alpha**2)
    axis = stage.axis
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    b1 = np.cross(axis, helper)
    b1 /= np.linalg.norm(b1, axis=-1, keepdims=True)
    b2 = np.cross(axis, b1)

    def per_j(vector: NDArray) -> NDArray:
        return vector[:, None, None]

    b1n, b2n = b1 @ normal, b2 @ normal
    beta = np.arctan2(b2n, b1n)
    cos_beta, sin_beta = per_j(np.cos(beta)), per_j(np.sin(beta))
    height = per_j((stage.centre - plane_point) @ normal)
    projection = per_j(np.hypot(b1n, b2n))
    cos_gamma = np.clip((-height - rho * alpha * per_j(axis @ normal))
                        / np.maximum(rho * sine * projection, 1e-12), -1.0, 1.0)
    sin_gamma = np.sqrt(1 - cos_gamma**2)
    # The pixels' side: the sign of (x - c) . (n x a) that the plane centre has.
    side_vector = np.cross(normal[None, :], axis)
    side = np.sign(np.einsum("ji,ji->j", plane_point - stage.centre, side_vector))
    side = per_j(np.where(side == 0, 1.0, side))
    p, q = (np.einsum("ji,ji->j", b, side_vector) for b in (b1, b2))
    lateral_plus = (alpha * per_j(np.einsum("ji,ji->j", axis, side_vector))
                    + sine * (cos_gamma * per_j(np.cos(beta) * p + np.sin(beta) * q)
                              + sin_gamma * per_j(np.cos(beta) * q - np.sin(beta) * p)))
    sign = np.where(np.sign(lateral_plus) == side, 1.0, -1.0)
    cos_phi = cos_beta * cos_gamma - sign * sin_beta * sin_gamma
    sin_phi = sin_beta * cos_gamma + sign * cos_beta * sin_gamma
    radial = rho * sine
    out = np.empty((*cos_phi.shape, 3))
    for i in range(3):
        out[..., i] = (per_j(stage.centre[:, i]) + rho * alpha * per_j(axis[:, i])
                       + radial * (cos_phi * per_j(b1[:, i]) + sin_phi * per_j(b2[:, i])))
    return out


def _children_of(child: _Stage, parent: _Stage) -> tuple[NDArray, NDArray]:
    """First and end child index of every parent sub-aperture."""
    return (np.searchsorted(child.first, parent.first).astype(np.uint32),
            np.searchsorted(child.first, parent.end).astype(np.uint32))


# --------------------------------------------------------------------------------------------
# The merge kernel
# --------------------------------------------------------------------------------------------
def _merge(stage: _Stage, points: NDArray, reference: NDArray, first_child: NDArray,
           end_child: NDArray, wavenumber: float, with_totals: bool = True,
           chunk: int = 1 << 22) -> tuple[NDArray, NDArray]:
    """Sum of the children's images at ``points``, demodulated about ``reference``.

    Returns ``sum_j V_j(rho_j, alpha_j) exp(j 2 pi k (rho_ref - rho_j))`` (k: two-way
    wavenumber ``2 f_c / c`` in cycles per metre) and ``sum_j T_j`` (T_j: the child's
    interpolated sum of sweep weights; zeros unless ``with_totals``). One kernel lane per
    point, a symbolic loop over its children ``first_child <= j < end_child``, in chunks of
    ``chunk`` points.
    """
    n_rho, n_alpha = stage.shape
    f32 = np.float32

    def column(array: NDArray, index: int) -> Float32:
        return jit_array(Float32, array[:, index], f32)

    child = [column(stage.centre, i) for i in range(3)] + [column(stage.axis, i)
                                                           for i in range(3)]
    child += [jit_array(Float32, stage.rho0, f32), jit_array(Float32, stage.alpha0, f32)]
    # (real, imag) float32 pairs, one 64-bit word per node: one gather per tap.
    values = jit_array(UInt64, np.ascontiguousarray(stage.values, dtype=np.complex64)
                       .view(np.uint64).ravel(), np.uint64)
    totals = jit_array(Float32, stage.totals.ravel() if with_totals else np.zeros(1), f32)
    scalars = {"rho_step": dr.opaque(Float32, stage.rho_step),
               "alpha_step": dr.opaque(Float32, stage.alpha_step),
               "n_rho": dr.opaque(UInt32, n_rho), "n_alpha": dr.opaque(UInt32, n_alpha),
               "wavenumber": dr.opaque(Float32, wavenumber)}
    reference = np.broadcast_to(reference, points.shape)
    out = np.zeros((3, len(points)))
    for start in range(0, len(points), chunk):
        part = slice(start, start + chunk)
        point_data = [jit_array(Float32, a[part, i], f32) for a in (points, reference)
                      for i in range(3)]
        result = _merge_loop(point_data, jit_array(UInt32, first_child[part], np.uint32),
                             jit_array(UInt32, end_child[part], np.uint32), child, values,
                             totals, scalars, with_totals)
        dr.eval(*result)
        for row, value in enumerate(result):
            out[row, part] = np.asarray(value, dtype=float)
    return out[0] + 1j * out[1], out[2]


def _merge_loop(point_data: list, first: UInt32, end: UInt32, child: list, values: UInt64,
                totals: Float32, scalars: dict, with_totals: bool) -> tuple:
    """One lane per point, a symbolic loop over its children (:func:`_merge_lanes`)."""
    width = dr.width(first)

    def condition(k: UInt32, *_: Float32) -> Any:
        return k < end

    def body(k: UInt32, acc_real: Float32, acc_imag: Float32, acc_total: Float32) -> tuple:
        part_real, part_imag, part_total = _merge_lanes(k, point_data, child, values, totals,
                                                        scalars, with_totals)
        return k + 1, acc_real + part_real, acc_imag + part_imag, acc_total + part_total

    state = (UInt32(first), *[dr.zeros(Float32, width) for _ in range(3)])
    return dr.while_loop(state, condition, body)[1:]


def _keys(t: Float32) -> tuple[Float32, Float32, Float32, Float32]:
    """Keys cubic-convolution weights (a = -1/2) of the taps at -1, 0, 1, 2 for offset t."""
    t2 = t * t
    t3 = t2 * t
    return (-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0,
            -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2)


def _merge_lanes(k: UInt32, point_data: list, child: list, values: UInt64, totals: Float32,
                 scalars: dict, with_totals: bool) -> tuple[Float32, Float32, Float32]:
    """Child k's re-phased image at the lane's point (steps 4-5 of the module docstring)."""
    x, y, z, rx, ry, rz = point_data
    cx_all, cy_all, cz_all, ax_all, ay_all, az_all, rho0_all, alpha0_all = child
    rho_step, alpha_step = scalars["rho_step"], scalars["alpha_step"]
    n_rho, n_alpha, wavenumber = scalars["n_rho"], scalars["n_alpha"], scalars["wavenumber"]
    cx = dr.gather(Float32, cx_all, k)
    cy = dr.gather(Float32, cy_all, k)
    cz = dr.gather(Float32, cz_all, k)
    ox, oy, oz = x - cx, y - cy, z - cz
    rho = dr.sqrt(ox * ox + oy * oy + oz * oz)
    alpha = (ox * dr.gather(Float32, ax_all, k) + oy * dr.gather(Float32, ay_all, k)
             + oz * dr.gather(Float32, az_all, k)) / rho
    u = (rho - dr.gather(Float32, rho0_all, k)) / rho_step
    v = (alpha - dr.gather(Float32, alpha0_all, k)) / alpha_step
    iu = dr.floor(u)
    iv = dr.floor(v)
    fu = dr.clip(u - iu, 0.0, 1.0)
    fv = dr.clip(v - iv, 0.0, 1.0)
    wu = _keys(fu)
    wv = _keys(fv)
    # Outside a child's grid its image is zero (the grid holds the window's support).
    valid = ((iu >= 1.0) & (iu <= Float32(n_rho - 3)) & (iv >= 1.0)
             & (iv <= Float32(n_alpha - 3)))
    iu = dr.clip(iu, 1.0, Float32(n_rho - 3))
    iv = dr.clip(iv, 1.0, Float32(n_alpha - 3))
    base = k * n_rho * n_alpha + (UInt32(iu) - 1) * n_alpha + UInt32(iv) - 1
    child_total = Float32(0.0)
    if with_totals:
        # Sweep weights: bilinear (they vary on the scale of the window, not of the phase).
        inner = base + n_alpha + 1
        weights_row = interpolate(dr.gather(Float32, totals, inner, valid),
                                  dr.gather(Float32, totals, inner + 1, valid), fv)
        weights_next = interpolate(dr.gather(Float32, totals, inner + n_alpha, valid),
                                   dr.gather(Float32, totals, inner + n_alpha + 1, valid), fv)
        child_total = interpolate(weights_row, weights_next, fu)
    v_real = Float32(0.0)
    v_imag = Float32(0.0)
    for a in range(4):
        row_real = Float32(0.0)
        row_imag = Float32(0.0)
        for b in range(4):
            word = dr.gather(UInt64, values, base + a * n_alpha + b, valid)
            row_real += wv[b] * dr.reinterpret_array(Float32, UInt32(word))
            row_imag += wv[b] * dr.reinterpret_array(Float32, UInt32(word >> 32))
        v_real += wu[a] * row_real
        v_imag += wu[a] * row_imag
    # rho_ref - rho_j = (c_j - c_ref) . (2 y - c_ref - c_j) / (rho_ref + rho_j): no
    # cancellation in float32 (docs/focusing.md, kernel speed).
    gx, gy, gz = cx - rx, cy - ry, cz - rz
    sx, sy, sz = x - rx, y - ry, z - rz
    rho_ref = dr.sqrt(sx * sx + sy * sy + sz * sz)
    difference = (gx * (sx + ox) + gy * (sy + oy) + gz * (sz + oz)) / (rho_ref + rho)
    turns = carrier_turns(difference, wavenumber, dr.floor)
    sin_phase, cos_phase = dr.sincos(2 * dr.pi * turns)
    # exp(+j phase): derotate by -phase.
    part_real, part_imag = derotate(v_real, v_imag, -sin_phase, cos_phase)
    return part_real, part_imag, child_total
