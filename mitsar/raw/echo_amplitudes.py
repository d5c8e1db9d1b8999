"""Echo amplitudes of the analytic simulator (paper eq. 2): one complex amplitude per scatterer
and sweep, per channel.

sqrt(RCS) reflectivity times the two-way antenna pattern and the radar equation at mid-sweep;
a channel whose elements have a pattern or boresight of their own
(:class:`mitsar.model.elements.Element`) weights by each element's field pattern instead
(:func:`mitsar.model.elements.channel_amplitude_factor`). :mod:`mitsar.raw.analytic` calls
:func:`channel_amplitudes` once per chunk of sweeps.
"""

from __future__ import annotations

import numpy as np
from numpy.typing import NDArray

from mitsar.model.elements import ElementBeam, channel_amplitude_factor
from mitsar.model.geometry.antenna import direction_sines, two_way_pattern
from mitsar.model.geometry.attitude import Look, antenna_frame
from mitsar.model.geometry.sweeps import SweepGeometry
from mitsar.model.radar import Radar
from mitsar.model.signal import radar_equation_amplitude
from mitsar.raw.echo_sums import channel_offsets


def echo_amplitudes(radar: Radar, look: Look, geometry: SweepGeometry, positions: NDArray,
                    velocities: NDArray, reflectivity: NDArray, *, normalized: bool,
                    pattern: bool) -> NDArray[np.complex128]:
    """Complex amplitude of every scatterer in every sweep, shape (sweeps, scatterers).

    sqrt(RCS) reflectivity, times the two-way pattern and the radar equation (per unit RCS) at
    mid-sweep (paper eq. 2).
    """
    offset = positions[None, :, :] + velocities[None, :, :] * (
        geometry.slow_time[:, None, None] + radar.sweep_duration / 2) \
        - geometry.position[:, None, :]
    centre_range = np.linalg.norm(offset, axis=-1)
    amplitude = reflectivity.astype(complex)
    if pattern:
        frames = antenna_frame(look, *geometry.attitude.T)
        directions = offset / centre_range[..., None]
        amplitude = amplitude * np.sqrt(two_way_pattern(
            directions, frames[:, None], radar.azimuth_beamwidth, radar.elevation_beamwidth))
    if not normalized:
        amplitude = amplitude * radar_equation_amplitude(radar, 1.0, centre_range)
    return amplitude


def channel_amplitudes(radar: Radar, look: Look, geometry: SweepGeometry, positions: NDArray,
                       velocities: NDArray, reflectivity: NDArray, *, normalized: bool,
                       pattern: bool) -> list[NDArray[np.complex128]]:
    """Complex amplitude of every scatterer in every sweep for each channel, shape
    (sweeps, scatterers) each.

    A channel whose two elements are the radar's antenna (no pattern or boresight of their
    own, :class:`mitsar.model.elements.Element`) shares :func:`echo_amplitudes` (bit for bit
    the single-antenna amplitudes). Any other channel (transmitter i, receiver j) gets
    ``sqrt(RCS) f_i(d) f_j(d) sqrt(P_T G_i G_j lambda^2 / ((4 pi)^3 R^4))``, each element's
    field pattern in its own frame (:func:`mitsar.model.elements.channel_amplitude_factor`),
    the direction ``d`` and range ``R`` from the track point at mid-sweep as for the radar's
    antenna (a centimetre offset turns the direction by ~1e-3 of a beamwidth at 8 m).
    """
    shared = echo_amplitudes(radar, look, geometry, positions, velocities, reflectivity,
                             normalized=normalized, pattern=pattern)
    channels = len(channel_offsets(radar))
    if not radar.has_element_beams:
        return [shared] * channels
    beams = radar.channel_beams(look)
    own = [not (is_radar_beam(t, radar) and is_radar_beam(r, radar)) for t, r in beams]
    offset = positions[None, :, :] + velocities[None, :, :] * (
        geometry.slow_time[:, None, None] + radar.sweep_duration / 2) \
        - geometry.position[:, None, :]
    centre_range = np.linalg.norm(offset, axis=-1)
    sines = direction_sines(offset / centre_range[..., None],
                            antenna_frame(look, *geometry.attitude.T)[:, None])
    scale = (reflectivity.astype(complex) if normalized else reflectivity.astype(complex)
             * radar_equation_amplitude(radar, 1.0, centre_range))
    out = []
    for (transmit, receive), different in zip(beams, own, strict=True):
        if not different:
            out.append(shared)
            continue
        gain = None if normalized else radar.antenna_gain
        if pattern:
            factor = channel_amplitude_factor(*sines, transmit, receive, gain)
        else:  # no pattern: the boresight gains only
            factor = 1.0 if gain is None else np.sqrt(transmit.gain * receive.gain) / gain
        out.append(scale * factor)
    return out


def is_radar_beam(beam: ElementBeam, radar: Radar) -> bool:
    """Whether an element's beam is the radar's antenna along the look's boresight."""
    return (beam.identity and beam.beamwidth_az == radar.azimuth_beamwidth
            and beam.beamwidth_el == radar.elevation_beamwidth)
