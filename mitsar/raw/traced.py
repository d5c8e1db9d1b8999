"""Ray-traced acquisitions: scene -> range histograms -> raw (docs/design.md §2, §5.4, §5.5).

:func:`trace` runs the Mitsuba ``radar`` integrator (``mitsar/plugins/radar.py``) over every
sweep of an acquisition -- direct backscatter and, with ``max_depth > 1``, multipath by shooting
and bouncing rays (``docs/multipath.md``) -- and returns the *histogram product*;
:func:`histogram_to_raw_product` turns it into the raw product (one inverse FFT per sweep),
:func:`trace_paths` returns the path log of some rays of one sweep (ray-geometry figures), and
:func:`simulate_scene` traces and synthesises while streaming over sweep chunks, optionally
adding analytic point targets and a background from :func:`mitsar.simulate_point_targets`.

Histogram product
-----------------
``histogram`` (sweep, order, bin) complex
    Sum of the deposits ``a exp{j 2 pi (f_c tau_0 - K tau_0^2/2 + phi)}`` at each apparent range
    bin [sqrt(W)]. ``order`` is the number of specular reflections on the path (0: direct
    backscatter; 1: e.g. a mirror; 2: dihedral; 3: trihedral), ``0 .. max_depth - 1``.
``apparent_range`` (bin) [m]
    ``(k_0 + j) dr``, ``dr`` = range cell / ``bins_per_cell`` (:mod:`mitsar.model.histogram`).
``slow_time``, ``platform_position``, ``platform_velocity``, ``boresight``, ``attitude``
    As in the raw product; ``sweep`` holds the absolute sweep indices of the acquisition.
attributes
    ``radar_*``, ``look_*``, ``product = "histogram"``, ``rvp``, ``normalized``, ``seed``,
    ``scatterer_count``, ``point_target_count``, ``scatterer_density``, ``bins_per_cell``,
    ``histogram_first_index``, ``acquisition_sweeps``, ``integrator`` (JSON), ``scene``,
    ``traced_pairs``, ``traced_candidate_pairs``, ``traced_shadow_rays``, ``traced_launches``,
    ``traced_rays``, ``traced_segments``, ``traced_captures`` (work counters), ``backscatter``,
    ``receiver_offset``, ``rays_per_sweep``, provenance.
"""

