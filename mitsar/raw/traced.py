"""Ray-traced acquisitions: scene -> range histograms -> raw (docs/design.md §2, §5.4, §5.5).

:func:`trace` runs the Mitsuba ``radar`` integrator (:mod:`mitsar.plugins.integrators.radar`)
over every sweep of an acquisition -- direct backscatter and, with ``max_depth > 1``, multipath
by shooting and bouncing rays (``docs/multipath.md``) -- and returns the *histogram product*
(:mod:`mitsar.products.histogram`);
:func:`histogram_to_raw_product` turns it into the raw product (one inverse FFT per sweep),
:func:`trace_paths` returns the path log of some rays of one sweep (ray-geometry figures), and
:func:`simulate_scene` traces and synthesises while streaming over sweep chunks, optionally
adding analytic point targets and a background from :func:`mitsar.simulate_point_targets`.

The histogram product's layout (``histogram`` (sweep, order, bin), ``apparent_range``, the
track, the tracer's attributes and work counters) is
:data:`~mitsar.products.histogram.HISTOGRAM_SCHEMA`, described in
:mod:`mitsar.products.histogram`; a multi-channel radar's channel traced by :func:`trace` adds
``channel`` and its ``transmitter_offset`` / ``receiver_offset``. Every option of a trace is a
field of the one trace request, :class:`mitsar.model.trace_options.TraceOptions`.
"""

from __future__ import annotations

import dataclasses
import warnings
from collections.abc import Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import MitsarWarning, ParameterError
from mitsar.model import histogram as hg
from mitsar.model.geometry.attitude import Look, antenna_frame
from mitsar.model.geometry.navigation import (
    NavigationErrors,
)
from mitsar.model.geometry.trajectory import Trajectory
from mitsar.model.noise import check_noise, thermal_noise
from mitsar.model.radar import Radar
from mitsar.model.targets import Background, PointTarget
from mitsar.model.trace_options import TraceOptions
from mitsar.plugins.integrators.radar import make_setup
from mitsar.products.histogram import (
    make_histogram_product,
    raw_from_histogram,
    validate_histogram,
)
from mitsar.products.raw import make_raw_product, radar_of
from mitsar.raw.analytic import simulate_point_targets
from mitsar.raw.trace_run import TraceRun

__all__ = ["histogram_to_raw_product", "simulate_scene", "trace", "trace_paths"]


def trace(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
          options: TraceOptions | None = None,
          navigation: Trajectory | NavigationErrors | None = None,
          motion: dict | None = None, **changes: Any) -> xr.Dataset:
    """Ray-trace an acquisition of a Mitsuba scene into range histograms.

    Parameters
    ----------
    radar, trajectory, look : Radar, Trajectory, Look
    scene : str, os.PathLike or mitsuba.Scene
        An XML file, a canned scene name, or a loaded scene. Its ``<integrator type="radar">``
        sets a layer of the trace request (under ``options`` and the keywords).
    options : TraceOptions, optional
        The trace request (:class:`mitsar.model.trace_options.TraceOptions`: sampling density
        and seed, kernels, multipath, 2D mode, physical optics, signal, determinism, bistatic
        receiver, sweeps, scene parameters, progress); its fields left ``None`` fall to the
        scene's integrator, then to the defaults.
    navigation : Trajectory or NavigationErrors, optional
        What the navigation system records (``trajectory`` is then the true track); see
        :func:`mitsar.simulate_point_targets`.
    motion : dict, optional
        ``{shape id: [vx, vy, vz]}`` [m/s] or ``{shape id: {"velocity": ..,
        "angular_velocity_deg": .., "centre": .., "path": {"times", "positions",
        "attitude_deg"}}}``: shapes that move during the acquisition, on top of the motion
        properties of the XML's shapes and the moving point targets
        (:mod:`mitsar.scene.motion`; docs/integrator.md §Moving objects). With any moving
        shape the scene is traced one sweep at a time, each with the shapes where they are.
    **changes
        Fields of :class:`~mitsar.model.trace_options.TraceOptions` set over ``options``, e.g.
        ``max_depth=3`` (multipath with up to two reflections), ``physical_optics=True``,
        ``sweeps=slice(0, 64)``, ``density=...`` (alias of ``scatterer_density``). The
        merge order and every field's unit and default: :mod:`mitsar.model.trace_options`.

    Returns
    -------
    xarray.Dataset
        The histogram product (module docstring).
    """
    run = TraceRun("trace", radar, trajectory, look, scene,
                   _request("trace", options, changes), navigation, motion)
    parts, indices = [], []
    for chosen, hist in run.chunks():
        indices.append(chosen)
        parts.append(hist if run.channels is None else hist[:, 0])  # the one channel
    sweeps = np.concatenate(indices)
    product = make_histogram_product(
        np.concatenate(parts, axis=0), run.radar, run.look, sweeps, run.ranges,
        *run.geometry_of(sweeps), rvp=run.config.rvp, normalized=run.config.normalized,
        first_index=int(run.grid[0]), attrs={**run.attrs(),
                                             **_sweep_stride("trace", sweeps, run.radar)})
    if run.channel is not None:  # one channel of several: its phase centres travel with it
        transmitters, receivers = run.radar.channel_offsets()
        product.attrs["channel"] = run.channel
        if run.radar.is_tdm:  # its transmitter's sweeps only (mitsar.products.raw.sweep_rate)
            product.attrs["sweep_stride"] = run.radar.transmitter_count
        for name, offset in (("transmitter_offset", transmitters[run.channel]),
                             ("receiver_offset", receivers[run.channel])):
            product[name] = ("xyz", np.asarray(offset, dtype=float),
                             {"units": "m", "long_name": f"body-frame {name.split('_')[0]} "
                              "phase centre of the channel"})
    return product


