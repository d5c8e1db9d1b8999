"""The stages of fast factorised back-projection as Dr.Jit kernels (:mod:`mitsar.focus.ffbp`).

A stage is a set of sub-apertures, each with a local polar grid in the image plane
(:class:`Stage`); its images stay in Dr.Jit memory from stage to stage (one 64-bit word per
node, a (real, imag) float32 pair, and a float32 sum of sweep weights), and its nodes are never
held as arrays: every kernel lane finds its node's position from its index and the
sub-aperture's frame (:func:`polar_node`, float64). Kernels:

- :func:`first_stage`: exact back-projection of each sub-aperture's sweeps onto its nodes with
  the BPA per-pulse sum (:func:`mitsar.focus.backprojection.pixel_pulse`), four nodes per lane
  sharing a sweep's geometry, then demodulation by ``exp(+j 2 pi f_c 2 rho / c)``;
- :func:`merge_nodes` and :func:`merge_points`: the children's images interpolated (Keys cubic,
  4 x 4 taps, each row of four taps one packet load, :func:`_tap_rows`) at a parent's nodes
  or at the output pixels, re-phased by
  ``2 pi (2 f_c / c)(rho_P - rho_j)`` (module docstring of :mod:`mitsar.focus.ffbp`, step 4).

A bistatic channel (``Stage.receiver``) replaces rho by half the path from the sub-aperture's
transmitter and receiver centres in the demodulation (:func:`_centre_paths`) and the
re-phasing (:func:`_range_change` of both centres), and its windowed pieces move their reads
in range too (:func:`_receiver_read`; docs/focusing.md § FFBP, "Channels").
"""

from __future__ import annotations

import functools
import math
from dataclasses import dataclass
from types import ModuleType
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.backend import drjit as dr  # imported when a kernel runs (LazyModule)
from mitsar.backend import namespace_of, safe_width
from mitsar.focus.backprojection import (
    carrier_turns,
    derotate,
    interpolate,
    jit_array,
    pixel_pulse,
    pulse_loop,
)
from mitsar.model.ops import NUMPY_OPS, ArrayOps
from mitsar.model.signal import half_path

__all__ = ["LANE_NODES", "Stage", "first_stage", "merge_band", "merge_nodes", "merge_points",
           "node_frames", "polar_node", "to_numpy"]

LANE_NODES = 4
"""First-stage nodes per kernel lane (consecutive in angle; one sweep gather for all)."""



@functools.cache
def _jit_ops() -> ArrayOps:
    """Dr.Jit's side of the ops namespace for the node formula (only sqrt, maximum, minimum,
    where are used; mitsar.plugins.ops would load Mitsuba), made when a kernel first needs it
    (Dr.Jit is imported then, :data:`mitsar.backend.drjit`)."""
    return NUMPY_OPS._replace(sqrt=dr.sqrt, maximum=dr.maximum, minimum=dr.minimum,
                              floor=dr.floor, where=dr.select)

_FRAME_FIELDS = ("cx", "cy", "cz", "ax", "ay", "az", "ux", "uy", "uz", "wx", "wy", "wz",
                 "height", "projection", "axis_normal", "side", "axis_side", "side_u",
                 "side_w")


@dataclass
class Stage:
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
    length: NDArray | None = None  # (J,) chord from first to last sweep [m]
    receiver: NDArray | None = None  # (J, 3) [m] a bistatic channel's receiver centre
    receiver_axis: NDArray | None = None  # (J, 3) its chord per unit of the transmitter's
    values: Any = None       # UInt64 (J N_rho N_alpha,): demodulated images, (re, im) float32
    totals: Any = None       # Float32 (J N_rho N_alpha,): sums of the sweeps' weights


# --------------------------------------------------------------------------------------------
# Node positions
# --------------------------------------------------------------------------------------------
def node_frames(stage: Stage, normal: NDArray, plane_point: NDArray) -> dict[str, NDArray]:
    """Per-sub-aperture constants of :func:`polar_node` (arrays of shape (J,)).

    With ``b1``, ``b2`` completing the axis ``a`` to an orthonormal frame, ``u`` is the unit
    projection of the plane normal n on the plane normal to a (``u = (b1.n b1 + b2.n b2) /
    projection``), ``w = a x u``; ``height = (c - p0).n``; ``side`` the sign of ``(x - c).(n
    x a)`` that the plane's centre p0 has (the pixels' side); ``axis_side``, ``side_u``,
    ``side_w`` the components of ``n x a`` on a, u and w.
    """
    axis = stage.axis
    helper = np.where(np.abs(axis[:, :1]) < 0.9, [[1.0, 0, 0]], [[0, 1.0, 0]])
    b1 = np.cross(axis, helper)
    b1 /= np.linalg.norm(b1, axis=-1, keepdims=True)
    b2 = np.cross(axis, b1)
    b1n, b2n = b1 @ normal, b2 @ normal
    projection = np.hypot(b1n, b2n)
    beta = np.arctan2(b2n, b1n)
    u = np.cos(beta)[:, None] * b1 + np.sin(beta)[:, None] * b2
    w = np.cos(beta)[:, None] * b2 - np.sin(beta)[:, None] * b1
    side_vector = np.cross(normal[None, :], axis)
    side = np.sign(np.einsum("ji,ji->j", plane_point - stage.centre, side_vector))
    columns = [*stage.centre.T, *axis.T, *u.T, *w.T]
    columns += [(stage.centre - plane_point) @ normal, projection, axis @ normal,
                np.where(side == 0, 1.0, side)]
    columns += [np.einsum("ji,ji->j", v, side_vector) for v in (axis, u, w)]
    return dict(zip(_FRAME_FIELDS, columns, strict=True))


