"""Focusing a multi-channel raw product: every channel by back-projection onto one grid.

A radar with declared phase centres (:attr:`mitsar.model.radar.Radar.has_channels`) makes raw
products with a ``channel`` dimension. Each channel is focused on its own exact geometry (its
transmitter and receiver at the track point plus their body-frame offsets rotated by the
attitude: :func:`mitsar.focus.bp_setup.channel_phase_centres`, the delay of the exact path
``(|t - x| + |x - r|) / c``) onto the *same pixels*: the grid is resolved once, on channel 0,
and the other channels are back-projected onto its pixel positions. So the channel images are
co-registered by construction, and a scatterer exactly at a pixel has the same phase in every
channel: the phase of the reference surface (the grid) is removed per pixel from the exact
geometry (docs/interferometry.md).

The image product gains ``channel`` in front of the grid's dims, the channels' body-frame
``transmitter_offset`` / ``receiver_offset`` (channel, xyz) [m] and the processed aperture's
track (``aperture_position`` (aperture, xyz) [m], ``aperture_attitude`` (aperture, angle)
[rad], ``aperture_time`` (aperture) [s], at mid-sweep), which the interferometry stage reads.

RDA, WDA and FSA (:data:`SPECTRAL_ALGORITHMS`) model a monostatic antenna on a straight
track. They focus every channel with one common reference: the same track (the body origin's,
``platform_position``), the same slant grid (so the same reference range, the centre of its
range span) and the same pixels. Before that, :func:`compensate_channel` moves each channel's
own bistatic path onto the monostatic path from the track point, as motion compensation does
for a track's deviation (:mod:`mitsar.focus.mocomp`; Moreira & Huang 1994's two steps): at
sweep s the half-path error ``e(s, r) = (|t_s - Q| + |Q - r_s|) / 2 - |p_s - Q|`` of the point
``Q(s, r)`` of the slant grid's surface at distance ``r`` from the track, seen from ``p_s`` at
the Doppler centroid, is removed, in delay and rate at the grid's centre range and in phase per
range bin. A scatterer on the grid's surface then focuses where the monostatic one would (the
channels co-registered) with the phase ``(2 pi / lambda)(L_k(q) - L_k(p))`` back-projection gives
pixel p (docs/interferometry.md §8, "Spectral focusing of channels"). What remains is ``e``'s
change with the direction sine within the processed aperture, evaluated at the centroid only.

Elements with beams of their own (:attr:`mitsar.model.radar.Radar.has_element_beams`): every
channel is processed on one **common** Doppler band, centred on the mean of the channels'
two-way beam centres (:meth:`mitsar.model.radar.Radar.channel_boresights`), not each on its
own: an interferometric pair must be processed to the same azimuth band, or the part of each
channel's spectrum the other lacks decorrelates the pair (azimuth common-band filtering; Rosen
et al. 2000; docs/interferometry.md §8, "Element beams in focusing"). With all elements
looking the same way the band is centred on their beam, where the look's own band would hold
no echo. The image records each channel's two-way ``channel_doppler_centroid`` [Hz] and the
band's ``processed_doppler_centroid`` [Hz].
"""

from __future__ import annotations

import warnings
from collections.abc import Callable

import numpy as np
import xarray as xr

from mitsar.errors import MitsarWarning, ParameterError
from mitsar.focus.autofocus.apply import correct_raw
from mitsar.focus.bp_setup import channel_phase_centres
from mitsar.focus.grid import Grid, PointsGrid, SlantGrid, VolumeGrid, track_frame
from mitsar.focus.motion import centroid_sines
from mitsar.model.geometry.attitude import body_to_world
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import fast_time
from mitsar.products.raw import look_of, radar_of

__all__ = ["CHANNEL_ALGORITHMS", "SPECTRAL_ALGORITHMS", "channel_view", "common_band",
           "compensate_channel", "focus_channels"]

SPECTRAL_ALGORITHMS = ("rda", "wda", "fsa")
"""Frequency-domain algorithms that focus channels after :func:`compensate_channel`."""

CHANNEL_ALGORITHMS = ("bpa", "ffbp", *SPECTRAL_ALGORITHMS)
"""Algorithms that focus multi-channel products: back-projection (BPA, and FFBP in all its
stages: :mod:`mitsar.focus.ffbp`) takes each channel's exact bistatic path, the spectral
algorithms each channel compensated onto the common monostatic reference (module
docstring)."""

