"""The one entry point of image formation: :func:`focus` checks, picks the algorithm, assembles.

Every algorithm writes the same image product (:mod:`mitsar.products.image`) on the same grids, so
images compare pixel for pixel.
"""

from __future__ import annotations

from collections.abc import Sequence

import numpy as np
import xarray as xr

from mitsar import checks
from mitsar.errors import ParameterError
from mitsar.focus.aperture import MAX_AZIMUTH_RESOLUTION, aperture_half_width
from mitsar.focus.autofocus import PulseSettings, make_options, run_autofocus
from mitsar.focus.band_limit import band_limited_focus
from mitsar.focus.bpa import focus_bpa
from mitsar.focus.channels import focus_channels
from mitsar.focus.ffbp import focus_ffbp
from mitsar.focus.frequency_domain import focus_frequency_domain
from mitsar.focus.grid import Grid, SlantGrid, VolumeGrid, from_dict
from mitsar.focus.interpolation import DEFAULT_INTERPOLATION, check_interpolation
from mitsar.focus.mocomp import compensate, reference_line, reference_product
from mitsar.focus.motion import is_straight_track
from mitsar.focus.nesz import noise_variables
from mitsar.focus.passes import COMBINE, focus_passes
from mitsar.focus.referenced import focus_referenced
from mitsar.focus.reuse import geometry_shared, shared_geometry
from mitsar.focus.volume import focus_ffbp_volume
from mitsar.focus.windows import WINDOWS
from mitsar.model.radar import Radar
from mitsar.products.image import make_image_product
from mitsar.products.raw import radar_of, sweep_rate

ALGORITHMS = ("bpa", "rda", "wda", "fsa", "ffbp")
"""Names of the focusing algorithms."""