from __future__ import annotations

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
          density: float | None = None, seed: int | None = None, sweeps: Any = None,
          chunk_lanes: int | None = None, bins_per_cell: int | None = None,
          beam_cull: float | None = None, rvp: bool = True, normalized: bool = False,
          scene_params: dict | None = None, progress: bool = False,
          max_depth: int | None = None, rays: int | None = None,
          ray_cover: float | None = None, capture: str | None = None,
          ghosts: bool | None = None, plane_normal: Any = None,
          slab_width: float | None = None, receiver_offset: Any = None,
          receiver_look: Look | None = None, backscatter: bool = True,
          navigation: Trajectory | NavigationErrors | None = None,
          visibility_feature: float | None = None, motion: dict | None = None,
          physical_optics: bool | Sequence[str] = False,
          deterministic: bool = True, block_kernel: bool | None = None) -> xr.Dataset:
    """Ray-trace an acquisition of a Mitsuba scene into range histograms.

    Parameters
    ----------
    radar, trajectory, look : Radar, Trajectory, Look
    scene : str, os.PathLike or mitsuba.Scene
        An XML file, a canned scene name, or a loaded scene. Its ``<integrator type="radar">``
        gives the defaults of the tracing parameters (else the integrator's defaults).
    density : float, optional
        Surface scatterers per m² (default: 9 per resolution cell, about 900 per m²).
    seed : int, optional
        Seed of the scatterer positions and speckle phases (default: the integrator's, 0).
    sweeps : slice or array of int, optional
        Sweeps of the acquisition to trace (default all). The bin grid does not depend on it,
        so pieces traced separately concatenate to the whole.
    chunk_lanes : int, optional
        Scatterer x sweep pairs per kernel launch (< 2^26).
    bins_per_cell : int, optional
        Histogram bins per range cell (default 16).
    beam_cull : float, optional
        Cull scatterers beyond this many beamwidths in direction sine (default 2: the
        two-way power beyond is about -33 dB of the total per axis).
    rvp : bool
        Keep the residual video phase ``-K tau^2/2`` (default).
    normalized : bool
        Unit amplitude per unit sqrt(RCS), no range loss (as :func:`simulate_point_targets`).
    scene_params : dict, optional
        Values of the scene's ``<default>`` parameters (:func:`mitsar.scene.load_scene`), e.g.
        ``{"rcs": 2.0}`` for the canned ``point_target``.
    progress : bool
        Show a progress bar.
    max_depth : int, optional
        Hits per ray, the paper's N_HITS (default 1: direct backscatter only). ``k > 1`` turns
        on multipath with up to ``k - 1`` specular reflections (paper: 3 in 2D, 4 for the
        trihedral's three reflections); the ``order`` axis then has ``k`` entries.
    rays : int, optional
        Multipath rays per sweep (default 4096; 2D mode: the size of the fan).
    ray_cover : float, optional
        Half-width of the ray grid in beamwidths (default 1: the main lobe to the first nulls).
    capture : {"tent", "box"}, optional
        Ray-tube capture kernel (default ``"tent"``; :mod:`mitsar.model.multipath`).
    ghosts : bool, optional
        Bistatic double-lobe scattering back to the receiver at every hit after the first
        (default False, as the paper).
    plane_normal : array_like, optional
        2D mode: rays in the plane through the antenna containing the boresight with this
        normal (e.g. ``[1, 0, 0]`` for the paper's y-z analyses), surface scatterers in a slab
        of ``slab_width`` around it.
    slab_width : float, optional
        Width of the 2D mode's scatterer slab [m] (default 0.1, the azimuth cell).
    receiver_offset : array_like, optional
        Bistatic receiver at the transmitter's position plus this world-frame offset [m]
        (default: monostatic). Needs ``backscatter=False``.
    receiver_look : Look, optional
        Mounting of the bistatic receiving antenna (default: the transmitter's ``look``).
    backscatter : bool
        Trace the direct backscatter of surface scatterers and point targets (order 0).
    navigation : Trajectory or NavigationErrors, optional
        What the navigation system records (``trajectory`` is then the true track); see
        :func:`mitsar.simulate_point_targets`.
    visibility_feature : float, optional
        Smallest occluder (or gap) width [m] that the reuse of shadow rays across sweeps must
        resolve (default 0.03; 0: a shadow ray per sweep); docs/integrator.md §"Visibility
        reuse".
    motion : dict, optional
        ``{shape id: [vx, vy, vz]}`` [m/s] or ``{shape id: {"velocity": ..,
        "angular_velocity_deg": .., "centre": .., "path": {"times", "positions",
        "attitude_deg"}}}``: shapes that move during the acquisition, on top of the motion
        properties of the XML's shapes and the moving point targets
        (:mod:`mitsar.scene.motion`; docs/integrator.md §Moving objects). With any moving
        shape the scene is traced one sweep at a time, each with the shapes where they are.
    physical_optics : bool or sequence of str
        Physical optics of planar facets (docs/physical_optics.md §5): ``True`` for every mesh
        with a radar material, or the ids of the shapes. Their specular returns come from PO:
        single facets at order 1 and, with ``max_depth = k > 2``, the bounce chains of up to
        ``k − 1`` of their facets (dihedrals, trihedrals) at order = chain length; multipath
        rays stop on these shapes (no path is counted twice). Monostatic, 3-D only; moving
        shapes carry their facets.
    deterministic : bool
        Bit-identical data run after run and on any thread count (default): the float64
        atomic adds of the lane kernels, multipath and physical optics on one Dr.Jit thread,
        the block kernel on every core with integer sums. ``False`` runs everything on every
        core (the block kernel with float32 sums, ~15 % faster; bins then differ in their
        last bits between runs; docs/integrator.md §"Determinism").
    block_kernel : bool, optional
        Direct backscatter of static 3-D scenes with shared shadow rays by the block kernel,
        a lane per scatterer and chunk of sweeps (default, XML ``block_kernel``), or ``False``:
        a lane per (scatterer, sweep), the kernels before it (docs/integrator.md
        §"Performance").

    Returns
    -------
    xarray.Dataset
        The histogram product (module docstring).
    """
    run = TraceRun("trace", radar, trajectory, look, scene, density, seed, sweeps, chunk_lanes,
               bins_per_cell, beam_cull, scene_params,
               _multipath_options(max_depth, rays, ray_cover, capture, ghosts, plane_normal,
                                  slab_width, visibility_feature, block_kernel),
               receiver_offset, receiver_look, backscatter, navigation, motion, physical_optics,
               deterministic=deterministic)
    parts, indices = [], []
    for chosen, hist in run.chunks(rvp, normalized, progress):
        indices.append(chosen)
        parts.append(hist)
    sweeps = np.concatenate(indices)
    return make_histogram_product(
        np.concatenate(parts, axis=0), run.radar, run.look, sweeps, run.ranges,
        *run.geometry_of(sweeps), rvp=rvp, normalized=normalized,
        first_index=int(run.grid[0]), attrs=run.attrs())


