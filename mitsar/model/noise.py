"""Receiver thermal noise and the noise-equivalent sigma zero (NESZ) of a focused pixel.

Thermal noise is circular Gaussian with power ``k T0 F f_s`` per complex sample
(:attr:`mitsar.model.radar.Radar.noise_power`; unit receiver gain, so the raw samples are referred
to the antenna port as the echoes of :mod:`mitsar.model.signal` are). Every simulator draws it
through :func:`thermal_noise`, seeded from the run's seed (docs/metrics.md §Noise).

Through a back-projection focuser that weighs the ``N_s`` samples of a sweep by a range window
and the ``M`` sweeps of a pixel's processed aperture by an azimuth window, and normalises so that
a point of amplitude ``a`` focuses to ``a`` (docs/design.md §5.6), white noise of power ``P_n`` per
sample comes out with power

``P_img = P_n * ENBW_r * ENBW_az / (N_s * M)``                  (docs/metrics.md §Noise, eq. N1)

where ``ENBW = <w^2> / <w>^2`` is the window's equivalent noise bandwidth in bins. A distributed
scatterer of reflectivity sigma0 gives the mean pixel power ``sigma0 |h_0|^2 A_eff``, with
``|h_0|`` the focused peak of a unit-RCS point at the pixel and
``A_eff = ENBW_r ENBW_az rho_r rho_a / sin(theta)`` the area under ``|h / h_0|^2`` on the
surface (rho_r = c / 2B, rho_a = lambda / (4 h), theta the incidence angle). Their ratio, the
NESZ, no longer depends on the windows:

``NESZ = P_n / (N_s M |h_0|^2 rho_r rho_a / sin(theta))``        (docs/metrics.md §Noise, eq. N2)
"""

from __future__ import annotations

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.errors import ParameterError
from mitsar.model.radar import Radar

NOISE_STREAM = 0x6E6F697365
"""Second word of the key of the noise generator (``numpy.random.SeedSequence([seed, this])``):
the noise of a run is independent of its other draws (scatterers, background) for the same seed."""

_WORDS_PER_COUNTER = 4
"""64-bit outputs of one Philox-4x64 counter value (Salmon et al. 2011)."""


def check_noise(where: str, radar: Radar, noise: bool, normalized: bool) -> None:
    """Refuse ``noise=True`` without a noise figure or with normalised echoes."""
    if noise and radar.noise_figure_db is None:
        raise ParameterError(where, "noise", "noise=False unless radar.noise_figure_db is set",
                             noise)
    if noise and normalized:
        raise ParameterError(where, "noise", "noise=False with normalized=True (noise is in "
                             "watts, normalised echoes are not)", noise)