DIRECTION_ERROR = "channel_direction_error"
"""Variable of a compensated channel: its half-path error over direction sines
(:func:`direction_error`), which :func:`mitsar.focus.spectral.prepare_spectrum` removes."""

DIRECTION_SAMPLES = 257
"""Direction sines at which :func:`direction_error` tabulates the error (over +-0.5 about the
centroid: beyond any processed band of the paper's 9 deg beam; linear in between)."""

RATE_STEP = 1e-3
"""Time step [s] of the central difference that gives the in-sweep rate of a channel's path
error at a fixed scene point."""

_OFFSETS = ("transmitter_offset", "receiver_offset")


def channel_view(raw: xr.Dataset, channel: int) -> xr.Dataset:
    """One channel of a multi-channel raw product as a single-channel raw product.

    Its ``raw`` is (sweep, sample); it keeps the channel's body-frame ``transmitter_offset``
    and ``receiver_offset`` (xyz) [m], which back-projection places on the track
    (:func:`mitsar.focus.bp_setup.channel_phase_centres`), and the attribute ``channel``.

    A TDM-MIMO channel (a product with ``fires``: :func:`mitsar.products.raw.channel_variables`)
    keeps only the sweeps its transmitter fired, every N_tx-th, each with its own track point
    (the per-slot motion), and the attribute ``sweep_stride = N_tx``: the focusers then sample
    the aperture at ``prf / N_tx`` (:func:`mitsar.products.raw.sweep_rate`), so their sweep
    windows and full-aperture weights count only the channel's sweeps.
    """
    view = raw.isel(channel=channel)
    attrs = {**raw.attrs, "channel": int(channel)}
    if "fires" in raw.variables:
        fires = np.asarray(view["fires"].values, dtype=bool)
        indices = np.asarray(raw["sweep"].values)[fires]
        stride = radar_of(raw).transmitter_count
        if len(indices) > 1 and not np.all(np.diff(indices) == stride):
            raise ParameterError("channel_view", "raw.sweep", f"the channel's sweeps every "
                                 f"{stride}-th (TDM-MIMO with {stride} transmitters: a contiguous "
                                 "run of acquisition sweeps)", "a gap in the sweeps")
        view = view.isel(sweep=np.flatnonzero(fires)).drop_vars(
            ["fires", "channel_transmitter", "channel_receiver"], errors="ignore")
        attrs["sweep_stride"] = int(stride)
    view.attrs = attrs
    return view