def polar_node(rho: Any, alpha: Any, frame: dict, ops: ArrayOps = NUMPY_OPS
               ) -> tuple[Any, Any, Any]:
    """Position [m] of polar node (rho, alpha) of a sub-aperture, in the image plane.

    The node is where the sphere ``|x - c| = rho``, the cone ``a.(x - c) = rho alpha`` and the
    image plane meet, on the pixels' side (docs/focusing.md § FFBP): ``x = c + rho alpha a +
    rho s (cos(gamma) u +- sin(gamma) w)``, ``s = sqrt(1 - alpha^2)``, where the plane equation
    gives ``cos(gamma) = -(height + rho alpha a.n) / (rho s projection)`` (clipped to [-1, 1]:
    a node the plane does not reach goes to the nearest point of its circle) and the sign of
    ``sin(gamma)`` is the one that puts ``(x - c).(n x a)`` on the side of the pixels.
    ``frame`` holds the sub-aperture's constants (:func:`node_frames`) gathered for the node;
    NumPy or Dr.Jit arrays alike (``ops``).
    """
    f = frame
    sine = ops.sqrt(ops.maximum(1.0 - alpha * alpha, 0.0))
    radial = rho * sine
    cos_gamma = ops.minimum(ops.maximum(
        -(f["height"] + rho * alpha * f["axis_normal"])
        / ops.maximum(radial * f["projection"], 1e-12), -1.0), 1.0)
    sin_gamma = ops.sqrt(ops.maximum(1.0 - cos_gamma * cos_gamma, 0.0))
    lateral = alpha * f["axis_side"] + sine * (cos_gamma * f["side_u"] + sin_gamma * f["side_w"])
    sin_gamma = ops.where(lateral * f["side"] > 0.0, sin_gamma, -sin_gamma)
    along, across_u, across_w = rho * alpha, radial * cos_gamma, radial * sin_gamma
    return tuple(f[f"c{i}"] + along * f[f"a{i}"] + across_u * f[f"u{i}"] + across_w * f[f"w{i}"]
                 for i in "xyz")


def _jit_frame(stage: Stage, frame: dict[str, NDArray], jit: ModuleType) -> dict[str, Any]:
    """The frame constants and grid origins as float64 Dr.Jit arrays of backend ``jit``."""
    Float64 = jit.Float64
    out = {key: jit_array(Float64, value, np.float64) for key, value in frame.items()}
    out["rho0"] = jit_array(Float64, stage.rho0, np.float64)
    out["alpha0"] = jit_array(Float64, stage.alpha0, np.float64)
    return out


def _lane_node(stage: Stage, frame: dict[str, Any], lane: Any, per_lane: int
               ) -> tuple[Any, Any, list[Any], list[tuple]]:
    """Sub-aperture, range, angles and positions of the ``per_lane`` nodes of every lane.

    Lanes run over (j, i_rho, i_alpha / per_lane); ``N_alpha`` is a multiple of ``per_lane``.
    """
    jit = namespace_of(lane)
    Float64 = jit.Float64
    n_rho, n_alpha = stage.shape
    groups = n_alpha // per_lane
    per_j = n_rho * groups
    j = lane // per_j
    rest = lane - j * per_j
    i_rho = rest // groups
    i_alpha = (rest - i_rho * groups) * per_lane
    gathered = {key: dr.gather(Float64, value, j) for key, value in frame.items()}
    rho = gathered["rho0"] + Float64(i_rho) * dr.opaque(Float64, stage.rho_step)
    alphas, nodes = [], []
    for g in range(per_lane):
        alpha = dr.clip(gathered["alpha0"] + Float64(i_alpha + g)
                        * dr.opaque(Float64, stage.alpha_step), -1.0, 1.0)
        alphas.append(alpha)
        nodes.append(polar_node(rho, alpha, gathered, _jit_ops()))
    return j, rho, alphas, nodes


def _pack(real: Any, imag: Any) -> Any:
    """(real, imag) float32 as one 64-bit word (real in the low half, as NumPy complex64)."""
    jit = namespace_of(real)
    UInt32, UInt64 = jit.UInt32, jit.UInt64
    return (UInt64(dr.reinterpret_array(UInt32, real))
            | (UInt64(dr.reinterpret_array(UInt32, imag)) << 32))