def _multipath_options(max_depth: Any, rays: Any, ray_cover: Any, capture: Any, ghosts: Any,
                       plane_normal: Any, slab_width: Any, visibility_feature: Any = None,
                       block_kernel: Any = None) -> dict[str, Any]:
    """The integrator options a call overrides (None: the scene integrator's)."""
    return {"max_depth": max_depth, "rays": rays, "ray_cover": ray_cover, "capture": capture,
            "ghosts": ghosts, "plane_normal": plane_normal, "slab_width": slab_width,
            "visibility_feature": visibility_feature, "block_kernel": block_kernel}


def trace_paths(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
                sweep: int = 0, rays: Any = 64, max_depth: int | None = None,
                ray_count: int | None = None, ray_cover: float | None = None,
                capture: str | None = None, plane_normal: Any = None,
                receiver_offset: Any = None, receiver_look: Look | None = None,
                scene_params: dict | None = None) -> xr.Dataset:
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
    max_depth, ray_cover, capture, plane_normal, receiver_offset, receiver_look, scene_params
        As :func:`trace` (``max_depth`` defaults to the scene integrator's, at least 2).
    ray_count : int, optional
        Size of the ray grid (``rays`` of :func:`trace`).

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
    options = _multipath_options(max_depth, ray_count, ray_cover, capture, None, plane_normal,
                                 None)
    run = TraceRun("trace_paths", radar, trajectory, look, scene, None, None, np.array([sweep]),
               None, None, None, scene_params, options, receiver_offset, receiver_look,
               backscatter=False)
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
    log = run.integrator.trace_paths(run.scene, run.geometry, radar, run.frames, int(sweep),
                                     chosen, config, run.setup)
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
    tx = run.geometry["position"][sweep]
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
    rx_frames = (None if run.receiver_look is None
                 else antenna_frame(run.receiver_look, *run.geometry["attitude"].T))
    return make_setup(run.radar, run.frames, config, run.setup.receiver_offset, rx_frames)


def _order_mask(where: str, orders: Any, available: NDArray) -> NDArray[np.bool_]:
    if orders is None:
        return np.ones(len(available), dtype=bool)
    wanted = np.atleast_1d(np.asarray(orders))
    if wanted.ndim != 1 or not np.issubdtype(wanted.dtype, np.integer) or np.any(wanted < 0):
        raise ParameterError(where, "orders", "None or path orders (integers >= 0)", orders)
    return np.isin(available, wanted)


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
    mask = _order_mask("histogram_to_raw_product", orders, histogram["order"].values)
    summed = histogram["histogram"].values[:, mask, :].sum(axis=1)
    samples = hg.histogram_to_raw(summed, histogram["apparent_range"].values, radar)
    return raw_from_histogram(histogram, samples, histogram["order"].values[mask])


def simulate_scene(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
                   targets: Sequence[PointTarget] = (), background: Background | None = None,
                   density: float | None = None, seed: int | None = None,
                   orders: Any = None, sweeps: Any = None, chunk_lanes: int | None = None,
                   bins_per_cell: int | None = None, beam_cull: float | None = None,
                   rvp: bool = True, normalized: bool = False, scene_params: dict | None = None,
                   progress: bool = False, max_depth: int | None = None,
                   rays: int | None = None, ray_cover: float | None = None,
                   capture: str | None = None, ghosts: bool | None = None,
                   plane_normal: Any = None, slab_width: float | None = None,
                   navigation: Trajectory | NavigationErrors | None = None,
                   noise: bool = False,
                   physical_optics: bool | Sequence[str] = False,
                   motion: dict | None = None, deterministic: bool = True,
                   visibility_feature: float | None = None,
                   block_kernel: bool | None = None) -> xr.Dataset:
    """Raw data of a Mitsuba scene: trace, synthesise (streaming), add analytic targets.

    Histograms are turned into raw sweeps chunk by chunk, so memory stays bounded by the chunk
    size and the raw output. Analytic ``targets`` and ``background``
    (:func:`mitsar.simulate_point_targets`, same ``seed``, ``rvp`` and ``normalized``) are added
    on top; they are not shadowed by the scene.

    Parameters
    ----------
    radar, trajectory, look, scene
        As :func:`trace`.
    targets : sequence of PointTarget
        Extra analytic point targets.
    background : Background, optional
        Extra analytic fluctuating background (paper eq. 4).
    orders : int or sequence of int, optional
        Path orders to keep (``0``: direct backscatter only); default all.
    density, seed, sweeps, chunk_lanes, bins_per_cell, beam_cull, rvp, normalized,
    scene_params, progress, max_depth, rays, ray_cover, capture, ghosts, plane_normal,
    slab_width, navigation
        As :func:`trace` (monostatic).
    noise : bool
        Add receiver noise ``k T0 F f_s`` per complex sample (needs ``radar.noise_figure_db``),
        drawn by :func:`mitsar.model.noise.thermal_noise` from the run's seed and each sample's
        sweep and index (so a subset of ``sweeps`` gets the same noise as in the full run).
    physical_optics : bool or sequence of str
        Physical-optics specular returns of planar facets and their bounce chains, as
        :func:`trace` (docs/physical_optics.md §5).
    motion : dict, optional
        Moving shapes, as :func:`trace`.
    deterministic : bool
        Bit-identical runs (default), as :func:`trace`.
    visibility_feature, block_kernel : optional
        As :func:`trace` (shadow rays shared across sweeps; the block kernel).

    Returns
    -------
    xarray.Dataset
        Raw product (:mod:`mitsar.products.raw`).
    """
    run = TraceRun("simulate_scene", radar, trajectory, look, scene, density, seed, sweeps,
               chunk_lanes, bins_per_cell, beam_cull, scene_params,
               _multipath_options(max_depth, rays, ray_cover, capture, ghosts, plane_normal,
                                  slab_width, visibility_feature, block_kernel),
               navigation=navigation, motion=motion,
               physical_optics=physical_optics, deterministic=deterministic)
    _order_mask("simulate_scene", orders, np.arange(1))  # validate early
    check_noise("simulate_scene", radar, noise, normalized)
    samples = np.zeros((len(run.sweeps), radar.samples_per_sweep), dtype=np.complex128)
    row = 0
    kept = np.arange(0)
    for chosen, hist in run.chunks(rvp, normalized, progress):
        mask = _order_mask("simulate_scene", orders, np.arange(hist.shape[1]))
        kept = np.arange(hist.shape[1])[mask]
        summed = hist[:, mask, :].sum(axis=1)
        samples[row:row + len(chosen)] = hg.histogram_to_raw(summed, run.ranges, radar)
        row += len(chosen)
    attrs = run.attrs()
    attrs.update(simulator="ray tracing (radar integrator)", normalized=int(normalized),
                 orders=[int(o) for o in kept])
    if targets or background is not None:
        analytic = simulate_point_targets(radar, trajectory, look, targets, background,
                                          seed=attrs["seed"], rvp=rvp, normalized=normalized,
                                          navigation=run.recorded)
        samples += analytic["raw"].values[run.sweeps]
        attrs["simulator"] += " + analytic point targets"
        attrs["analytic_config"] = analytic.attrs.get("config", "{}")
    if not np.any(samples):
        warnings.warn(f"simulate_scene: raw data of exact zeros: nothing of the scene is in the "
                      f"beam ({attrs['scatterer_count']} surface scatterers, "
                      f"{attrs['point_target_count']} point targets, orders {attrs['orders']}): "
                      "check the look angles, the trajectory, the materials and the orders",
                      MitsarWarning, stacklevel=2)
    attrs["noise"] = int(noise)
    if noise:
        samples += thermal_noise(radar, attrs["seed"], run.sweeps)
        attrs.update(noise_power=radar.noise_power, noise_seed=int(attrs["seed"]))
    recorded, true = run.geometry_of(run.sweeps)
    product = make_raw_product(samples, radar, look, recorded, rvp=rvp, attrs=attrs,
                               true_geometry=true)
    return product.assign_coords(sweep=run.sweeps)
