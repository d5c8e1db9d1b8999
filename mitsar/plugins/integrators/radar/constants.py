"""What a kernel launch reads: packed scalar constants and per-sweep device arrays.

Every per-acquisition value (radar constants, bin grid, chunk offsets) reaches the kernels as an
element of a padded opaque device array, and every per-sweep or per-scatterer value as a device
array, so each kernel is traced and compiled once and reused from Dr.Jit's cache for every chunk,
acquisition and trajectory (docs/integrator.md, "Compiled once").
"""

from __future__ import annotations

import math
from typing import Any

import drjit as dr
import mitsuba as mi
import numpy as np
from numpy.typing import NDArray

from mitsar.model.multipath import RaySet, multipath_amplitude_constant
from mitsar.model.radar import Radar
from mitsar.model.signal import radar_equation_amplitude
from mitsar.model.trace_options import TraceOptions
from mitsar.scene.scatterers import ScattererSet

BACKSCATTER_FLOATS = ("fc", "chirp_rate", "first_range", "inv_step", "last_lower", "beta_az",
                      "beta_el", "cull_az", "cull_el", "radar_const", "rvp", "normalized",
                      "doppler_bins",
                      # chunk-level cull: mid-sweep antenna position and frame, margins
                      "mid_px", "mid_py", "mid_pz", "mid_f00", "mid_f10", "mid_f20", "mid_f01",
                      "mid_f11", "mid_f21", "mid_f02", "mid_f12", "mid_f22", "mid_disp",
                      "mid_turn", "mid_time", "slab_half")
"""Float64 constants of the backscatter kernels."""