# --------------------------------------------------------------------------------------------
# First stage
# --------------------------------------------------------------------------------------------
def first_stage(stage: Stage, frame: dict[str, NDArray], tables: tuple, wavenumber: float
                ) -> None:
    """Exact back-projection of every sub-aperture onto its nodes (sets ``stage.values``).

    Parameters
    ----------
    stage : Stage
        First stage; ``N_alpha`` a multiple of :data:`LANE_NODES`.
    frame : dict
        :func:`node_frames` of the stage.
    tables : tuple
        ``(constants, sweep_arrays, pairs)`` of
        :func:`mitsar.focus.backprojection.kernel_tables`, with sweep positions in the same
        local frame as the stage.
    wavenumber : float
        Two-way carrier wavenumber ``2 f_c / c`` [cycles/m].

    Each node's sum over its sub-aperture's sweeps is the BPA sum
    (:func:`mitsar.focus.backprojection.pixel_pulse`), demodulated by
    ``exp(+j 2 pi wavenumber rho)`` (rho: the node's range, float64, wrapped to one turn); for
    a bistatic channel (``stage.receiver``; the tables' sweeps then hold its receiver) by
    half the node's path from the sub-aperture's two centres instead (:func:`_centre_paths`).
    """
    types = namespace_of(tables[2])
    Float32, Float64, UInt32, UInt64 = types.Float32, types.Float64, types.UInt32, types.UInt64
    constants, sweep_arrays, pairs = tables
    n_rho, n_alpha = stage.shape
    lanes = len(stage.first) * n_rho * n_alpha // LANE_NODES
    lane, keep, width = _padded_lanes(UInt32, lanes)
    jit = _jit_frame(stage, frame, types)
    j, rho, _, nodes = _lane_node(stage, jit, lane, LANE_NODES)
    first = dr.gather(UInt32, jit_array(UInt32, stage.first, np.uint32), j)
    end = dr.gather(UInt32, jit_array(UInt32, stage.end, np.uint32), j)
    pixels = [(*node, first, end) for node in nodes]
    sums = pulse_loop(pixels, first, end, sweep_arrays, pairs, constants, width)
    phases = [dr.sincos(Float32(2 * np.pi) * Float32(carrier_turns(
        path, dr.opaque(Float64, wavenumber), dr.floor)))
        for path in _centre_paths(stage, j, rho, nodes)]
    # One kernel for the loop: the scatters below would otherwise each re-run it.
    dr.eval(*sums, *(part for phase in phases for part in phase))
    values = dr.zeros(UInt64, lanes * LANE_NODES)
    totals = dr.zeros(Float32, lanes * LANE_NODES)
    for g in range(LANE_NODES):
        sin_phase, cos_phase = phases[g % len(phases)]
        real, imag = derotate(sums[3 * g], sums[3 * g + 1], -sin_phase, cos_phase)
        index = lane * LANE_NODES + g
        dr.scatter(values, _pack(real, imag), index, keep)
        dr.scatter(totals, sums[3 * g + 2], index, keep)
    dr.eval(values, totals)
    stage.values, stage.totals = values, totals


def _centre_paths(stage: Stage, j: Any, rho: Any, nodes: list[tuple]) -> list[Any]:
    """The range [m] by which the nodes of a lane are demodulated: their range ``rho`` from
    the sub-aperture's centre (one for the lane: its nodes share it), or for a bistatic
    channel half each node's path ``(|x - c| + |x - d|) / 2`` from the centres of the
    sub-aperture's transmitter (c) and receiver (d) positions (float64; :func:`half_path`):
    the residual phase of a sweep is then the change of its own half path along the
    sub-aperture, which varies across the polar grid as the monostatic one does."""
    if stage.receiver is None:
        return [rho]
    Float64 = namespace_of(rho).Float64
    centre = [dr.gather(Float64, jit_array(Float64, stage.receiver[:, i], np.float64), j)
              for i in range(3)]
    return [half_path(rho, dr.sqrt(sum((node[i] - centre[i]) ** 2 for i in range(3))))
            for node in nodes]


# --------------------------------------------------------------------------------------------
# Merges
# --------------------------------------------------------------------------------------------
def merge_nodes(stage: Stage, parent: Stage, frame: dict[str, NDArray], children: tuple,
                wavenumber: float, with_totals: bool) -> None:
    """Merge ``stage`` onto the nodes of ``parent`` (sets ``parent.values``/``totals``).

    ``children``: first and end child index of every parent sub-aperture; ``frame``:
    :func:`node_frames` of the parent. One lane per parent node, its position from
    :func:`polar_node` (float64, then float32 for the interpolation).
    """
    types = namespace_of(stage.values)
    Float32, Float64, UInt32 = types.Float32, types.Float64, types.UInt32
    n_rho, n_alpha = parent.shape
    lanes = len(parent.first) * n_rho * n_alpha
    lane, keep, _ = _padded_lanes(UInt32, lanes)
    jit = _jit_frame(parent, frame, types)
    j, _, _, nodes = _lane_node(parent, jit, lane, 1)
    point = [Float32(v) for v in nodes[0]]
    reference = [Float32(dr.gather(Float64, jit[key], j)) for key in ("cx", "cy", "cz")]
    if parent.receiver is not None:  # and the parent's receiver centre (_merge_lanes)
        reference += [Float32(dr.gather(Float64, jit_array(Float64, parent.receiver[:, i],
                                                            np.float64), j)) for i in range(3)]
    first = dr.gather(UInt32, jit_array(UInt32, children[0], np.uint32), j)
    end = dr.gather(UInt32, jit_array(UInt32, children[1], np.uint32), j)
    real, imag, total = _merge_loop(point + reference, first, end, _child_data(stage),
                                    _tap_rows(stage.values), stage.totals,
                                    _scalars(stage, wavenumber), with_totals)
    parent.values = dr.zeros(types.UInt64, lanes)
    dr.scatter(parent.values, _pack(real, imag), lane, keep)
    parent.totals = dr.zeros(Float32, lanes if with_totals else 1)
    if with_totals:
        dr.scatter(parent.totals, total, lane, keep)
    dr.eval(parent.values, parent.totals)


def _padded_lanes(uint32: type, lanes: int) -> tuple[Any, Any, int]:
    """Lane indices of a kernel over ``lanes`` lanes launched at
    :func:`mitsar.backend.safe_width` (past Dr.Jit 1.5's crashing widths): the extra lanes
    repeat the last one, and ``keep`` masks their results out of the scatters."""
    width = safe_width(lanes)
    index = dr.arange(uint32, width)
    return dr.minimum(index, lanes - 1), index < lanes, width


