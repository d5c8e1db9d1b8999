"""The echo sums of the analytic simulator (paper §3.1, eqs. 1-2): exact per-sample delays.

For every sweep k and fast-time sample n the transmitter (and, for a bistatic channel, the
receiver) position at ``eta_k + T/2 + t_n`` and the target position at the same instant give
the delay (:func:`mitsar.model.signal.two_way_delay`, :func:`mitsar.model.signal.bistatic_delay`),
and each sample is the sum over scatterers of the dechirped echo
(:func:`mitsar.model.signal.dechirped_phase_cycles`). Two implementations of the same formulas:
:func:`sum_echoes_numpy`, the NumPy reference, and :func:`sum_echoes_drjit`, a Dr.Jit kernel
with one lane per sample (docs/gpu.md). :mod:`mitsar.raw.analytic` calls them.
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.backend import array_namespace, namespace_of, safe_width, syntax
from mitsar.backend import drjit as dr  # imported when a kernel runs (LazyModule)
from mitsar.model.geometry.attitude import body_offset_to_world
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import bistatic_delay, dechirped_phase_cycles, fast_time, two_way_delay


def channel_offsets(radar: Radar) -> list[tuple[NDArray, NDArray] | None]:
    """Body-frame (transmitter, receiver) phase centres [m] of each channel, or ``[None]``
    for the single monostatic channel of a radar without declared phase centres."""
    if not radar.has_channels:
        return [None]
    transmitters, receivers = radar.channel_offsets()
    return [(np.asarray(t, dtype=float), np.asarray(r, dtype=float))
            for t, r in zip(transmitters, receivers, strict=True)]


def phase_centres(trajectory: Trajectory, absolute_time: NDArray,
                  offsets: tuple[NDArray, NDArray] | None) -> tuple[NDArray, NDArray | None]:
    """World positions [m] of the transmitter and, for a bistatic channel, the receiver at
    each sample time: the track's point plus the body-frame offsets rotated by the attitude at
    that instant (:func:`mitsar.model.geometry.attitude.body_offset_to_world`); ``None`` for the
    receiver of a monostatic channel (it is the transmitter)."""
    platform = trajectory.position(absolute_time)
    if offsets is None or not (np.any(offsets[0]) or np.any(offsets[1])):
        return platform, None
    attitude = np.moveaxis(trajectory.attitude_at(absolute_time), -1, 0)
    if all(np.all(angle == angle.flat[0]) for angle in attitude):  # held attitude: rotate once
        attitude = attitude.reshape(3, -1)[:, :1]
    transmitter = platform + body_offset_to_world(offsets[0], *attitude)
    if np.array_equal(offsets[0], offsets[1]):
        return transmitter, None
    return transmitter, platform + body_offset_to_world(offsets[1], *attitude)


def sample_times(radar: Radar, geometry: SweepGeometry, sweep_slice: slice) -> NDArray:
    """Absolute time of every sample of the sweeps in ``sweep_slice``, shape (sweeps, N_s)."""
    return (geometry.slow_time[sweep_slice, None] + radar.sweep_duration / 2
            + fast_time(radar)[None, :])


def sum_echoes_numpy(radar: Radar, trajectory: Trajectory, geometry: SweepGeometry,
                     positions: NDArray, velocities: NDArray, amplitude: NDArray, *,
                     rvp: bool, progress: bool,
                     chunk_elements: int, offsets: tuple[NDArray, NDArray] | None = None
                     ) -> NDArray[np.complex128]:
    """Reference sum of the dechirped echoes, vectorised over (sweep, sample, scatterer).

    ``offsets``: body-frame (transmitter, receiver) phase centres of a channel [m]
    (:func:`phase_centres`; exact bistatic delay, :func:`mitsar.model.signal.bistatic_delay`);
    ``None``: the monostatic antenna at the track. The Python loop runs over memory chunks only.
    """
    sweeps = len(geometry.slow_time)
    times = fast_time(radar)
    sample_count = len(times)
    samples = np.zeros((sweeps, sample_count), dtype=complex)
    sweeps_per_chunk = max(1, min(sweeps, chunk_elements // sample_count))
    scatterers_per_chunk = max(1, chunk_elements // (sweeps_per_chunk * sample_count))
    chunks = [(s, m) for s in range(0, sweeps, sweeps_per_chunk)
              for m in range(0, len(positions), scatterers_per_chunk)]
    for sweep0, scatterer0 in tqdm(chunks, disable=not progress, desc="simulate", unit="chunk"):
        sweep_slice = slice(sweep0, sweep0 + sweeps_per_chunk)
        scatterer_slice = slice(scatterer0, scatterer0 + scatterers_per_chunk)
        absolute_time = sample_times(radar, geometry, sweep_slice)
        platform, receiver = phase_centres(trajectory, absolute_time, offsets)
        target = (positions[None, None, scatterer_slice, :]
                  + velocities[None, None, scatterer_slice, :] * absolute_time[..., None, None])
        delay = (two_way_delay(platform[:, :, None, :], target) if receiver is None
                 else bistatic_delay(platform[:, :, None, :], receiver[:, :, None, :], target))
        cycles = dechirped_phase_cycles(delay, times[None, :, None], radar, rvp=rvp)
        phasor = np.exp(2j * np.pi * (cycles - np.round(cycles)))
        samples[sweep_slice] += np.einsum("snm,sm->sn", phasor,
                                          amplitude[sweep_slice, scatterer_slice])
    return samples


def sum_echoes_drjit(radar: Radar, trajectory: Trajectory, geometry: SweepGeometry,
                     positions: NDArray, velocities: NDArray, amplitude: NDArray, *,
                     rvp: bool, progress: bool,
                     chunk_elements: int, offsets: tuple[NDArray, NDArray] | None = None
                     ) -> NDArray[np.complex128]:
    """Sum of the dechirped echoes as a Dr.Jit kernel: one lane per sample, loop over scatterers.

    Same formulas as :func:`sum_echoes_numpy` (``mitsar.model.signal``; ``offsets`` as there);
    geometry and phase in float64, sin/cos of the wrapped phase in float32. Runs on the backend
    of :func:`mitsar.backend.array_namespace` (LLVM on the CPU or CUDA; docs/gpu.md).
    """
    jit = array_namespace()
    Float64, UInt32 = jit.Float64, jit.UInt32  # Dr.Jit type names
    sweeps = len(geometry.slow_time)
    times = fast_time(radar)
    sample_count = len(times)
    sweeps_per_chunk = max(1, min(sweeps, chunk_elements // sample_count))
    scatterers = len(positions)
    scatterer_arrays = [Float64(np.ascontiguousarray(a)) for a in (*positions.T, *velocities.T)]
    constants = (dr.opaque(Float64, radar.carrier_frequency), dr.opaque(Float64, radar.chirp_rate),
                 dr.opaque(Float64, 1.0 if rvp else 0.0), dr.opaque(UInt32, scatterers),
                 dr.opaque(UInt32, sample_count))
    samples = np.zeros((sweeps, sample_count), dtype=complex)
    for sweep0 in tqdm(range(0, sweeps, sweeps_per_chunk), disable=not progress,
                       desc="simulate", unit="chunk"):
        sweep_slice = slice(sweep0, sweep0 + sweeps_per_chunk)
        absolute_time = sample_times(radar, geometry, sweep_slice)
        platform, receiver = phase_centres(trajectory, absolute_time, offsets)
        platform = platform.reshape(-1, 3)
        chunk_amplitude = np.ascontiguousarray(amplitude[sweep_slice])
        width = len(platform)  # lanes, padded past Dr.Jit 1.5's crashing widths (safe_width):
        pad = safe_width(width) - width  # < 16 lanes, one extra sweep of zero amplitude
        if pad:
            chunk_amplitude = np.vstack([chunk_amplitude, np.zeros_like(chunk_amplitude[:1])])

        def lane_array(values: NDArray, pad: int = pad) -> Any:
            return Float64(np.pad(np.ascontiguousarray(values), (0, pad), mode="edge"))

        lanes = (lane_array(platform[:, 0]), lane_array(platform[:, 1]),
                 lane_array(platform[:, 2]), lane_array(absolute_time.ravel()),
                 lane_array(np.tile(times, width // sample_count)))
        receiver_lanes = (None if receiver is None
                          else tuple(lane_array(a) for a in receiver.reshape(-1, 3).T))
        real, imag = _echo_loop(*lanes, *scatterer_arrays, Float64(chunk_amplitude.real.ravel()),
                                Float64(chunk_amplitude.imag.ravel()), *constants,
                                receiver_lanes)
        dr.eval(real, imag)
        samples[sweep_slice] = (np.asarray(real)[:width]
                                + 1j * np.asarray(imag)[:width]).reshape(-1, sample_count)
    return samples


def _lane_delay(dx: Any, dy: Any, dz: Any, qx: Any, qy: Any, qz: Any, receiver: tuple | None
                ) -> Any:
    """Delay [s] of a lane from its offset to the transmitter (d = p - q): ``2 |d| / c``, or
    ``(|d| + |r - q|) / c`` with a bistatic receiver at r (:func:`bistatic_delay`)."""
    outgoing = dr.sqrt(dx * dx + dy * dy + dz * dz)
    if receiver is None:
        return (2.0 / SPEED_OF_LIGHT) * outgoing
    ex, ey, ez = receiver[0] - qx, receiver[1] - qy, receiver[2] - qz
    return (outgoing + dr.sqrt(ex * ex + ey * ey + ez * ez)) / SPEED_OF_LIGHT


@syntax  # drjit.syntax, applied on the first call (mitsar.backend.syntax)
def _echo_loop(px, py, pz, absolute_time, fast, qx, qy, qz, vx, vy, vz, amp_real,  # noqa: ANN001, ANN202
               amp_imag, carrier, chirp_rate, rvp, scatterers, sample_count, receiver=None):
    """Per sample lane: sum over scatterers of a exp{j 2 pi [f_c tau + K tau t - rvp K tau^2/2]}
    (``receiver``: the lanes' bistatic receiver positions, or None: monostatic). Array types
    from the inputs' backend (:func:`mitsar.backend.namespace_of`)."""
    jit = namespace_of(px)
    Float32, Float64, UInt32 = jit.Float32, jit.Float64, jit.UInt32
    lane = dr.arange(UInt32, dr.width(px))
    sweep = lane // sample_count
    acc_real = dr.zeros(Float64, dr.width(px))
    acc_imag = dr.zeros(Float64, dr.width(px))
    m = UInt32(0)
    while m < scatterers:
        tx = dr.gather(Float64, qx, m) + dr.gather(Float64, vx, m) * absolute_time
        ty = dr.gather(Float64, qy, m) + dr.gather(Float64, vy, m) * absolute_time
        tz = dr.gather(Float64, qz, m) + dr.gather(Float64, vz, m) * absolute_time
        delay = _lane_delay(px - tx, py - ty, pz - tz, tx, ty, tz, receiver)
        cycles = (carrier * delay + chirp_rate * delay * fast
                  - rvp * 0.5 * chirp_rate * delay * delay)
        # Wrapped to one cycle in float64, then sin/cos in float32 (error < 1e-6 rad).
        sin_phase, cos_phase = dr.sincos(Float32(2 * dr.pi * (cycles - dr.round(cycles))))
        sin_phase, cos_phase = Float64(sin_phase), Float64(cos_phase)
        index = sweep * scatterers + m
        a_real = dr.gather(Float64, amp_real, index)
        a_imag = dr.gather(Float64, amp_imag, index)
        acc_real += a_real * cos_phase - a_imag * sin_phase
        acc_imag += a_real * sin_phase + a_imag * cos_phase
        m += 1
    return acc_real, acc_imag
