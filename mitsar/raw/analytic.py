"""The analytic point-target simulator (paper §3.1): exact per-sample delays, no stop-and-go.

For every sweep k and fast-time sample n the platform position ``p(eta_k + T/2 + t_n)`` and the
target position ``q(eta_k + T/2 + t_n)`` give the two-way delay, and the echo is the dechirped
signal of :mod:`mitsar.model.signal` (paper eqs. 1-2, with the residual video phase unless
``rvp=False``). Amplitudes follow the radar equation with the two-way antenna pattern at
mid-sweep (within one 4 ms sweep it changes by < 1% at the beam edge, a second-order effect
since mid-sweep is the centre of the symmetric fast-time interval).

This module plans a simulation (checks, geometry, scatterers, warnings, product) and streams it
by chunks of sweeps; the amplitudes are :mod:`mitsar.raw.echo_amplitudes`'s and the echo sums
(NumPy reference and Dr.Jit kernel) :mod:`mitsar.raw.echo_sums`'s.
"""

from __future__ import annotations

import dataclasses
import math
import warnings
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray
from tqdm.auto import tqdm

from mitsar.budget import require_memory
from mitsar.checks import integer
from mitsar.checks import seed as check_seed
from mitsar.errors import MitsarWarning, ParameterError
from mitsar.model.elements import element_beam, element_frame
from mitsar.model.geometry.attitude import Look, antenna_frame, body_to_world
from mitsar.model.geometry.navigation import (
    NavigationErrors,
    describe_navigation,
    resolve_navigation,
)
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.noise import check_noise, thermal_noise
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.reception import channel_warnings, reception, reception_warnings
from mitsar.model.signal import apparent_beat_frequency, sweep_count
from mitsar.model.targets import Background, PointTarget
from mitsar.products.raw import make_raw_product
from mitsar.raw.echo_amplitudes import channel_amplitudes
from mitsar.raw.echo_sums import channel_offsets, sum_echoes_drjit, sum_echoes_numpy
from mitsar.raw.product import require_raw_memory, sweep_geometry

STREAM_KERNEL_LANES = 2**16
"""Samples per kernel launch of :func:`stream_point_targets` (about 60 bytes each in the
kernel), so that a streamed simulation's memory is one chunk of output, not of lanes."""

TABLE1_AZIMUTH_RESOLUTION = 0.10
"""Azimuth resolution of paper Table 1 [m], the default azimuth size of a background cell."""


def background_cell_area(radar: Radar, background: Background, platform_position: NDArray,
                         azimuth_resolution: float = TABLE1_AZIMUTH_RESOLUTION) -> float:
    """Area of one resolution cell on the background patch [m^2].

    Ground-range cell ``(c / 2B) / sin(theta_inc)`` (theta_inc: incidence on the patch seen
    from ``platform_position``) times the azimuth resolution.
    """
    normal = np.cross(background.axis_u, background.axis_v)
    line_of_sight = np.asarray(background.center) - platform_position
    cos_incidence = abs(line_of_sight @ normal) / np.linalg.norm(line_of_sight)
    sin_incidence = max(np.sqrt(max(1.0 - cos_incidence**2, 0.0)), 1e-3)
    return radar.range_resolution / sin_incidence * azimuth_resolution


def require_background_memory(background: Background, count: int, sweeps: int) -> None:
    """Refuse a background whose scatterers would not fit in memory (docs/reliability.md §2).

    Per scatterer: position and velocity (48 bytes) and, per sweep it is drawn for (every
    sweep in ``pulse`` mode), its Gaussian draw, reflectivity, stacked copy and echo amplitude
    (4 x 16 bytes).
    """
    draws = sweeps if background.mode == "pulse" else 1
    nbytes = float(count) * (96 + 64 * draws) + float(count) * 16 * sweeps
    require_memory("simulate_point_targets", "background.size", nbytes,
                   f"{count:.3g} scatterers (size / resolution cell x scatterers_per_cell "
                   f"{background.scatterers_per_cell}) over {sweeps} sweeps: a smaller patch or "
                   "fewer scatterers_per_cell")