def focus_channels(raw: xr.Dataset, algorithm: str, grid: Grid,
                   focus_one: Callable[[xr.Dataset, Grid, str | None], xr.Dataset],
                   autofocus: str | None = None) -> xr.Dataset:
    """Focus every channel of ``raw`` onto the pixels of channel 0's grid (module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        A raw product with a ``channel`` dimension.
    algorithm : str
        One of :data:`CHANNEL_ALGORITHMS` (every algorithm of :func:`mitsar.focus`, which
        refuses any other name first).
    grid : Grid
        The output grid, resolved on channel 0.
    focus_one : callable
        ``focus_one(single_channel_raw, grid, autofocus) -> image``: :func:`mitsar.focus` with
        the caller's options.
    autofocus : {"pga", "entropy"} or None
        Autofocus channel 0 and apply *its* phase per sweep to every channel
        (:func:`mitsar.focus.autofocus.apply.correct_raw`) before focusing them: the error of
        a navigation track is the platform's, common to phase centres centimetres apart, and
        one phase screen keeps the interferometric phase unbiased (an autofocus per channel
        would give each channel its own constant and linear phase). The image records
        ``autofocus_phase`` and ``autofocus_channels = "channel 0's phase applied to all"``.
        A TDM-MIMO channel of another slot takes that phase interpolated to its own sweeps
        (:func:`_phase_at`).

    Returns
    -------
    xarray.Dataset
        The image product with a ``channel`` dimension (module docstring).
    """
    band = (common_band(raw) if radar_of(raw).has_element_beams
            and "look_off_nadir_deg" in raw.attrs else None)
    if band is not None:  # every channel on the channels' common band (module docstring)
        raw = raw.assign(boresight=(("sweep", "xyz"), band[0], raw["boresight"].attrs))
        _warn_beams_off_band(raw, band[1], band[2])
    if algorithm in SPECTRAL_ALGORITHMS:
        first, images = _focus_spectral(raw, algorithm, grid, focus_one)
    else:
        first = focus_one(channel_view(raw, 0), grid, autofocus)
        # a volume's voxels are in the scene frame already (the same for every channel)
        pixels = grid if isinstance(grid, VolumeGrid) else PointsGrid(first["position"].values)

        def view(k: int) -> xr.Dataset:
            channel = channel_view(raw, k)
            if autofocus is None:
                return channel
            return correct_raw(channel, _phase_at(first["autofocus_phase"], channel))

        images = [first["image"].values] + [focus_one(view(k), pixels, None)["image"].values
                                            for k in range(1, raw.sizes["channel"])]
    image = first.copy()
    image["image"] = (("channel", *first["image"].dims), np.stack(images),
                      first["image"].attrs)
    image = image.assign_coords(channel=raw["channel"].values)
    for name in _OFFSETS:
        image[name] = raw[name]
    for name in ("channel_transmitter", "channel_receiver"):  # TDM-MIMO: the channel's pair
        if name in raw.variables:
            image[name] = raw[name]
    radar = radar_of(raw)
    image["aperture_position"] = (("aperture", "xyz"), raw["platform_position"].values,
                                  {"units": "m", "long_name": "track point at mid-sweep"})
    image["aperture_attitude"] = (("aperture", "angle"), raw["attitude"].values,
                                  {"units": "rad", "long_name": "heading, pitch, roll"})
    image["aperture_time"] = (("aperture",), raw["slow_time"].values
                              + radar.sweep_duration / 2, {"units": "s",
                                                           "long_name": "mid-sweep time"})
    image.attrs.pop("channel", None)
    if band is not None:
        image["channel_doppler_centroid"] = (("channel",), band[1], {
            "units": "Hz", "long_name": "Doppler centroid of the channel's two-way beam "
            "(transmit x receive element), mean over the pass"})
        image.attrs["processed_doppler_centroid"] = band[2]
        image.attrs["processed_band"] = ("common to all channels, centred on the mean of their "
                                         "two-way beams (mitsar.focus.channels.common_band)")
    if autofocus is not None:
        image.attrs["autofocus_channels"] = "channel 0's phase applied to all"
    return image


def common_band(raw: xr.Dataset) -> tuple[np.ndarray, np.ndarray, float]:
    """The common processed band of a multi-channel raw product with element beams (module
    docstring).

    Returns
    -------
    boresight : ndarray, shape (sweeps, 3)
        World-frame unit vector per sweep whose Doppler centroid the focusers centre every
        channel's band on: the normalised mean of the channels' two-way beam centres
        (:meth:`mitsar.model.radar.Radar.channel_boresights`, body frame) rotated by each
        sweep's attitude.
    channel_centroids : ndarray, shape (channels,)
        Each of the product's channels' (its ``channel`` coordinate: the radar's channel
        indices) two-way Doppler centroid ``2 v (v_hat . R b_k) / lambda`` [Hz], mean
        over the sweeps (positive looking ahead; :func:`mitsar.focus.motion.doppler_centroid`).
    centroid : float
        The common band's Doppler centroid [Hz], mean over the sweeps.
    """
    radar = radar_of(raw)
    beams = radar.channel_boresights(look_of(raw))
    # the radar's channels this product holds (a selection such as raw.isel(channel=[i, j])
    # keeps their indices as its coordinate)
    beams = beams[np.asarray(raw["channel"].values, dtype=int)]
    common = beams.mean(axis=0)
    common /= np.linalg.norm(common)
    rotation = body_to_world(*np.asarray(raw["attitude"].values, dtype=float).T)
    velocity = np.asarray(raw["platform_velocity"].values, dtype=float)
    speed = np.linalg.norm(velocity, axis=-1)
    direction = velocity / np.where(speed > 0, speed, 1.0)[:, None]
    scale = 2.0 * speed / radar.wavelength
    world = np.einsum("sij,cj->csi", rotation, np.vstack([common, beams]))
    centroids = (scale[None, :] * np.einsum("csi,si->cs", world, direction)).mean(axis=1)
    return world[0], centroids[1:], float(centroids[0])