def focus(raw: xr.Dataset | Sequence[xr.Dataset], algorithm: str = "bpa",
          grid: Grid | dict | None = None, *,
          window: str = "rect", range_window: str | None = None,
          azimuth_resolution: float | None = None, remove_rvp: bool = True,
          motion_correction: bool = True, backend: str = "drjit",
          range_upsample: int = 8, pixel_chunk: int | None = None,
          algorithm_options: dict | None = None, progress: bool = False,
          motion_compensation: bool = True, autofocus: str | None = None,
          autofocus_options: dict | None = None, combine: str = "coherent",
          range_interpolation: str = DEFAULT_INTERPOLATION, band_limit: bool = True
          ) -> xr.Dataset:
    """Focus a raw product into an image, or several passes into one image or volume.

    Parameters
    ----------
    raw : xarray.Dataset or sequence of xarray.Dataset
        Raw product (:mod:`mitsar.raw.product`); a list (or tuple) of raw products is a set
        of passes, each back-projected onto the same pixels or voxels and summed
        (:mod:`mitsar.focus.passes`; tomographic back-projection on a
        :class:`~mitsar.focus.grid.VolumeGrid`, docs/focusing.md "3-D focusing from several
        passes").
    algorithm : {"bpa", "rda", "wda", "fsa", "ffbp"}
        Focusing algorithm: back-projection (any trajectory, any grid), its fast factorised
        form ("ffbp", any trajectory, any grid; :mod:`mitsar.focus.ffbp`) or the frequency-domain
        range-Doppler, wavenumber-domain and frequency-scaling algorithms (straight track at
        constant velocity, slant grids only; see ``docs/focusing.md``).
    grid : SlantGrid, PlaneGrid, PointsGrid, VolumeGrid, dict or None
        Output grid; a dict is passed to :func:`mitsar.focus.grid.from_dict`; default slant grid
        (one raw product). A :class:`~mitsar.focus.grid.VolumeGrid` gives an image with dims
        ``("z", "y", "x")`` (back-projection: "bpa", or "ffbp" slice by slice).
    window : str
        Azimuth window over the processed aperture (and the range window unless
        ``range_window`` is given): "rect", "hamming", "hann", "taylor".
    azimuth_resolution : float, optional
        Nominal azimuth resolution rho [m]: the processed aperture spans ``lambda / (2 rho)``
        in direction sine (paper: 0.10 m). Default: the whole beam.
    remove_rvp : bool
        Remove the residual video phase.
    motion_correction : bool
        Correct the continuous-motion (Doppler) range shift.
    backend : {"drjit", "numpy"}
        BPA kernel.
    range_upsample : int
        Zero-padding factor of the range FFT before the back-projections' interpolation.
    range_interpolation : {"cubic", "linear"}
        Interpolation of the range profiles in the back-projections (4-tap Lagrange cubic, or
        linear; :mod:`mitsar.focus.interpolation`; cubic at 8x: -71 dB, linear at 16x: -48 dB
        against a float64 reference, docs/focusing.md error budget).
    band_limit : bool
        BPA and FFBP onto a 2-D grid off a straight uniform track: select the processed band in
        the image (:mod:`mitsar.focus.band_limit`: a wider per-pixel aperture, then the band
        about each pixel's centre of aperture), so the pixels are band-limited to 1/rho as SICD
        declares them (attribute ``band_limit = "image"``); False keeps the per-pixel band that
        slides with the pixel. Not with ``autofocus``: the phase it cannot observe (a linear
        ramp over the sweeps) shifts the spectrum off the band the geometry predicts.
    pixel_chunk : int, optional
        Pixels per kernel launch (memory bound); default 2^20, or 2^16 with a progress bar.
    algorithm_options : dict, optional
        Options of the frequency-domain algorithms (``rda``: ``src``; ``wda``: ``gate_cells``;
        ``fsa``: ``upsample``, ``check_aliasing``, ``src``; ``ffbp``: ``factor``,
        ``first_subaperture``, ``final_subapertures``, ``angle_oversample``, ...:
        :data:`mitsar.focus.ffbp.FFBP_DEFAULTS`); see ``docs/focusing.md``.
    progress : bool
        Show a progress bar (back-projection).
    motion_compensation : bool
        RDA, WDA and FSA on a track that is not straight: compensate the data to the fitted
        straight reference line (:mod:`mitsar.focus.mocomp`, limits in ``docs/focusing.md``);
        False refuses such a track.
    autofocus : {"pga", "entropy"} or None
        Estimate a phase error per sweep from the image (phase gradient or minimum-entropy
        autofocus), correct the raw sweeps and refocus; back-projection only ("bpa", "ffbp").
        The image then holds ``autofocus_phase`` (sweep) [rad] and ``autofocus_*``
        attributes (:mod:`mitsar.focus.autofocus`, ``docs/autofocus.md``).
    autofocus_options : dict, optional
        Options of the autofocus method (:class:`mitsar.focus.autofocus.PGAOptions`,
        :class:`mitsar.focus.autofocus.EntropyOptions`).
    combine : {"coherent", "incoherent"}
        Several passes: the mean of their complex images (phase-stable navigation: the passes
        form an aperture across the line of sight) or ``sqrt(mean |image|^2)`` (an amplitude,
        for passes without phase-stable navigation). Only with a list of raw products.

    Returns
    -------
    xarray.Dataset
        Image product: ``image`` (two dims, metre coordinates), ``position`` (pixel world
        positions), attributes ``range_resolution``, ``azimuth_resolution``, ``range_axis``,
        ``azimuth_axis``, grid description and provenance.
    """
    if autofocus is not None and not geometry_shared():  # the refocus reuses the geometry
        with shared_geometry():  # of the first focus (mitsar.focus.reuse)
            return focus(**locals())
    if isinstance(raw, list | tuple):  # several passes onto the same pixels (focus.passes)
        return focus_passes(raw, algorithm, grid, combine, lambda one, chosen: focus(
            one, algorithm, chosen, window=window, range_window=range_window,
            azimuth_resolution=azimuth_resolution, remove_rvp=remove_rvp,
            motion_correction=motion_correction, backend=backend,
            range_upsample=range_upsample, pixel_chunk=pixel_chunk,
            algorithm_options=algorithm_options, progress=progress,
            motion_compensation=motion_compensation, autofocus=autofocus,
            autofocus_options=autofocus_options, range_interpolation=range_interpolation,
            band_limit=band_limit), autofocus)
    if combine != "coherent":
        raise ParameterError("focus", "combine", f"'coherent' for one raw product (one of "
                             f"{COMBINE} combines a list of passes)", combine)
    if not isinstance(raw, xr.Dataset):
        raise ParameterError("focus", "raw", "a raw product (xarray.Dataset from "
                             "mitsar.simulate_point_targets, simulate_scene, read_raw, load)",
                             type(raw))
    if algorithm not in ALGORITHMS:
        raise ParameterError("focus", "algorithm", f"one of {ALGORITHMS}", algorithm)
    checks.integer("focus", "range_upsample", range_upsample, 1)
    check_interpolation("focus", range_interpolation)
    band_limit = checks.boolean("focus", "band_limit", band_limit)
    if pixel_chunk is not None:
        checks.integer("focus", "pixel_chunk", pixel_chunk, 1)
    if window not in WINDOWS:
        raise ParameterError("focus", "window", f"one of {WINDOWS}", window)
    range_window = window if range_window is None else range_window
    if azimuth_resolution is not None:
        azimuth_resolution = checks.positive("focus", "azimuth_resolution", azimuth_resolution,
                                             "None or a finite resolution > 0 m")
        if azimuth_resolution > MAX_AZIMUTH_RESOLUTION:
            raise ParameterError("focus", "azimuth_resolution",
                                 f"at most {MAX_AZIMUTH_RESOLUTION:g} m (a processed band that "
                                 "narrow holds no sweep of an indoor pass)", azimuth_resolution)
    if backend not in ("drjit", "numpy"):
        raise ParameterError("focus", "backend", "'drjit' or 'numpy'", backend)
    if autofocus is not None:
        focusers = tuple(name for name in ("bpa", "ffbp") if name in ALGORITHMS)
        if algorithm not in focusers:
            raise ParameterError("focus", "autofocus", f"None with algorithm {algorithm!r} "
                                 f"(autofocus needs a back-projection image: algorithm in "
                                 f"{focusers})", autofocus)
        make_options(autofocus, autofocus_options)  # refuse a bad method or option early
    if raw.attrs.get("product") != "raw":
        raise ParameterError("focus", "raw", "a raw product (attribute product='raw')",
                             raw.attrs.get("product"))
    if isinstance(grid, dict):
        grid = from_dict(grid)
    grid = SlantGrid() if grid is None else grid
    if not isinstance(grid, Grid):
        raise ParameterError("focus", "grid", "None, a dict (mitsar.grid.from_dict) or a "
                             "SlantGrid, PlaneGrid, PointsGrid or VolumeGrid",
                             type(grid).__name__)
    if isinstance(grid, VolumeGrid):
        _check_volume(raw, algorithm, autofocus)
    if "channel" in raw["raw"].dims:  # every channel onto channel 0's pixels (focus.channels)
        return focus_channels(raw, algorithm, grid, lambda view, chosen, method: focus(
            view, algorithm, chosen, window=window, range_window=range_window,
            azimuth_resolution=azimuth_resolution, remove_rvp=remove_rvp,
            motion_correction=motion_correction, backend=backend,
            range_upsample=range_upsample, pixel_chunk=pixel_chunk,
            algorithm_options=algorithm_options, progress=progress,
            motion_compensation=motion_compensation, autofocus=method,
            autofocus_options=autofocus_options, range_interpolation=range_interpolation,
            # one band selection for every channel: channel 0's autofocus turns it off
            band_limit=band_limit and not autofocus), autofocus)

    radar = radar_of(raw)
    half_width = aperture_half_width(radar, azimuth_resolution)
    if "reference_range" not in raw.variables:  # recordings carry their own sampling
        _check_processed_band(raw, radar, half_width, azimuth_resolution)
    nominal_azimuth = radar.wavelength / (4 * half_width)
    processing = {"algorithm": algorithm, "window": window, "range_window": range_window,
                  "azimuth_resolution_requested": -1.0 if azimuth_resolution is None
                  else float(azimuth_resolution),
                  "rvp_removed": int(remove_rvp), "motion_correction": int(motion_correction),
                  "backend": backend}
    if "reference_range" in raw.variables:
        # Recorded data referenced to a scene point (mitsar.raw.recorded): back-projection only.
        if algorithm != "bpa":
            raise ParameterError("focus", "algorithm", "'bpa' for recorded data referenced to "
                                 "a scene point (raw has 'reference_range')", algorithm)
        values, layout, extra = focus_referenced(
            raw, grid, azimuth_resolution=azimuth_resolution, window=window,
            range_window=range_window, range_upsample=range_upsample,
            range_interpolation=range_interpolation)
        coverage = np.ones(values.shape)
        extra = {"rvp_removed": 0, "motion_correction": 0, "backend": "numpy", **extra}
    elif algorithm == "ffbp":
        layout = grid.resolve(raw, radar, nominal_azimuth)
        ffbp = focus_ffbp_volume if isinstance(grid, VolumeGrid) else focus_ffbp
        values, coverage, extra = band_limited_focus(
            lambda width, taper: ffbp(
                raw, layout, half_width=width, window=taper, range_window=range_window,
                remove_rvp=remove_rvp, motion_correction=motion_correction,
                range_upsample=range_upsample, options=algorithm_options, progress=progress,
                range_interpolation=range_interpolation),
            raw, radar, layout["position"], half_width, window, band_limit and not autofocus)
        extra = {"backend": "drjit", **extra}
    elif algorithm != "bpa":
        raw, layout, compensation = _straighten(raw, radar, grid, nominal_azimuth, half_width,
                                                motion_compensation)
        processing.update(compensation)
        values, coverage, extra = focus_frequency_domain(
            raw, algorithm, layout, half_width=half_width, window=window,
            range_window=range_window, remove_rvp_flag=remove_rvp,
            motion_correction=motion_correction, options=algorithm_options)
        extra = {"backend": "numpy", **extra}
    else:
        layout = grid.resolve(raw, radar, nominal_azimuth)
        # a 2-D grid off a straight track: a wider aperture, then the band in the image
        values, coverage, extra = band_limited_focus(
            lambda width, taper: focus_bpa(
                raw, layout["position"].reshape(-1, 3), half_width=width, window=taper,
                range_window=range_window, remove_rvp=remove_rvp,
                motion_correction=motion_correction, backend=backend,
                range_upsample=range_upsample, progress=progress,
                range_interpolation=range_interpolation,
                pixel_chunk=pixel_chunk or (1 << 16 if progress else 1 << 20),
                row_length=(layout["position"].shape[-2] if layout["position"].ndim > 2
                            else None),
                slab_rows=(layout["position"].shape[-3] if layout["position"].ndim > 2
                           else None)),
            raw, radar, layout["position"], half_width, window, band_limit and not autofocus)
    shape = layout["position"].shape[:-1]  # the grid's dims: two, or three for a volume
    image = make_image_product(raw, np.reshape(values, shape), layout, {**processing, **extra},
                               coverage=np.reshape(coverage, shape))
    if "channel" not in raw.attrs:  # the aperture the image was formed from, for SICD
        # (mitsar.export.sicd; a multi-channel image gets the pass's from focus.channels)
        image["aperture_time"] = ("aperture", raw["slow_time"].values
                                  + radar.sweep_duration / 2, {"units": "s"})
        for name in ("platform_position", "platform_velocity", "boresight", "attitude"):
            if name in raw.variables:
                image[f"aperture_{name.removeprefix('platform_')}"] = (
                    ("aperture", raw[name].dims[-1]), raw[name].values, raw[name].attrs)
        image.attrs["raw_normalized"] = int(raw.attrs.get("normalized", 0))
    if algorithm == "bpa" and "reference_range" not in raw.variables:  # docs/metrics.md §Noise
        noise = noise_variables(raw, layout["position"].reshape(-1, 3), np.ravel(coverage),
                                half_width, window, range_window)
        for name, (flat, attrs) in (noise or {}).items():
            image[name] = (layout["dims"], np.reshape(flat, shape), attrs)
    if autofocus is None:
        return image
    settings = PulseSettings(half_width=half_width, window=window, range_window=range_window,
                             remove_rvp=remove_rvp, motion_correction=motion_correction,
                             range_upsample=range_upsample,
                             range_interpolation=range_interpolation)
    return run_autofocus(raw, image, lambda corrected: focus(
        corrected, algorithm, grid, window=window, range_window=range_window,
        azimuth_resolution=azimuth_resolution, remove_rvp=remove_rvp,
        motion_correction=motion_correction, backend=backend, range_upsample=range_upsample,
        pixel_chunk=pixel_chunk, algorithm_options=algorithm_options, progress=progress,
        motion_compensation=motion_compensation, range_interpolation=range_interpolation,
        band_limit=False), autofocus, autofocus_options, settings)


