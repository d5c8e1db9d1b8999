"""What a kernel launch reads: packed scalar constants and per-sweep device arrays.

Every per-acquisition value (radar constants, bin grid, chunk offsets) reaches the kernels as an
element of a padded opaque device array (:class:`Constants`), and every per-sweep or
per-scatterer value as a device array, held by one type each (:class:`ScattererArrays`,
:class:`SweepArrays` with its :class:`VisibilityBlocks` and :class:`SharedProbes`,
:class:`MultipathSweepArrays`), so each kernel is traced and compiled once and reused from
Dr.Jit's cache for every chunk, acquisition and trajectory (docs/integrator.md, "Compiled once").
"""

from __future__ import annotations

import math
from collections.abc import Mapping
from dataclasses import dataclass
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np
from numpy.typing import NDArray

from mitsar.backend import safe_width
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.multipath import RaySet, multipath_amplitude_constant
from mitsar.model.radar import Radar
from mitsar.model.scatterers import ScattererSet
from mitsar.model.signal import radar_equation_amplitude
from mitsar.model.trace_options import TraceOptions

BACKSCATTER_FLOATS = ("fc", "chirp_rate", "first_range", "inv_step", "last_lower", "beta_az",
                      "beta_el", "cull_az", "cull_el", "radar_const", "rvp", "normalized",
                      "doppler_bins",
                      # chunk-level cull: mid-sweep antenna position and frame, margins
                      "mid_px", "mid_py", "mid_pz", "mid_f00", "mid_f10", "mid_f20", "mid_f01",
                      "mid_f11", "mid_f21", "mid_f02", "mid_f12", "mid_f22", "mid_disp",
                      "mid_turn", "mid_time", "slab_half")
"""Float64 constants of the backscatter kernels."""

UINTS = ("sweep_stride", "receiver_stride", "bins", "first", "sweeps", "blocks", "width",
         "bin_lo", "bin_width")
"""UInt32 constants of every kernel."""

MULTIPATH_FLOATS = ("fc", "chirp_rate", "first_range", "inv_step", "last_lower", "beta_az",
                    "beta_el", "rvp", "normalized", "amp_const", "norm_const", "dp", "dq",
                    "slab_width", "ghost_cell_inv")
"""Float64 constants of the multipath kernel."""

PACK = 32
"""Length of the constant arrays and multiple of the sweep arrays: small allocations may be
unaligned, and the alignment of a load is part of the kernel hash (measured: size-1 opaque
scalars recompile)."""


class Constants:
    """Per-launch scalars packed in two device arrays, read with literal-index gathers.

    The one type of a kernel launch's constants (backscatter and multipath alike): built from
    Python values, packed once, and never changed; :meth:`replace` gives the constants of the
    next chunk or launch. ``constants["name"]`` is a Float64 (or UInt32) of width 1 for the
    kernels, ``constants.f32("name")`` its Float32 value, ``constants.value("name")`` the
    Python number it was packed from (for the host side: packet windows, fixed-point scale).

    Parameters
    ----------
    values : mapping of str to float or int
        At least every name of ``floats`` and :data:`UINTS` (SI units).
    floats : tuple of str
        The Float64 names of the kernel (:data:`BACKSCATTER_FLOATS`,
        :data:`MULTIPATH_FLOATS`); their order is their index in the packed array.
    """

    def __init__(self, values: Mapping[str, float], floats: tuple[str, ...]) -> None:
        self._values = dict(values)
        self._floats = floats
        packed = np.zeros(PACK)
        packed_u = np.zeros(PACK, dtype=np.uint32)
        if len(floats) > PACK:
            raise ValueError(f"at most {PACK} packed constants")  # a bug, not a user error
        packed[:len(floats)] = [values[n] for n in floats]
        packed_u[:len(UINTS)] = [values[n] for n in UINTS]
        self._f = mi.Float64(packed)
        self._u = mi.UInt32(packed_u)
        dr.make_opaque(self._f, self._u)

    def __getitem__(self, name: str) -> Any:
        if name in UINTS:
            return dr.gather(mi.UInt32, self._u, UINTS.index(name))
        return dr.gather(mi.Float64, self._f, self._floats.index(name))

    def f32(self, name: str) -> Any:
        """The Float32 value of ``name`` (width 1)."""
        return mi.Float(self[name])

    def value(self, name: str) -> Any:
        """The Python number ``name`` was packed from (host side, no device read)."""
        return self._values[name]

    @property
    def values(self) -> dict[str, Any]:
        """A copy of every packed value by name."""
        return dict(self._values)

    def replace(self, **changes: Any) -> Constants:
        """These constants with ``changes`` (names of this kernel's floats or :data:`UINTS`),
        packed anew."""
        return Constants({**self._values, **changes}, self._floats)

    @property
    def carrier_frequency(self) -> Any:
        """f_c [Hz], under :class:`~mitsar.model.radar.Radar`'s name (for the model formulas)."""
        return self["fc"]

    @property
    def chirp_rate(self) -> Any:
        """K [Hz/s], under :class:`~mitsar.model.radar.Radar`'s name."""
        return self["chirp_rate"]