def _check_inputs(radar: Radar, trajectory: Trajectory, look: Look,
                  targets: Sequence[PointTarget], background: Background | None) -> None:
    if not isinstance(radar, Radar):
        raise ParameterError("simulate_point_targets", "radar", "a mitsar.Radar", type(radar))
    if not isinstance(trajectory, Trajectory):
        raise ParameterError("simulate_point_targets", "trajectory", "a mitsar.Trajectory",
                             type(trajectory))
    if not isinstance(look, Look):
        raise ParameterError("simulate_point_targets", "look", "a mitsar.Look", type(look))
    for index, target in enumerate(targets):
        if not isinstance(target, PointTarget):
            raise ParameterError("simulate_point_targets", f"targets[{index}]",
                                 "a mitsar.PointTarget", type(target))
    if background is not None and not isinstance(background, Background):
        raise ParameterError("simulate_point_targets", "background",
                             "None or a mitsar.Background", type(background))
    if not targets and background is None:
        raise ParameterError("simulate_point_targets", "targets",
                             "at least one target or a background", targets)


def simulate_point_targets(radar: Radar, trajectory: Trajectory, look: Look,
                           targets: Sequence[PointTarget] = (),
                           background: Background | None = None, seed: int = 0, *,
                           rvp: bool = True, normalized: bool = False, pattern: bool = True,
                           noise: bool = False, progress: bool = False, backend: str = "drjit",
                           chunk_elements: int = 2**20,
                           navigation: Trajectory | NavigationErrors | None = None
                           ) -> xr.Dataset:
    """Simulate dechirped FMCW raw data of point targets and a fluctuating background.

    Parameters
    ----------
    radar : Radar
    trajectory : Trajectory
    look : Look
    targets : sequence of PointTarget
    background : Background, optional
        Fluctuating background (paper eq. 4).
    seed : int
        Seed of every random draw (background, noise); recorded in the product.
    rvp : bool
        Include the residual video phase (default) or drop it (paper eq. 1).
    normalized : bool
        Unit amplitude per unit sqrt(RCS) instead of radar-equation amplitudes (paper eq. 1).
    pattern : bool
        Weight by the two-way antenna pattern.
    noise : bool
        Add thermal noise ``k T0 F f_s`` per complex sample (needs ``radar.noise_figure_db``).
    progress : bool
        Show a progress bar.
    backend : {"drjit", "numpy"}
        The Dr.Jit kernel (one lane per sample, a loop over scatterers) or the NumPy reference.
    chunk_elements : int
        Bound on the lanes (Dr.Jit: sweeps x samples) or on sweeps x samples x scatterers
        (NumPy) evaluated at once (memory). The default 2**20 keeps Dr.Jit 1.5's LLVM backend
        clear of a crash seen with two consecutive launches of ~2**22 lanes (7942 sweeps of
        the paper's radar; tests/test_simulate.py keeps a long pass in the suite).
    navigation : Trajectory or NavigationErrors, optional
        What the navigation system records: ``trajectory`` is then the *true* track (echoes,
        antenna pattern and attitude follow it), and the product's platform variables hold the
        navigation track, with the true one under ``true_*`` (docs/navigation.md).

    Returns
    -------
    xarray.Dataset
        The raw product (:mod:`mitsar.raw.product`).

    Examples
    --------
    >>> import mitsar
    >>> raw = mitsar.simulate_point_targets(
    ...     mitsar.Radar(), mitsar.Trajectory.linear([14.8, 1.4, 4.5], [0.5, 0, 0], 0.1),
    ...     mitsar.Look(55.7), [mitsar.PointTarget([15.0, 8.0, 0.0])])
    >>> raw["raw"].dims
    ('sweep', 'sample')
    """
    plan = _plan(radar, trajectory, look, targets, background, seed, rvp=rvp,
                 normalized=normalized, pattern=pattern, noise=noise, backend=backend,
                 navigation=navigation)
    sweeps = plan["sweeps"]
    amplitudes = channel_amplitudes(radar, look, plan["geometry"], plan["positions"],
                                    plan["velocities"], plan["reflectivity"](sweeps),
                                    normalized=normalized, pattern=pattern)
    if not any(np.any(amplitude) for amplitude in amplitudes):
        raise _all_zero_error()
    sum_echoes = sum_echoes_drjit if backend == "drjit" else sum_echoes_numpy
    channels = [_channel_samples(radar, trajectory, plan, plan["geometry"], amplitudes[channel],
                                 np.arange(sweeps), channel, offsets, sum_echoes, rvp=rvp,
                                 noise=noise, seed=seed, progress=progress,
                                 chunk_elements=chunk_elements)
                for channel, offsets in enumerate(channel_offsets(radar))]
    return _product(plan, _stack(radar, channels), slice(0, sweeps), first=True)


