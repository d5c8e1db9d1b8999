"""Ray-traced acquisitions: scene -> range histograms -> raw (DESIGN §2, §5.4, §5.5).

:func:`trace` runs the Mitsuba ``radar`` integrator (``mitsar/plugins/radar.py``) over every
sweep of an acquisition and returns the *histogram product*; :func:`histogram_to_raw_product`
turns it into the raw product (one inverse FFT per sweep), and :func:`simulate_scene` does both
while streaming over sweep chunks, optionally adding analytic point targets and a background
from :func:`mitsar.simulate_point_targets`.

Histogram product
-----------------
``histogram`` (sweep, order, bin) complex
    Sum of the deposits ``a exp{j 2 pi (f_c tau_0 - K tau_0^2/2 + phi)}`` at each apparent range
    bin [sqrt(W)]. ``order`` is the number of specular reflections on the path (0: direct
    backscatter; only order 0 is traced yet).
``apparent_range`` (bin) [m]
    ``(k_0 + j) dr``, ``dr`` = range cell / ``bins_per_cell`` (:mod:`mitsar.histogram`).
``slow_time``, ``platform_position``, ``platform_velocity``, ``boresight``, ``attitude``
    As in the raw product; ``sweep`` holds the absolute sweep indices of the acquisition.
attributes
    ``radar_*``, ``look_*``, ``product = "histogram"``, ``rvp``, ``normalized``, ``seed``,
    ``scatterer_count``, ``point_target_count``, ``scatterer_density``, ``bins_per_cell``,
    ``histogram_first_index``, ``acquisition_sweeps``, ``integrator`` (JSON), ``scene``,
    ``traced_pairs``, ``traced_candidate_pairs``, ``traced_shadow_rays``, ``traced_launches``
    (work counters), provenance.
"""

from __future__ import annotations

import json
import os
from collections.abc import Iterator, Sequence
from typing import Any

import numpy as np
import xarray as xr
from numpy.typing import NDArray

import mitsar
from mitsar import histogram as hg
from mitsar.errors import ParameterError
from mitsar.geometry.attitude import Look, antenna_frame
from mitsar.geometry.trajectory import Trajectory
from mitsar.radar import Radar
from mitsar.raw import look_of, make_raw_product, radar_of, sweep_geometry
from mitsar.signal import sweep_count
from mitsar.targets import Background, PointTarget

__all__ = ["histogram_to_raw_product", "simulate_scene", "trace"]


# --------------------------------------------------------------------------------------------
# Set-up shared by trace and simulate_scene
# --------------------------------------------------------------------------------------------

class _Run:
    """Everything one traced acquisition needs, resolved and validated."""

    def __init__(self, where: str, radar: Radar, trajectory: Trajectory, look: Look, scene: Any,
                 density: float | None, seed: int | None, sweeps: Any, chunk_lanes: int | None,
                 bins_per_cell: int | None, beam_cull: float | None,
                 scene_params: dict | None) -> None:
        from mitsar.scene import load_scene, register_plugins

        if not isinstance(radar, Radar):
            raise ParameterError(where, "radar", "a mitsar.Radar", type(radar))
        if not isinstance(trajectory, Trajectory):
            raise ParameterError(where, "trajectory", "a mitsar.Trajectory", type(trajectory))
        if not isinstance(look, Look):
            raise ParameterError(where, "look", "a mitsar.Look", type(look))
        radar.check_prf(trajectory.max_speed())
        total = sweep_count(radar, trajectory.duration)
        if total < 1:
            raise ParameterError(where, "trajectory.duration",
                                 f">= one sweep ({radar.sweep_duration:g} s)", trajectory.duration)
        self.sweeps = _select_sweeps(where, sweeps, total)
        register_plugins()
        import mitsuba as mi

        from mitsar.plugins.radar import range_limits

        self.scene_name = scene if isinstance(scene, str | os.PathLike) else "<mitsuba.Scene>"
        self.scene = load_scene(scene, **(scene_params or {}))
        self.integrator = _radar_integrator(self.scene, mi)
        self.config = self.integrator.config.replace(
            where, scatterer_density=density, seed=seed, chunk_lanes=chunk_lanes,
            bins_per_cell=bins_per_cell, beam_cull=beam_cull)
        self.radar, self.trajectory, self.look = radar, trajectory, look
        self.total = total
        self.geometry = sweep_geometry(radar, trajectory, look, total)
        self.frames = antenna_frame(look, *self.geometry["attitude"].T)
        self.scatterers = self.integrator.scatterers(self.scene, self.config.density(radar),
                                                     self.config.seed)
        low, high = range_limits(self.scatterers, self.geometry["position"],
                                 trajectory.max_speed(), radar, trajectory.duration)
        self.grid = hg.bin_grid(radar, low, high, self.config.bins_per_cell)
        self.ranges = hg.bin_ranges(radar, *self.grid, self.config.bins_per_cell)

    def chunks(self, rvp: bool, normalized: bool, progress: bool
               ) -> Iterator[tuple[NDArray, NDArray]]:
        return self.integrator.trace_histograms(
            self.scene, self.geometry, self.radar, self.frames, self.scatterers, self.grid,
            sweeps=self.sweeps, config=self.config, rvp=rvp, normalized=normalized,
            progress=progress)

    def attrs(self) -> dict[str, Any]:
        return {"seed": int(self.config.seed), "scatterer_count": self.scatterers.surface_count,
                "point_target_count": self.scatterers.point_target_count,
                "scatterer_density": float(self.scatterers.density),
                "bins_per_cell": int(self.config.bins_per_cell),
                "acquisition_sweeps": int(self.total),
                "integrator": self.config.to_dict(), "scene": str(self.scene_name),
                **{f"traced_{key}": int(value)
                   for key, value in self.integrator.statistics.items()},
                "trajectory_kind": self.trajectory.kind,
                "trajectory_straight": int(self.trajectory.is_straight),
                "config": {"trajectory": self.trajectory.describe()}}

    def geometry_of(self, sweeps: NDArray) -> dict[str, NDArray]:
        return {key: value[sweeps] for key, value in self.geometry.items()}