def _warn_beams_off_band(raw: xr.Dataset, centroids: np.ndarray, centroid: float) -> None:
    """MitsarWarning naming the channels whose two-way beam centre lies more than half their
    narrower element's azimuth beamwidth (in direction sine) from the common band's centre:
    the band's scatterers reach them on their beam's edge (weak images; the pair stays
    coherent on its common band)."""
    radar = radar_of(raw)
    speed = float(np.mean(np.linalg.norm(np.asarray(raw["platform_velocity"].values,
                                                    dtype=float), axis=-1)))
    if not speed > 0:
        return
    offsets = np.abs(centroids - centroid) * radar.wavelength / (2.0 * speed)
    channels = np.asarray(raw["channel"].values, dtype=int)
    limits = np.array([0.5 * min(t.beamwidth_az, r.beamwidth_az)
                       for t, r in radar.channel_beams(look_of(raw))])[channels]
    off = np.flatnonzero(offsets > limits)
    if off.size:
        warnings.warn(
            f"focus: the two-way beams of channels {channels[off].tolist()} are centred "
            f"{np.degrees(np.arcsin(np.minimum(offsets[off], 1.0))).round(1).tolist()} deg "
            "(along track) from the channels' common processed band, more than half their "
            "azimuth beamwidth: their images hold the band's scatterers on the beam's edge "
            "(weak). Point the elements' boresights closer together (docs/interferometry.md "
            "§8, 'Element beams in focusing')", MitsarWarning, stacklevel=3)


def _focus_spectral(raw: xr.Dataset, algorithm: str, grid: Grid,
                    focus_one: Callable[[xr.Dataset, Grid, str | None], xr.Dataset]
                    ) -> tuple[xr.Dataset, list[np.ndarray]]:
    """RDA/WDA/FSA of every channel, compensated onto the common reference (module
    docstring), onto the one slant grid: channel 0's product and every channel's image."""
    radar = radar_of(raw)
    if not isinstance(grid, SlantGrid):
        raise ParameterError("focus", "grid", f"a SlantGrid for {algorithm!r} (the frequency-"
                             "domain algorithms form the image in along-track / slant-range "
                             "coordinates; use algorithm='bpa' for plane and point grids)",
                             type(grid).__name__)
    # The grid's surface and range axis (its along-track extent does not matter here).
    layout = grid.resolve(channel_view(raw, 0), radar, 1.0)
    first = focus_one(compensate_channel(channel_view(raw, 0), radar, layout), grid, None)
    products = [first]
    for k in range(1, raw.sizes["channel"]):
        view = compensate_channel(channel_view(raw, k), radar, layout)
        products.append(focus_one(view, _same_pixels(grid, first, view), None))
    first.attrs["channel_compensation"] = ("each channel's bistatic path compensated onto the "
                                           "monostatic track reference (mitsar.focus.channels)")
    return first, [product["image"].values for product in products]


def _phase_at(phase: xr.DataArray, view: xr.Dataset) -> np.ndarray:
    """Channel 0's autofocus phase (``autofocus_phase`` over its sweeps) [rad] at the sweeps of
    a channel view: the same where they are its sweeps; a TDM-MIMO channel of another slot
    fires between them, and the platform's phase error, smooth over a sweep or two, is
    interpolated linearly in the sweep index (unwrapped; held at the ends)."""
    own = np.asarray(phase["sweep"].values)
    sweeps = np.asarray(view["sweep"].values)
    values = np.asarray(phase.values, dtype=float)
    if np.array_equal(own, sweeps):
        return values
    return np.interp(sweeps, own, np.unwrap(values))


def _same_pixels(grid: SlantGrid, first: xr.Dataset, view: xr.Dataset) -> SlantGrid:
    """``grid`` for a channel view whose track starts elsewhere than channel 0's (a TDM-MIMO
    channel: its first sweep is its slot's, a sweep's step or more along): a slant grid's
    along-track axis counts from the view's first track point (:func:`mitsar.focus.grid.
    track_frame`), so channel 0's axis (``first``'s ``azimuth``) is moved by the offset between
    the two starts, and the view's pixels are channel 0's."""
    origin, along, _ = track_frame(view)
    shift = float((np.asarray(first.attrs["grid_origin"], dtype=float) - origin) @ along)
    if shift == 0.0:
        return grid
    return SlantGrid(along_track=np.asarray(first["azimuth"].values, dtype=float) + shift,
                     slant_range=np.asarray(first["range"].values, dtype=float))