def backscatter_constants(radar: Radar, config: TraceOptions, grid: tuple[int, int],
                          step: float, orders: int, rvp: bool, normalized: bool,
                          max_speed: float, planar: bool, receivers: int = 1) -> Constants:
    """Constants of an acquisition for :data:`BACKSCATTER_FLOATS` (chunk values replaced per
    chunk and launch).

    Parameters
    ----------
    grid : (first_index, bins)
        Histogram bin grid (:func:`mitsar.model.histogram.bin_grid`); ``step`` its bin width [m].
    max_speed : float
        Largest relative speed of antenna and scatterers [m/s] (Doppler margin of the cull).
    receivers : int
        Receivers of the transmitter traced (:attr:`~.setup.TraceSetup.channel_receivers`):
        bin ``b`` of order ``o`` of receiver ``k`` in sweep row ``s`` of the histogram buffer
        is at ``s * sweep_stride + k * receiver_stride + o * bins + b``.
    """
    first_index, bins = grid
    cull = min(float(config.beam_cull), 1e30)
    chunk = dict.fromkeys((name for name in BACKSCATTER_FLOATS if name.startswith("mid_")),
                          0.0)  # the chunk's middle sweep: replaced per chunk (chunk_bounds)
    return Constants({
        **chunk,
        "fc": radar.carrier_frequency,
        "chirp_rate": radar.chirp_rate,
        "first_range": first_index * step,
        "inv_step": 1.0 / step,
        "last_lower": float(bins - 1),
        "beta_az": radar.azimuth_beamwidth,
        "beta_el": radar.elevation_beamwidth,
        "cull_az": cull * radar.azimuth_beamwidth,
        "cull_el": cull * radar.elevation_beamwidth,
        "radar_const": float(radar_equation_amplitude(radar, 1.0, 1.0)),
        "rvp": 1.0 if rvp else 0.0,
        "normalized": 1.0 if normalized else 0.0,
        "doppler_bins": max_speed * radar.carrier_frequency / radar.chirp_rate / step,
        "slab_half": 0.5 * config.slab_width if planar else 1e30,
        "sweep_stride": receivers * orders * bins,
        "receiver_stride": orders * bins,
        "bins": bins,
        "first": 0,
        "sweeps": 1,
        "blocks": 1,
        "width": 0,
        "bin_lo": 0,
        "bin_width": bins,
    }, BACKSCATTER_FLOATS)


def multipath_constants(radar: Radar, config: TraceOptions, backscatter: Constants,
                        rays: RaySet) -> Constants:
    """Constants of the multipath kernel (:data:`MULTIPATH_FLOATS`) from those of
    :func:`backscatter_constants`."""
    shared = backscatter.values
    out = {name: shared[name] for name in set(MULTIPATH_FLOATS + UINTS) & set(shared)}
    out.update(amp_const=multipath_amplitude_constant(radar),
               norm_const=0.5 * math.sqrt(math.pi), dp=rays.dp, dq=rays.dq,
               slab_width=float(config.slab_width), ghost_cell_inv=2.0 / radar.wavelength,
               first=0, sweeps=1, blocks=1)
    return Constants(out, MULTIPATH_FLOATS)