def _select_sweeps(where: str, sweeps: Any, total: int) -> NDArray[np.int64]:
    if sweeps is None:
        return np.arange(total)
    if isinstance(sweeps, slice):
        chosen = np.arange(total)[sweeps]
    else:
        chosen = np.asarray(sweeps)
        if chosen.ndim != 1 or not np.issubdtype(chosen.dtype, np.integer):
            raise ParameterError(where, "sweeps", "None, a slice or a 1-D array of sweep "
                                 "indices", sweeps)
        chosen = chosen.astype(np.int64)
    if len(chosen) == 0 or chosen.min() < 0 or chosen.max() >= total \
            or np.any(np.diff(chosen) <= 0):
        raise ParameterError(where, "sweeps", f"increasing sweep indices in [0, {total})",
                             sweeps)
    return chosen


_DEFAULT_INTEGRATORS: dict[int, tuple[Any, Any]] = {}
"""Default integrators of recently used scenes (id -> (scene, integrator)); the integrator
caches the scene's scatterers, so tracing a loaded scene again does not resample it."""


def _radar_integrator(scene: Any, mi: Any) -> Any:
    """The scene's ``radar`` integrator if the XML declares one, else a default one."""
    integrator = scene.integrator()
    if getattr(integrator, "MITSAR_KIND", None) == "radar":
        return integrator
    if id(scene) not in _DEFAULT_INTEGRATORS:
        while len(_DEFAULT_INTEGRATORS) >= 2:
            _DEFAULT_INTEGRATORS.pop(next(iter(_DEFAULT_INTEGRATORS)))
        _DEFAULT_INTEGRATORS[id(scene)] = (scene, mi.load_dict({"type": "radar"}))
    return _DEFAULT_INTEGRATORS[id(scene)][1]


# --------------------------------------------------------------------------------------------
# Public API
# --------------------------------------------------------------------------------------------

