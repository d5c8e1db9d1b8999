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
  4 x 4 taps, each row of four taps one packet load, :func:`tap_rows`) at a parent's nodes
  or at the output pixels, re-phased by
  ``2 pi (2 f_c / c)(rho_P - rho_j)`` (module docstring of :mod:`mitsar.focus.ffbp`, step 4).

A bistatic channel (``Stage.receiver``) replaces rho by half the path from the sub-aperture's
transmitter and receiver centres in the demodulation (:func:`_centre_paths`) and the
re-phasing (:func:`_range_change` of both centres), and its windowed pieces move their reads
in range too (:func:`mitsar.focus.ffbp_band._receiver_read`; docs/focusing.md § FFBP,
"Channels"). The final stage of a band narrower than the beam on a curved track is
:mod:`mitsar.focus.ffbp_band`.
"""

from __future__ import annotations

import functools
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
    pulse_loop,
)
from mitsar.model.ops import NUMPY_OPS, ArrayOps
from mitsar.model.signal import half_path

__all__ = ["LANE_NODES", "Stage", "first_stage", "merge_lanes", "merge_nodes", "merge_points",
           "node_frames", "polar_node", "stage_columns", "tap_rows", "to_numpy"]

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
    if parent.receiver is not None:  # and the parent's receiver centre (merge_lanes)
        reference += [Float32(dr.gather(Float64, jit_array(Float64, parent.receiver[:, i],
                                                            np.float64), j)) for i in range(3)]
    first = dr.gather(UInt32, jit_array(UInt32, children[0], np.uint32), j)
    end = dr.gather(UInt32, jit_array(UInt32, children[1], np.uint32), j)
    real, imag, total = _merge_loop(point + reference, first, end, _child_data(stage),
                                    tap_rows(stage.values), stage.totals,
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
        jit_array(UInt32, end_child, np.uint32), _child_data(stage), tap_rows(stage.values),
        stage.totals, _scalars(stage, wavenumber), with_totals)
    distance = dr.sqrt(sum(v * v for v in coordinates))
    turns = carrier_turns(distance, dr.opaque(Float64, wavenumber), dr.floor)
    sin_phase, cos_phase = dr.sincos(Float32(2 * np.pi) * Float32(turns))
    real, imag = derotate(real, imag, sin_phase, cos_phase)
    dr.eval(real, imag, total)  # launched: the caller may work while it runs
    return real, imag, total


def to_numpy(real: Any, imag: Any, total: Any) -> tuple[NDArray, NDArray]:
    """:func:`merge_points`' results as NumPy (complex values, totals); waits for them."""
    return np.asarray(real, dtype=float) + 1j * np.asarray(imag, dtype=float), np.asarray(
        total, dtype=float)


def tap_rows(values: Any) -> Any:
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
    channel's receiver centres (:func:`merge_lanes`)."""
    return stage_columns([stage], namespace_of(stage.values).Float32)


def stage_columns(stages: list[Stage], Float32: type) -> list[Any]:
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
    """One lane per point, a symbolic loop over its children (:func:`merge_lanes`)."""
    jit = namespace_of(first)
    Float32, UInt32 = jit.Float32, jit.UInt32
    width = dr.width(first)

    def condition(k: Any, *_: Any) -> Any:
        return k < end

    def body(k: Any, acc_real: Any, acc_imag: Any, acc_total: Any) -> tuple:
        part_real, part_imag, part_total = merge_lanes(k, point_data, child, values, totals,
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


def merge_lanes(k: Any, point_data: list, child: list, values: Any, totals: Any,
                 scalars: dict, with_totals: bool, node_base: Any = None,
                 alpha_shift: Any = None, rho_shift: Any = None) -> tuple[Any, Any, Any]:
    """Child k's re-phased image at the lane's point (steps 4-5 of :mod:`mitsar.focus.ffbp`).

    ``scalars`` may hold per-lane arrays (the grid of each lane's child,
    :func:`mitsar.focus.ffbp_band.merge_band`);
    ``node_base``: index of the child's first node in ``values`` (default ``k N_rho N_alpha``);
    ``alpha_shift``: read the image that far off the point's direction cosine
    (:func:`mitsar.focus.ffbp_band._windowed_piece`).
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
        # The row's four taps in one packet load (values: rows of four, tap_rows).
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