def padded_lanes(lanes: int) -> tuple[Any, Any]:
    """Lane indices of a launch of ``lanes`` lanes, padded past the widths at which Dr.Jit
    1.5's LLVM backend crashes (:func:`mitsar.backend.safe_width`, docs/reliability.md §5: at
    most 15 extra lanes): ``(index, valid)``. The extra lanes repeat the last lane (their
    index is clamped, so every gather stays in bounds) and are not ``valid``: the caller
    masks their deposits, compressions and codes. Without padding, ``valid`` is True."""
    width = safe_width(lanes)
    index = dr.arange(mi.UInt32, width)
    if width == lanes:
        return index, mi.Bool(True)
    return dr.minimum(index, lanes - 1), index < lanes


def lane_pairs(lane: Any, constants: Constants, candidates: Any) -> tuple[Any, Any]:
    """Lane index -> (sweep of the chunk, item): sweep ``lane % sweeps`` and the candidate
    ``first + lane // sweeps`` (a scatterer or a ray). Neighbouring lanes belong to different
    sweeps, so their deposits go to different histograms (neighbouring scatterers of one sweep
    would fight over the same bins in the atomic scatter-add)."""
    local = lane // constants["sweeps"]
    return (lane - local * constants["sweeps"],
            dr.gather(mi.UInt32, candidates, local + constants["first"]))


Vector = tuple[Any, Any, Any]
"""x, y, z components of a vector per item, one device array each."""

Frame = tuple[Vector, Vector, Vector]
"""A rotation per item, entry ``(i, j)`` at ``frame[i][j]`` (column ``j``: an antenna axis in
world coordinates), one Float32 device array each."""


@dataclass
class ScattererArrays:
    """Device arrays of a scatterer set (:class:`~mitsar.model.scatterers.ScattererSet`), one
    element per scatterer; uploaded once (:func:`scatterer_arrays`).

    Attributes
    ----------
    position, position32 : Vector
        Position at time 0 [m], Float64 and Float32.
    velocity, velocity32 : Vector
        Velocity [m/s], Float64 and Float32.
    normal : Vector
        Unit surface normal (Float32).
    weight : mi.Float
        Area share [m²] (surfaces) or RCS [m²] (point targets) multiplying σ⁰.
    phase : mi.Float64
        Frozen speckle phase [cycles].
    table_row : mi.UInt32
        Row of the scatterer's material in ``tables``.
    stop : mi.Float
        How far short of the scatterer its shadow ray stops [m].
    tables : mi.Float
        Monostatic σ⁰ tables of the materials, rows of
        :data:`~mitsar.model.doublelobe.TABLE_SIZE`, flattened.
    static : bool
        No scatterer moves: kernels without the velocity gathers (compiled once).
    sigma_bound : float or None
        Largest σ⁰ table value times the largest weight [m²], reduced once on demand
        (:func:`~.blocks.fixed_point_scale`).
    """

    position: Vector
    position32: Vector
    velocity: Vector
    velocity32: Vector
    normal: Vector
    weight: Any
    phase: Any
    table_row: Any
    stop: Any
    tables: Any
    static: bool
    sigma_bound: float | None = None

    @property
    def count(self) -> int:
        """Number of scatterers."""
        return dr.width(self.weight)


@dataclass
class VisibilityBlocks:
    """Device arrays of the visibility blocks of a chunk (docs/integrator.md §"Visibility
    reuse"; :func:`visibility_block_arrays`).

    Attributes
    ----------
    block_of : mi.UInt32
        Block of each sweep of the chunk.
    first_sweep, last_sweep : mi.UInt32
        First and last sweep of each block (indices into the chunk).
    sweep_bits : (mi.UInt64, mi.UInt64) or None
        Per block, bit ``s`` of word ``s // 64`` set for each sweep ``s`` of the block (the
        sweep masks of :func:`~.blocks.block_trace`); None for chunks over
        :data:`MAX_CHUNK_SWEEPS` sweeps.
    """

    block_of: Any
    first_sweep: Any
    last_sweep: Any
    sweep_bits: tuple[Any, Any] | None