def thermal_noise(radar: Radar, seed: int, sweeps: ArrayLike,
                  channel: int = 0) -> NDArray[np.complex128]:
    """Receiver noise of the given sweeps: circular Gaussian samples of power ``k T0 F f_s`` each.

    Real and imaginary parts are independent with variance ``P_n / 2`` each, so that
    ``E|n|^2 = P_n`` [W] (:attr:`Radar.noise_power`, complex sampling: noise bandwidth ``f_s``);
    values in sqrt(W), referred to the antenna port like the echoes.

    The noise of sample n of sweep k is a pure function of ``(seed, k, n)``: a counter-based
    Philox-4x64 generator (Salmon, Moraes, Dror & Shaw 2011, docs/metrics.md §Noise) keyed by
    the seed is started at sweep k's own counter, and Box-Muller turns its uniforms into normals.
    So a whole acquisition, any subset of its sweeps (``simulate_scene(sweeps=...)``) and any
    chunking of it (streamed products, campaigns on N workers) carry the very same noise.

    Parameters
    ----------
    radar : Radar
        With ``noise_figure_db`` set (else the noise is zero).
    seed : int
        The run's seed (0 ... 2**63 - 1).
    sweeps : array_like of int, shape (S,)
        Sweep indices of the acquisition.
    channel : int
        Receive channel (>= 0): each channel's receiver has its own independent noise, a
        stream keyed by ``(seed, channel)``; channel 0 is the single-channel radar's stream.

    Returns
    -------
    ndarray, shape (S, radar.samples_per_sweep), complex
    """
    sweeps = np.asarray(sweeps, dtype=np.int64).ravel()
    samples = radar.samples_per_sweep
    # two uniforms per complex sample; every sweep starts on a counter value of its own
    stride = -(-2 * samples // _WORDS_PER_COUNTER)
    entropy = [int(seed), NOISE_STREAM] + ([int(channel)] if channel else [])
    key = np.random.SeedSequence(entropy).generate_state(2, np.uint64)
    words = np.empty((len(sweeps), stride * _WORDS_PER_COUNTER), dtype=np.uint64)
    breaks = np.flatnonzero(np.diff(sweeps) != 1) + 1
    for run, first in zip(np.split(np.arange(len(sweeps)), breaks),  # contiguous runs (few)
                          np.split(sweeps, breaks), strict=True):
        if len(run):
            counter = np.array([first[0] * stride, 0, 0, 0], dtype=np.uint64)
            words[run] = np.random.Philox(key=key, counter=counter).random_raw(
                len(run) * stride * _WORDS_PER_COUNTER).reshape(len(run), -1)
    uniform = (words[:, : 2 * samples] >> np.uint64(11)).astype(np.float64) * 2.0**-53
    radius = np.sqrt(-2.0 * np.log1p(-uniform[:, 0::2]))      # 1 - u in (0, 1]
    sigma = np.sqrt(radar.noise_power / 2)
    return sigma * radius * np.exp(2j * np.pi * uniform[:, 1::2])


def window_noise_bandwidth(coefficients: ArrayLike) -> float:
    """Equivalent noise bandwidth ``<w^2> / <w>^2`` [bins] of a cosine-series window.

    For ``w(x) = a_0 + sum_m a_m cos(2 pi m (x - 1/2))`` on ``[0, 1]``: ``<w> = a_0`` and
    ``<w^2> = a_0^2 + sum_{m>=1} a_m^2 / 2`` (1 for the rectangular window, 1.36 for Hamming).
    """
    a = np.ravel(np.asarray(coefficients, dtype=float))
    return float((a[0] ** 2 + 0.5 * np.sum(a[1:] ** 2)) / a[0] ** 2)


def focused_noise_power(noise_power: float, samples_per_sweep: int, aperture_sweeps: ArrayLike,
                        range_enbw: float = 1.0, azimuth_enbw: float = 1.0) -> NDArray:
    """Noise power of a focused pixel, eq. N1 of the module docstring [W].

    Parameters
    ----------
    noise_power : float
        Noise power per complex raw sample ``P_n`` [W].
    samples_per_sweep : int
        ``N_s``, the samples summed coherently per sweep.
    aperture_sweeps : array_like
        ``M``, sweeps in each pixel's processed aperture.
    range_enbw, azimuth_enbw : float
        Equivalent noise bandwidths of the range and azimuth windows
        (:func:`window_noise_bandwidth`).
    """
    return (noise_power * range_enbw * azimuth_enbw
            / (samples_per_sweep * np.asarray(aperture_sweeps, dtype=float)))


def noise_equivalent_sigma0(noise_power: float, samples_per_sweep: int,
                            aperture_sweeps: ArrayLike, unit_peak_power: ArrayLike,
                            range_resolution: float, azimuth_resolution: float,
                            sin_incidence: ArrayLike) -> NDArray:
    """NESZ of a focused pixel, eq. N2 of the module docstring [m^2/m^2, linear].

    Parameters
    ----------
    noise_power : float
        ``P_n`` per complex raw sample [W].
    samples_per_sweep : int
        ``N_s``.
    aperture_sweeps : array_like
        ``M`` per pixel.
    unit_peak_power : array_like
        ``|h_0|^2``: focused peak power of a 1 m^2 point at the pixel [W] (radar equation and
        two-way pattern over the aperture, :func:`mitsar.model.signal.radar_equation_amplitude`).
    range_resolution, azimuth_resolution : float
        ``c / 2B`` and ``lambda / (4 h)`` [m].
    sin_incidence : array_like
        Sine of the incidence angle on the surface (projects the slant-range cell on it).
    """
    cell = range_resolution * azimuth_resolution / np.asarray(sin_incidence, dtype=float)
    return noise_power / (samples_per_sweep * np.asarray(aperture_sweeps, dtype=float)
                          * np.asarray(unit_peak_power, dtype=float) * cell)
