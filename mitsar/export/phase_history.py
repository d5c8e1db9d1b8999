"""Dechirped FMCW sweeps as FX-domain phase history: the signal of a CPHD vector.

A dechirped sweep with delay tau holds ``a exp{j 2 pi [f_c tau + K tau t - K tau^2 / 2]}``
(docs/conventions.md, waveform). :func:`fx_phase_history` turns it, sweep by sweep, into the
phase history of a stop-and-go pulse at the mid-sweep antenna position, sampled at the RF
frequencies ``f_n = f_c + K t_n``, referenced to a scene reference point (SRP), in the sign
convention of NGA.STND.0068-1 CPHD 1.0.1 (§2 and §4, FX domain, ``SGN = -1``):

1. intra-sweep motion (``motion``): the sample at fast time t was taken at slow time
   ``eta + t`` (Meta et al. 2007 §II-B); ``"exact"`` (straight, uniform tracks) applies
   ``H_cm = exp(-j 2 pi f_eta t)`` after an azimuth FFT (:func:`mitsar.focus.motion.
   motion_correction_phase`, zero-padded to twice the sweeps, azimuth frequencies unwrapped
   around the data's Doppler centroid); ``"srp"`` (any track) removes the SRP's delay rate
   ``exp(-j 2 pi f_c dtau_srp/dt t)`` (exact at the SRP, first order elsewhere); ``"none"``
   keeps it (the target then sits ``-c f_D / (2K)`` off in range);
2. residual video phase: ``exp(+j pi f^2 / K)`` on each sweep's spectrum (Carrara et al.
   1995 App. C, as :func:`mitsar.focus.compression.range_spectrum`), skipped when the product
   has none (``rvp = 0``). Sample n is now ``a exp(+j 2 pi f_n tau)``;
3. SRP compensation: ``exp(-j 2 pi f_n tau_srp,k)``, ``tau_srp,k = 2 |p_k - SRP| / c``, so a
   scatterer at ``Delta TOA = tau - tau_srp`` has phase ``2 pi f_n Delta TOA``;
4. CPHD sign: conjugation, phase ``SGN 2 pi f_n Delta TOA`` with ``SGN = -1``.

Everything here is NumPy on the mitsar lab frame; :mod:`mitsar.export.cphd` writes it.
"""

from __future__ import annotations

from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.focus.motion import doppler_centroid, is_straight_track, motion_correction_phase
from mitsar.model.radar import SPEED_OF_LIGHT
from mitsar.model.signal import fast_time
from mitsar.raw.product import radar_of

__all__ = ["MOTION_MODES", "PhaseHistory", "fx_phase_history", "scene_reference_point"]

MOTION_MODES = ("auto", "exact", "srp", "none")
"""Ways to remove the intra-sweep motion (module docstring); "auto" is "exact" on straight
uniform tracks and "srp" otherwise."""

PHASE_SIGN = -1
"""CPHD ``Global/SGN`` of the exported signal."""


@dataclass(frozen=True)
class PhaseHistory:
    """FX-domain vectors of one channel, in the lab frame (module docstring)."""

    signal: NDArray[np.complex128]
    """(vectors, samples): phase history, CPHD sign ``SGN = -1``."""
    first_frequency: float
    """``SC0 = f_c - B/2``: RF frequency of sample 0 [Hz]."""
    frequency_step: float
    """``SCSS = K / f_s`` [Hz]."""
    time: NDArray[np.float64]
    """(vectors,): mid-sweep time ``eta_k + T/2`` [s] (the stop-and-go instant)."""
    position: NDArray[np.float64]
    """(vectors, 3): antenna phase centre at mid-sweep [m]."""
    velocity: NDArray[np.float64]
    """(vectors, 3): antenna velocity at mid-sweep [m/s]."""
    srp: NDArray[np.float64]
    """(3,): scene reference point [m]."""
    reference_range: NDArray[np.float64]
    """(vectors,): ``|p_k - SRP|`` [m]."""
    motion: str
    """The intra-sweep motion removal applied ("exact", "srp" or "none")."""
    rvp_removed: bool
    """Whether the residual video phase was removed here (False: the product had none)."""


