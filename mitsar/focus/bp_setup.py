"""What every back-projection focuser does before and after its sum (BPA, FFBP).

:func:`prepare` (steps 1-2 of :mod:`mitsar.focus.bpa`): the band selection — ``"doppler"``
band-pass of the processed azimuth band on straight uniform tracks whose band is narrower than
the beam (:func:`mitsar.focus.aperture.doppler_bandpass`), ``"pixel"`` weighting by each
sweep's direction sine otherwise — and the range compression on a zero-padded, sweep-centred
FFT (:func:`mitsar.focus.compression.range_spectrum`; paper eq. 1), of only the bins the
pixels can be looked up in when they are given (:func:`beat_band`).

:func:`normalise` (step 4): division by the weight a full aperture would have
(:func:`mitsar.focus.aperture.full_aperture_weight`), so that a point of amplitude a focuses to
about a, and the aperture coverage of every pixel.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import NDArray

from mitsar.errors import ParameterError
from mitsar.focus.aperture import (
    aperture_half_width,
    band_coverage,
    doppler_bandpass,
    full_aperture_weight,
    is_uniform_straight_track,
    normalise_image,
    track_coordinates,
)
from mitsar.focus.compression import range_spectrum
from mitsar.focus.grid import track_frame
from mitsar.focus.windows import window_coefficients
from mitsar.model.geometry.attitude import body_offset_to_world
from mitsar.model.geometry.bounds import bounding_box
from mitsar.model.radar import Radar
from mitsar.model.signal import fast_time
from mitsar.products.raw import radar_of, sweep_rate

__all__ = ["Prepared", "aperture_weights", "beat_band", "normalise", "prepare"]


def beat_band(radar: Radar, points: NDArray, positions: NDArray, max_speed: float,
              range_margin: float = 0.0) -> tuple[float, float]:
    """Beat frequencies [Hz] at which ``points`` can be looked up from ``positions``.

    Slant ranges between the points' bounding box and the antenna positions bound the beat
    frequency ``2 K R / c`` (paper eq. 1; nearest point of the box, farthest corner), widened
    by the largest Doppler shift ``f_c v / K`` (in range), half a metre and ``range_margin``
    [m].
    """
    low_corner, high_corner = bounding_box(points)
    nearest = np.clip(positions, low_corner, high_corner)
    corners = np.array(np.meshgrid(*zip(low_corner, high_corner, strict=True),
                                   indexing="ij")).reshape(3, -1).T
    low = np.linalg.norm(positions - nearest, axis=-1).min()
    high = np.linalg.norm(positions[:, None, :] - corners[None], axis=-1).max()
    margin = 0.5 + range_margin + radar.carrier_frequency * max_speed / radar.chirp_rate
    return radar.beat_frequency(max(low - margin, 0.0)), radar.beat_frequency(high + margin)


@dataclass
class Prepared:
    """Range profiles and per-sweep geometry of a back-projection, after band selection.

    ``kernel_half_width`` and ``kernel_window`` are what the BP sum windows by (the whole beam
    and no window after a Doppler band-pass, else the processed band and its window);
    ``coefficients`` the cosine series of the processed window.
    """

    radar: Radar
    band_selection: str
    straight: bool
    positions: NDArray[np.float64]
    velocities: NDArray[np.float64]
    speed: NDArray[np.float64]
    centroid: NDArray[np.float64]
    mean_speed: float
    mean_centroid: float
    beam_half_width: float
    coefficients: NDArray[np.float64]
    kernel_half_width: float
    kernel_window: NDArray[np.float64]
    frequency: NDArray[np.float64]
    profile: NDArray[np.complexfloating]
    sweep_rate: float
    """Rate [Hz] at which the sweeps sample the aperture: the PRF, or PRF / N_tx for one
    TDM-MIMO channel (:func:`mitsar.products.raw.sweep_rate`)."""
    receivers: NDArray[np.float64] | None = None
    """A bistatic channel's receive phase centre per sweep [m] (``positions`` is then its
    transmitter's); None: monostatic (:func:`channel_phase_centres`)."""


def channel_phase_centres(raw: xr.Dataset) -> tuple[NDArray, NDArray | None]:
    """The transmitter's position per sweep [m], and the receiver's where it differs.

    A single-channel product is monostatic at its track (``platform_position``). One channel of
    a multi-channel product (:func:`mitsar.focus.channels.channel_view`) carries its
    body-frame ``transmitter_offset`` and ``receiver_offset`` [m]: each is placed at the track
    point plus the offset rotated by the sweep's attitude
    (:func:`mitsar.model.geometry.attitude.body_offset_to_world`), as the simulators do.
    """
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    if "transmitter_offset" not in raw.variables:
        return positions, None
    attitude = np.asarray(raw["attitude"].values, dtype=float).T
    transmitter_offset = np.asarray(raw["transmitter_offset"].values, dtype=float)
    receiver_offset = np.asarray(raw["receiver_offset"].values, dtype=float)
    transmitters = positions + body_offset_to_world(transmitter_offset, *attitude)
    if np.array_equal(transmitter_offset, receiver_offset):
        return transmitters, None
    return transmitters, positions + body_offset_to_world(receiver_offset, *attitude)