def _request(where: str, options: TraceOptions | None, changes: dict[str, Any]) -> TraceOptions:
    """The caller's layer of the trace request: ``options`` with the keyword ``changes``."""
    if options is not None and not isinstance(options, TraceOptions):
        raise ParameterError(where, "options", "None or a mitsar.TraceOptions", type(options))
    return (options or TraceOptions()).replace(where, **changes)


def trace_paths(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
                sweep: int = 0, rays: Any = 64, options: TraceOptions | None = None,
                **changes: Any) -> xr.Dataset:
    """Path log of a subset of the multipath rays of one sweep (ray-geometry figures).

    The rays are traced by the same kernel as :func:`trace` (nothing is deposited).

    Parameters
    ----------
    radar, trajectory, look, scene
        As :func:`trace`.
    sweep : int
        The sweep.
    rays : int or array_like of int
        How many rays of the grid to log (evenly spaced over the grid), or their indices.
    options, **changes
        The trace request, as :func:`trace` (``max_depth`` defaults to the scene integrator's,
        at least 2; the size of the ray grid is the request's ``rays``, or the keyword
        ``ray_count``). Direct backscatter is not traced.

    Returns
    -------
    xarray.Dataset
        Dims ``path`` (logged ray), ``segment`` (0: from the transmitter, k: after k
        reflections), ``xyz``. ``start`` and ``end`` (path, segment, xyz) [m]: the segment's
        origin and its hit, or a point 1.5x the scene's size away when it escapes (``hit``
        False); ``alive`` (the segment exists), ``field`` (product of ``Γ R`` at its start),
        ``power`` (transmit pattern x field², relative to the boresight ray's power density
        ignoring spreading), ``captured`` (capture weight; > 0: this segment's tube reaches the
        receiver), ``image`` (the transmitter's image the segment comes from), ``ray`` (grid
        index), ``launch`` (path, 2: launch direction sines p, q); ``transmitter``,
        ``receiver`` (xyz). Attribute ``plane_normal`` in 2D mode.
    """
    if "ray_count" in changes:  # the grid size (``rays`` here names the logged rays)
        changes["rays"] = changes.pop("ray_count")
    request = _request("trace_paths", options, changes).replace(
        "trace_paths", sweeps=np.array([sweep]), backscatter=False)
    run = TraceRun("trace_paths", radar, trajectory, look, scene, request)
    config = run.config
    if config.max_depth < 2:
        config = config.replace("trace_paths", max_depth=2)
        run.setup = _setup_for(run, config)
    grid = run.setup.rays
    chosen = np.asarray(rays)
    if chosen.ndim == 0:
        count = int(min(max(int(chosen), 1), len(grid)))
        chosen = np.unique(np.round(np.linspace(0, len(grid) - 1, count)).astype(np.int64))
    if chosen.ndim != 1 or np.any(chosen < 0) or np.any(chosen >= len(grid)):
        raise ParameterError("trace_paths", "rays", f"a count or ray indices in [0, "
                             f"{len(grid)})", rays)
    log = run.integrator.trace_paths(run.scene, run.geometry, run.trace_radar, run.frames,
                                     int(sweep), chosen, config, run.setup)
    box = run.scene.bbox()
    size = float(np.linalg.norm(np.array([float(v) for v in box.max])
                                - np.array([float(v) for v in box.min]))) or 1.0
    reach = np.where(log["hit"], log["t_hit"], 1.5 * size)
    end = log["origin"] + log["direction"] * reach[..., None]
    dead = ~log["alive"]
    for key in ("origin", "image"):
        log[key] = np.where(dead[..., None], np.nan, log[key])
    end = np.where(dead[..., None], np.nan, end)
    log["hit"] = log["hit"] & log["alive"]
    tx = run.geometry.position[sweep]
    data = xr.Dataset(
        {"start": (("path", "segment", "xyz"), log["origin"], {"units": "m"}),
         "end": (("path", "segment", "xyz"), end, {"units": "m"}),
         "hit": (("path", "segment"), log["hit"]),
         "alive": (("path", "segment"), log["alive"]),
         "field": (("path", "segment"), log["field"], {"long_name": "product of Gamma R"}),
         "power": (("path", "segment"), log["pattern"] * log["field"] ** 2,
                   {"long_name": "transmit pattern x field^2"}),
         "captured": (("path", "segment"), log["captured"]),
         "image": (("path", "segment", "xyz"), log["image"], {"units": "m"}),
         "launch": (("path", "pq"), np.stack([grid.p[chosen], grid.q[chosen]], axis=-1)),
         "transmitter": ("xyz", tx, {"units": "m"}),
         "receiver": ("xyz", tx + run.setup.receiver_offset, {"units": "m"}),
         "boresight": ("xyz", run.frames[sweep][:, 2])},
        coords={"path": np.arange(len(chosen)), "ray": ("path", chosen),
                "segment": np.arange(config.max_depth), "xyz": ["x", "y", "z"],
                "pq": ["p", "q"]})
    half_p = np.abs(grid.p).max() + 0.5 * grid.dp if not grid.planar else 0.0
    half_q = np.abs(grid.q).max() + 0.5 * grid.dq
    data.attrs.update(product="path_log", sweep=int(sweep), max_depth=int(config.max_depth),
                      rays_per_sweep=len(grid), scene=str(run.scene_name),
                      ray_cover=float(grid.cover), ray_dp=float(grid.dp), ray_dq=float(grid.dq),
                      beamwidth_p=float(half_p / grid.cover),
                      beamwidth_q=float(half_q / grid.cover),
                      look_off_nadir_deg=look.off_nadir_deg, look_squint_deg=look.squint_deg)
    if run.setup.planar:
        data.attrs["plane_normal"] = [float(v) for v in run.setup.plane_normals[sweep]]
        data.attrs["plane_axis"] = [float(v) for v in run.setup.ray_frames[sweep][:, 1]]
    data.attrs.update(run.radar.to_attrs())
    return data