def _check_volume(raw: xr.Dataset, algorithm: str, autofocus: str | None) -> None:
    """Refuse, before any work, what a volume grid cannot be focused with: the spectral
    algorithms (slant grids only), recordings referenced to a scene point (their aperture is
    chosen for a 2-D grid's centre) and autofocus (its phase estimate reads a 2-D image)."""
    if algorithm not in ("bpa", "ffbp"):
        raise ParameterError("focus", "algorithm", "'bpa' or 'ffbp' with a VolumeGrid (the "
                             "spectral algorithms focus slant grids only)", algorithm)
    if "reference_range" in raw.variables:
        raise ParameterError("focus", "grid", "a 2-D grid for recorded data referenced to a "
                             "scene point (raw has 'reference_range')", "VolumeGrid")
    if autofocus is not None:
        raise ParameterError("focus", "autofocus", "None with a VolumeGrid (autofocus "
                             "estimates its phase from a 2-D image: autofocus a plane through "
                             "the volume and focus the corrected raw product)", autofocus)


def _straighten(raw: xr.Dataset, radar: Radar, grid: Grid, nominal_azimuth: float,
                half_width: float, allowed: bool) -> tuple[xr.Dataset, dict, dict]:
    """The raw product on a straight line for RDA/WDA/FSA: as it is when its track is straight,
    else motion-compensated to the fitted reference line (:mod:`mitsar.focus.mocomp`)."""
    straight, _ = is_straight_track(raw, radar)
    if straight or not allowed:  # not allowed: the algorithm's own check refuses a curved track
        return raw, grid.resolve(raw, radar, nominal_azimuth), {"motion_compensation": 0}
    line = reference_line(raw)
    reference = reference_product(raw, line, radar)
    layout = grid.resolve(reference, radar, nominal_azimuth)
    compensated, info = compensate(raw, reference, line, radar, layout, half_width)
    return compensated, layout, {"motion_compensation": 1, **info}


