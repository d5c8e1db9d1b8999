"""The dechirped FMCW signal model: one place for the physics of a single echo.

Used by the analytic simulator (exact per-sample delay) and by the histogram synthesis of the
ray tracer, so both producers of raw data share one formula.

Convention (``docs/conventions.md``, docs/design.md §4): transmit phase ``2 pi (f_c t + K t^2 / 2)``
over the sweep, fast time ``t`` centred on the sweep, dechirp ``s = s_tx conj(s_rx)``. An echo
with two-way delay ``tau`` then gives

``s(t) = a exp{ j 2 pi [ f_c tau + K tau t - K tau^2 / 2 ] }``   (paper eq. 1 with the RVP)

with beat frequency ``K tau`` and residual video phase ``-K tau^2 / 2`` (Meta 2007 eq. 3).
"""

from __future__ import annotations

from typing import Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.model.radar import SPEED_OF_LIGHT, Radar


def fast_time(radar: Radar) -> NDArray[np.float64]:
    """Fast-time sample instants ``t_n = -T/2 + n / f_s`` [s], n = 0 .. N_s - 1."""
    return -radar.sweep_duration / 2 + np.arange(radar.samples_per_sweep) / radar.sampling_frequency


def sweep_start_times(radar: Radar, sweeps: int) -> NDArray[np.float64]:
    """Slow time of each sweep's start, ``eta_k = k / PRF`` [s]."""
    return np.arange(sweeps) / radar.prf


def sweep_count(radar: Radar, duration: float) -> int:
    """Number of whole sweeps that fit in ``duration`` seconds of flight."""
    return int(np.floor(duration * radar.prf + 1e-9))


def two_way_delay(platform_position: ArrayLike, target_position: ArrayLike) -> NDArray:
    """Two-way delay ``tau = 2 |p - q| / c`` of a co-located antenna [s].

    Evaluated at the sample instant itself (no stop-and-go, Meta 2007 §II); the light-time
    correction (v/c ~ 1e-9) is neglected.
    """
    offset = np.asarray(platform_position) - np.asarray(target_position)
    return 2.0 * np.linalg.norm(offset, axis=-1) / SPEED_OF_LIGHT


def bistatic_delay(transmitter_position: ArrayLike, receiver_position: ArrayLike,
                   target_position: ArrayLike) -> NDArray:
    """Delay ``tau = (|t - q| + |q - r|) / c`` of a transmitter at t and a receiver at r [s].

    The exact path of one channel of a multi-channel radar (Rosen et al. 2000 §II;
    docs/interferometry.md); :func:`two_way_delay` when ``t = r``. Evaluated at the sample
    instant, as :func:`two_way_delay`.
    """
    target = np.asarray(target_position)
    outgoing = np.linalg.norm(np.asarray(transmitter_position) - target, axis=-1)
    incoming = np.linalg.norm(np.asarray(receiver_position) - target, axis=-1)
    return (outgoing + incoming) / SPEED_OF_LIGHT


def half_path(outgoing: Any, incoming: Any) -> Any:
    """Half the bistatic path ``(|t - q| + |q - r|) / 2`` [m] (or half its rate [m/s]): the
    "range" whose two-way delay ``2 R / c`` is the channel's exact delay
    (:func:`bistatic_delay`), which the back-projection and the tracer's deposit take for a
    channel whose transmitter and receiver differ (docs/interferometry.md). NumPy and Dr.Jit
    alike."""
    return 0.5 * (outgoing + incoming)


def dechirped_phase_cycles(delay: ArrayLike, fast_time: ArrayLike, radar: Radar,
                           rvp: bool = True) -> NDArray[np.float64]:
    """Phase of the dechirped echo in cycles: ``f_c tau + K tau t - K tau^2 / 2`` (paper eq. 1).

    Parameters
    ----------
    delay : array_like
        Two-way delay tau [s] (float64: ``f_c tau`` is ~2e4 cycles at 30 m).
    fast_time : array_like
        Fast time t [s], centred on the sweep; broadcast against ``delay``.
    radar : Radar
    rvp : bool
        Keep the residual video phase ``-K tau^2 / 2`` (default); ``False`` gives paper eq. 1.
    """
    delay = np.asarray(delay, dtype=np.float64)
    cycles = radar.carrier_frequency * delay + radar.chirp_rate * delay * np.asarray(fast_time)
    if rvp:
        cycles = cycles - 0.5 * radar.chirp_rate * delay**2
    return cycles


def radar_equation_amplitude(radar: Radar, rcs: ArrayLike, transmit_range: ArrayLike,
                             receive_range: ArrayLike | None = None,
                             two_way_pattern: ArrayLike = 1.0) -> NDArray:
    """Echo amplitude from the radar equation [sqrt(W)].

    ``a = sqrt( P_T G_T G_R lambda^2 sigma / ((4 pi)^3 R_t^2 R_r^2) )`` with
    ``G_T G_R = G^2 * two_way_pattern`` (docs/design.md §4).

    Parameters
    ----------
    radar : Radar
    rcs : array_like
        Radar cross section sigma [m^2].
    transmit_range, receive_range : array_like
        Ranges antenna-to-scatterer and back [m]; monostatic when ``receive_range`` is None.
    two_way_pattern : array_like
        Product of the transmit and receive power patterns (1 on boresight).
    """
    transmit_range = np.asarray(transmit_range, dtype=float)
    receive_range = transmit_range if receive_range is None else np.asarray(receive_range)
    power = (radar.transmit_power * radar.antenna_gain**2 * np.asarray(two_way_pattern)
             * radar.wavelength**2 * np.asarray(rcs)
             / ((4 * np.pi) ** 3 * transmit_range**2 * receive_range**2))
    return np.sqrt(power)


def beat_frequency(delay: Any, delay_rate: Any, chirp_rate: Any, carrier_frequency: Any) -> Any:
    """Beat frequency of a moving echo, ``f = K tau + f_c dtau/dt`` [Hz] (Meta 2007 §II-B).

    Operators only, so the same expression runs on NumPy arrays and inside the Dr.Jit
    back-projection kernel (where ``K`` and ``f_c`` are opaque scalars).

    Parameters
    ----------
    delay : array_like
        Two-way delay ``tau`` [s].
    delay_rate : array_like
        ``dtau/dt`` [s/s]; 0 for the stop-and-go beat frequency ``K tau``.
    chirp_rate, carrier_frequency : float or array_like
        ``K`` [Hz/s] and ``f_c`` [Hz].
    """
    return chirp_rate * delay + carrier_frequency * delay_rate


def apparent_beat_frequency(delay: ArrayLike, delay_rate: ArrayLike, radar: Radar) -> NDArray:
    """Beat frequency of a moving echo to first order in fast time [Hz] (docs/design.md §5.5).

    ``f = K tau_0 + f_c dtau/dt`` (:func:`beat_frequency`): with the Doppler frequency
    ``f_D = -f_c dtau/dt`` the beat frequency moves by ``-f_D``, which reads as a range shift of
    ``-c f_D / (2K)`` (Meta 2007 §II-B): an approaching target (f_D > 0) appears nearer.
    """
    return beat_frequency(np.asarray(delay), np.asarray(delay_rate), radar.chirp_rate,
                          radar.carrier_frequency)