@dataclass
class SharedProbes:
    """Device arrays of the shared visibility probes of a chunk (:func:`shared_probe_arrays`).

    Attributes
    ----------
    sweep : mi.UInt32
        The chunk's probed sweeps.
    first, end : mi.UInt32
        Per block, the indices into ``sweep`` of the probes at its first sweep and at its end
        (the next block's first; :func:`~mitsar.model.geometry.visibility.shared_probe_sweeps`).
    """

    sweep: Any
    first: Any
    end: Any


@dataclass
class SweepArrays:
    """Per-sweep device arrays of a chunk for the backscatter kernels (padded to
    :data:`PACK`; :func:`backscatter_sweep_arrays`).

    Attributes
    ----------
    time, time32 : mi.Float64, mi.Float
        Mid-sweep time [s].
    position, position32 : Vector
        Antenna position at mid-sweep [m], Float64 and Float32.
    velocity : Vector
        Antenna velocity [m/s] (Float64).
    plane_normal : Vector
        2D mode: the normal of the plane (Float32; zeros in 3D).
    frame : Frame
        Antenna-to-world rotation at mid-sweep.
    planar : bool
        2D mode (a kernel variant with the slab test).
    blocks : VisibilityBlocks or None
        The chunk's visibility blocks, when shadow rays are shared.
    probes : SharedProbes or None
        The chunk's shared probes (block kernel).
    step : Vector or None
        Antenna step per sweep over the chunk [m] (Float64, width 1; block kernel,
        :func:`chunk_step_arrays`).
    receivers : tuple of (Vector or None)
        The receive phase centre at mid-sweep [m] (Float64) of each receiver of the
        transmitter (:attr:`~.setup.TraceSetup.channel_receivers`); None for a receiver at the
        transmitter (monostatic). One monostatic receiver by default.
    beams : tuple of (ElementBeam, ElementBeam, float), or None
        Per receiver, the (transmit, receive) element beams of its channel and gain ratio
        (:attr:`~.setup.TraceSetup.channel_beams`; lane kernels only), or None.
    receiver_visibility : bool
        Whether the receivers away from the transmitter cast their own shadow rays (probes
        and lanes; the trace request's ``receiver_visibility``).
    """

    time: Any
    time32: Any
    position: Vector
    position32: Vector
    velocity: Vector
    plane_normal: Vector
    frame: Frame
    planar: bool
    blocks: VisibilityBlocks | None = None
    probes: SharedProbes | None = None
    step: Vector | None = None
    receivers: tuple[Vector | None, ...] = (None,)
    beams: tuple[tuple[Any, Any, float], ...] | None = None
    receiver_visibility: bool = False

    @property
    def bistatic(self) -> bool:
        """Whether some receiver is not at the transmitter."""
        return any(receiver is not None for receiver in self.receivers)

    @property
    def shadowing_receivers(self) -> tuple[Vector, ...]:
        """The receivers that cast their own shadow rays: those away from the transmitter,
        with :attr:`receiver_visibility`."""
        if not self.receiver_visibility:
            return ()
        return tuple(receiver for receiver in self.receivers if receiver is not None)


