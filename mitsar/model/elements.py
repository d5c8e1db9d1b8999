"""Antenna elements: a phase centre with its own pattern and boresight (docs/interferometry.md §8).

A multi-channel :class:`~mitsar.model.radar.Radar` declares its transmit and receive phase
centres as :class:`Element` records. An element without a beam of its own uses the radar's
antenna: its beamwidths (:attr:`Radar.azimuth_beamwidth`, :attr:`Radar.elevation_beamwidth`)
and the boresight of the experiment's :class:`~mitsar.model.geometry.attitude.Look`. An element
may instead carry

* its own beamwidths (``azimuth_beamwidth_deg``, ``elevation_beamwidth_deg``): the uniform
  rectangular aperture of :mod:`mitsar.model.geometry.antenna` (sinc field pattern per axis,
  Balanis), with boresight gain ``G = 4 pi / (beta_az beta_el)`` (:attr:`Radar.antenna_gain`'s
  formula);
* its own boresight in the body frame, either as angles (``off_nadir_deg``, ``squint_deg``:
  the :class:`Look` convention, ``Rz(squint) (0, sin theta, -cos theta)``) or as a body-frame
  unit vector ``boresight`` (x forward, y left, z up). The element's antenna frame is then the
  :class:`Look`'s for angles, and for a vector ``b`` the azimuth axis ``b x z / |b x z|`` (the
  body's forward axis for a nadir-looking ``b``) and the elevation axis ``b x azimuth``, which
  is the :class:`Look`'s frame for every ``b`` a :class:`Look` can express.

The two-way amplitude of channel (transmitter i, receiver j) towards a direction ``d`` is

``a = sqrt(P_T G_i G_j lambda^2 sigma / ((4 pi)^3 R^4)) f_i(d) f_j(d)``,

``f`` the one-way field pattern in each element's own frame (zero behind it): the radar
equation (paper eq. 2, docs/design.md §4) with ``G^2 P^2`` replaced by the two elements' gains
and patterns. With both elements the radar's it is today's ``G f^2``.

:func:`element_field_pattern` and :func:`channel_amplitude_factor` are generic over the array
library (the ``ops`` pattern, :mod:`mitsar.model.ops`): they take the direction sines in the
*radar's* antenna frame, which the ray tracer's kernels already compute, and the element's
constant rotation from that frame (:func:`element_beam`), so a kernel serves every element
with three multiply-adds per axis.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any, NamedTuple

import numpy as np
from numpy.typing import NDArray

from mitsar.checks import KnownFields, is_real
from mitsar.errors import ParameterError
from mitsar.model.geometry.attitude import Look
from mitsar.model.ops import NUMPY_OPS

__all__ = ["Element", "ElementBeam", "channel_amplitude_factor", "element_beam",
           "element_field_pattern", "element_frame", "two_way_boresight"]

MAX_OFFSET = 10.0
"""Largest body-frame offset of a phase centre [m] (an antenna a drone can carry)."""

BEAM_FIELDS = ("azimuth_beamwidth_deg", "elevation_beamwidth_deg", "off_nadir_deg",
               "squint_deg", "boresight")
"""The fields of an :class:`Element` that give it a beam of its own."""


@dataclass(frozen=True)
class Element(metaclass=KnownFields):
    """One transmit or receive phase centre and, optionally, its own pattern and boresight.

    Parameters
    ----------
    position : 3-vector
        Phase centre in the body frame [m] (x forward, y left, z up at zero attitude), relative
        to the track point; ``|x| <= 10 m`` per axis.
    azimuth_beamwidth_deg, elevation_beamwidth_deg : float or None
        The element's beamwidths ``lambda / D`` [deg] in (0, 180) (first null of its sinc
        pattern); ``None``: the radar's.
    off_nadir_deg, squint_deg : float or None
        The element's boresight as :class:`~mitsar.model.geometry.attitude.Look` angles in the
        body frame [deg] (off nadir in [0, 180), squint in (-90, 90), squint 0 by default);
        ``None``: the look's (or ``boresight``).
    boresight : 3-vector or None
        The element's boresight as a body-frame vector (normalised here); not with the angles.

    Examples
    --------
    >>> Element((0, 0, 0.05), off_nadir_deg=40.0).has_own_beam
    True
    >>> Element((0, 0, 0.05)).has_own_beam
    False
    """

    position: tuple[float, float, float] = (0.0, 0.0, 0.0)
    azimuth_beamwidth_deg: float | None = None
    elevation_beamwidth_deg: float | None = None
    off_nadir_deg: float | None = None
    squint_deg: float | None = None
    boresight: tuple[float, float, float] | None = None

    def __post_init__(self) -> None:
        position = body_vector("Element", "position", self.position,
                               f"a body-frame 3-vector [m] with |x| <= {MAX_OFFSET:g} m per axis")
        if any(abs(v) > MAX_OFFSET for v in position):
            raise ParameterError("Element", "position", f"|x| <= {MAX_OFFSET:g} m per axis (an "
                                 "antenna a drone can carry)", self.position)
        object.__setattr__(self, "position", position)
        for name in ("azimuth_beamwidth_deg", "elevation_beamwidth_deg"):
            value = getattr(self, name)
            if value is not None and not (is_real(value) and 0 < value < 180):
                raise ParameterError("Element", name, "None (the radar's) or a beamwidth in "
                                     "(0, 180) deg", value)
            if value is not None:
                object.__setattr__(self, name, float(value))
        if self.squint_deg is not None and self.off_nadir_deg is None:
            raise ParameterError("Element", "off_nadir_deg", "an off-nadir angle [deg] with "
                                 "squint_deg (the element's boresight is both angles, in the "
                                 "body frame as a Look)", None)
        if self.off_nadir_deg is not None:
            if self.boresight is not None:
                raise ParameterError("Element", "boresight", "None with off_nadir_deg (give "
                                     "the boresight as angles or as a vector, not both)",
                                     self.boresight)
            try:  # Look's checks: off nadir in [0, 180), squint in (-90, 90)
                look = Look(self.off_nadir_deg, 0.0 if self.squint_deg is None
                            else self.squint_deg)
            except ParameterError as error:
                raise ParameterError("Element", error.name, error.expected,
                                     error.found) from None
            object.__setattr__(self, "off_nadir_deg", float(look.off_nadir_deg))
            object.__setattr__(self, "squint_deg", float(look.squint_deg))
        if self.boresight is not None:
            vector = np.asarray(body_vector("Element", "boresight", self.boresight,
                                            "a non-zero body-frame 3-vector"))
            norm = float(np.linalg.norm(vector))
            if not norm > 0:
                raise ParameterError("Element", "boresight", "a non-zero body-frame 3-vector",
                                     self.boresight)
            object.__setattr__(self, "boresight", tuple(float(v) for v in vector / norm))

    @classmethod
    def of(cls, value: Any, where: str) -> Element:
        """An :class:`Element` from an Element, a dict of its fields or a 3-vector position.

        ``where`` names the parameter in the error (e.g. ``"receivers[1]"``).
        """
        if isinstance(value, Element):
            return value
        try:
            if isinstance(value, dict):
                return cls(**value)
            return cls(position=value)
        except ParameterError as error:
            raise ParameterError("Radar", f"{where}.{error.name}", error.expected,
                                 error.found) from None

    @property
    def has_own_beam(self) -> bool:
        """Whether the element gives its own beamwidths or boresight."""
        return any(getattr(self, name) is not None for name in BEAM_FIELDS)

    def to_dict(self) -> dict[str, Any]:
        """The fields that are set, as plain lists and floats (JSON, TOML)."""
        out: dict[str, Any] = {"position": list(self.position)}
        for name in BEAM_FIELDS:
            value = getattr(self, name)
            if value is not None:
                out[name] = list(value) if isinstance(value, tuple) else value
        return out


def body_vector(where: str, name: str, value: Any, expected: str
                ) -> tuple[float, float, float]:
    """``value`` as a 3-tuple of finite floats (a body-frame vector), or a
    :class:`~mitsar.errors.ParameterError` of ``where`` naming ``name``."""
    try:
        row = tuple(float(v) for v in value)
    except (TypeError, ValueError):
        raise ParameterError(where, name, expected, value) from None
    if len(row) != 3 or not all(math.isfinite(v) for v in row):
        raise ParameterError(where, name, expected, value)
    return row  # type: ignore[return-value]


def element_frame(element: Element, look: Look) -> NDArray[np.float64]:
    """The element's antenna-to-body rotation (columns: azimuth axis, elevation axis,
    boresight), module docstring; the look's for an element without a boresight of its own.
    A ``boresight`` vector takes the azimuth axis ``b x z`` (body x for a boresight along body
    z): the roll jumps by 90 degrees between a boresight straight down and one a hair off it,
    which swaps the axes of a beam whose azimuth and elevation widths differ; give
    ``off_nadir_deg``/``squint_deg`` for such a beam near nadir."""
    if element.off_nadir_deg is not None:
        return Look(element.off_nadir_deg, element.squint_deg or 0.0).antenna_to_body()
    if element.boresight is None:
        return look.antenna_to_body()
    b = np.asarray(element.boresight, dtype=float)
    azimuth = np.cross(b, [0.0, 0.0, 1.0])
    norm = float(np.linalg.norm(azimuth))
    azimuth = np.array([1.0, 0.0, 0.0]) if norm < 1e-12 else azimuth / norm
    return np.stack([azimuth, np.cross(b, azimuth), b], axis=-1)


def two_way_boresight(transmit: Element, receive: Element, beamwidths: tuple[float, float],
                      look: Look) -> NDArray[np.float64]:
    """Centre of the two-way beam of channel (``transmit``, ``receive``), a body-frame unit
    vector: the boresights ``b_t``, ``b_r`` (:func:`element_frame`'s third column) weighted by
    the inverse squared azimuth beamwidths, ``b ~ b_t / beta_t^2 + b_r / beta_r^2``.

    Near its boresight an element's one-way field is ``sinc(u / beta) ~ exp(-(pi^2/6)
    (u / beta)^2)`` (second order in the azimuth sine u), so the two-way pattern
    ``f_t f_r`` peaks at ``u = (u_t / beta_t^2 + u_r / beta_r^2) / (1 / beta_t^2 + 1 /
    beta_r^2)``: the weighted mean above, whose component along the track is the channel's
    Doppler-centroid sine (docs/interferometry.md §8, "Element beams in focusing"). Exact
    when both elements look the same way (a ping-pong channel, or a receiver that shares the
    transmitter's boresight); to second order in the boresights' separation otherwise.
    ``beamwidths``: the radar's (azimuth, elevation) [rad], for elements without their own.
    """
    weights = [1.0 / element_beam(e, beamwidths, look).beamwidth_az ** 2
               for e in (transmit, receive)]
    vector = (weights[0] * element_frame(transmit, look)[:, 2]
              + weights[1] * element_frame(receive, look)[:, 2])
    norm = float(np.linalg.norm(vector))
    if not norm > 1e-9:
        raise ParameterError("two_way_boresight", "receive", "an element that does not look "
                             "opposite its transmitter (the channel has no two-way beam)",
                             receive)
    return vector / norm


class ElementBeam(NamedTuple):
    """What a kernel needs of one element's beam (:func:`element_beam`), as Python floats.

    Attributes
    ----------
    rotation : tuple of 3 tuples of 3 floats
        ``M = E^T A``: direction sines in the antenna frame ``A`` (the look's, the radar's
        antenna; or the frame :func:`element_beam` is given: the transmit element the ray
        tracer follows) to the
        element's frame ``E`` (:func:`element_frame`), ``s_element = M s_radar``.
    beamwidth_az, beamwidth_el : float
        The element's beamwidths [rad].
    gain : float
        Boresight gain ``4 pi / (beta_az beta_el)`` [-].
    identity : bool
        Whether ``M`` is the identity (the element looks along the radar's boresight), so that
        kernels may skip the rotation.
    """

    rotation: tuple[tuple[float, float, float], ...]
    beamwidth_az: float
    beamwidth_el: float
    gain: float
    identity: bool


def element_beam(element: Element, beamwidths: tuple[float, float], look: Look,
                 frame: NDArray | None = None) -> ElementBeam:
    """The :class:`ElementBeam` of ``element`` mounted with ``look`` on a radar whose antenna
    has ``beamwidths`` = (azimuth, elevation) [rad] (:attr:`Radar.azimuth_beamwidth`,
    :attr:`Radar.elevation_beamwidth`: an element without its own takes the radar's).
    ``frame``: the antenna-to-body rotation the direction sines are taken in (default the
    look's, the radar's antenna; the ray tracer takes a transmit element's own)."""
    az = (beamwidths[0] if element.azimuth_beamwidth_deg is None
          else math.radians(element.azimuth_beamwidth_deg))
    el = (beamwidths[1] if element.elevation_beamwidth_deg is None
          else math.radians(element.elevation_beamwidth_deg))
    radar_frame = look.antenna_to_body() if frame is None else np.asarray(frame, dtype=float)
    rotation = element_frame(element, look).T @ radar_frame
    identity = bool(np.allclose(rotation, np.eye(3), rtol=0.0, atol=1e-12))
    if identity:
        rotation = np.eye(3)
    return ElementBeam(rotation=tuple(tuple(float(v) for v in row) for row in rotation),
                       beamwidth_az=float(az), beamwidth_el=float(el),
                       gain=4.0 * math.pi / (az * el), identity=identity)


def element_field_pattern(u_az: Any, u_el: Any, u_boresight: Any, beam: ElementBeam,
                          ops: Any = NUMPY_OPS) -> Any:
    """One-way field pattern of an element, ``sinc(s_az / beta_az) sinc(s_el / beta_el)`` in
    its own frame, zero behind it (``s_b <= 0``); Balanis' uniform aperture
    (:func:`mitsar.model.geometry.antenna.field_pattern`).

    Parameters
    ----------
    u_az, u_el, u_boresight : array_like (NumPy or Dr.Jit)
        Direction sines of the unit direction towards the scatterer in the *radar's* antenna
        frame (:func:`mitsar.model.geometry.antenna.direction_sines`) [-].
    beam : ElementBeam
        :func:`element_beam`.
    ops : namespace
        Array operations (:mod:`mitsar.model.ops`).
    """
    if beam.identity:
        s_az, s_el, s_b = u_az, u_el, u_boresight
    else:
        m = beam.rotation
        s_az = m[0][0] * u_az + m[0][1] * u_el + m[0][2] * u_boresight
        s_el = m[1][0] * u_az + m[1][1] * u_el + m[1][2] * u_boresight
        s_b = m[2][0] * u_az + m[2][1] * u_el + m[2][2] * u_boresight
    field = ops.sinc(s_az / beam.beamwidth_az) * ops.sinc(s_el / beam.beamwidth_el)
    return ops.where(s_b > 0.0, field, 0.0 * field)


def channel_amplitude_factor(u_az: Any, u_el: Any, u_boresight: Any, transmit: ElementBeam,
                             receive: ElementBeam, radar_gain: float | None,
                             ops: Any = NUMPY_OPS) -> Any:
    """Two-way amplitude factor of channel (transmit, receive) relative to the radar equation
    with the radar's boresight gain (module docstring):

    ``f_t(d) f_r(d) sqrt(G_t G_r) / G``,

    so that ``amplitude = factor * sqrt(P_T G^2 lambda^2 sigma / ((4 pi)^3 R^4))``; it takes the
    place of the monostatic two-way factor ``f(d)^2`` (the one-way power pattern) of a radar
    whose elements are all its own. ``radar_gain=None``: patterns only (normalised amplitudes,
    no radar equation). Generic over ``ops``: the ray tracer's kernels call it with Dr.Jit
    arrays and :data:`mitsar.plugins.ops.DRJIT_OPS` (``transmit``/``receive`` hold Python
    floats only).

    Parameters
    ----------
    u_az, u_el, u_boresight : array_like
        Direction sines in the radar's antenna frame (:func:`element_field_pattern`).
    transmit, receive : ElementBeam
        The channel's elements (:func:`element_beam`).
    radar_gain : float or None
        The radar's boresight gain :attr:`Radar.antenna_gain`.
    ops : namespace
    """
    factor = (element_field_pattern(u_az, u_el, u_boresight, transmit, ops)
              * element_field_pattern(u_az, u_el, u_boresight, receive, ops))
    if radar_gain is None:
        return factor
    return factor * (math.sqrt(transmit.gain * receive.gain) / radar_gain)