def scene_reference_point(raw: xr.Dataset, image: xr.Dataset | None = None) -> NDArray:
    """Default SRP [m]: the centre pixel of ``image`` when given, else where the mid-sweep
    boresight meets the ground plane z = 0 (or, looking up, the point 10 m along it)."""
    if image is not None:
        position = np.asarray(image["position"].values, dtype=float)
        return position[position.shape[0] // 2, position.shape[1] // 2]
    mid = len(raw["sweep"]) // 2
    origin = np.asarray(raw["platform_position"].values[mid], dtype=float)
    look = np.asarray(raw["boresight"].values[mid], dtype=float)
    distance = -origin[2] / look[2] if look[2] < -1e-6 and origin[2] > 0 else 10.0
    return origin + distance * look


def fx_phase_history(raw: xr.Dataset, srp: ArrayLike, motion: str = "auto") -> PhaseHistory:
    """FX-domain phase history of a dechirped raw product (module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Dechirped raw product (:mod:`mitsar.raw.product`), not a referenced recording.
    srp : array_like, shape (3,)
        Scene reference point in the lab frame [m].
    motion : {"auto", "exact", "srp", "none"}
        Intra-sweep motion removal.

    Returns
    -------
    PhaseHistory

    Raises
    ------
    ParameterError
        For a referenced product, an unknown ``motion``, or ``"exact"`` on a track that is not
        straight and uniform.
    """
    if "reference_range" in raw.variables:
        raise ParameterError("write_cphd", "raw", "a dechirped raw product (absolute range)",
                             "a referenced recording (it is already phase history)")
    if motion not in MOTION_MODES:
        raise ParameterError("write_cphd", "motion", f"one of {MOTION_MODES}", motion)
    radar = radar_of(raw)
    samples = np.asarray(raw["raw"].values, dtype=np.complex128)
    t = fast_time(radar)
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    velocities = np.asarray(raw["platform_velocity"].values, dtype=float)
    point = np.asarray(srp, dtype=float).reshape(3)
    offset = positions - point
    srp_range = np.linalg.norm(offset, axis=1)
    straight, why = is_straight_track(raw, radar)
    if motion == "auto":
        motion = "exact" if straight else "srp"
    if motion == "exact":
        if not straight:
            raise ParameterError("write_cphd", "motion", "'srp' or 'none' for this track "
                                 "('exact' needs a straight, uniform track)", why)
        sweeps = samples.shape[0]
        size = int(2 ** np.ceil(np.log2(2 * sweeps)))
        spectrum = np.fft.fft(samples, n=size, axis=0)
        centre = -float(np.mean(doppler_centroid(raw, radar)))  # data azimuth frequency
        frequency = np.fft.fftfreq(size, 1.0 / radar.prf)
        frequency = centre + (frequency - centre + radar.prf / 2) % radar.prf - radar.prf / 2
        spectrum *= motion_correction_phase(t[None, :], frequency[:, None])
        samples = np.fft.ifft(spectrum, axis=0)[:sweeps]
    elif motion == "srp":
        delay_rate = 2.0 * np.einsum("si,si->s", velocities, offset) / (srp_range
                                                                       * SPEED_OF_LIGHT)
        samples = samples * np.exp(-2j * np.pi * radar.carrier_frequency
                                   * delay_rate[:, None] * t[None, :])
    rvp = bool(int(raw.attrs.get("rvp", 1)))
    if rvp:
        beat = np.fft.fftfreq(samples.shape[1], 1.0 / radar.sampling_frequency)
        samples = np.fft.ifft(np.fft.fft(samples, axis=1)
                              * np.exp(1j * np.pi * beat**2 / radar.chirp_rate), axis=1)
    rf = radar.carrier_frequency + radar.chirp_rate * t
    srp_delay = 2.0 * srp_range / SPEED_OF_LIGHT
    turns = rf[None, :] * srp_delay[:, None]
    samples = samples * np.exp(-2j * np.pi * (turns - np.floor(turns)))
    signal = np.conj(samples) if PHASE_SIGN < 0 else samples
    return PhaseHistory(
        signal=signal, first_frequency=float(rf[0]),
        frequency_step=radar.chirp_rate / radar.sampling_frequency,
        time=np.asarray(raw["slow_time"].values, dtype=float) + radar.sweep_duration / 2,
        position=positions, velocity=velocities, srp=point, reference_range=srp_range,
        motion=motion, rvp_removed=rvp)