def channel_path_error(raw: xr.Dataset, layout: dict, shift: float = 0.0,
                       centroid: float | np.ndarray | None = None
                       ) -> tuple[np.ndarray, np.ndarray]:
    """Half-path error ``e(s, r)`` [m] of one channel (module docstring) and the monostatic
    range ``|p_s - Q(s, r)|`` [m], both (sweeps, ranges).

    ``Q(s, r)``: the point of the slant grid's surface (``origin + a along + r look``) at the
    grid's distance ``r`` from the track that the track point ``p_s`` sees at the mean Doppler
    centroid sine ``u_c`` (``a = x_s + r u_c / sqrt(1 - u_c^2)``, ``x_s`` the along-track
    coordinate of ``p_s``). ``shift`` [s] moves the phase centres and the track point by the
    platform velocity times ``shift`` with ``Q`` fixed (the in-sweep rate). ``centroid``
    replaces ``u_c``: a scalar, or, with a one-range grid, an array of sines that takes the
    place of the range axis (:func:`direction_error`).
    """
    attrs = layout["attrs"]
    origin = np.asarray(attrs["grid_origin"], dtype=float)
    along = np.asarray(attrs["grid_along_track"], dtype=float)
    look = np.asarray(attrs["grid_look"], dtype=float)
    r = np.asarray(layout["coords"]["range"], dtype=float)
    track = np.asarray(raw["platform_position"].values, dtype=float)
    u_c = (float(np.clip(np.mean(centroid_sines(raw)), -0.999, 0.999)) if centroid is None
           else np.asarray(centroid, dtype=float))
    a = ((track - origin) @ along)[:, None] + r[None, :] * (u_c / np.sqrt(1.0 - u_c**2))
    points = origin + a[..., None] * along + (r[None, :] + 0.0 * a)[..., None] * look
    transmitter, receiver = channel_phase_centres(raw)
    receiver = transmitter if receiver is None else receiver
    move = np.asarray(raw["platform_velocity"].values, dtype=float) * shift
    track, transmitter, receiver = track + move, transmitter + move, receiver + move
    monostatic = np.linalg.norm(points - track[:, None, :], axis=-1)
    path = (np.linalg.norm(points - transmitter[:, None, :], axis=-1)
            + np.linalg.norm(points - receiver[:, None, :], axis=-1))
    return 0.5 * path - monostatic, monostatic