def stream_point_targets(radar: Radar, trajectory: Trajectory, look: Look,
                         targets: Sequence[PointTarget] = (),
                         background: Background | None = None, seed: int = 0, *,
                         rvp: bool = True, normalized: bool = False, pattern: bool = True,
                         noise: bool = False, progress: bool = False, backend: str = "drjit",
                         sweeps_per_chunk: int = 1024,
                         navigation: Trajectory | NavigationErrors | None = None,
                         first_chunk: int = 0) -> Iterator[xr.Dataset]:
    """:func:`simulate_point_targets` chunk by chunk of sweeps, for products larger than memory.

    Yields raw products of ``sweeps_per_chunk`` consecutive sweeps (the last one shorter) whose
    ``sweep`` coordinate counts from the acquisition's first sweep; concatenated along
    ``sweep`` they are the product :func:`simulate_point_targets` makes with the same
    arguments (the same samples: the background is drawn in the same order, and the thermal
    noise of a sample depends only on the seed and its sweep and sample index). Variables
    without a ``sweep`` dimension (targets, background draw) come with the first chunk only.
    Memory: the per-sweep geometry of the whole pass (a few hundred bytes a sweep) plus one
    chunk's samples, amplitudes and kernel lanes.

    Parameters
    ----------
    sweeps_per_chunk : int
        Sweeps per yielded chunk (>= 1).
    first_chunk : int
        Chunks not yielded, to resume an interrupted run (:func:`mitsar.experiment.runs.
        simulate_to`): their random draws are still made, without the echo sums, so that the
        chunks yielded are those of a run from the start, bit for bit.
    Other parameters
        As for :func:`simulate_point_targets`.

    Raises
    ------
    ParameterError
        As :func:`simulate_point_targets` (an all-zero acquisition after the last chunk).
    """
    sweeps_per_chunk = integer("stream_point_targets", "sweeps_per_chunk", sweeps_per_chunk, 1)
    first_chunk = integer("stream_point_targets", "first_chunk", first_chunk, 0)
    plan = _plan(radar, trajectory, look, targets, background, seed, rvp=rvp,
                 normalized=normalized, pattern=pattern, noise=noise, backend=backend,
                 navigation=navigation, budget_sweeps=sweeps_per_chunk)
    sweeps, geometry = plan["sweeps"], plan["geometry"]
    sum_echoes = sum_echoes_drjit if backend == "drjit" else sum_echoes_numpy
    any_echo = False
    for start in tqdm(range(0, sweeps, sweeps_per_chunk), disable=not progress,
                      desc="simulate", unit="chunk"):
        part = slice(start, min(start + sweeps_per_chunk, sweeps))
        chunk_geometry = geometry.select(part)
        amplitudes = channel_amplitudes(radar, look, chunk_geometry, plan["positions"],
                                        plan["velocities"],
                                        plan["reflectivity"](part.stop - start),
                                        normalized=normalized, pattern=pattern)
        any_echo = any_echo or any(bool(np.any(amplitude)) for amplitude in amplitudes)
        if start < first_chunk * sweeps_per_chunk:  # done by an interrupted run: draws only
            continue
        channels = [_channel_samples(radar, trajectory, plan, chunk_geometry, amplitudes[channel],
                                     np.arange(part.start, part.stop), channel, offsets,
                                     sum_echoes, rvp=rvp, noise=noise, seed=seed,
                                     progress=False, chunk_elements=STREAM_KERNEL_LANES)
                    for channel, offsets in enumerate(channel_offsets(radar))]
        yield _product(plan, _stack(radar, channels), part, first=start == 0)
    if not any_echo:
        raise _all_zero_error()


