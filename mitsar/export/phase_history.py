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
   scatterer at ``Delta TOA = tau - tau_srp`` has phase ``2 pi f_n Delta TOA``; for one
   channel of a multi-channel product (:func:`mitsar.focus.channels.channel_view`) with its
   transmitter at ``t_k`` and receiver at ``r_k`` (:func:`phase_centre_tracks`),
   ``tau_srp,k = (|t_k - SRP| + |r_k - SRP|) / c``, and the ``"srp"`` motion removal takes
   that bistatic delay's rate;
4. CPHD sign: conjugation, phase ``SGN 2 pi f_n Delta TOA`` with ``SGN = -1``.

Every step is invertible, and :func:`dechirped_samples` undoes them in reverse order (4 to 1):
steps 2-4 and the ``"srp"``/``"none"`` motion removals exactly (unit-modulus factors per sample
or per bin of the same N-bin spectrum); the ``"exact"`` one, whose zero-padded azimuth FFT drops
what the shift moves past the track's ends, by solving ``A x = y`` in least squares per
fast-time sample (:func:`restore_motion`: conjugate gradients, ``A^H`` being the opposite
shift; ``A`` is well conditioned, smallest singular value 0.31 for a half-sweep shift). The
round trip CPHD -> :func:`mitsar.export.read_cphd` therefore gives back the dechirped raw
product itself (docs/products.md, the round trip).