def prepare(raw: xr.Dataset, *, half_width: float, window: str, range_window: str,
            remove_rvp: bool, range_upsample: int, band_selection: str | None = None,
            points: NDArray | None = None, range_margin: float = 0.0,
            profile_dtype: type = np.complex128) -> Prepared:
    """Band selection and range compression of a raw product for a BP sum (module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product.
    half_width : float
        Processed half width in direction sine, ``lambda / (4 rho)``.
    window, range_window : str
        Azimuth and range windows.
    remove_rvp : bool
        Remove the residual video phase.
    range_upsample : int
        Zero-padding factor of the range FFT.
    band_selection : {"doppler", "pixel"} or None
        Default: "doppler" on straight uniform tracks with a band narrower than the beam.
    points : ndarray, shape (Q, 3), optional
        Points that bound the pixels (e.g. the pixels): only the profile bins they can be
        looked up in are computed (:func:`beat_band`, zoom transform of
        :func:`mitsar.focus.compression.range_spectrum`).
    range_margin : float
        Extra range [m] kept beyond the points' band (FFBP's polar grids reach past them).
    profile_dtype : numpy complex type
        Precision of the range compression (``dtype`` of
        :func:`mitsar.focus.compression.range_spectrum`).

    Raises
    ------
    ParameterError
        ``band_selection="doppler"`` on a curved track or a varying speed.
    """
    radar = radar_of(raw)
    rate = sweep_rate(raw, radar)
    beam_half_width = aperture_half_width(radar, None)
    straight = is_uniform_straight_track(raw)
    if band_selection is None:
        band_selection = "doppler" if straight and half_width < beam_half_width else "pixel"
    if band_selection == "doppler" and not straight:
        raise ParameterError("focus", "band_selection",
                             "'pixel' for a curved track or a varying speed", band_selection)
    positions, receivers = channel_phase_centres(raw)
    velocities = raw["platform_velocity"].values
    speed = np.linalg.norm(velocities, axis=-1)
    centroid = np.einsum("si,si->s", raw["boresight"].values, velocities) / np.where(
        speed > 0, speed, 1.0)
    coefficients = window_coefficients(window)
    mean_speed, mean_centroid = float(speed.mean()), float(centroid.mean())
    samples = raw["raw"].values
    if band_selection == "doppler":
        bandwidth = 4 * mean_speed * half_width / radar.wavelength  # B_a = v / rho
        rf_frequency = radar.carrier_frequency + radar.chirp_rate * fast_time(radar)
        pad = int(np.ceil(4 * rate / bandwidth))
        samples = doppler_bandpass(samples, rate, mean_centroid, half_width, mean_speed,
                                   rf_frequency, coefficients, pad)
        kernel_half_width, kernel_window = beam_half_width, window_coefficients("rect")
    else:
        kernel_half_width, kernel_window = half_width, coefficients
    frequency, profile = range_spectrum(
        samples, radar, window=range_window, remove_rvp=remove_rvp, upsample=range_upsample,
        rvp_present=bool(raw.attrs.get("rvp", 1)),
        band=None if points is None else beat_band(radar, points, positions,
                                                   float(speed.max()), range_margin),
        dtype=profile_dtype)
    return Prepared(radar=radar, band_selection=band_selection, straight=straight,
                    positions=positions, velocities=velocities, speed=speed, centroid=centroid,
                    mean_speed=mean_speed, mean_centroid=mean_centroid,
                    beam_half_width=beam_half_width, coefficients=coefficients,
                    kernel_half_width=kernel_half_width, kernel_window=kernel_window,
                    frequency=frequency, profile=profile, sweep_rate=rate,
                    receivers=receivers)


def aperture_weights(prepared: Prepared, raw: xr.Dataset, pixels: NDArray, half_width: float,
                     coordinates: tuple[NDArray, NDArray] | None = None
                     ) -> tuple[NDArray, NDArray | None]:
    """Full-aperture weight of every pixel and, after a Doppler band-pass, its coverage.

    The part of :func:`normalise` that needs no BP sum (a focuser may compute it while its
    kernels run). ``coordinates``: the pixels'
    :func:`mitsar.focus.aperture.track_coordinates` along ``track_frame(raw)``, if known.
    """
    origin, direction, _ = track_frame(raw)
    p = prepared
    coordinates = coordinates or track_coordinates(pixels, origin, direction)
    signal_weight = full_aperture_weight(pixels, origin, direction, p.mean_speed, p.sweep_rate,
                                         p.mean_centroid, half_width, float(p.coefficients[0]),
                                         coordinates)
    if p.band_selection != "doppler":
        return signal_weight, None
    track_length = float((p.positions[-1] - origin) @ direction)
    return signal_weight, band_coverage(pixels, origin, direction, track_length,
                                        p.mean_centroid, half_width, coordinates)


def normalise(prepared: Prepared, raw: xr.Dataset, pixels: NDArray, sums: NDArray,
              totals: NDArray, half_width: float,
              weights: tuple[NDArray, NDArray | None] | None = None
              ) -> tuple[NDArray, NDArray]:
    """Image values and aperture coverage from the BP sums and weight totals (module doc);
    ``weights`` from :func:`aperture_weights` if already computed."""
    signal_weight, coverage = weights or aperture_weights(prepared, raw, pixels, half_width)
    if coverage is not None:
        return sums / np.where(signal_weight > 0, signal_weight, 1.0), coverage
    return normalise_image(sums, totals, signal_weight)