def _check_processed_band(raw: xr.Dataset, radar: Radar, half_width: float,
                          azimuth_resolution: float | None) -> None:
    """Refuse a hovering platform and a processed Doppler band wider than the PRF.

    The processed band ``4 v h / lambda`` (h: half width in direction sine) must fit in the
    PRF, else the azimuth spectrum aliases into ghosts.
    """
    speed = np.linalg.norm(raw["platform_velocity"].values, axis=-1)
    if not np.all(np.isfinite(speed)) or speed.mean() <= 1e-9:
        raise ParameterError("focus", "platform_velocity", "a moving platform (a synthetic "
                             "aperture needs motion)", f"mean speed {speed.mean():.3g} m/s")
    band = 4 * speed.max() * half_width / radar.wavelength
    rate = sweep_rate(raw, radar)  # the PRF; PRF / N_tx for one TDM-MIMO channel
    if band > rate:
        hint = ("set azimuth_resolution (the whole beam is processed by default)"
                if azimuth_resolution is None else "raise azimuth_resolution")
        raise ParameterError(
            "focus", "azimuth_resolution",
            f"a processed Doppler band 4 v h / lambda <= the sweep rate {rate:g} Hz (PRF "
            f"{radar.prf:g} Hz{_per_slot(raw)}; {hint}; the finest resolution at "
            f"{speed.max():.3g} m/s is {speed.max() / rate:.3g} m)",
            f"{azimuth_resolution} ({band:.4g} Hz)")


def _per_slot(raw: xr.Dataset) -> str:
    """How a TDM-MIMO channel's sweep rate follows from the PRF, for messages."""
    stride = int(raw.attrs.get("sweep_stride", 1))
    return "" if stride == 1 else f" / {stride} transmitters in turn, TDM-MIMO"
