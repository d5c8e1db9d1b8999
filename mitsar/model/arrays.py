"""Uniform antenna arrays: a compact form of a radar's transmit and receive phase centres.

A :class:`UniformArray` is the ``[radar.array]`` table of an experiment file (and the argument
of :meth:`mitsar.model.radar.Radar.array`): ``receivers`` elements on a line through ``origin``
along ``axis``, ``spacing`` apart, and optionally ``transmitters`` elements on a line through
``transmitter_origin`` along ``transmitter_axis``, ``transmitter_spacing`` apart, all in the
body frame (x forward, y left, z up; docs/interferometry.md §8). It expands to the same
:class:`~mitsar.model.elements.Element` records as the explicit ``receivers`` /
``transmitters`` lists:

``r_j = origin + j d_r a_r``, ``t_i = origin_t + i d_t a_t``  (``a`` unit axes),

so receiver j of a 4-element line 0.5 lambda apart along z sits at ``(0, 0, j lambda / 2)``.

Defaults follow TI's cascade-free TDM-MIMO layout (docs/interferometry.md §8, "TDM-MIMO";
../shared/reference/interferometry-notes.md §3): receivers lambda/2 apart, transmitters
``N_rx`` receiver spacings apart on the same axis, so that the far-field virtual array
``t_i + r_j`` is a filled line of ``N_tx N_rx`` elements lambda/2 apart. A spacing is given
in metres or in wavelengths of the radar's carrier, not both, and must be at least
:data:`MIN_SPACING_WAVELENGTHS` wavelengths: phase centres closer than a patch element's own
size (about ``lambda / (2 sqrt(eps_r))``, lambda/4 on a substrate of eps_r = 4; Balanis,
*Antenna Theory*, 4th ed., §14.2) cannot be built. An optional ``receiver_beam`` /
``transmitter_beam`` gives every element of the line its own pattern and boresight (the beam
fields of :class:`~mitsar.model.elements.Element`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np

from mitsar.checks import KnownFields, is_real
from mitsar.errors import ParameterError
from mitsar.model.elements import BEAM_FIELDS, Element, body_vector

__all__ = ["MIN_SPACING_WAVELENGTHS", "UniformArray"]

MIN_SPACING_WAVELENGTHS = 0.25
"""Smallest element spacing [wavelengths] of a :class:`UniformArray` (module docstring)."""

MAX_ELEMENTS = 64
"""Most elements of one line (:data:`mitsar.model.radar.MAX_CHANNELS`)."""

DEFAULT_SPACING_WAVELENGTHS = 0.5
"""Receiver spacing [wavelengths] when none is given (TI's lambda/2)."""


@dataclass(frozen=True)
class UniformArray(metaclass=KnownFields):
    """Uniform linear transmit and receive lines in the body frame (module docstring).

    Parameters
    ----------
    receivers : int
        Number of receive elements N_rx >= 1.
    transmitters : int or None
        Number of transmit elements N_tx >= 1 (more than one: TDM-MIMO, each in its own
        sweep); ``None``: the radar's one transmitter at the body origin (so that
        ``ping_pong`` may be used).
    spacing, spacing_wavelengths : float or None
        Receiver spacing [m] or [wavelengths]; at most one; default 0.5 wavelengths.
    transmitter_spacing, transmitter_spacing_wavelengths : float or None
        Transmitter spacing [m] or [wavelengths]; at most one; default ``N_rx`` receiver
        spacings (a filled virtual array).
    axis : 3-vector
        Direction of the receive line, body frame (normalised here); default z (up: a
        vertical, cross-track interferometric baseline).
    transmitter_axis : 3-vector or None
        Direction of the transmit line; default ``axis``.
    origin : 3-vector
        First receiver's phase centre, body frame [m].
    transmitter_origin : 3-vector or None
        First transmitter's phase centre [m]; default ``origin``.
    receiver_beam, transmitter_beam : dict or None
        Beam fields of :class:`~mitsar.model.elements.Element` (``azimuth_beamwidth_deg``,
        ``elevation_beamwidth_deg``, ``off_nadir_deg``, ``squint_deg``, ``boresight``) given
        to every element of the line; ``None``: the radar's antenna.

    Examples
    --------
    >>> transmitters, receivers = UniformArray(receivers=4, transmitters=3).elements(0.004)
    >>> [round(e.position[2], 4) for e in receivers], [e.position[2] for e in transmitters]
    ([0.0, 0.002, 0.004, 0.006], [0.0, 0.008, 0.016])
    """

    receivers: int = 1
    transmitters: int | None = None
    spacing: float | None = None
    spacing_wavelengths: float | None = None
    transmitter_spacing: float | None = None
    transmitter_spacing_wavelengths: float | None = None
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    transmitter_axis: tuple[float, float, float] | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    transmitter_origin: tuple[float, float, float] | None = None
    receiver_beam: dict[str, Any] | None = None
    transmitter_beam: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        for name in ("receivers", "transmitters"):
            value = getattr(self, name)
            if name == "transmitters" and value is None:
                continue
            if (isinstance(value, bool) or not isinstance(value, int | np.integer)
                    or not 1 <= value <= MAX_ELEMENTS):
                raise ParameterError("UniformArray", name, f"an integer number of elements in "
                                     f"[1, {MAX_ELEMENTS}]", value)
            object.__setattr__(self, name, int(value))
        for metres, wavelengths in (("spacing", "spacing_wavelengths"),
                                    ("transmitter_spacing", "transmitter_spacing_wavelengths")):
            for name in (metres, wavelengths):
                value = getattr(self, name)
                if value is not None and not (is_real(value) and math.isfinite(value)
                                              and value > 0):
                    raise ParameterError("UniformArray", name, "None or a spacing > 0 "
                                         f"[{'m' if name == metres else 'wavelengths'}]", value)
            if getattr(self, metres) is not None and getattr(self, wavelengths) is not None:
                raise ParameterError("UniformArray", wavelengths, f"None when {metres} [m] is "
                                     f"given (one spacing: in metres or in wavelengths)",
                                     getattr(self, wavelengths))
        for name in ("axis", "transmitter_axis"):
            value = getattr(self, name)
            if value is not None:
                vector = body_vector("UniformArray", name, value, "a non-zero body-frame 3-vector")
                norm = math.sqrt(sum(v * v for v in vector))
                if not norm > 0:
                    raise ParameterError("UniformArray", name, "a non-zero body-frame 3-vector",
                                         value)
                object.__setattr__(self, name, tuple(v / norm for v in vector))
        for name in ("origin", "transmitter_origin"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, body_vector("UniformArray", name, value,
                                                              "a body-frame 3-vector [m]"))
        for name in ("receiver_beam", "transmitter_beam"):
            value = getattr(self, name)
            if value is None:
                continue
            if not isinstance(value, dict) or not set(value) <= set(BEAM_FIELDS):
                unknown = sorted(set(value) - set(BEAM_FIELDS)) if isinstance(value, dict) else []
                raise ParameterError("UniformArray", f"{name}.{unknown[0]}" if unknown else name,
                                     f"a table of the element beam fields {list(BEAM_FIELDS)}",
                                     value[unknown[0]] if unknown else value)

    def spacings(self, wavelength: float) -> tuple[float, float]:
        """(receiver, transmitter) spacing [m] at ``wavelength`` [m]; refuses a spacing below
        :data:`MIN_SPACING_WAVELENGTHS` wavelengths, naming the field."""
        receiver = (self.spacing if self.spacing is not None else wavelength * (
            DEFAULT_SPACING_WAVELENGTHS if self.spacing_wavelengths is None
            else self.spacing_wavelengths))
        transmitter = (self.transmitter_spacing if self.transmitter_spacing is not None
                       else receiver * self.receivers
                       if self.transmitter_spacing_wavelengths is None
                       else wavelength * self.transmitter_spacing_wavelengths)
        minimum = MIN_SPACING_WAVELENGTHS * wavelength
        checks = (("spacing", receiver, self.receivers),
                  ("transmitter_spacing", transmitter, self.transmitters or 1))
        for name, value, count in checks:
            if count > 1 and value < minimum * (1.0 - 1e-12):
                given = (name if getattr(self, name) is not None
                         else f"{name}_wavelengths" if getattr(self, f"{name}_wavelengths")
                         is not None else name)
                raise ParameterError(
                    "UniformArray", given, f">= {MIN_SPACING_WAVELENGTHS:g} wavelengths = "
                    f"{minimum * 1e3:.4g} mm at lambda = {wavelength * 1e3:.4g} mm (phase "
                    "centres closer than an element's own size cannot be built); widen the "
                    "spacing", f"{value * 1e3:.4g} mm")
        return receiver, transmitter

    def elements(self, wavelength: float
                 ) -> tuple[tuple[Element, ...] | None, tuple[Element, ...]]:
        """(transmitters, receivers) as :class:`~mitsar.model.elements.Element` records at the
        radar's ``wavelength`` [m] (``transmitters`` None when :attr:`transmitters` is)."""
        receiver_spacing, transmitter_spacing = self.spacings(wavelength)
        receivers = _line(self.receivers, self.origin, self.axis, receiver_spacing,
                          self.receiver_beam, "receivers")
        if self.transmitters is None:
            return None, receivers
        return (_line(self.transmitters, self.transmitter_origin or self.origin,
                      self.transmitter_axis or self.axis, transmitter_spacing,
                      self.transmitter_beam, "transmitters"), receivers)

    @classmethod
    def of(cls, value: Any) -> UniformArray:
        """A :class:`UniformArray` from itself or a dict of its fields."""
        if isinstance(value, UniformArray):
            return value
        if not isinstance(value, dict):
            raise ParameterError("Radar", "array", "a UniformArray or a dict of its fields "
                                 "(receivers, transmitters, spacing, axis, ...)", value)
        return cls(**value)


def _line(count: int, origin: tuple[float, ...], axis: tuple[float, ...], spacing: float,
          beam: dict[str, Any] | None, name: str) -> tuple[Element, ...]:
    """``count`` elements at ``origin + i spacing axis`` with ``beam``'s fields."""
    positions = (np.asarray(origin, dtype=float)[None, :]
                 + spacing * np.arange(count)[:, None] * np.asarray(axis, dtype=float)[None, :])
    elements = []
    for i, position in enumerate(positions):
        try:
            elements.append(Element(position=tuple(float(v) for v in position), **(beam or {})))
        except ParameterError as error:
            field = (f"{name[:-1]}_beam.{error.name}" if error.name != "position"
                     else ("origin" if name == "receivers" else "transmitter_origin"))
            raise ParameterError("UniformArray", field, error.expected if error.name != "position"
                                 else f"a line (origin + i spacing axis) whose element {i} has "
                                 f"{error.expected}",
                                 error.found) from None
    return tuple(elements)