def _channel_samples(radar: Radar, trajectory: Trajectory, plan: dict, geometry: SweepGeometry,
                     amplitude: NDArray, sweep_indices: NDArray, channel: int,
                     offsets: tuple[NDArray, NDArray] | None, sum_echoes: Any, *, rvp: bool,
                     noise: bool, seed: int, progress: bool, chunk_elements: int
                     ) -> NDArray[np.complex128]:
    """Samples (sweeps, samples) of one channel over the sweeps ``sweep_indices`` (acquisition
    indices) with their ``geometry`` and echo ``amplitude`` rows, and its thermal noise.

    Under TDM-MIMO (:attr:`Radar.is_tdm`) only the sweeps of the channel's transmitter slot
    are simulated (:meth:`Radar.firing`); the others stay exact zeros, noise included: that
    transmitter is silent and the receiver's samples of those sweeps belong to other
    channels. Each fired sample's delay is the exact bistatic one at its own time, so the
    platform motion between the slots is in the samples.
    """
    if not radar.is_tdm:
        samples = sum_echoes(radar, trajectory, geometry, plan["positions"], plan["velocities"],
                             amplitude, rvp=rvp, progress=progress,
                             chunk_elements=chunk_elements, offsets=offsets)
        if noise:
            samples += thermal_noise(radar, seed, sweep_indices, channel)
        return samples
    fires = radar.firing(sweep_indices)[channel]
    samples = np.zeros((len(sweep_indices), radar.samples_per_sweep), dtype=complex)
    if not fires.any():
        return samples
    samples[fires] = sum_echoes(radar, trajectory, geometry.select(fires), plan["positions"],
                                plan["velocities"], amplitude[fires], rvp=rvp,
                                progress=progress, chunk_elements=chunk_elements,
                                offsets=offsets)
    if noise:
        samples[fires] += thermal_noise(radar, seed, sweep_indices[fires], channel)
    return samples


def _stack(radar: Radar, channels: list[NDArray]) -> NDArray:
    """Samples (sweeps, samples) of a single-channel radar, (channels, sweeps, samples) else."""
    return np.stack(channels) if radar.has_channels else channels[0]


def _all_zero_error() -> ParameterError:
    return ParameterError(
        "simulate_point_targets", "targets", "echoes inside the antenna beam in some sweep "
        "(every target and background scatterer has a zero two-way pattern or RCS: check "
        "the look angles and the positions, or pattern=False)", "raw data of exact zeros")


