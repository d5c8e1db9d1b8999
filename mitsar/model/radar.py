"""FMCW radar parameters (paper Table 1), derived values and their validation.

Conventions (``docs/conventions.md``): SI units, sweep duration ``T = 1/PRF`` (duty cycle 1),
chirp rate ``K = B/T``, fast time centred on the sweep.
"""

from __future__ import annotations

import dataclasses
import json
import math
from dataclasses import dataclass, field
from typing import TYPE_CHECKING, Any

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.checks import KnownFields, check_units, finite, is_real, positive
from mitsar.errors import ParameterError
from mitsar.model.arrays import UniformArray
from mitsar.model.elements import (
    MAX_OFFSET,
    Element,
    ElementBeam,
    element_beam,
    two_way_boresight,
)

if TYPE_CHECKING:
    from mitsar.model.geometry.attitude import Look

SPEED_OF_LIGHT = 299_792_458.0
"""Speed of light in vacuum [m/s]."""

BOLTZMANN = 1.380_649e-23
"""Boltzmann constant [J/K]."""

REFERENCE_TEMPERATURE = 290.0
"""Reference noise temperature T0 [K] of the noise figure."""


MAX_CHANNELS = 64
"""Most channels of one radar (receivers, times the transmitters under TDM-MIMO)."""

MAX_PHASE_CENTRE_OFFSET = MAX_OFFSET
"""Largest body-frame offset of a phase centre [m] (an antenna a drone can carry;
:data:`mitsar.model.elements.MAX_OFFSET`)."""

MAX_SAMPLES_PER_SWEEP = 10**6
"""Largest number of fast-time samples per sweep (16 MB of complex samples)."""

_UPPER_BOUNDS = (
    ("transmit_power", 1e3, "W", "a drone's radar; 1e300 W overflows the radar equation"),
    ("antenna_width", 10.0, "m", "an antenna a drone can carry"),
    ("antenna_length", 10.0, "m", "an antenna a drone can carry"),
    ("carrier_frequency", 1e13, "Hz", "radio frequencies up to 10 THz"),
)
"""Physical upper bounds on parameters that are otherwise only required to be positive."""