def trace(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
          density: float | None = None, seed: int | None = None, sweeps: Any = None,
          chunk_lanes: int | None = None, bins_per_cell: int | None = None,
          beam_cull: float | None = None, rvp: bool = True, normalized: bool = False,
          scene_params: dict | None = None, progress: bool = False) -> xr.Dataset:
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

    Returns
    -------
    xarray.Dataset
        The histogram product (module docstring).
    """
    run = _Run("trace", radar, trajectory, look, scene, density, seed, sweeps, chunk_lanes,
               bins_per_cell, beam_cull, scene_params)
    parts, indices = [], []
    for chosen, hist in run.chunks(rvp, normalized, progress):
        indices.append(chosen)
        parts.append(hist)
    histogram = np.concatenate(parts, axis=0)
    geometry = run.geometry_of(np.concatenate(indices))
    return _histogram_product(histogram, run, geometry, np.concatenate(indices), rvp,
                              normalized)


def _histogram_product(histogram: NDArray, run: _Run, geometry: dict, sweeps: NDArray,
                       rvp: bool, normalized: bool) -> xr.Dataset:
    data = xr.Dataset(
        {
            "histogram": (("sweep", "order", "bin"), histogram,
                          {"units": "sqrt(W)", "long_name": "complex range histogram"}),
            "platform_position": (("sweep", "xyz"), geometry["position"], {"units": "m"}),
            "platform_velocity": (("sweep", "xyz"), geometry["velocity"], {"units": "m/s"}),
            "boresight": (("sweep", "xyz"), geometry["boresight"], {"units": "1"}),
            "attitude": (("sweep", "angle"), geometry["attitude"], {"units": "rad"}),
        },
        coords={
            "sweep": sweeps,
            "order": np.arange(histogram.shape[1]),
            "bin": np.arange(histogram.shape[2]),
            "apparent_range": ("bin", run.ranges, {"units": "m", "long_name":
                                                   "apparent range c f / (2K)"}),
            "slow_time": ("sweep", geometry["slow_time"], {"units": "s",
                                                          "long_name": "sweep start time"}),
            "xyz": ["x", "y", "z"],
            "angle": ["heading", "pitch", "roll"],
        },
    )
    data.attrs.update(run.radar.to_attrs())
    data.attrs.update(product="histogram", look_off_nadir_deg=run.look.off_nadir_deg,
                      look_squint_deg=run.look.squint_deg, rvp=int(rvp),
                      normalized=int(normalized), histogram_first_index=int(run.grid[0]),
                      mitsar_version=mitsar.__version__)
    for key, value in run.attrs().items():
        data.attrs[key] = json.dumps(value) if isinstance(value, dict | list) else value
    return data


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
        Raw product (:mod:`mitsar.raw`).
    """
    if histogram.attrs.get("product") != "histogram":
        raise ParameterError("histogram_to_raw_product", "histogram",
                             "a histogram product (attribute product='histogram')",
                             histogram.attrs.get("product"))
    radar = radar_of(histogram)
    mask = _order_mask("histogram_to_raw_product", orders, histogram["order"].values)
    summed = histogram["histogram"].values[:, mask, :].sum(axis=1)
    samples = hg.histogram_to_raw(summed, histogram["apparent_range"].values, radar)
    geometry = {"slow_time": histogram["slow_time"].values,
                "position": histogram["platform_position"].values,
                "velocity": histogram["platform_velocity"].values,
                "attitude": histogram["attitude"].values,
                "boresight": histogram["boresight"].values}
    attrs = {key: histogram.attrs[key] for key in (
        "seed", "normalized", "scatterer_count", "point_target_count", "scatterer_density",
        "bins_per_cell", "integrator", "scene", "trajectory_kind", "trajectory_straight",
        "config") if key in histogram.attrs}
    attrs.update({key: value for key, value in histogram.attrs.items()
                  if key.startswith("traced_")})
    attrs.update(simulator="ray tracing (radar integrator)",
                 orders=[int(o) for o in histogram["order"].values[mask]])
    product = make_raw_product(samples, radar, look_of(histogram), geometry,
                               rvp=bool(histogram.attrs.get("rvp", 1)), attrs=attrs)
    return product.assign_coords(sweep=histogram["sweep"].values)


def simulate_scene(radar: Radar, trajectory: Trajectory, look: Look, scene: Any, *,
                   targets: Sequence[PointTarget] = (), background: Background | None = None,
                   density: float | None = None, seed: int | None = None,
                   orders: Any = None, sweeps: Any = None, chunk_lanes: int | None = None,
                   bins_per_cell: int | None = None, beam_cull: float | None = None,
                   rvp: bool = True, normalized: bool = False, scene_params: dict | None = None,
                   progress: bool = False) -> xr.Dataset:
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
    scene_params, progress
        As :func:`trace`.

    Returns
    -------
    xarray.Dataset
        Raw product (:mod:`mitsar.raw`).
    """
    run = _Run("simulate_scene", radar, trajectory, look, scene, density, seed, sweeps,
               chunk_lanes, bins_per_cell, beam_cull, scene_params)
    _order_mask("simulate_scene", orders, np.arange(1))  # validate early
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
        analytic = mitsar.simulate_point_targets(radar, trajectory, look, targets, background,
                                                 seed=attrs["seed"], rvp=rvp,
                                                 normalized=normalized)
        samples += analytic["raw"].values[run.sweeps]
        attrs["simulator"] += " + analytic point targets"
        attrs["analytic_config"] = analytic.attrs.get("config", "{}")
    product = make_raw_product(samples, radar, look, run.geometry_of(run.sweeps), rvp=rvp,
                               attrs=attrs)
    return product.assign_coords(sweep=run.sweeps)