def compensate_channel(raw: xr.Dataset, radar: Radar, layout: dict) -> xr.Dataset:
    """One channel (:func:`channel_view`) as the monostatic radar at its track point would
    have recorded the slant grid's surface (module docstring; the steps of
    :mod:`mitsar.focus.mocomp` with the channel's path error for the track's deviation):

    1. delay ``dtau = 2 e(s, r_0) / c`` at the grid's centre range ``r_0`` and its in-sweep rate
       ``dtau'`` (the path error of a fixed point as the platform moves): every sample times
       ``exp{-j 2 pi [f_c dtau + (K dtau + f_c dtau') t]}``, carrier, envelope and in-sweep
       motion at once;
    2. per bin of a range FFT (apparent range ``c f / 2K``): ``exp{-j 4 pi [e(s, r) -
       e(s, r_0)] / lambda}``, ``e`` interpolated linearly in the monostatic range.

    A channel at the track point (both offsets zero) is returned as it is.

    Parameters
    ----------
    raw : xarray.Dataset
        One channel of a multi-channel raw product (``transmitter_offset``,
        ``receiver_offset``).
    radar : Radar
    layout : dict
        The slant grid resolved on ``raw`` (``attrs`` ``grid_origin``, ``grid_along_track``,
        ``grid_look``; ``coords["range"]``).

    Returns
    -------
    xarray.Dataset
        ``raw`` with compensated samples and without the offsets (a monostatic product), the
        attribute ``channel_path_error_m`` the largest ``|e|`` removed.
    """
    offsets = [np.asarray(raw[name].values, dtype=float) for name in _OFFSETS
               if name in raw.variables]
    out = raw.drop_vars(list(_OFFSETS), errors="ignore")
    if not any(np.any(offset) for offset in offsets):
        return out
    error, monostatic = channel_path_error(raw, layout)
    r = np.asarray(layout["coords"]["range"], dtype=float)
    centre = int(np.argmin(np.abs(r - 0.5 * (r.min() + r.max()))))
    at_centre = dict(layout, coords={"range": r[centre:centre + 1]})
    ahead, _ = channel_path_error(raw, at_centre, RATE_STEP)
    behind, _ = channel_path_error(raw, at_centre, -RATE_STEP)
    t = fast_time(radar)
    dtau = 2.0 * error[:, centre] / SPEED_OF_LIGHT
    dtau_rate = (ahead[:, 0] - behind[:, 0]) / (RATE_STEP * SPEED_OF_LIGHT)
    samples = np.asarray(raw["raw"].values, dtype=complex) * np.exp(-2j * np.pi * (
        radar.carrier_frequency * dtau[:, None]
        + (radar.chirp_rate * dtau[:, None] + radar.carrier_frequency * dtau_rate[:, None])
        * t[None, :]))
    count = samples.shape[1]
    bin_range = (SPEED_OF_LIGHT * np.fft.fftfreq(count, 1.0 / radar.sampling_frequency)
                 / (2.0 * radar.chirp_rate))
    # The monostatic ranges of the grid's points are the same at every sweep of a straight
    # track (the points move with the sweep): the middle sweep's serve all, and every sweep's
    # error curve is interpolated linearly on them in one vectorised step (clamped at the ends).
    order = np.argsort(monostatic[len(monostatic) // 2])
    ranges = monostatic[len(monostatic) // 2, order]
    rest = (error - error[:, centre:centre + 1])[:, order]
    if len(ranges) > 1:
        index = np.clip(np.searchsorted(ranges, bin_range) - 1, 0, len(ranges) - 2)
        weight = np.clip((bin_range - ranges[index]) / (ranges[index + 1] - ranges[index]),
                         0.0, 1.0)
        extra = (1.0 - weight) * rest[:, index] + weight * rest[:, index + 1]
    else:
        extra = np.zeros((len(samples), count))
    spectrum = np.fft.fft(samples, axis=1) * np.exp(-4j * np.pi * extra / radar.wavelength)
    out["raw"] = (raw["raw"].dims, np.fft.ifft(spectrum, axis=1), raw["raw"].attrs)
    out.attrs["channel_path_error_m"] = float(np.abs(error).max())
    sines, residual = direction_error(raw, layout, float(r[centre]))
    out[DIRECTION_ERROR] = (("direction_sine",), residual, {
        "units": "m", "long_name": "half-path error of the channel at the grid's centre range "
        "seen at each direction sine, less that at the Doppler centroid (removed in the "
        "azimuth-wavenumber domain by mitsar.focus.spectral.prepare_spectrum)"})
    out = out.assign_coords(direction_sine=sines)
    return out


def direction_error(raw: xr.Dataset, layout: dict, centre_range: float
                    ) -> tuple[np.ndarray, np.ndarray]:
    """The channel's half-path error ``e(u) - e(u_c)`` [m] at the grid's centre range, over
    direction sines ``u`` (the beam and more, :data:`DIRECTION_SAMPLES` of them): the part of
    its error that :func:`compensate_channel`'s sweep-by-sweep correction, evaluated at the
    Doppler centroid ``u_c``, leaves. A scatterer is seen at ``u = -k_x / k_r`` in the
    azimuth-wavenumber domain, where the spectral front end removes it
    (:func:`mitsar.focus.spectral.prepare_spectrum`). Evaluated at the middle sweep.
    """
    middle = raw.isel(sweep=[raw.sizes["sweep"] // 2])
    centroid = float(np.clip(np.mean(centroid_sines(raw)), -0.999, 0.999))
    sines = np.clip(centroid + np.linspace(-0.5, 0.5, DIRECTION_SAMPLES), -0.999, 0.999)
    local = dict(layout, coords={"range": np.array([centre_range])})
    error, _ = channel_path_error(middle, local, centroid=np.append(centroid, sines))
    return sines, error[0, 1:] - error[0, 0]