def _setup_for(run: TraceRun, config: Any) -> Any:
    """The run's set-up remade for ``config`` (another ``max_depth``): the traced antenna's
    ray set, the run's receive channels and their beams kept."""
    rx_frames = (None if run.receiver_look is None
                 else antenna_frame(run.receiver_look, *run.geometry.attitude.T))
    setup = make_setup(run.trace_radar, run.frames, config, run.setup.receiver_offset,
                       rx_frames)
    return dataclasses.replace(setup, channel_receivers=run.setup.channel_receivers,
                               channel_beams=run.setup.channel_beams)


def _transmitter_groups(radar: Radar) -> list[tuple[int, ...]]:
    """The channels of a multi-channel radar grouped by transmitter (element: offset and beam;
    time slot), in channel order: one trace each (:class:`~mitsar.raw.trace_run.TraceRun`)."""
    elements, _ = radar.channel_elements()
    slots = radar.firing(np.arange(radar.transmitter_count))
    groups: dict[Any, list[int]] = {}
    for channel in range(radar.channel_count):
        groups.setdefault((elements[channel], tuple(slots[channel])), []).append(channel)
    return [tuple(group) for group in groups.values()]


def _trace_raw(run: TraceRun) -> tuple[TraceRun, NDArray[np.complex128], NDArray]:
    """(run, raw samples, orders kept) of one traced acquisition, chunk by chunk of sweeps
    (:func:`_synthesise`): samples (sweeps, samples_per_sweep), or (channels, sweeps,
    samples_per_sweep) for the channels of one transmitter (:attr:`TraceRun.channels`)."""
    receivers = 1 if run.channels is None else len(run.channels)
    samples = np.zeros((receivers, len(run.sweeps), run.radar.samples_per_sweep),
                       dtype=np.complex128)
    row = 0
    kept = np.arange(0)
    for chosen, hist in run.chunks(reuse=True):   # each chunk synthesised before the next
        per_receiver = hist[:, None] if run.channels is None else hist
        # every receiver of the chunk in one inverse FFT call: (sweeps, receivers, samples)
        chunk, kept = _synthesise(per_receiver, np.arange(hist.shape[-2]), run.config.orders,
                                  run.ranges, run.radar)
        samples[:, row:row + len(chosen)] = np.moveaxis(chunk, 1, 0)
        row += len(chosen)
    return run, samples if run.channels is not None else samples[0], kept