def _plan(radar: Radar, trajectory: Trajectory, look: Look, targets: Sequence[PointTarget],
          background: Background | None, seed: int, *, rvp: bool, normalized: bool,
          pattern: bool, noise: bool, backend: str,
          navigation: Trajectory | NavigationErrors | None,
          budget_sweeps: int | None = None) -> dict:
    """Checks, geometry, scatterers and product metadata of an analytic simulation.

    ``budget_sweeps``: sweeps held in memory at once (default all; a streamed simulation holds
    one chunk), for the memory checks.

    ``reflectivity(n)`` draws the complex sqrt(RCS) of every scatterer for the next ``n``
    sweeps, shape (n, scatterers), in the order a single draw of all sweeps would make.
    """
    if isinstance(targets, PointTarget):
        raise ParameterError("simulate_point_targets", "targets", "a list of mitsar.PointTarget "
                             "(wrap a single target: [target])", "one PointTarget")
    try:
        targets = list(targets)
    except TypeError:
        raise ParameterError("simulate_point_targets", "targets", "a list of mitsar.PointTarget",
                             type(targets)) from None
    _check_inputs(radar, trajectory, look, targets, background)
    seed = check_seed("simulate_point_targets", "seed", seed)
    if backend not in ("drjit", "numpy"):
        raise ParameterError("simulate_point_targets", "backend", "'drjit' or 'numpy'", backend)
    radar.check_prf(trajectory.max_speed())
    check_noise("simulate_point_targets", radar, noise, normalized)
    sweeps = sweep_count(radar, trajectory.duration)
    if sweeps < 1:
        raise ParameterError("simulate_point_targets", "trajectory.duration",
                             f">= one sweep ({radar.sweep_duration:g} s)", trajectory.duration)
    held = sweeps if budget_sweeps is None else min(sweeps, budget_sweeps)
    require_raw_memory("simulate_point_targets", radar, held)
    rng = np.random.default_rng(seed)
    geometry = sweep_geometry(radar, trajectory, look, sweeps)
    recorded = resolve_navigation("simulate_point_targets", trajectory, navigation)

    positions = np.array([t.position for t in targets], dtype=float).reshape(-1, 3)
    velocities = np.array([t.velocity for t in targets], dtype=float).reshape(-1, 3)
    target_reflectivity = np.sqrt(np.array([t.rcs for t in targets], dtype=float))
    extra_attrs: dict = {}
    background_draw = None
    if background is not None:
        mid = geometry.position[sweeps // 2]
        cell_area = background_cell_area(radar, background, mid)
        count = background.scatterer_count(cell_area)
        require_background_memory(background, count, held)
        background_positions = background.draw_positions(count, rng)
        frozen = (None if background.mode == "pulse"
                  else background.draw_reflectivities((count,), rng, cell_area))
        positions = np.vstack([positions, background_positions])
        velocities = np.vstack([velocities, np.zeros((count, 3))])
        background_draw = [background_positions, frozen]
        extra_attrs.update(background_scatterers=count, background_cell_area=cell_area,
                           background_mode=background.mode,
                           background_cell_rcs_db=background.cell_rcs_db)

    _check_beat_frequencies(radar, geometry, positions, velocities, len(targets))
    unreceived = _reception_warnings(radar, look, geometry, targets, pattern)

    def reflectivity(n: int) -> NDArray[np.complex128]:
        parts = [np.broadcast_to(target_reflectivity, (n, len(targets))).astype(complex)]
        if background_draw is not None:
            count = len(background_draw[0])
            drawn = (background.draw_reflectivities((n, count), rng, cell_area)
                     if background.mode == "pulse" else background_draw[1])
            drawn = np.broadcast_to(drawn, (n, count))
            if background_draw[1] is None:
                background_draw[1] = np.array(drawn[0])  # first sweep, for the record
            parts.append(drawn)
        return np.hstack(parts)

    config = {"targets": [{"position": list(t.position), "rcs": t.rcs,
                           "velocity": list(t.velocity)} for t in targets],
              "trajectory": trajectory.describe(),
              "navigation": describe_navigation(navigation),
              "background": None if background is None else {
                  "center": list(background.center), "size": list(background.size),
                  "cell_rcs_db": background.cell_rcs_db,
                  "scatterers_per_cell": background.scatterers_per_cell,
                  "mode": background.mode, "axis_u": list(background.axis_u),
                  "axis_v": list(background.axis_v)}}
    attrs = {"seed": int(seed), "normalized": int(normalized), "pattern": int(pattern),
             "noise": int(noise), "simulator": "analytic point targets",
             "trajectory_kind": (trajectory if recorded is None else recorded).kind,
             "trajectory_straight": int((trajectory if recorded is None
                                         else recorded).is_straight), "config": config,
             **extra_attrs}
    if unreceived:  # docs/reliability.md: echoes that cannot be received, said and recorded
        attrs["reception_warnings"] = "\n".join(unreceived)
    if targets:  # mitsar.products.requests: the targets, for the figures' marks
        attrs["target_positions"] = tuple(float(v) for t in targets for v in t.position)
    if noise:  # docs/metrics.md §Noise
        attrs.update(noise_power=radar.noise_power, noise_seed=int(seed))
    return {"sweeps": sweeps, "geometry": geometry, "rng": rng, "positions": positions,
            "velocities": velocities, "reflectivity": reflectivity, "targets": targets,
            "background_draw": background_draw, "attrs": attrs, "radar": radar, "look": look,
            "rvp": rvp, "recorded_geometry": None if recorded is None
            else sweep_geometry(radar, recorded, look, sweeps)}


def _product(plan: dict, samples: NDArray, part: slice, first: bool) -> xr.Dataset:
    """The raw product of the sweeps ``part`` (:func:`make_raw_product`); with ``first`` also
    the variables without a sweep dimension."""
    def cut(geometry: SweepGeometry | None) -> SweepGeometry | None:
        return None if geometry is None else geometry.select(part)

    geometry, recorded = cut(plan["geometry"]), cut(plan["recorded_geometry"])
    product = make_raw_product(
        samples, plan["radar"], plan["look"], geometry if recorded is None else recorded,
        rvp=plan["rvp"], true_geometry=None if recorded is None else geometry,
        attrs=plan["attrs"], sweeps=np.arange(part.start, part.start + samples.shape[-2]))
    if not first:
        return product
    targets, background_draw = plan["targets"], plan["background_draw"]
    product["target_position"] = (("target", "xyz"), np.array(
        [t.position for t in targets], dtype=float).reshape(-1, 3), {"units": "m"})
    product["target_rcs"] = (("target",), np.array([t.rcs for t in targets], dtype=float),
                             {"units": "m^2"})
    if background_draw is not None:
        product["background_position"] = (("scatterer", "xyz"), background_draw[0],
                                          {"units": "m"})
        product["background_reflectivity"] = (("scatterer",), background_draw[1], {
            "units": "m", "long_name": "complex sqrt(RCS) of each scatterer, first sweep"})
    return product


def _check_beat_frequencies(radar: Radar, geometry: SweepGeometry, positions: NDArray,
                            velocities: NDArray, target_count: int) -> None:
    """Refuse echoes whose beat frequency exceeds the Nyquist limit (they would wrap around).

    ``K tau + f_c dtau/dt`` (:func:`mitsar.model.signal.apparent_beat_frequency`) at mid-sweep of
    the first, middle and last sweeps, for every scatterer.
    """
    sweeps = len(geometry.slow_time)
    for sweep in sorted({0, sweeps // 2, sweeps - 1}):
        time = geometry.slow_time[sweep] + radar.sweep_duration / 2
        offset = positions + velocities * time - geometry.position[sweep]
        slant_range = np.linalg.norm(offset, axis=-1)
        rate = 2 / SPEED_OF_LIGHT * np.einsum(
            "mi,mi->m", velocities - geometry.velocity[sweep], offset) / slant_range
        beat = apparent_beat_frequency(2 * slant_range / SPEED_OF_LIGHT, rate, radar)
        worst = int(np.argmax(np.abs(beat)))
        if abs(beat[worst]) > radar.sampling_frequency / 2:
            name = f"targets[{worst}]" if worst < target_count else "background"
            raise ParameterError(
                "simulate_point_targets", name,
                f"an echo within the receiver's band: beat frequency <= fs/2 = "
                f"{radar.sampling_frequency / 2:g} Hz, i.e. slant range <= "
                f"{radar.max_range:g} m (max_range)",
                f"{beat[worst]:.4g} Hz at {slant_range[worst]:.3f} m (sweep {sweep})")


def _reception_warnings(radar: Radar, look: Look, geometry: SweepGeometry,
                        targets: list[PointTarget], pattern: bool) -> list[str]:
    """Warn (:class:`MitsarWarning`), before any compute, about each target whose echo a real
    radar could not receive as modelled: outside the main lobe for the whole flight, beyond
    ``max_range`` or in the antenna's near field (:mod:`mitsar.model.reception`); returns the
    sentences, which the raw product records (``reception_warnings``)."""
    if not targets:
        return []
    positions = np.array([t.position for t in targets], dtype=float)
    seen = reception(radar, positions, geometry.position,
                     antenna_frame(look, *geometry.attitude.T),
                     np.array([t.velocity for t in targets], dtype=float),
                     geometry.slow_time + radar.sweep_duration / 2)
    names = [f"targets[{i}] at [{', '.join(f'{v:g}' for v in p)}] m"
             for i, p in enumerate(positions)]
    messages = reception_warnings(radar, seen, names, pattern=pattern)
    messages += channel_warnings(radar, positions, geometry.position,  # each channel's own
                                 body_to_world(*geometry.attitude.T), names, seen,
                                 [t.velocity for t in targets],
                                 geometry.slow_time + radar.sweep_duration / 2)
    if pattern and radar.has_element_beams:
        messages += _element_warnings(radar, look, geometry, positions, targets, names)
    for message in messages:
        warnings.warn(f"simulate_point_targets: {message}", MitsarWarning, stacklevel=4)
    return messages


def _element_warnings(radar: Radar, look: Look, geometry: SweepGeometry, positions: NDArray,
                      targets: list[PointTarget], names: list[str]) -> list[str]:
    """One sentence per (element with its own beam, target) outside that element's main lobe
    in every sweep (:func:`mitsar.model.reception.reception` with the element's beamwidths and
    frame): the channels through it receive the target through sidelobes only, or nothing
    behind the element."""
    transmitters, receivers = radar.channel_elements()
    attitude = body_to_world(*geometry.attitude.T)
    messages = []
    roles = ((("transmit-receive", receivers),) if radar.ping_pong
             else (("transmitter", transmitters), ("receiver", receivers)))
    for role, elements in roles:
        for element in dict.fromkeys(e for e in elements if e.has_own_beam):
            channels = [k for k, e in enumerate(elements) if e == element]
            beam = element_beam(element, (radar.azimuth_beamwidth, radar.elevation_beamwidth),
                                look)
            own = dataclasses.replace(radar, azimuth_beamwidth_deg=math.degrees(
                beam.beamwidth_az), elevation_beamwidth_deg=math.degrees(beam.beamwidth_el),
                receivers=None, transmitters=None, ping_pong=False)
            seen = reception(own, positions, geometry.position,
                             attitude @ element_frame(element, look),
                             np.array([t.velocity for t in targets], dtype=float),
                             geometry.slow_time + radar.sweep_duration / 2)
            for i in np.flatnonzero(~seen.main_lobe):
                peak = float(np.sqrt(seen.peak_pattern[i]))  # one-way power pattern
                what = ("is behind it or on a null of its pattern in every sweep: no echo"
                        if peak <= 0.0 else f"is outside its main lobe in every sweep (peak "
                        f"one-way pattern {10 * np.log10(peak):.1f} dB): sidelobes only")
                messages.append(
                    f"{names[i]}, seen by the {role} element at "
                    f"[{', '.join(f'{v:g}' for v in element.position)}] m with its own "
                    f"pattern/boresight (channels {channels}), {what} (check the element's "
                    "boresight and beamwidths)")
    return messages