UINTS = ("sweep_stride", "bins", "first", "sweeps", "blocks", "width", "bin_lo", "bin_width")
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

    ``k["name"]`` is a Float64 (or UInt32) of width 1; ``k.f32("name")`` its Float32 value.
    """

    def __init__(self, values: dict, floats: tuple[str, ...]) -> None:
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
        return mi.Float(self[name])

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
                          max_speed: float, planar: bool) -> dict:
    """Constants of an acquisition for :data:`BACKSCATTER_FLOATS` (chunk values added later).

    Parameters
    ----------
    grid : (first_index, bins)
        Histogram bin grid (:func:`mitsar.model.histogram.bin_grid`); ``step`` its bin width [m].
    max_speed : float
        Largest relative speed of antenna and scatterers [m/s] (Doppler margin of the cull).
    """
    first_index, bins = grid
    cull = min(float(config.beam_cull), 1e30)
    return {
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
        "sweep_stride": orders * bins,
        "bins": bins,
        "first": 0,
        "sweeps": 1,
        "blocks": 1,
        "width": 0,
        "bin_lo": 0,
        "bin_width": bins,
    }


def multipath_constants(radar: Radar, config: TraceOptions, k: dict,
                        rays: RaySet) -> dict:
    """Constants of the multipath kernel (:data:`MULTIPATH_FLOATS`) from those of
    :func:`backscatter_constants`."""
    out = {name: k[name] for name in set(MULTIPATH_FLOATS + UINTS) & set(k)}
    out.update(amp_const=multipath_amplitude_constant(radar),
               norm_const=0.5 * math.sqrt(math.pi), dp=rays.dp, dq=rays.dq,
               slab_width=float(config.slab_width), ghost_cell_inv=2.0 / radar.wavelength,
               first=0, sweeps=1, blocks=1)
    return out


def lane_pairs(idx: Any, k: Constants, candidates: Any) -> tuple[Any, Any]:
    """Lane index -> (sweep of the chunk, item): sweep ``idx % sweeps`` and the candidate
    ``first + idx // sweeps`` (a scatterer or a ray). Neighbouring lanes belong to different
    sweeps, so their deposits go to different histograms (neighbouring scatterers of one sweep
    would fight over the same bins in the atomic scatter-add)."""
    local = idx // k["sweeps"]
    return idx - local * k["sweeps"], dr.gather(mi.UInt32, candidates, local + k["first"])


def _padded(chosen: NDArray) -> NDArray:
    return np.concatenate([chosen, np.full(-len(chosen) % PACK, chosen[-1])])


def _upload(sw: dict, name: str, kind: type, values: NDArray) -> None:
    sw[name] = kind(np.ascontiguousarray(values))


def _upload_frames(sw: dict, prefix: str, frames: NDArray) -> None:
    for i in range(3):
        for j in range(3):
            _upload(sw, f"{prefix}{i}{j}", mi.Float, frames[:, i, j])


def backscatter_sweep_arrays(geometry: dict, frames: NDArray, radar: Radar, chosen: NDArray,
                             plane_normals: NDArray) -> dict:
    """Per-sweep device arrays of the backscatter kernels: mid-sweep time, antenna position
    and velocity, antenna frame ``f``, 2D plane normal ``n2``."""
    padded = _padded(chosen)
    pos, vel = geometry["position"][padded], geometry["velocity"][padded]
    mid = geometry["slow_time"][padded] + radar.sweep_duration / 2
    sw: dict = {}
    _upload(sw, "time", mi.Float64, mid)
    _upload(sw, "time32", mi.Float, mid)
    for i, axis in enumerate("xyz"):
        _upload(sw, "p" + axis, mi.Float64, pos[:, i])
        _upload(sw, "v" + axis, mi.Float64, vel[:, i])
        _upload(sw, "p" + axis + "32", mi.Float, pos[:, i])
        _upload(sw, "n2" + axis, mi.Float, plane_normals[padded, i])
    _upload_frames(sw, "f", frames[padded])
    dr.make_opaque(*sw.values())
    # 3D (no plane normal): a kernel variant without the 2D slab test, compiled once.
    sw["planar"] = bool(np.any(plane_normals[padded] != 0.0))
    return sw


def visibility_block_arrays(blocks: NDArray) -> dict:
    """Device arrays of the visibility blocks of a chunk (docs/integrator.md §"Visibility
    reuse"): ``block_of`` (block of each sweep of the chunk), ``block_first`` and
    ``block_last`` (first and last sweep of each block, indices into the chunk), and for
    chunks of at most 128 sweeps ``block_bits0`` and ``block_bits1`` (UInt64: bit ``s`` of
    word ``s // 64`` set for each sweep ``s`` of the block, the sweep masks of
    :func:`~.blocks.block_trace`).

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
    sw: dict = {}
    _upload(sw, "block_of", mi.UInt32, blocks[_padded(index)].astype(np.uint32))
    _upload(sw, "block_first", mi.UInt32, _padded(first).astype(np.uint32))
    _upload(sw, "block_last", mi.UInt32, _padded(last).astype(np.uint32))
    if len(blocks) <= MAX_CHUNK_SWEEPS:
        bits = [sum(1 << int(s) for s in range(f, e + 1)) for f, e in zip(first, last,
                                                                          strict=True)]
        for word in range(2):
            _upload(sw, f"block_bits{word}", mi.UInt64, _padded(np.array(
                [(b >> (64 * word)) & (2**64 - 1) for b in bits], dtype=np.uint64)))
    dr.make_opaque(*sw.values())
    return sw


def shared_probe_arrays(sweeps: NDArray, first: NDArray, end: NDArray) -> dict:
    """Device arrays of shared visibility probes (docs/integrator.md §"Visibility reuse"):
    ``probe_sweep`` (the chunk's probed sweeps) and, per block, ``probe_first`` and
    ``probe_end`` (indices into them; :func:`~mitsar.model.geometry.visibility.
    shared_probe_sweeps`)."""
    sw: dict = {}
    for name, values in (("probe_sweep", sweeps), ("probe_first", first), ("probe_end", end)):
        _upload(sw, name, mi.UInt32, _padded(np.asarray(values)).astype(np.uint32))
    dr.make_opaque(*sw.values())
    return sw


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


def chunk_step_arrays(geometry: dict, frames: NDArray, chosen: NDArray
                      ) -> tuple[dict, bool, float]:
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
    dict
        ``stepx``, ``stepy``, ``stepz``: Float64 (padded) [m].
    bool
        True if the chunk is uniform (float32 advance).
    float
        Largest antenna displacement from the anchor sweep [m].
    """
    pos, vel = geometry["position"][chosen], geometry["velocity"][chosen]
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
    sw: dict = {}
    for i, axis in enumerate("xyz"):
        _upload(sw, "step" + axis, mi.Float64, _padded(step[i:i + 1]))
    dr.make_opaque(*sw.values())
    return sw, uniform, half_span


def multipath_sweep_arrays(geometry: dict, frames: NDArray, setup: Any, chosen: NDArray
                           ) -> dict:
    """Per-sweep device arrays of the multipath kernel: transmitter ``p`` and receiver ``q``
    positions, velocity, its components in the ray frame ``va``, the antenna frame ``f``, the
    ray frame ``r`` and the receiving frame ``g``."""
    padded = _padded(chosen)
    pos, vel = geometry["position"][padded], geometry["velocity"][padded]
    rx = pos + setup.receiver_offset
    ray_frames = setup.ray_frames[padded]
    va = np.einsum("sij,si->sj", ray_frames, vel)
    sw: dict = {}
    for i, axis in enumerate("xyz"):
        _upload(sw, "p" + axis, mi.Float64, pos[:, i])
        _upload(sw, "p" + axis + "32", mi.Float, pos[:, i])
        _upload(sw, "q" + axis, mi.Float64, rx[:, i])
        _upload(sw, "q" + axis + "32", mi.Float, rx[:, i])
        _upload(sw, "v" + axis, mi.Float, vel[:, i])
        _upload(sw, f"va{i}", mi.Float, va[:, i])
    _upload_frames(sw, "f", frames[padded])
    _upload_frames(sw, "r", ray_frames)
    _upload_frames(sw, "g", setup.receiver_frames[padded])
    dr.make_opaque(*sw.values())
    return sw


def scatterer_arrays(sc: ScattererSet) -> dict:
    """Device arrays of a scatterer set (uploaded once and kept in ``sc.device``)."""
    if "px" not in sc.device:
        dev: dict = {}
        for i, axis in enumerate("xyz"):
            _upload(dev, "p" + axis, mi.Float64, sc.position[:, i])
            _upload(dev, "v" + axis, mi.Float64, sc.velocity[:, i])
            _upload(dev, "n" + axis, mi.Float, sc.normal[:, i])
            _upload(dev, "p" + axis + "32", mi.Float, sc.position[:, i])
            _upload(dev, "v" + axis + "32", mi.Float, sc.velocity[:, i])
        _upload(dev, "weight", mi.Float, sc.weight)
        _upload(dev, "phase", mi.Float64, sc.phase)
        _upload(dev, "row", mi.UInt32, sc.table_row.astype(np.uint32))
        _upload(dev, "stop", mi.Float, sc.stop)
        _upload(dev, "tables", mi.Float, sc.tables.ravel())
        dr.make_opaque(*dev.values())
        # Static sets (no moving point target or shape) use kernels without velocity gathers.
        dev["static"] = bool(sc.max_speed() == 0.0)
        sc.device.update(dev)
    return sc.device


def chunk_bounds(geometry: dict, frames: NDArray, radar: Radar, chosen: NDArray,
                 target_speed: float) -> dict:
    """Middle sweep of a chunk and how far the antenna moves [m] and turns around it."""
    mid = chosen[len(chosen) // 2]
    pos = geometry["position"]
    times = geometry["slow_time"]
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