def _synthesise(histogram: NDArray, available: NDArray, orders: tuple[int, ...] | None,
                ranges: NDArray, radar: Radar) -> tuple[NDArray[np.complex128], NDArray]:
    """Raw sweeps of histograms (sweeps, [receivers,] orders, bins): the kept path orders
    summed, then one inverse FFT per sweep and receiver
    (:func:`mitsar.model.histogram.histogram_to_raw`, docs/design.md §5.5). The one
    histogram -> raw path of :func:`simulate_scene` and
    :func:`histogram_to_raw_product`.

    Returns
    -------
    samples : ndarray, shape (sweeps, [receivers,] samples_per_sweep)
    kept : ndarray of int
        The orders summed (of ``available``, the orders of the histogram's order axis).
    """
    mask = (np.ones(len(available), dtype=bool) if orders is None
            else np.isin(available, np.asarray(orders)))
    # one order kept: its histograms as they are (a view; a sum of one term is that term);
    # several: added order by order into one array (the same sums as .sum(axis=-2), without
    # the copy a boolean index of the order axis makes: 15 -> 4 ms on 2 receivers x 3 orders)
    chosen = np.flatnonzero(mask)
    if len(chosen) == 0:   # none of the traced orders kept: silence
        kept = np.zeros(histogram.shape[:-2] + histogram.shape[-1:], histogram.dtype)
    else:
        kept = histogram[..., int(chosen[0]), :]
    if len(chosen) > 1:
        kept = kept.copy()
        for order in chosen[1:]:
            np.add(kept, histogram[..., int(order), :], out=kept)
    samples = hg.histogram_to_raw(kept, ranges, radar)
    return samples, available[mask]


def histogram_to_raw_product(histogram: xr.Dataset, orders: Any = None) -> xr.Dataset:
    """The raw product of a histogram product (one inverse FFT per sweep).

    Parameters
    ----------
    histogram : xarray.Dataset
        Output of :func:`trace`.
    orders : int or sequence of int, optional
        Path orders to keep (e.g. ``0`` for direct backscatter only); default all, summed.

    Returns
    -------
    xarray.Dataset
        Raw product (:mod:`mitsar.products.raw`).
    """
    validate_histogram(histogram, "histogram_to_raw_product")
    radar = radar_of(histogram)
    wanted = TraceOptions().replace("histogram_to_raw_product", orders=orders).orders
    samples, kept = _synthesise(histogram["histogram"].values, histogram["order"].values,
                                wanted, histogram["apparent_range"].values, radar)
    return raw_from_histogram(histogram, samples, kept)