@dataclass
class MultipathSweepArrays:
    """Per-sweep device arrays of a chunk for the multipath kernel (padded to :data:`PACK`;
    :func:`multipath_sweep_arrays`).

    Attributes
    ----------
    transmitter, transmitter32 : Vector
        Transmitter position at mid-sweep [m], Float64 and Float32.
    receivers, receivers32 : tuple of Vector
        Each receiver's position [m], Float64 and Float32: the bistatic receiver (or the
        transmitter) of a single-channel trace, or every receiver of the transmitter traced
        (:attr:`~.setup.TraceSetup.channel_receivers`, histogram rows ``k receiver_stride``).
    velocity : Vector
        Platform velocity [m/s] (Float32).
    ray_velocity : Vector
        Its components along the ray frame's axes [m/s] (Float32).
    antenna_frame, ray_frame, receiver_frame : Frame
        Transmitting antenna, ray grid and receiving antenna to world rotations.
    beams : tuple of (ElementBeam, ElementBeam, float), or None
        Per receiver, its channel's (transmit, receive) element beams and gain ratio
        (:attr:`~.setup.TraceSetup.channel_beams`): receive elements with a beam of their own
        weight their captures and ghosts by it (:func:`~.bounce.receive_pattern`); None: the
        radar's antenna for every receiver.
    """

    transmitter: Vector
    transmitter32: Vector
    receivers: tuple[Vector, ...]
    receivers32: tuple[Vector, ...]
    velocity: Vector
    ray_velocity: Vector
    antenna_frame: Frame
    ray_frame: Frame
    receiver_frame: Frame
    beams: tuple[tuple[Any, Any, float], ...] | None = None


def _padded(chosen: NDArray) -> NDArray:
    return np.concatenate([chosen, np.full(-len(chosen) % PACK, chosen[-1])])


def _upload(kind: type, values: NDArray) -> Any:
    """One opaque device array of ``values``."""
    array = kind(np.ascontiguousarray(values))
    dr.make_opaque(array)
    return array


def _upload_vector(kind: type, values: NDArray) -> Vector:
    """The columns of ``values`` (items, 3) as three opaque device arrays."""
    return tuple(_upload(kind, values[:, i]) for i in range(3))


def _upload_frames(frames: NDArray) -> Frame:
    """Rotations (items, 3, 3) as nine opaque Float32 device arrays."""
    return tuple(tuple(_upload(mi.Float, frames[:, i, j]) for j in range(3))
                 for i in range(3))


def backscatter_sweep_arrays(geometry: SweepGeometry, frames: NDArray, radar: Radar,
                             chosen: NDArray, plane_normals: NDArray,
                             receivers: tuple[NDArray | None, ...] | None = None
                             ) -> SweepArrays:
    """Per-sweep device arrays of the backscatter kernels for the sweeps ``chosen``
    (``receivers``: the receive phase centre per sweep of the acquisition of each receiver of
    the transmitter, None for one at the transmitter; default one monostatic receiver)."""
    padded = _padded(chosen)
    pos, vel = geometry.position[padded], geometry.velocity[padded]
    mid = geometry.slow_time[padded] + radar.sweep_duration / 2
    return SweepArrays(
        time=_upload(mi.Float64, mid), time32=_upload(mi.Float, mid),
        position=_upload_vector(mi.Float64, pos), position32=_upload_vector(mi.Float, pos),
        velocity=_upload_vector(mi.Float64, vel),
        plane_normal=_upload_vector(mi.Float, plane_normals[padded]),
        frame=_upload_frames(frames[padded]),
        # 3D (no plane normal): a kernel variant without the 2D slab test, compiled once.
        planar=bool(np.any(plane_normals[padded] != 0.0)),
        receivers=(None,) if receivers is None else tuple(
            None if rx is None else _upload_vector(mi.Float64, rx[padded]) for rx in receivers))


def visibility_block_arrays(blocks: NDArray) -> VisibilityBlocks:
    """Device arrays of the visibility blocks of a chunk (:class:`VisibilityBlocks`).

    Parameters
    ----------
    blocks : ndarray of int, shape (sweeps,)
        :func:`mitsar.model.geometry.visibility.visibility_blocks` of the chunk's sweeps.
    """
    blocks = np.asarray(blocks, dtype=np.int64)
    index = np.arange(len(blocks))
    count = int(blocks[-1]) + 1
    first = np.searchsorted(blocks, np.arange(count), side="left")
    last = np.searchsorted(blocks, np.arange(count), side="right") - 1
    bits = None
    if len(blocks) <= MAX_CHUNK_SWEEPS:
        masks = [sum(1 << int(s) for s in range(f, e + 1)) for f, e in zip(first, last,
                                                                           strict=True)]
        bits = tuple(_upload(mi.UInt64, _padded(np.array(
            [(b >> (64 * word)) & (2**64 - 1) for b in masks], dtype=np.uint64)))
            for word in range(2))
    return VisibilityBlocks(
        block_of=_upload(mi.UInt32, blocks[_padded(index)].astype(np.uint32)),
        first_sweep=_upload(mi.UInt32, _padded(first).astype(np.uint32)),
        last_sweep=_upload(mi.UInt32, _padded(last).astype(np.uint32)),
        sweep_bits=bits)