Everything here is NumPy on the mitsar lab frame; :mod:`mitsar.export.cphd` writes it.
"""

from __future__ import annotations

import warnings
from dataclasses import dataclass

import numpy as np
import xarray as xr
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.focus.aperture import doppler_geometry
from mitsar.focus.motion import doppler_centroid, is_straight_track, motion_correction_phase
from mitsar.model.geometry.attitude import body_offset_to_world
from mitsar.model.radar import SPEED_OF_LIGHT, Radar
from mitsar.model.signal import fast_time
from mitsar.products.raw import radar_of, sweep_rate

__all__ = ["MOTION_MODES", "PhaseHistory", "dechirped_samples", "fx_phase_history",
           "motion_phase", "motion_shift", "phase_centre_tracks", "remove_motion",
           "restore_motion", "rvp_filter", "scene_reference_point", "srp_delay",
           "srp_delay_rate"]

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
    """(vectors, 3): antenna (transmit) phase centre at mid-sweep [m]."""
    velocity: NDArray[np.float64]
    """(vectors, 3): antenna (transmit) phase centre velocity at mid-sweep [m/s]."""
    srp: NDArray[np.float64]
    """(3,): scene reference point [m]."""
    reference_range: NDArray[np.float64]
    """(vectors,): ``|p_k - SRP|`` [m]; half the bistatic path
    ``(|t_k - SRP| + |r_k - SRP|) / 2`` for a channel whose receiver is elsewhere."""
    motion: str
    """The intra-sweep motion removal applied ("exact", "srp" or "none")."""
    rvp_removed: bool
    """Whether the residual video phase was removed here (False: the product had none)."""
    azimuth_centre: float = 0.0
    """Azimuth frequency [Hz] the ``"exact"`` removal unwrapped its frequencies around (the
    data's Doppler centroid, ``-f_Dc``); 0 for the other modes."""
    receive_position: NDArray[np.float64] | None = None
    """(vectors, 3): receive phase centre at mid-sweep [m] of a channel whose receiver is not
    its transmitter (:func:`phase_centre_tracks`); None: the same as ``position``."""
    receive_velocity: NDArray[np.float64] | None = None
    """(vectors, 3): velocity of the receive phase centre [m/s], with ``receive_position``."""
    sweep_rate: float | None = None
    """Rate [Hz] at which the vectors sample the aperture (:func:`mitsar.products.raw.
    sweep_rate`: ``prf / N_tx`` for a TDM-MIMO channel); the ``"exact"`` removal's azimuth
    frequencies span it."""


def phase_centre_tracks(raw: xr.Dataset) -> tuple[NDArray, NDArray, NDArray | None,
                                                      NDArray | None]:
    """Transmit and receive phase centres of a (one-channel) raw product per sweep, and their
    velocities.

    A single-channel product is monostatic at its track: ``platform_position`` and
    ``platform_velocity``, no receiver. One channel of a multi-channel product
    (:func:`mitsar.focus.channels.channel_view`) holds its body-frame ``transmitter_offset``
    and ``receiver_offset`` [m]: each phase centre is the track point plus the offset rotated
    by the sweep's attitude (:func:`mitsar.model.geometry.attitude.body_offset_to_world`,
    as the simulators and :func:`mitsar.focus.bp_setup.channel_phase_centres` place them), and
    moves with the track's velocity plus the rate of the rotated offset (``numpy.gradient``
    over the mid-sweep times: exactly zero at a constant attitude).

    Parameters
    ----------
    raw : xarray.Dataset
        Raw product with a (sweep, sample) ``raw``.

    Returns
    -------
    transmit_position, transmit_velocity : ndarray, shape (sweeps, 3)
        [m], [m/s].
    receive_position, receive_velocity : ndarray, shape (sweeps, 3), or None
        [m], [m/s]; None where the receiver is the transmitter (monostatic, ping-pong).
    """
    positions = np.asarray(raw["platform_position"].values, dtype=float)
    velocities = np.asarray(raw["platform_velocity"].values, dtype=float)
    if "transmitter_offset" not in raw.variables:
        return positions, velocities, None, None
    attitude = np.asarray(raw["attitude"].values, dtype=float).T
    slow_time = np.asarray(raw["slow_time"].values, dtype=float)

    def place(offset: NDArray) -> tuple[NDArray, NDArray]:
        world = body_offset_to_world(offset, *attitude)
        rate = (np.gradient(world, slow_time, axis=0) if len(slow_time) > 1
                else np.zeros_like(world))
        return positions + world, velocities + rate

    transmit = np.asarray(raw["transmitter_offset"].values, dtype=float)
    receive = np.asarray(raw["receiver_offset"].values, dtype=float)
    transmit_position, transmit_velocity = place(transmit)
    if np.array_equal(transmit, receive):
        return transmit_position, transmit_velocity, None, None
    return (transmit_position, transmit_velocity, *place(receive))


def srp_delay(positions: ArrayLike, srp: ArrayLike,
              receive_positions: ArrayLike | None = None) -> NDArray[np.float64]:
    """Delay of the SRP per sweep [s]: ``2 |p_k - SRP| / c``, or
    ``(|t_k - SRP| + |r_k - SRP|) / c`` with the receive phase centres ``r_k``."""
    point = np.asarray(srp, dtype=float).reshape(3)
    srp_range = np.linalg.norm(np.asarray(positions, dtype=float) - point, axis=1)
    if receive_positions is None:
        return 2.0 * srp_range / SPEED_OF_LIGHT
    receive_range = np.linalg.norm(np.asarray(receive_positions, dtype=float) - point, axis=1)
    return (srp_range + receive_range) / SPEED_OF_LIGHT


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


def fx_phase_history(raw: xr.Dataset, srp: ArrayLike, motion: str = "auto", *,
                     azimuth_centre: float | None = None) -> PhaseHistory:
    """FX-domain phase history of a dechirped raw product (module docstring).

    Parameters
    ----------
    raw : xarray.Dataset
        Dechirped raw product (:mod:`mitsar.raw.product`), not a referenced recording; one
        channel (a multi-channel product channel by channel:
        :func:`mitsar.focus.channels.channel_view`, whose phase centres it then uses:
        :func:`phase_centre_tracks`).
    srp : array_like, shape (3,)
        Scene reference point in the lab frame [m].
    motion : {"auto", "exact", "srp", "none"}
        Intra-sweep motion removal.
    azimuth_centre : float, optional
        Azimuth frequency [Hz] the ``"exact"`` removal unwraps around (default the data's
        Doppler centroid ``-mean f_Dc``); the channels of one product share channel 0's.

    Returns
    -------
    PhaseHistory

    Raises
    ------
    ParameterError
        For a referenced product, a product with a ``channel`` dim, an unknown ``motion``, or
        ``"exact"`` on a track that is not straight and uniform.
    """
    if "channel" in raw["raw"].dims:
        raise ParameterError("write_cphd", "raw", "one channel (mitsar.focus.channels."
                             "channel_view(raw, k))", f"{raw.sizes['channel']} channels")
    if "reference_range" in raw.variables:
        raise ParameterError("write_cphd", "raw", "a dechirped raw product (absolute range)",
                             "a referenced recording (it is already phase history)")
    if motion not in MOTION_MODES:
        raise ParameterError("write_cphd", "motion", f"one of {MOTION_MODES}", motion)
    radar = radar_of(raw)
    samples = np.asarray(raw["raw"].values, dtype=np.complex128)
    t = fast_time(radar)
    positions, velocities, receive, receive_velocity = phase_centre_tracks(raw)
    point = np.asarray(srp, dtype=float).reshape(3)
    delay = srp_delay(positions, point, receive)
    reference_range = (np.linalg.norm(positions - point, axis=1) if receive is None
                       else delay * (SPEED_OF_LIGHT / 2.0))
    straight, why = is_straight_track(raw, radar)
    if motion == "auto":
        motion = "exact" if straight else "srp"
    if motion == "exact" and not straight:
        raise ParameterError("write_cphd", "motion", "'srp' or 'none' for this track "
                             "('exact' needs a straight, uniform track)", why)
    centre = 0.0
    if motion == "exact":
        centre = (-float(np.mean(doppler_centroid(raw, radar))) if azimuth_centre is None
                  else float(azimuth_centre))
    delay_rates = _delay_rate(positions, velocities, point, receive, receive_velocity)
    samples = remove_motion(samples, motion, t, radar, centre, delay_rates,
                            sweep_rate(raw, radar))
    rvp = bool(int(raw.attrs.get("rvp", 1)))
    if rvp:
        samples = rvp_filter(samples, radar, +1)
    rf = radar.carrier_frequency + radar.chirp_rate * t
    samples = samples * _srp_phase(rf, delay, -1)
    signal = np.conj(samples) if PHASE_SIGN < 0 else samples
    return PhaseHistory(
        signal=signal, first_frequency=float(rf[0]),
        frequency_step=radar.chirp_rate / radar.sampling_frequency,
        time=np.asarray(raw["slow_time"].values, dtype=float) + radar.sweep_duration / 2,
        position=positions, velocity=velocities, srp=point, reference_range=reference_range,
        motion=motion, rvp_removed=rvp, azimuth_centre=centre, receive_position=receive,
        receive_velocity=receive_velocity, sweep_rate=sweep_rate(raw, radar))


def srp_delay_rate(positions: ArrayLike, velocities: ArrayLike, srp: ArrayLike) -> NDArray:
    """Delay rate of the SRP ``dtau_srp/dt = 2 v.(p - SRP) / (c |p - SRP|)`` per sweep [s/s]
    (:func:`mitsar.focus.aperture.doppler_geometry`)."""
    point = np.asarray(srp, dtype=float).reshape(1, 3)
    return doppler_geometry(point, np.asarray(positions, dtype=float),
                            np.asarray(velocities, dtype=float))[2][:, 0]


def _delay_rate(positions: NDArray, velocities: NDArray, srp: NDArray,
                receive: NDArray | None, receive_velocity: NDArray | None) -> NDArray:
    """The SRP's delay rate [s/s]: :func:`srp_delay_rate`, or the mean of the transmitter's and
    the receiver's, ``(v_t.u_t + v_r.u_r) / c``, for a bistatic channel."""
    rate = srp_delay_rate(positions, velocities, srp)
    if receive is None:
        return rate
    return (rate + srp_delay_rate(receive, receive_velocity, srp)) / 2.0


def _srp_phase(rf: NDArray, srp_delay: NDArray, sign: int) -> NDArray:
    """``exp(sign j 2 pi f_n tau_srp,k)`` with the turns wrapped in float64 (step 3)."""
    turns = rf[None, :] * srp_delay[:, None]
    return np.exp(sign * 2j * np.pi * (turns - np.floor(turns)))


def rvp_filter(samples: NDArray, radar: Radar, sign: int) -> NDArray:
    """Residual video phase filter ``exp(sign j pi f^2 / K)`` on each sweep's N-bin spectrum
    (step 2; Carrara et al. 1995 App. C): +1 removes the RVP, -1 puts it back (exact inverse)."""
    beat = np.fft.fftfreq(samples.shape[1], 1.0 / radar.sampling_frequency)
    return np.fft.ifft(np.fft.fft(samples, axis=1)
                       * np.exp(sign * 1j * np.pi * beat**2 / radar.chirp_rate), axis=1)


def motion_phase(sweeps: int, t: NDArray, prf: float, centre: float) -> NDArray:
    """``H_cm = exp(-j 2 pi f_eta t)`` (:func:`mitsar.focus.motion.motion_correction_phase`;
    Meta et al. 2007 §II-B) on the azimuth FFT grid of :func:`motion_shift`: a power of two
    >= twice ``sweeps`` bins, f_eta unwrapped around ``centre`` [Hz]. Shape (bins, N).
    ``prf``: the rate [Hz] at which the sweeps sample the aperture."""
    size = int(2 ** np.ceil(np.log2(2 * sweeps)))
    frequency = np.fft.fftfreq(size, 1.0 / prf)
    frequency = centre + (frequency - centre + prf / 2) % prf - prf / 2
    return motion_correction_phase(t[None, :], frequency[:, None])


def motion_shift(samples: NDArray, phase: NDArray, sign: int) -> NDArray:
    """The azimuth shift of the ``"exact"`` motion removal, ``A`` (sign +1) or ``A^H`` (-1).

    ``A``: zero-pad the sweeps to the bins of ``phase`` (:func:`motion_phase`), azimuth FFT,
    multiply by ``H_cm``, inverse FFT, keep the first sweeps. ``A^H``: the same with
    ``conj(H_cm)``.
    """
    sweeps = samples.shape[0]
    spectrum = np.fft.fft(samples, n=phase.shape[0], axis=0)
    spectrum *= phase if sign > 0 else np.conj(phase)
    return np.fft.ifft(spectrum, axis=0)[:sweeps]


def remove_motion(samples: NDArray, motion: str, t: NDArray, radar: Radar, centre: float,
                  delay_rate: NDArray, rate: float | None = None) -> NDArray:
    """Step 1 (module docstring): ``"exact"`` :func:`motion_shift`, ``"srp"``
    ``exp(-j 2 pi f_c dtau_srp/dt t)``, ``"none"`` nothing. ``rate``: the sweeps' rate [Hz]
    (default the PRF; ``prf / N_tx`` for a TDM-MIMO channel)."""
    if motion == "exact":
        return motion_shift(samples, motion_phase(len(samples), t, radar.prf if rate is None
                                                  else rate, centre), +1)
    if motion == "srp":
        return samples * np.exp(-2j * np.pi * radar.carrier_frequency
                                * delay_rate[:, None] * t[None, :])
    return samples


def restore_motion(samples: NDArray, motion: str, t: NDArray, radar: Radar, centre: float,
                   delay_rate: NDArray, tolerance: float = 1e-9,
                   iterations: int = 200, rate: float | None = None) -> NDArray:
    """Inverse of :func:`remove_motion` (``rate``: the sweeps' rate [Hz], default the PRF).

    ``"exact"``: least squares ``min ||A x - y||`` for every fast-time sample at once by
    conjugate gradients on the normal equations (CGLS, docs/products.md, the round trip), with
    ``A`` and ``A^H`` from :func:`motion_shift`, starting from ``A^H y`` (the opposite shift),
    until every column's normal-equation residual falls below ``tolerance`` of its start
    (6 to 8 iterations for 100 to 1000 sweeps; ``A`` has condition number about 3.2).
    """
    if motion == "srp":
        return samples * np.exp(2j * np.pi * radar.carrier_frequency
                                * delay_rate[:, None] * t[None, :])
    if motion != "exact":
        return samples

    phase = motion_phase(len(samples), t, radar.prf if rate is None else rate, centre)

    def forward(x: NDArray) -> NDArray:
        return motion_shift(x, phase, +1)

    def adjoint(x: NDArray) -> NDArray:
        return motion_shift(x, phase, -1)

    x = adjoint(samples)  # the opposite shift: the inverse away from the track's ends
    residual = samples - forward(x)
    gradient = adjoint(residual)
    direction = gradient.copy()
    gamma = np.sum(np.abs(gradient) ** 2, axis=0)
    stop = tolerance**2 * np.maximum(gamma, np.finfo(float).tiny)
    for _ in range(iterations):
        if np.all(gamma <= stop):
            break
        image = forward(direction)
        alpha = gamma / np.maximum(np.sum(np.abs(image) ** 2, axis=0), np.finfo(float).tiny)
        alpha = np.where(gamma > stop, alpha, 0.0)
        x = x + alpha * direction
        residual = residual - alpha * image
        gradient = adjoint(residual)
        updated = np.sum(np.abs(gradient) ** 2, axis=0)
        direction = gradient + (updated / np.maximum(gamma, np.finfo(float).tiny)) * direction
        gamma = updated
    if not np.all(gamma <= stop):
        worst = float(np.sqrt(np.max(gamma / np.maximum(stop / tolerance**2,
                                                        np.finfo(float).tiny))))
        warnings.warn(f"read_cphd: undoing the 'exact' intra-sweep motion removal did not converge "
                      f"in {iterations} iterations (residual {worst:.2g} of its start, aim "
                      f"{tolerance:.0e}); the dechirped samples are approximate. Read with "
                      f"form='referenced' to skip the inversion.", RuntimeWarning, stacklevel=3)
    return x


def dechirped_samples(signal: ArrayLike, radar: Radar, positions: ArrayLike,
                      velocities: ArrayLike, srp: ArrayLike, motion: str,
                      azimuth_centre: float = 0.0, rvp_removed: bool = True,
                      phase_sign: int = PHASE_SIGN, *,
                      receive_positions: ArrayLike | None = None,
                      receive_velocities: ArrayLike | None = None,
                      sweep_rate: float | None = None) -> NDArray[np.complex128]:
    """The dechirped sweeps a phase history was made from: steps 4 to 1 undone.

    Parameters
    ----------
    signal : array_like, shape (sweeps, N)
        Phase history (:attr:`PhaseHistory.signal`) on the RF frequencies
        ``f_c + K t_n`` of ``radar``.
    radar : Radar
        The radar of the dechirped product.
    positions, velocities : array_like, shape (sweeps, 3)
        Mid-sweep antenna (transmit) phase centres [m] and their velocities [m/s].
    srp : array_like, shape (3,)
        Scene reference point [m].
    motion : {"exact", "srp", "none"}
        The intra-sweep motion removal that was applied.
    azimuth_centre : float
        :attr:`PhaseHistory.azimuth_centre` [Hz] (``"exact"``).
    rvp_removed : bool
        Whether the residual video phase was removed (and is put back here).
    phase_sign : {+1, -1}
        Sign of the phase history (CPHD ``SGN``).
    receive_positions, receive_velocities : array_like, shape (sweeps, 3), optional
        Receive phase centres [m] and velocities [m/s] of a bistatic channel
        (:attr:`PhaseHistory.receive_position`); None: monostatic.
    sweep_rate : float, optional
        :attr:`PhaseHistory.sweep_rate` [Hz] (default the PRF).

    Returns
    -------
    ndarray, shape (sweeps, N)
        Dechirped samples ``a exp{j 2 pi [f_c tau + K tau t - K tau^2 / 2]}`` (docs/conventions.md).
    """
    if motion not in MOTION_MODES[1:]:
        raise ParameterError("dechirped_samples", "motion", f"one of {MOTION_MODES[1:]}",
                             motion)
    samples = np.asarray(signal, dtype=np.complex128)
    samples = np.conj(samples) if phase_sign < 0 else samples
    t = fast_time(radar)
    positions = np.asarray(positions, dtype=float)
    velocities = np.asarray(velocities, dtype=float)
    point = np.asarray(srp, dtype=float).reshape(3)
    receive = None if receive_positions is None else np.asarray(receive_positions, float)
    receive_velocity = (None if receive_velocities is None
                        else np.asarray(receive_velocities, float))
    rf = radar.carrier_frequency + radar.chirp_rate * t
    samples = samples * _srp_phase(rf, srp_delay(positions, point, receive), +1)
    if rvp_removed:
        samples = rvp_filter(samples, radar, -1)
    delay_rates = _delay_rate(positions, velocities, point, receive, receive_velocity)
    return restore_motion(samples, motion, t, radar, azimuth_centre, delay_rates,
                          rate=sweep_rate)