def merge_points(stage: Stage, points: NDArray, first_child: NDArray, end_child: NDArray,
                 wavenumber: float, with_totals: bool) -> tuple[Any, Any, Any]:
    """Sum of the children's images at ``points`` (P, 3) [m, local frame], re-modulated.

    Returns ``sum_j V_j(rho_j, alpha_j) exp(-j 2 pi wavenumber rho_j)`` (the carrier of each
    child's range, applied as the rotation from the local origin's range ``|y|`` followed by
    ``exp(-j 2 pi wavenumber |y|)`` in float64) and ``sum_j T_j``, as Dr.Jit arrays (real,
    imaginary, totals) whose kernel has been launched (:func:`to_numpy` waits for them).
    """
    jit = namespace_of(stage.values)
    Float32, Float64, UInt32 = jit.Float32, jit.Float64, jit.UInt32
    coordinates = [jit_array(Float64, points[:, i], np.float64) for i in range(3)]
    point = [Float32(v) for v in coordinates]
    zero = dr.zeros(Float32, len(points))
    references = 3 if stage.receiver is None else 6  # the origin for both centres
    real, imag, total = _merge_loop(
        point + [zero] * references, jit_array(UInt32, first_child, np.uint32),
        jit_array(UInt32, end_child, np.uint32), _child_data(stage), _tap_rows(stage.values),
        stage.totals, _scalars(stage, wavenumber), with_totals)
    distance = dr.sqrt(sum(v * v for v in coordinates))
    turns = carrier_turns(distance, dr.opaque(Float64, wavenumber), dr.floor)
    sin_phase, cos_phase = dr.sincos(Float32(2 * np.pi) * Float32(turns))
    real, imag = derotate(real, imag, sin_phase, cos_phase)
    dr.eval(real, imag, total)  # launched: the caller may work while it runs
    return real, imag, total