def shared_probe_arrays(sweeps: NDArray, first: NDArray, end: NDArray) -> SharedProbes:
    """Device arrays of shared visibility probes (:class:`SharedProbes`) from
    :func:`~mitsar.model.geometry.visibility.shared_probe_sweeps`."""
    sweep, first, end = (_upload(mi.UInt32, _padded(np.asarray(values)).astype(np.uint32))
                         for values in (sweeps, first, end))
    return SharedProbes(sweep=sweep, first=first, end=end)


MAX_CHUNK_SWEEPS = 128
"""Sweeps of a chunk the block kernel traces: one bit each in a lane's two UInt64 words of
sweep masks (:func:`visibility_block_arrays`)."""

MAX_HALF_SPAN = 0.15
"""Largest antenna displacement from a chunk's anchor sweep for the float32 advance [m] (the
paper's 2 mm per sweep: 128 sweeps hold 0.128 m). The phase's remainder after its exact linear
ramp is at most ``(2 f_c/c) span² / (2 R)``: ~7 cycles at 5 m, rounded to ~1e-6 cycles
(docs/integrator.md §"Performance"); faster platforms get shorter chunks
(:func:`~.blocks.block_chunk_sweeps`), and chunks beyond it take the float64 path
(:func:`chunk_step_arrays`)."""

UNIFORM_TOLERANCES = (1e-9, 1e-7, 1e-6)
"""Largest deviation of a chunk from uniform motion that :func:`chunk_step_arrays` accepts:
antenna position from ``p_a + (s - a) step`` [m] (a phase error below 4e-6 rad at 94 GHz),
antenna frame entries [-] and velocity [m/s] from their values at the anchor sweep ``a``."""


def chunk_step_arrays(geometry: SweepGeometry, frames: NDArray, chosen: NDArray
                      ) -> tuple[Vector, bool, float]:
    """Antenna step per sweep over a chunk, whether the block kernel may advance it in float32,
    and how far the antenna moves from the anchor.

    The block kernel (:func:`~.blocks.block_trace`) advances every sweep ``s`` of a chunk from
    its middle sweep ``a = len // 2`` by ``p_s = p_a + (s - a) step``, ``step = (p_last -
    p_first) / (len - 1)``, with the frame and velocity of the anchor, when the chunk satisfies
    that to :data:`UNIFORM_TOLERANCES` (a straight track at constant speed and attitude, as the
    paper flies) and stays within :data:`MAX_HALF_SPAN` of the anchor; otherwise it gathers
    them per sweep and takes the range in float64.

    Returns
    -------
    Vector
        The step's x, y, z: Float64 (padded) [m] (:attr:`SweepArrays.step`).
    bool
        True if the chunk is uniform (float32 advance).
    float
        Largest antenna displacement from the anchor sweep [m].
    """
    pos, vel = geometry.position[chosen], geometry.velocity[chosen]
    rot = frames[chosen]
    anchor = len(chosen) // 2
    step = (pos[-1] - pos[0]) / max(len(chosen) - 1, 1)
    j = np.arange(len(chosen)) - anchor
    half_span = float(np.linalg.norm(pos - pos[anchor], axis=1).max())
    tol_p, tol_f, tol_v = UNIFORM_TOLERANCES
    uniform = bool(np.abs(pos - pos[anchor] - j[:, None] * step).max() <= tol_p
                   and np.abs(rot - rot[anchor]).max() <= tol_f
                   and np.abs(vel - vel[anchor]).max() <= tol_v
                   and half_span <= MAX_HALF_SPAN * (1.0 + 1e-9))
    step_arrays = tuple(_upload(mi.Float64, _padded(step[i:i + 1])) for i in range(3))
    return step_arrays, uniform, half_span