def simulate_scene(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
                   targets: Sequence[PointTarget] = (), background: Background | None = None,
                   options: TraceOptions | None = None,
                   navigation: Trajectory | NavigationErrors | None = None,
                   motion: dict | None = None, **changes: Any) -> xr.Dataset:
    """Raw data of a Mitsuba scene: trace, synthesise (streaming), add analytic targets.

    Histograms are turned into raw sweeps chunk by chunk, so memory stays bounded by the chunk
    size and the raw output. Analytic ``targets`` and ``background``
    (:func:`mitsar.simulate_point_targets`, same seed, ``rvp`` and ``normalized``) are added
    on top; they are not shadowed by the scene.

    Parameters
    ----------
    radar, trajectory, look, scene, navigation, motion
        As :func:`trace` (monostatic).
    targets : sequence of PointTarget
        Extra analytic point targets.
    background : Background, optional
        Extra analytic fluctuating background (paper eq. 4).
    options, **changes
        The trace request, as :func:`trace`; here also ``orders`` (path orders kept, default
        all) and ``noise`` (receiver noise ``k T0 F f_s`` per complex sample, needs
        ``radar.noise_figure_db``, drawn by :func:`mitsar.model.noise.thermal_noise` from the
        request's seed and each sample's sweep and index, so a subset of ``sweeps`` gets the
        same noise as in the full run).

    Returns
    -------
    xarray.Dataset
        Raw product (:mod:`mitsar.products.raw`).
    """
    request = _request("simulate_scene", options, changes)
    resolved = request.resolve("simulate_scene")  # refused before the scene is loaded
    check_noise("simulate_scene", radar, resolved.noise, resolved.normalized)
    # One trace per transmitter of a radar with phase centres, serving all its receivers
    # (docs/interferometry.md §8); the scene's scatterers are drawn once and shared.
    groups = _transmitter_groups(radar) if radar.has_channels else [None]
    traced = [_trace_raw(TraceRun("simulate_scene", radar, trajectory, look, scene, request,
                                  navigation, motion, channels=groups[0]))]
    for group in groups[1:]:  # the first group's loaded scene: its scatterers are reused
        shared = dataclasses.replace(request, scene_params=None)
        traced.append(_trace_raw(TraceRun("simulate_scene", radar, trajectory, look,
                                          traced[0][0].scene, shared, navigation, motion,
                                          channels=group)))
    run, kept = traced[0][0], traced[0][2]
    sweeps = run.acquisition_sweeps
    if radar.has_channels:  # each group traced its slot's sweeps (TDM-MIMO: zeros elsewhere)
        samples = np.zeros((radar.channel_count, len(sweeps), radar.samples_per_sweep), complex)
        for group, (group_run, group_samples, _) in zip(groups, traced, strict=True):
            samples[np.ix_(group, np.searchsorted(sweeps, group_run.sweeps))] = group_samples
    else:
        samples = traced[0][1]
    channels = range(radar.channel_count)
    config = run.config
    attrs = run.attrs()
    # every transmitter's reception warnings (each traces its own beam), each sentence once
    sentences = dict.fromkeys(line for group_run, _, _ in traced
                              for line in group_run.reception_warnings)
    if sentences:
        attrs["reception_warnings"] = "\n".join(sentences)
    attrs.update(simulator="ray tracing (radar integrator)", normalized=int(config.normalized),
                 orders=[int(o) for o in kept])
    if targets or background is not None:
        analytic = simulate_point_targets(radar, trajectory, look, targets, background,
                                          seed=config.seed, rvp=config.rvp,
                                          normalized=config.normalized, navigation=run.recorded)
        samples += analytic["raw"].values[..., sweeps, :]
        attrs["simulator"] += " + analytic point targets"
        attrs["analytic_config"] = analytic.attrs.get("config", "{}")
    if not np.any(samples):
        warnings.warn(f"simulate_scene: raw data of exact zeros: nothing of the scene is in the "
                      f"beam ({attrs['scatterer_count']} surface scatterers, "
                      f"{attrs['point_target_count']} point targets, orders {attrs['orders']}): "
                      "check the look angles, the trajectory, the materials and the orders",
                      MitsarWarning, stacklevel=2)
    attrs["noise"] = int(config.noise)
    if config.noise and radar.has_channels:  # independent noise per receiver
        fires = radar.firing(sweeps)  # TDM-MIMO: only in the sweeps a channel fires
        for k in channels:
            samples[k, fires[k]] += thermal_noise(radar, config.seed, sweeps[fires[k]], k)
    elif config.noise:
        samples += thermal_noise(radar, config.seed, sweeps)
    if config.noise:
        attrs.update(noise_power=radar.noise_power, noise_seed=int(config.seed))
    attrs.update(_sweep_stride("simulate_scene", sweeps, radar))
    recorded, true = run.geometry_of(sweeps)
    return make_raw_product(samples, radar, look, recorded, rvp=config.rvp, attrs=attrs,
                            true_geometry=true, sweeps=sweeps)


def _sweep_stride(where: str, sweeps: NDArray, radar: Radar) -> dict[str, int]:
    """``{"sweep_stride": s}`` for sweeps every ``s``-th sweep of the acquisition (``s > 1``):
    the focusers then take the product's pulse rate as PRF/s (:func:`mitsar.products.raw.
    sweep_rate`; without it BPA selects its Doppler band at the full PRF and misfocuses).
    Sweeps that are not evenly spaced are said (:class:`MitsarWarning`): the focusers assume
    one pulse rate."""
    steps = np.diff(np.asarray(sweeps))
    if len(steps) == 0 or radar.is_tdm:  # TDM-MIMO: channel_view gives each slot's stride
        return {}
    if np.all(steps == steps[0]):
        return {"sweep_stride": int(steps[0])} if steps[0] > 1 else {}
    warnings.warn(f"{where}: the sweeps traced are not evenly spaced (steps {int(steps.min())} "
                  f"to {int(steps.max())}): the focusers assume one pulse rate, so focus "
                  "a contiguous or evenly strided selection", MitsarWarning, stacklevel=3)
    return {}