@dataclass(frozen=True)
class Radar(metaclass=KnownFields):
    """An FMCW SAR sensor: waveform, sampling and antenna (paper Table 1 defaults).

    Parameters
    ----------
    carrier_frequency : float
        Centre frequency f_c of the sweep [Hz].
    bandwidth : float
        Swept bandwidth B [Hz].
    sampling_frequency : float
        Complex (I/Q) sampling rate f_s of the dechirped signal [Hz].
    prf : float
        Sweep repetition frequency [Hz]; the sweep lasts ``T = 1/prf`` (duty cycle 1).
    max_range : float
        Largest range the receiver must hold [m]; its beat frequency ``2 K R / c`` must not
        exceed the Nyquist limit ``f_s / 2`` of complex sampling centred on zero.
    antenna_width : float
        Antenna aperture size in elevation d [m].
    antenna_length : float
        Antenna aperture size in azimuth l_AZ [m].
    transmit_power : float
        Transmitted power P_T [W].
    noise_figure_db : float or None
        Receiver noise figure [dB]; ``None`` means a noiseless receiver.
    azimuth_beamwidth_deg, elevation_beamwidth_deg : float or None
        Beamwidths [deg]; by default ``lambda / l_AZ`` and ``lambda / d`` (paper Table 1:
        9 deg and 18 deg).
    receivers : sequence of 3-vectors, dicts or Elements, or None
        Receive phase centres in the body frame [m] (x forward, y left, z up at zero
        attitude; :func:`mitsar.model.geometry.attitude.body_to_world`), one receive channel
        each; ``None``: one monostatic channel at the origin (the products then have no
        ``channel`` dimension). docs/interferometry.md. An item is a position, an
        :class:`~mitsar.model.elements.Element` or a dict of its fields
        (``{"position": ..., "elevation_beamwidth_deg": ..., "off_nadir_deg": ...}``): an
        element with its own pattern and boresight. The field then holds the positions
        (3-tuples) and :attr:`receiver_elements` the elements.
    transmitters : sequence of 3-vectors, dicts or Elements, or None
        Transmit phase centres in the body frame [m] (items as ``receivers``); ``None``: one
        at the origin. With one transmitter every receiver listens to it (single-pass
        interferometer); with ``ping_pong`` each receiver's own element transmits. Several
        transmitters take turns sweep by sweep (TDM-MIMO: :attr:`is_tdm`), giving
        N_tx x N_rx channels.
    ping_pong : bool
        Each channel transmits and receives on its own phase centre (the interferometric
        phase doubles: docs/interferometry.md).

    Examples
    --------
    >>> radar = Radar()
    >>> round(radar.range_resolution, 4), radar.samples_per_sweep
    (0.0999, 660)
    """

    carrier_frequency: float = 94e9
    bandwidth: float = 1.5e9
    sampling_frequency: float = 165e3
    prf: float = 250.0
    max_range: float = 30.0
    antenna_width: float = 0.01
    antenna_length: float = 0.02
    transmit_power: float = 1e-3
    noise_figure_db: float | None = None
    azimuth_beamwidth_deg: float | None = None
    elevation_beamwidth_deg: float | None = None
    receivers: tuple[tuple[float, float, float], ...] | None = None
    transmitters: tuple[tuple[float, float, float], ...] | None = None
    ping_pong: bool = False
    receiver_elements: tuple[Element, ...] | None = field(default=None, init=False,
                                                          repr=False)
    """The receive elements (position, own pattern and boresight), or None."""
    transmitter_elements: tuple[Element, ...] | None = field(default=None, init=False,
                                                             repr=False)
    """The transmit elements, or None."""

    def __post_init__(self) -> None:
        self._check_phase_centres()
        positive_fields = (
            "carrier_frequency", "bandwidth", "sampling_frequency", "prf", "max_range",
            "antenna_width", "antenna_length", "transmit_power",
        )
        for name in positive_fields:
            object.__setattr__(self, name, positive("Radar", name, getattr(self, name)))
        for name in ("azimuth_beamwidth_deg", "elevation_beamwidth_deg"):
            value = getattr(self, name)
            if value is not None and not (is_real(value) and 0 < value < 180):
                raise ParameterError("Radar", name, "None or a beamwidth in (0, 180) deg", value)
        if self.noise_figure_db is not None:
            finite("Radar", "noise_figure_db", self.noise_figure_db, "None or a finite dB value")
            check_units("Radar", self, {"noise_figure_db": "dB"})  # as [radar] (issue 27)
        for name, limit, unit, why in _UPPER_BOUNDS:
            if getattr(self, name) > limit:
                raise ParameterError("Radar", name, f"<= {limit:g} {unit} ({why})",
                                     getattr(self, name))
        if self.bandwidth >= self.carrier_frequency:
            raise ParameterError("Radar", "bandwidth", f"< carrier_frequency "
                                 f"({self.carrier_frequency:g} Hz)", self.bandwidth)
        if self.samples_per_sweep > MAX_SAMPLES_PER_SWEEP:
            raise ParameterError("Radar", "sampling_frequency",
                                 f"<= {MAX_SAMPLES_PER_SWEEP * self.prf:g} Hz at PRF "
                                 f"{self.prf:g} Hz (at most {MAX_SAMPLES_PER_SWEEP} samples per "
                                 "sweep: one sweep of raw data must fit in memory)",
                                 self.sampling_frequency)
        if self.samples_per_sweep < 8:
            raise ParameterError("Radar", "sampling_frequency",
                                 f">= 8 * prf = {8 * self.prf:g} Hz (at least 8 samples per sweep)",
                                 self.sampling_frequency)
        if self.max_beat_frequency > self.sampling_frequency / 2:
            limit = self.range_for_beat_frequency(self.sampling_frequency / 2)
            raise ParameterError(
                "Radar", "max_range",
                f"<= {limit:.3f} m: its beat frequency 2*K*R/c must stay below the Nyquist "
                f"limit fs/2 = {self.sampling_frequency / 2:g} Hz (beat frequency at max_range "
                f"is {self.max_beat_frequency:g} Hz); raise sampling_frequency or lower "
                "max_range", self.max_range)

    def _check_phase_centres(self) -> None:
        """Normalise ``receivers``/``transmitters`` to tuples of float 3-tuples (and their
        :class:`Element` records to ``*_elements``), or refuse."""
        for name in ("receivers", "transmitters"):
            value = getattr(self, name)
            if value is None:
                continue
            expected = (f"None or a non-empty list of body-frame 3-vectors [m] with |x| <= "
                        f"{MAX_PHASE_CENTRE_OFFSET:g} m (or Elements / dicts with a "
                        "'position'), e.g. [(0, 0, 0), (0, 0, 0.05)]")
            if isinstance(value, str | bytes | dict | Element):
                raise ParameterError("Radar", name, expected, value)
            try:
                items = list(value)
            except TypeError:
                raise ParameterError("Radar", name, expected, value) from None
            if not items:
                raise ParameterError("Radar", name, expected, value)
            if len(items) > MAX_CHANNELS:
                raise ParameterError("Radar", name, f"at most {MAX_CHANNELS} phase centres",
                                     len(items))
            elements = tuple(Element.of(item, f"{name}[{i}]") for i, item in enumerate(items))
            object.__setattr__(self, name, tuple(e.position for e in elements))
            object.__setattr__(self, f"{name[:-1]}_elements", elements)
        if not isinstance(self.ping_pong, bool):
            raise ParameterError("Radar", "ping_pong", "true or false", self.ping_pong)
        if self.ping_pong and self.transmitters is not None:
            raise ParameterError("Radar", "transmitters", "None with ping_pong (each receiver "
                                 "transmits on its own phase centre)", self.transmitters)
        if self.channel_count > MAX_CHANNELS:
            raise ParameterError("Radar", "transmitters", f"at most {MAX_CHANNELS} channels "
                                 f"(transmitters x receivers, TDM-MIMO): {len(self.transmitters)}"
                                 f" x {len(self.receivers or ((0, 0, 0),))} = "
                                 f"{self.channel_count}", len(self.transmitters))

    @classmethod
    def array(cls, array: UniformArray | dict[str, Any], **fields: Any) -> Radar:
        """A radar whose phase centres are a uniform array (``[radar.array]``).

        ``array`` (a :class:`~mitsar.model.arrays.UniformArray` or a dict of its fields)
        expands to the :class:`~mitsar.model.elements.Element` records of ``receivers`` and
        ``transmitters`` at this radar's wavelength; ``fields`` are the other
        :class:`Radar` fields (not ``receivers``/``transmitters``: one form or the other).
        Errors of the array name ``array.<field>``.

        Examples
        --------
        >>> radar = Radar.array({"receivers": 4, "transmitters": 3})   # TI-style 3 TX x 4 RX
        >>> radar.channel_count, round(radar.receivers[1][2] / radar.wavelength, 6)
        (12, 0.5)
        """
        for name in ("receivers", "transmitters"):
            if name in fields:
                raise ParameterError("Radar", name, "None with array= (give the phase centres "
                                     "as a uniform array or as a list, not both)", fields[name])
        radar = cls(**fields)
        try:
            transmitters, receivers = UniformArray.of(array).elements(radar.wavelength)
        except ParameterError as error:
            name = error.name if error.name == "array" else f"array.{error.name}"
            raise ParameterError("Radar", name, error.expected, error.found) from None
        try:
            return dataclasses.replace(radar, receivers=receivers, transmitters=transmitters)
        except ParameterError as error:  # the channel count, ping_pong with transmitters
            if error.name.split("[")[0].split(".")[0] not in ("receivers", "transmitters"):
                raise
            raise ParameterError("Radar", f"array.{error.name}", error.expected,
                                 error.found) from None

    # --- channels ---------------------------------------------------------------------------
    @property
    def has_channels(self) -> bool:
        """Whether the radar declares its phase centres (products get a ``channel`` dim)."""
        return self.receivers is not None or self.transmitters is not None or self.ping_pong

    @property
    def transmitter_count(self) -> int:
        """Number of transmitters N_tx taking turns (TDM-MIMO when > 1; ping-pong: 1)."""
        return 1 if self.transmitters is None else len(self.transmitters)

    @property
    def is_tdm(self) -> bool:
        """Whether several transmitters take turns sweep by sweep (TDM-MIMO).

        Sweep k is transmitted by transmitter ``k mod N_tx`` (TI's chirp-by-chirp TDM: each
        chirp a full sweep of duration 1/PRF) while every receiver listens; channel
        ``c = i N_rx + j`` is the pair (transmitter i, receiver j) and has samples only in the
        sweeps of its slot i (docs/interferometry.md §8, "TDM-MIMO").
        """
        return self.transmitter_count > 1

    @property
    def channel_count(self) -> int:
        """Number of channels: receivers, times the transmitters under TDM-MIMO."""
        receivers = 1 if self.receivers is None else len(self.receivers)
        return self.transmitter_count * receivers

    def channel_pairs(self) -> tuple[tuple[int, int], ...]:
        """(transmitter, receiver) indices of each channel; channel ``c = i N_rx + j``.

        Without TDM-MIMO the transmitter index is 0 (with ``ping_pong`` each channel's own
        phase centre transmits; its index is still reported as 0: one time slot).
        """
        receivers = 1 if self.receivers is None else len(self.receivers)
        return tuple((i, j) for i in range(self.transmitter_count) for j in range(receivers))

    def firing(self, sweeps: ArrayLike) -> NDArray[np.bool_]:
        """Whether each channel has samples in each sweep, shape (channels, sweeps).

        ``sweeps``: acquisition sweep indices k (counted from the pass's first sweep). Under
        TDM-MIMO channel (i, j) fires in the sweeps ``k mod N_tx == i``; otherwise in all.
        """
        sweeps = np.asarray(sweeps, dtype=np.int64)
        slots = np.array([i for i, _ in self.channel_pairs()], dtype=np.int64)
        return sweeps[None, :] % self.transmitter_count == slots[:, None]

    def channel_offsets(self) -> tuple[tuple[tuple[float, float, float], ...],
                                       tuple[tuple[float, float, float], ...]]:
        """Body-frame (transmitter, receiver) phase centre of each channel [m].

        Returns
        -------
        transmitters, receivers : tuple of 3-tuples, one per channel
            Under TDM-MIMO channel ``c = i N_rx + j`` is (t_i, r_j) (:meth:`channel_pairs`).
        """
        receivers = self.receivers or ((0.0, 0.0, 0.0),)
        if self.ping_pong:
            return receivers, receivers
        transmitters = self.transmitters or ((0.0, 0.0, 0.0),)
        pairs = self.channel_pairs()
        return (tuple(transmitters[i] for i, _ in pairs),
                tuple(receivers[j] for _, j in pairs))

    def channel_elements(self) -> tuple[tuple[Element, ...], tuple[Element, ...]]:
        """(transmit, receive) :class:`~mitsar.model.elements.Element` of each channel, as
        :meth:`channel_offsets` (ping-pong: the receiver's element transmits too; a radar
        without declared phase centres: the radar's own antenna at the origin)."""
        origin = (Element(),)
        receivers = self.receiver_elements or origin
        if self.ping_pong:
            return receivers, receivers
        transmitters = self.transmitter_elements or origin
        pairs = self.channel_pairs()
        return (tuple(transmitters[i] for i, _ in pairs),
                tuple(receivers[j] for _, j in pairs))

    @property
    def has_element_beams(self) -> bool:
        """Whether some element declares its own pattern or boresight (docs/interferometry.md
        §8); otherwise every phase centre uses the radar's antenna and the look's boresight."""
        return any(e.has_own_beam for e in (self.receiver_elements or ())
                   + (self.transmitter_elements or ()))

    def channel_beams(self, look: Look, frame: NDArray[np.float64] | None = None
                      ) -> tuple[tuple[ElementBeam, ElementBeam], ...]:
        """(transmit, receive) :class:`~mitsar.model.elements.ElementBeam` of each channel
        with the antenna mounted by ``look``: what the kernels need for
        :func:`mitsar.model.elements.channel_amplitude_factor` (``frame``: the antenna frame
        the direction sines are taken in, default the look's; :func:`element_beam`)."""
        transmitters, receivers = self.channel_elements()
        widths = (self.azimuth_beamwidth, self.elevation_beamwidth)
        return tuple((element_beam(t, widths, look, frame), element_beam(r, widths, look, frame))
                     for t, r in zip(transmitters, receivers, strict=True))

    def channel_boresights(self, look: Look) -> NDArray[np.float64]:
        """Centre of each channel's two-way beam (transmit element x receive element), body
        frame, shape (channels, 3): :func:`mitsar.model.elements.two_way_boresight`; the
        look's boresight for channels whose elements are the radar's antenna."""
        transmitters, receivers = self.channel_elements()
        widths = (self.azimuth_beamwidth, self.elevation_beamwidth)
        return np.array([two_way_boresight(t, r, widths, look)
                         for t, r in zip(transmitters, receivers, strict=True)])

    def virtual_phase_centres(self) -> NDArray[np.float64]:
        """Far-field virtual array element of each channel, ``t_i + r_j`` (body frame) [m].

        Far from the antenna (``R >> |t|, |r|``) the two-way path of the pair is
        ``|t - q| + |q - r| ~ 2 R - u.(t + r)`` (u: unit vector from the body origin to the
        target q at range R), the path of a one-way array element at ``t + r`` (MIMO virtual
        array; the equivalent monostatic phase centre is ``(t + r) / 2``). Not valid in the
        near field: the neglected term is ``(|t_perp|^2 + |r_perp|^2) / (2 R)`` of path
        (perp: the parts across u), ``pi (|t_perp|^2 + |r_perp|^2) / (lambda R)`` of phase
        (docs/interferometry.md §8). Only for figures and far-field reasoning; the simulators
        and the focusers use the exact pair. Source: ../shared/reference/interferometry-notes.md
        §3.

        Returns
        -------
        ndarray, shape (channels, 3)
        """
        transmitters, receivers = self.channel_offsets()
        return np.asarray(transmitters, dtype=float) + np.asarray(receivers, dtype=float)

    # --- derived values -------------------------------------------------------------------
    @property
    def wavelength(self) -> float:
        """Carrier wavelength lambda = c / f_c [m]."""
        return SPEED_OF_LIGHT / self.carrier_frequency

    @property
    def sweep_duration(self) -> float:
        """Sweep duration T = 1/PRF [s] (duty cycle 1)."""
        return 1.0 / self.prf

    @property
    def chirp_rate(self) -> float:
        """Chirp rate K = B/T [Hz/s]."""
        return self.bandwidth / self.sweep_duration

    @property
    def samples_per_sweep(self) -> int:
        """Number of fast-time samples per sweep N_s = round(f_s T)."""
        return int(round(self.sampling_frequency * self.sweep_duration))

    @property
    def range_resolution(self) -> float:
        """Slant-range resolution c / (2B) [m]."""
        return SPEED_OF_LIGHT / (2.0 * self.bandwidth)

    @property
    def max_beat_frequency(self) -> float:
        """Beat frequency of a static target at ``max_range``: 2 K R_max / c [Hz]."""
        return self.beat_frequency(self.max_range)

    @property
    def azimuth_beamwidth(self) -> float:
        """Azimuth beamwidth [rad]: given, or lambda / l_AZ (paper Table 1)."""
        if self.azimuth_beamwidth_deg is not None:
            return math.radians(self.azimuth_beamwidth_deg)
        return self.wavelength / self.antenna_length

    @property
    def elevation_beamwidth(self) -> float:
        """Elevation beamwidth [rad]: given, or lambda / d (paper Table 1)."""
        if self.elevation_beamwidth_deg is not None:
            return math.radians(self.elevation_beamwidth_deg)
        return self.wavelength / self.antenna_width

    @property
    def antenna_gain(self) -> float:
        """Boresight gain of a uniform aperture, G = 4 pi A / lambda^2 (unit efficiency).

        When beamwidths are given explicitly the effective aperture follows from them,
        ``A = lambda^2 / (theta_AZ theta_EL)``, so that pattern and gain stay consistent.
        """
        area = (self.wavelength / self.azimuth_beamwidth) * (self.wavelength /
                                                             self.elevation_beamwidth)
        return 4.0 * math.pi * area / self.wavelength**2

    @property
    def noise_power(self) -> float:
        """Complex noise power per sample k T0 F f_s [W]; zero without a noise figure."""
        if self.noise_figure_db is None:
            return 0.0
        return (BOLTZMANN * REFERENCE_TEMPERATURE * 10 ** (self.noise_figure_db / 10)
                * self.sampling_frequency)

    def beat_frequency(self, slant_range: float) -> float:
        """Beat frequency 2 K R / c of a static target at ``slant_range`` [Hz] (paper eq. 1)."""
        return 2.0 * self.chirp_rate * slant_range / SPEED_OF_LIGHT

    def range_for_beat_frequency(self, beat_frequency: float) -> float:
        """Slant range c f / (2K) that a beat frequency ``f`` [Hz] maps to [m]."""
        return SPEED_OF_LIGHT * beat_frequency / (2.0 * self.chirp_rate)

    def doppler_bandwidth(self, speed: float) -> float:
        """Doppler bandwidth of the azimuth beam at platform ``speed`` [Hz].

        ``B_D = 4 v sin(theta_AZ / 2) / lambda``: the span of ``2 v sin(phi) / lambda``
        over the beam ``|phi| <= theta_AZ / 2``.
        """
        return 4.0 * speed * math.sin(self.azimuth_beamwidth / 2) / self.wavelength

    def check_prf(self, speed: float) -> None:
        """Refuse a PRF below the Doppler bandwidth of the beam at ``speed`` m/s.

        The beam is Table 1's beamwidth lambda / l_AZ (the one-way -3.9 dB width of the sinc^2
        pattern); its sidelobe and beam-edge energy beyond it still aliases weakly.
        Focusing refuses, separately, a *processed* band wider than the PRF. Under TDM-MIMO
        (:attr:`is_tdm`) each channel is sampled at ``prf / N_tx``, and that rate must hold the
        band.
        """
        speed = finite("Radar.check_prf", "speed", speed, "a finite platform speed >= 0 m/s")
        if speed < 0:
            raise ParameterError("Radar.check_prf", "speed", "a finite platform speed >= 0 m/s",
                                 speed)
        band = self.doppler_bandwidth(speed)
        if self.is_tdm:  # each channel is sampled once per N_tx sweeps
            rate = self.prf / self.transmitter_count
            if not rate >= band:
                raise ParameterError(
                    "Radar", "prf",
                    f"prf / N_tx >= the azimuth Doppler bandwidth 4 v sin(theta_AZ/2)/lambda = "
                    f"{band:.1f} Hz at platform speed {speed:g} m/s: with {self.transmitter_count}"
                    f" transmitters in turn (TDM-MIMO) each channel is sampled at prf / "
                    f"{self.transmitter_count} = {rate:.1f} Hz (else azimuth aliases); raise "
                    f"the PRF to >= {band * self.transmitter_count:.1f} Hz, lower the speed to "
                    f"<= {speed * rate / band:.3g} m/s or use fewer transmitters", self.prf)
            return
        if not self.prf >= band:
            raise ParameterError(
                "Radar", "prf",
                f">= the azimuth Doppler bandwidth 4 v sin(theta_AZ/2)/lambda = {band:.1f} Hz "
                f"at platform speed {speed:g} m/s (else azimuth aliases); lower the speed to "
                f"<= {speed * self.prf / band:.3g} m/s or raise the PRF", self.prf)

    # --- serialisation --------------------------------------------------------------------
    def to_attrs(self) -> dict[str, Any]:
        """Parameters as a flat dict of ``radar_<name>`` attributes (None and a false
        ``ping_pong`` dropped; phase centres as flat lists of 3k floats, ``ping_pong`` as 1;
        elements with their own beam as ``radar_receiver_elements`` /
        ``radar_transmitter_elements``, JSON lists of :meth:`Element.to_dict`, only then)."""
        attrs: dict[str, Any] = {}
        for f in dataclasses.fields(self):
            value = getattr(self, f.name)
            if value is None or value is False:
                continue
            if f.name in _ELEMENTS:
                if any(e.has_own_beam for e in value):
                    attrs[f"radar_{f.name}"] = json.dumps([e.to_dict() for e in value])
                continue
            if f.name in _PHASE_CENTRES:
                value = [float(v) for row in value for v in row]
            attrs[f"radar_{f.name}"] = int(value) if value is True else value
        return attrs

    @classmethod
    def from_attrs(cls, attrs: dict[str, Any]) -> Radar:
        """Inverse of :meth:`to_attrs` (extra attributes are ignored)."""
        kwargs: dict[str, Any] = {}
        for f in dataclasses.fields(cls):
            key = f"radar_{f.name}"
            if key not in attrs or not f.init:
                continue
            if f.name in _PHASE_CENTRES:
                elements = attrs.get(f"radar_{f.name[:-1]}_elements")
                if elements is not None:
                    kwargs[f.name] = json.loads(str(elements))
                    continue
                flat = [float(v) for v in np.ravel(attrs[key])]
                kwargs[f.name] = tuple(tuple(flat[i:i + 3]) for i in range(0, len(flat), 3))
            elif f.name == "ping_pong":
                kwargs[f.name] = bool(int(attrs[key]))
            else:
                kwargs[f.name] = float(attrs[key])
        return cls(**kwargs)


_PHASE_CENTRES = ("receivers", "transmitters")
_ELEMENTS = ("receiver_elements", "transmitter_elements")