def multipath_sweep_arrays(geometry: SweepGeometry, frames: NDArray, setup: Any,
                           chosen: NDArray) -> MultipathSweepArrays:
    """Per-sweep device arrays of the multipath kernel for the sweeps ``chosen``
    (:class:`MultipathSweepArrays`; ``setup``: the :class:`~.setup.TraceSetup`)."""
    padded = _padded(chosen)
    pos, vel = geometry.position[padded], geometry.velocity[padded]
    receivers = [pos + setup.receiver_offset if rx is None else rx[padded]
                 for rx in (setup.channel_receivers or (None,))]
    ray_frames = setup.ray_frames[padded]
    va = np.einsum("sij,si->sj", ray_frames, vel)
    return MultipathSweepArrays(
        transmitter=_upload_vector(mi.Float64, pos),
        transmitter32=_upload_vector(mi.Float, pos),
        receivers=tuple(_upload_vector(mi.Float64, rx) for rx in receivers),
        receivers32=tuple(_upload_vector(mi.Float, rx) for rx in receivers),
        velocity=_upload_vector(mi.Float, vel), ray_velocity=_upload_vector(mi.Float, va),
        antenna_frame=_upload_frames(frames[padded]), ray_frame=_upload_frames(ray_frames),
        receiver_frame=_upload_frames(setup.receiver_frames[padded]),
        beams=setup.channel_beams)


def scatterer_arrays(scatterers: ScattererSet) -> ScattererArrays:
    """Device arrays of a scatterer set (uploaded once and kept in its ``device`` cache)."""
    if "arrays" not in scatterers.device:
        position, velocity = scatterers.position, scatterers.velocity
        scatterers.device["arrays"] = ScattererArrays(
            position=_upload_vector(mi.Float64, position),
            position32=_upload_vector(mi.Float, position),
            velocity=_upload_vector(mi.Float64, velocity),
            velocity32=_upload_vector(mi.Float, velocity),
            normal=_upload_vector(mi.Float, scatterers.normal),
            weight=_upload(mi.Float, scatterers.weight),
            phase=_upload(mi.Float64, scatterers.phase),
            table_row=_upload(mi.UInt32, scatterers.table_row.astype(np.uint32)),
            stop=_upload(mi.Float, scatterers.stop),
            tables=_upload(mi.Float, scatterers.tables.ravel()),
            # Static sets (no moving point target or shape) use kernels without velocity
            # gathers.
            static=bool(scatterers.max_speed() == 0.0))
    return scatterers.device["arrays"]


def chunk_bounds(geometry: SweepGeometry, frames: NDArray, radar: Radar, chosen: NDArray,
                 target_speed: float) -> dict[str, float]:
    """Middle sweep of a chunk and how far the antenna moves [m] and turns around it: the
    ``mid_*`` values of :data:`BACKSCATTER_FLOATS` (for :meth:`Constants.replace`)."""
    mid = chosen[len(chosen) // 2]
    pos = geometry.position
    times = geometry.slow_time
    disp = (np.linalg.norm(pos[chosen] - pos[mid], axis=1).max()
            + target_speed * np.abs(times[chosen] - times[mid]).max())
    turn = np.linalg.norm(frames[chosen] - frames[mid], axis=1).max()
    out = {"mid_disp": float(disp), "mid_turn": float(turn),
           "mid_time": float(times[mid] + radar.sweep_duration / 2)}
    for i, axis in enumerate("xyz"):
        out["mid_p" + axis] = float(pos[mid, i])
    for i in range(3):
        for j in range(3):
            out[f"mid_f{i}{j}"] = float(frames[mid, i, j])
    return out