def merge_band(stages: list[Stage], points: NDArray, frame: tuple[NDArray, NDArray],
               sweep_range: tuple[NDArray, NDArray], tables: tuple, half_width: float,
               window: NDArray, wavenumber: float, normal: NDArray | None = None
               ) -> tuple[Any, Any, Any]:
    """Each point's sum over the sweeps of its own processed band (aspect-angle window).

    The band of point x is the sweeps k with ``|g_k| <= h``, ``g_k = d . l_k - u`` (its
    aspect frame ``(d, u)``, :func:`mitsar.focus.aperture.aspect_frames`; ``l_k`` the unit
    line of sight from sweep k to x), with BPA's edge fractions: a sweep within half a
    sweep's step of ``|g| = h`` counts by the part of its stretch inside
    (:func:`mitsar.focus.backprojection.edge_fraction`). Along a pass ``g_k`` falls
    monotonically (the line of sight turns one way), so the band is one run of sweeps
    ``[k_1, k_2)`` (``|g_k| <= h``), found by bisection inside ``sweep_range`` (float64). The
    run is summed from pieces that are whole sub-apertures of any stage (the sub-aperture
    images, interpolated at x and re-phased as in :func:`merge_points`; the largest aligned
    sub-aperture that fits, then the next, as in a segment tree: at most ``2 (factor - 1)``
    per stage) between the first-stage boundaries ``b_1 = ceil((k_1 + 1) / n_0) n_0`` and
    ``b_2 = floor((k_2 - 1) / n_0) n_0``, and at its two ends (``[k_1 - 1, b_1)``,
    ``[b_2, k_2 + 1)``: the sweeps whose edge fraction may lie between 0 and 1, the first
    and last of the run and one outside either end) from single sweeps by BPA's own
    per-pulse sum (:func:`pixel_pulse <mitsar.focus.backprojection.pixel_pulse>`, which
    applies the window and the edge fraction itself, so the edges are BPA's to the sweep;
    the pieces hold sweeps at least one step inside, whose fraction is 1). With a window other
    than rect each piece's sweeps are weighted by :func:`_windowed_piece` (one more read of
    its image per harmonic of the window).

    Parameters
    ----------
    stages : list of Stage
        Every stage, first to last, with its images (``values``).
    points : ndarray, shape (P, 3)
        Points [m] in the stages' local frame.
    frame : (ndarray (P, 3), ndarray (P,))
        Aspect frame ``(d, u)`` of every point.
    sweep_range : (ndarray (P,), ndarray (P,))
        First and end sweep that can hold the band (a safe bound,
        :func:`mitsar.focus.bpa.curved_sweep_range`).
    tables : tuple
        :func:`mitsar.focus.backprojection.kernel_tables` (sweep positions in the local frame).
    half_width : float
        Band half width h in direction sine.
    window : ndarray
        Cosine-series coefficients of the azimuth window.
    wavenumber : float
        Two-way carrier wavenumber ``2 f_c / c`` [cycles/m].
    normal : ndarray, shape (3,), optional
        Unit normal of the image plane (the polar grids'); needed for a bistatic channel's
        windowed pieces (:func:`_windowed_piece`).

    Returns
    -------
    real, imag, total : Dr.Jit arrays, launched
        The BPA sum of every point and the sum of its sweeps' window weights.
    """
    constants, sweep_arrays, pairs = tables
    jit = namespace_of(pairs)
    Float32, Float64, UInt32 = jit.Float32, jit.Float64, jit.UInt32
    sweeps = int(stages[0].end[-1])
    count = len(points)
    coordinates = [jit_array(Float64, points[:, i], np.float64) for i in range(3)]
    direction = [jit_array(Float32, frame[0][:, i], np.float32) for i in range(3)]
    centre = jit_array(Float32, frame[1], np.float32)
    low = jit_array(UInt32, sweep_range[0], np.uint32)
    high = jit_array(UInt32, np.maximum(sweep_range[1], sweep_range[0]), np.uint32)
    coefficients = np.zeros(4)
    coefficients[: len(window)] = window
    edge_constants = {**constants, "half_width": dr.opaque(Float32, half_width),
                      "coefficients": [float(c) for c in coefficients],
                      "fractional_edges": True}  # a band narrower than the beam

    # The band [k1, k2): bisection on g (falling along the pass), float64.
    d64 = [Float64(v) for v in direction]

    def offset(k: Any, active: Any) -> Any:
        ox, oy, oz = (coordinates[i] - dr.gather(Float64, sweep_arrays[i], k, active)
                      for i in range(3))
        distance = dr.sqrt(ox * ox + oy * oy + oz * oz)
        return (ox * d64[0] + oy * d64[1] + oz * d64[2]) / distance - Float64(centre)

    def bisect(threshold: float, strict: bool) -> Any:
        lo, hi = UInt32(low), UInt32(high)
        for _ in range(max(1, int(sweeps).bit_length())):
            active = lo < hi
            mid = (lo + hi) >> 1
            g = offset(dr.select(active, mid, 0), active)
            left = (g < threshold) if strict else (g <= threshold)
            hi = dr.select(active & left, mid, hi)
            lo = dr.select(active & ~left, mid + 1, lo)
        return lo

    k1 = bisect(half_width, strict=False)
    k2 = dr.maximum(bisect(-half_width, strict=True), k1)
    size0 = int(stages[0].end[0] - stages[0].first[0])
    # the first and last sweeps of the run go to the edges (their edge fraction may be < 1)
    b1 = (k1 + size0) // size0 * size0
    b2 = dr.select(k2 > 0, k2 - 1, 0) // size0 * size0
    empty = b2 <= b1
    stop = dr.minimum(k2 + 1, sweeps)
    b1 = dr.select(empty, stop, b1)
    b2 = dr.select(empty, stop, b2)

    # Pieces: whole sub-apertures of any stage between b1 and b2.
    sizes = [int(s.end[0] - s.first[0]) for s in stages]
    counts = [len(s.first) for s in stages]
    nodes = [len(s.first) * s.shape[0] * s.shape[1] for s in stages]
    node_offset = np.concatenate([[0], np.cumsum(nodes)[:-1]]).astype(np.int64)
    sub_offset = np.concatenate([[0], np.cumsum(counts)[:-1]]).astype(np.int64)
    node_base = np.concatenate([offset + np.arange(len(s.first)) * (s.shape[0] * s.shape[1])
                                for offset, s in zip(node_offset, stages, strict=True)])
    child = _columns(stages, Float32)
    spacing = jit_array(Float32, np.concatenate([_sweep_spacing(s) for s in stages]),
                        np.float32)
    bases = jit_array(UInt32, node_base, np.uint32)
    level_arrays = {
        "alpha_step": jit_array(Float32, [s.alpha_step for s in stages], np.float32),
        "n_rho": jit_array(UInt32, [s.shape[0] for s in stages], np.uint32),
        "n_alpha": jit_array(UInt32, [s.shape[1] for s in stages], np.uint32),
    }
    rows = dr.concat([_tap_rows(s.values) for s in stages]) if len(stages) > 1 else _tap_rows(
        stages[0].values)
    dr.eval(rows)
    point = [Float32(v) for v in coordinates]
    zero = dr.zeros(Float32, count)
    point_data = point + [zero] * (3 if stages[0].receiver is None else 6)
    rho_step = dr.opaque(Float32, stages[0].rho_step)
    wave = dr.opaque(Float32, wavenumber)
    n_sweeps = dr.opaque(UInt32, sweeps)
    rect = not np.any(coefficients[1:])
    harmonics = [(m, float(coefficients[m])) for m in range(len(coefficients))]
    wavelength = 2.0 / wavenumber

    def piece_condition(cursor: Any, *_: Any) -> Any:
        return cursor < b2

    def piece_body(cursor: Any, acc_real: Any, acc_imag: Any, acc_total: Any) -> tuple:
        # The largest stage whose sub-aperture starts at the cursor and ends by b2 (sizes
        # are Python constants: no division by a gathered, possibly masked, value).
        level, piece, size = UInt32(0), cursor // sizes[0], UInt32(sizes[0])
        for index in range(1, len(stages)):
            fits = ((cursor % sizes[index]) == 0) & (
                dr.minimum(cursor + sizes[index], n_sweeps) <= b2)
            level = dr.select(fits, index, level)
            piece = dr.select(fits, int(sub_offset[index]) + cursor // sizes[index], piece)
            size = dr.select(fits, sizes[index], size)
        piece_end = dr.minimum(cursor + size, n_sweeps)
        scalars = {"rho_step": rho_step, "wavenumber": wave,
                   "alpha_step": dr.gather(Float32, level_arrays["alpha_step"], level),
                   "n_rho": dr.gather(UInt32, level_arrays["n_rho"], level),
                   "n_alpha": dr.gather(UInt32, level_arrays["n_alpha"], level)}
        base = dr.gather(UInt32, bases, piece)
        part_real, part_imag, _ = _merge_lanes(piece, point_data, child, rows, None,
                                               scalars, False, base)
        weight = Float32(piece_end - cursor)
        if not rect:
            part_real, part_imag, weight = _windowed_piece(
                piece, point_data, (child, spacing), rows, scalars, base,
                (part_real, part_imag), weight, direction, centre, harmonics, half_width,
                wavelength, normal)
        return piece_end, acc_real + part_real, acc_imag + part_imag, acc_total + weight

    state = (UInt32(b1), *[dr.zeros(Float32, count) for _ in range(3)])
    real, imag, total = dr.while_loop(state, piece_condition, piece_body)[1:]
    distance = dr.sqrt(sum(v * v for v in coordinates))
    turns = carrier_turns(distance, dr.opaque(Float64, wavenumber), dr.floor)
    sin_phase, cos_phase = dr.sincos(Float32(2 * np.pi) * Float32(turns))
    real, imag = derotate(real, imag, sin_phase, cos_phase)

    # Edges: single sweeps [k1 - 1, b1) and [b2, k2 + 1), BPA's per-pulse sum, window and
    # edge fraction.
    start = dr.select(k1 > 0, k1 - 1, k1)
    left = b1 - dr.minimum(start, b1)
    length = left + (stop - dr.minimum(b2, stop))
    pixel = (*coordinates, UInt32(0), dr.opaque(UInt32, sweeps), *direction, centre)

    def edge_condition(t: Any, *_: Any) -> Any:
        return t < length

    def edge_body(t: Any, acc_real: Any, acc_imag: Any, acc_total: Any) -> tuple:
        k = dr.select(t < left, start + t, b2 + (t - left))
        sweep = tuple(dr.gather(type(a), a, k) for a in sweep_arrays)
        part = pixel_pulse(k, pixel, sweep, pairs, edge_constants)
        return t + 1, acc_real + part[0], acc_imag + part[1], acc_total + part[2]

    state = (UInt32(0), real, imag, total)
    real, imag, total = dr.while_loop(state, edge_condition, edge_body)[1:]
    dr.eval(real, imag, total)  # launched: the caller may work while it runs
    return real, imag, total


def _windowed_piece(piece: Any, point_data: list, children: tuple[list, Any], rows: Any,
                    scalars: dict, base: Any, plain: tuple[Any, Any], count: Any, direction: list,
                    centre: Any, harmonics: list, half_width: float, wavelength: float,
                    normal: NDArray | None = None) -> tuple[Any, Any, Any]:
    """A whole sub-aperture's image at the point, each sweep weighted by the window.

    The window is a cosine series in the aspect offset, ``W(g) = sum_m a_m cos(pi m g / h)``
    (:func:`mitsar.focus.windows.cosine_series` at ``g / 2h``). Across a sub-aperture ``g``
    is linear in the sweep's offset s along the axis, ``g = g_c + gamma s`` with ``gamma =
    (-d.a + (d.l)(a.l)) / rho`` (l, rho: line of sight and range from the centre to the
    point), and the demodulated polar image holds sweep s with the phase ``2 pi (2 /
    lambda) s alpha`` (step 3 of :mod:`mitsar.focus.ffbp`): the weight ``exp(j pi m g / h)``
    of every sweep is therefore the image read at ``alpha + m gamma lambda / (4 h)`` times
    ``exp(j pi m g_c / h)``. Each harmonic costs one more interpolation; the sum of the
    weights is ``sum_m a_m cos(pi m g_c / h) D_m`` with the Dirichlet kernel ``D_m`` of the
    n sweeps' phase steps.

    A bistatic channel's image holds sweep s with the phase ``2 pi (2 / lambda) s (a.l +
    a'.l') / 2`` (its half path, :func:`first_stage`), which moves by ``(1 + kappa) / 2`` per
    step of alpha along the polar grid's circle, and that step also moves half its path,
    hence its compressed pulse (:func:`_receiver_read`): the reads are shifted by ``2 / (1 +
    kappa)`` times the monostatic shift in alpha and in range so that half the path stays.
    Measured on the 20-degree turn with a Hamming window and a receiver at (0.3, 0.2, 0.4) m
    in the body frame: -35.5 dB from BPA reading at the monostatic shift, -41.1 dB with the
    range shift, -41.6 dB with both (the monostatic channel: -41.8 dB).
    """
    jit = namespace_of(piece)
    Float32 = jit.Float32
    child, spacing = children  # (_child_data, each sub-aperture's sweep spacing)
    x, y, z = point_data[:3]
    cx, cy, cz, ax, ay, az = (dr.gather(Float32, c, piece) for c in child[:6])
    ox, oy, oz = x - cx, y - cy, z - cz
    rho = dr.sqrt(ox * ox + oy * oy + oz * oz)
    lx, ly, lz = ox / rho, oy / rho, oz / rho
    along_d = direction[0] * lx + direction[1] * ly + direction[2] * lz
    along_a = ax * lx + ay * ly + az * lz
    g_centre = along_d - centre
    gamma = (-(direction[0] * ax + direction[1] * ay + direction[2] * az)
             + along_d * along_a) / rho
    step = dr.opaque(Float32, math.pi / half_width)
    reading = dr.opaque(Float32, wavelength / (4 * half_width))  # image shift per gamma
    radial = None  # a bistatic channel: the range shift per shift of alpha
    if len(child) > 8:
        rate, radial = _receiver_read(point_data[:3], *([dr.gather(Float32, c, piece)
                                                         for c in child[i:i + 3]]
                                                        for i in (8, 11)),
                                      (lx, ly, lz), rho, (ax, ay, az), normal)
        reading = reading * 2.0 / (1.0 + rate)
    real, imag = harmonics[0][1] * plain[0], harmonics[0][1] * plain[1]
    # per-sweep phase step of harmonic 1 (sweeps evenly spaced along the chord)
    theta = step * gamma * dr.gather(Float32, spacing, piece)
    total = harmonics[0][1] * count
    for m, a_m in harmonics[1:]:
        if a_m == 0.0:
            continue
        sin_c, cos_c = dr.sincos(m * step * g_centre)
        for sign in (1.0, -1.0):
            shift = sign * m * gamma * reading
            v_real, v_imag, _ = _merge_lanes(piece, point_data, child, rows, None, scalars,
                                             False, base, shift,
                                             None if radial is None else shift * radial)
            # times a_m / 2 exp(sign j pi m g_c / h)
            rotated_real = v_real * cos_c - sign * v_imag * sin_c
            rotated_imag = v_imag * cos_c + sign * v_real * sin_c
            real += 0.5 * a_m * rotated_real
            imag += 0.5 * a_m * rotated_imag
        half = 0.5 * m * theta
        small = dr.abs(dr.sin(half)) < 1e-6
        dirichlet = dr.select(small, count, dr.sin(count * half)
                              / dr.select(small, 1.0, dr.sin(half)))
        total += a_m * cos_c * dirichlet
    return real, imag, total


def _receiver_read(point: list, receiver: list, receiver_axis: list, line: tuple,
                   rho: Any, axis: tuple, normal: NDArray) -> tuple[Any, Any]:
    """Where a bistatic channel's windowed piece reads its image (:func:`_windowed_piece`):
    ``kappa`` and the range shift per shift of ``alpha``.

    Sweep s moves the transmitter by ``s a`` and the receiver by ``s a'`` (``a'``: the
    receiver's chord per unit of the transmitter's, ``Stage.receiver_axis``: not ``a`` where
    the attitude turns a horizontal offset), so its phase ramps are ``s a.l`` and ``s a'.l'``
    (l, l': unit lines of sight from the centres c and d, ranges rho and rho'). Along the
    polar grid's circle (fixed rho, in the image plane of normal n: ``e = n x l``, ``dx /
    d alpha = rho e / (a.e)``), ``grad (a.l) . e = a.e / rho`` and ``grad (a'.l') . e = (a'.e -
    (a'.l')(l'.e)) / rho'``: ``kappa`` is their ratio. The same step moves the receiver's
    range by ``rho (l'.e) / (a.e)``, hence half the path (the compressed pulse's position in
    the image) by half that: the read moves in range by ``-rho (l'.e) / (a.e) / (1 + l.l')``
    per unit of alpha to keep it (half the path grows by ``(1 + l.l') / 2`` per metre of
    range). Where the circle runs across the axis (``a.e`` ~ 0): 1 and 0.
    """
    n = [float(v) for v in normal]
    e = (n[1] * line[2] - n[2] * line[1], n[2] * line[0] - n[0] * line[2],
         n[0] * line[1] - n[1] * line[0])
    q = [p - r for p, r in zip(point, receiver, strict=True)]
    rho_receiver = dr.sqrt(q[0] * q[0] + q[1] * q[1] + q[2] * q[2])
    ramp = sum(a * v for a, v in zip(receiver_axis, q, strict=True)) / rho_receiver
    across = sum(v * w for v, w in zip(q, e, strict=True)) / rho_receiver
    along = sum(a * w for a, w in zip(axis, e, strict=True))
    along_receiver = sum(a * w for a, w in zip(receiver_axis, e, strict=True))
    flat = dr.abs(along) < 1e-6
    safe = dr.select(flat, 1.0, along)
    kappa = dr.select(flat, 1.0, (rho / rho_receiver) * (along_receiver - ramp * across) / safe)
    # half the path from the centres along e per unit alpha, over its radial rate
    facing = sum(v * w for v, w in zip(q, line, strict=True)) / rho_receiver
    radial = dr.select(flat, 0.0, -(rho * across / safe) / (1.0 + facing))
    return kappa, radial


def _sweep_spacing(stage: Stage) -> NDArray:
    """Mean spacing [m] of every sub-aperture's sweeps along its axis (0 for one sweep)."""
    return stage.length / np.maximum(stage.end - stage.first - 1, 1)


def to_numpy(real: Any, imag: Any, total: Any) -> tuple[NDArray, NDArray]:
    """:func:`merge_points`' results as NumPy (complex values, totals); waits for them."""
    return np.asarray(real, dtype=float) + 1j * np.asarray(imag, dtype=float), np.asarray(
        total, dtype=float)


def _tap_rows(values: Any) -> Any:
    """Every node's value followed by its next three along the row, four words per node.

    Node n's interpolation row (taps n ... n + 3) is then one aligned 32-byte packet at
    ``4 n``, which Dr.Jit loads at once (``dr.gather(Array4u64, ...)``): 4 packet loads per
    point and child instead of 16 gathers. Indices past the end repeat the last node (they
    are only read for invalid points, whose gathers are masked).
    """
    jit = namespace_of(values)
    UInt32, UInt64 = jit.UInt32, jit.UInt64
    count = dr.width(values)
    index = dr.arange(UInt32, 4 * count)
    node = dr.minimum((index >> 2) + (index & 3), count - 1)
    rows = dr.gather(UInt64, values, node)
    dr.eval(rows)
    return rows


def _child_data(stage: Stage) -> list[Any]:
    """Centres, axes and grid origins of the children, float32 columns, and a bistatic
    channel's receiver centres (:func:`_merge_lanes`)."""
    return _columns([stage], namespace_of(stage.values).Float32)


def _columns(stages: list[Stage], Float32: type) -> list[Any]:
    """:func:`_child_data` of the sub-apertures of ``stages`` one after the other."""
    def column(get: Any) -> Any:
        return jit_array(Float32, np.concatenate([get(s) for s in stages]), np.float32)

    data = ([column(lambda s, i=i: s.centre[:, i]) for i in range(3)]
            + [column(lambda s, i=i: s.axis[:, i]) for i in range(3)]
            + [column(lambda s: s.rho0), column(lambda s: s.alpha0)])
    if stages[0].receiver is not None:
        data += [column(lambda s, i=i: s.receiver[:, i]) for i in range(3)]
        data += [column(lambda s, i=i: s.receiver_axis[:, i]) for i in range(3)]
    return data


def _scalars(stage: Stage, wavenumber: float) -> dict:
    jit = namespace_of(stage.values)
    Float32, UInt32 = jit.Float32, jit.UInt32
    n_rho, n_alpha = stage.shape
    return {"rho_step": dr.opaque(Float32, stage.rho_step),
            "alpha_step": dr.opaque(Float32, stage.alpha_step),
            "n_rho": dr.opaque(UInt32, n_rho), "n_alpha": dr.opaque(UInt32, n_alpha),
            "wavenumber": dr.opaque(Float32, wavenumber)}


def _merge_loop(point_data: list, first: Any, end: Any, child: list, values: Any,
                totals: Any, scalars: dict, with_totals: bool) -> tuple:
    """One lane per point, a symbolic loop over its children (:func:`_merge_lanes`)."""
    jit = namespace_of(first)
    Float32, UInt32 = jit.Float32, jit.UInt32
    width = dr.width(first)

    def condition(k: Any, *_: Any) -> Any:
        return k < end

    def body(k: Any, acc_real: Any, acc_imag: Any, acc_total: Any) -> tuple:
        part_real, part_imag, part_total = _merge_lanes(k, point_data, child, values, totals,
                                                        scalars, with_totals)
        return k + 1, acc_real + part_real, acc_imag + part_imag, acc_total + part_total

    state = (UInt32(first), *[dr.zeros(Float32, width) for _ in range(3)])
    return dr.while_loop(state, condition, body)[1:]


def _range_change(point: list, centre: list, reference: list, rho: Any = None) -> Any:
    """``|y - c_ref| - |y - c_j|`` [m] for the point y, a child's centre c_j and the
    reference (parent's) centre c_ref, float32, as ``(c_j - c_ref) . (2 y - c_ref - c_j) /
    (|y - c_ref| + |y - c_j|)``: no cancellation (docs/focusing.md, kernel speed).
    ``rho``: ``|y - c_j|`` if known."""
    o = [p - c for p, c in zip(point, centre, strict=True)]
    s = [p - r for p, r in zip(point, reference, strict=True)]
    if rho is None:
        rho = dr.sqrt(o[0] * o[0] + o[1] * o[1] + o[2] * o[2])
    rho_ref = dr.sqrt(s[0] * s[0] + s[1] * s[1] + s[2] * s[2])
    return sum((c - r) * (si + oi) for c, r, si, oi in zip(centre, reference, s, o, strict=True)
               ) / (rho_ref + rho)


def _keys(t: Any) -> tuple[Any, Any, Any, Any]:
    """Keys cubic-convolution weights (a = -1/2) of the taps at -1, 0, 1, 2 for offset t."""
    t2 = t * t
    t3 = t2 * t
    return (-0.5 * t3 + t2 - 0.5 * t, 1.5 * t3 - 2.5 * t2 + 1.0,
            -1.5 * t3 + 2.0 * t2 + 0.5 * t, 0.5 * t3 - 0.5 * t2)


def _merge_lanes(k: Any, point_data: list, child: list, values: Any, totals: Any,
                 scalars: dict, with_totals: bool, node_base: Any = None,
                 alpha_shift: Any = None, rho_shift: Any = None) -> tuple[Any, Any, Any]:
    """Child k's re-phased image at the lane's point (steps 4-5 of :mod:`mitsar.focus.ffbp`).

    ``scalars`` may hold per-lane arrays (the grid of each lane's child, :func:`merge_band`);
    ``node_base``: index of the child's first node in ``values`` (default ``k N_rho N_alpha``);
    ``alpha_shift``: read the image that far off the point's direction cosine
    (:func:`_windowed_piece`).
    """
    jit = namespace_of(k)
    Array4u64, Float32, UInt32 = jit.Array4u64, jit.Float32, jit.UInt32
    x, y, z = point_data[:3]
    cx_all, cy_all, cz_all, ax_all, ay_all, az_all, rho0_all, alpha0_all = child[:8]
    rho_step, alpha_step = scalars["rho_step"], scalars["alpha_step"]
    n_rho, n_alpha, wavenumber = scalars["n_rho"], scalars["n_alpha"], scalars["wavenumber"]
    if node_base is None:
        node_base = k * n_rho * n_alpha
    cx = dr.gather(Float32, cx_all, k)
    cy = dr.gather(Float32, cy_all, k)
    cz = dr.gather(Float32, cz_all, k)
    ox, oy, oz = x - cx, y - cy, z - cz
    rho = dr.sqrt(ox * ox + oy * oy + oz * oz)
    alpha = (ox * dr.gather(Float32, ax_all, k) + oy * dr.gather(Float32, ay_all, k)
             + oz * dr.gather(Float32, az_all, k)) / rho
    if alpha_shift is not None:
        alpha = alpha + alpha_shift
    u = (rho - dr.gather(Float32, rho0_all, k)) / rho_step
    if rho_shift is not None:
        u = u + rho_shift / rho_step
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
    base = node_base + (UInt32(iu) - 1) * n_alpha + UInt32(iv) - 1
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
        # The row's four taps in one packet load (values: rows of four, _tap_rows).
        words = dr.gather(Array4u64, values, base + a * n_alpha, valid)
        for b in range(4):
            row_real += wv[b] * dr.reinterpret_array(Float32, UInt32(words[b]))
            row_imag += wv[b] * dr.reinterpret_array(Float32, UInt32(words[b] >> 32))
        v_real += wu[a] * row_real
        v_imag += wu[a] * row_imag
    difference = _range_change(point_data[:3], (cx, cy, cz), point_data[3:6], rho)
    if len(child) > 8:  # a bistatic channel: half the change of its two ranges (first_stage)
        receiver = [dr.gather(Float32, c, k) for c in child[8:11]]
        difference = half_path(difference, _range_change(point_data[:3], receiver,
                                                         point_data[6:9]))
    turns = carrier_turns(difference, wavenumber, dr.floor)
    sin_phase, cos_phase = dr.sincos(2 * dr.pi * turns)
    # exp(+j phase): derotate by -phase.
    part_real, part_imag = derotate(v_real, v_imag, -sin_phase, cos_phase)
    return part_real, part_imag, child_total
