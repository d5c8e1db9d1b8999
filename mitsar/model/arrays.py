"""Uniform antenna arrays: a compact form of a radar's transmit and receive phase centres.

A :class:`UniformArray` is the ``[radar.array]`` table of an experiment file (and the argument
of :meth:`mitsar.model.radar.Radar.array`): ``receivers`` elements on a line (or a planar grid)
through ``origin`` along ``axis`` (and ``cross_axis``), ``spacing`` apart, and optionally
``transmitters`` elements laid out the same way from ``transmitter_origin``, all in the body
frame (x forward, y left, z up; docs/interferometry.md §8). It expands to the same
:class:`~mitsar.model.elements.Element` records as the explicit ``receivers`` /
``transmitters`` lists: element ``(j_u, j_v)`` of a grid of ``N_u x N_v`` is at

``origin + j_u d_u a + j_v d_v c``   (``a``, ``c`` the unit ``axis`` and ``cross_axis``),

listed with ``j_u`` fastest (index ``j_v N_u + j_u``); a line is ``N_v = 1``. So receiver j
of a 4-element line 0.5 lambda apart along z sits at ``(0, 0, j lambda / 2)``.

Defaults follow TI's cascade-free TDM-MIMO layout (docs/interferometry.md §8, "TDM-MIMO";
../shared/reference/interferometry-notes.md §3): receivers lambda/2 apart, transmitters
``N_rx`` receiver spacings apart along each axis, so that the far-field virtual array
``t_i + r_j`` is a filled line (grid) of elements lambda/2 apart. A spacing is given in metres
or in wavelengths of the radar's carrier, not both, and no two phase centres of one line may be
closer than :data:`MIN_SPACING_WAVELENGTHS` wavelengths: phase centres closer than a patch
element's own size (about ``lambda / (2 sqrt(eps_r))``, lambda/4 on a substrate of
eps_r = 4; Balanis, *Antenna Theory*, 4th ed., §14.2) cannot be built. An optional
``receiver_beam`` / ``transmitter_beam`` gives every element its own pattern and boresight
(the beam fields of :class:`~mitsar.model.elements.Element`).
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Any

import numpy as np
from numpy.typing import NDArray

from mitsar.checks import KnownFields, is_real
from mitsar.errors import ParameterError
from mitsar.model.elements import BEAM_FIELDS, Element, body_vector

__all__ = ["MIN_SPACING_WAVELENGTHS", "UniformArray"]

MIN_SPACING_WAVELENGTHS = 0.25
"""Smallest distance between two phase centres of one line or grid [wavelengths] (module
docstring)."""

MAX_ELEMENTS = 64
"""Most elements of one line or grid (:data:`mitsar.model.radar.MAX_CHANNELS`)."""

DEFAULT_SPACING_WAVELENGTHS = 0.5
"""Receiver spacing [wavelengths] when none is given (TI's lambda/2)."""

_WHERE = "UniformArray"


@dataclass(frozen=True)
class UniformArray(metaclass=KnownFields):
    """Uniform transmit and receive lines or planar grids in the body frame (module docstring).

    Parameters
    ----------
    receivers : int or (int, int)
        Receive elements: N_rx on a line along ``axis``, or ``(N_u, N_v)`` on a grid along
        ``axis`` and ``cross_axis``; at least one, at most 64 in all.
    transmitters : int, (int, int) or None
        Transmit elements, as ``receivers`` (more than one: TDM-MIMO, each in its own sweep);
        ``None``: the radar's one transmitter at the body origin (so that ``ping_pong`` may be
        used).
    spacing, spacing_wavelengths : float, (float, float) or None
        Receiver spacing along (``axis``, ``cross_axis``) [m] or [wavelengths]; at most one of
        the two; one number for both axes; default 0.5 wavelengths.
    transmitter_spacing, transmitter_spacing_wavelengths : float, (float, float) or None
        Transmitter spacing, as ``spacing``; default ``(N_u d_u, N_v d_v)`` of the receivers
        (a filled virtual array).
    axis : 3-vector
        First direction of the receive line or grid, body frame (normalised here); default z
        (up: a vertical, cross-track interferometric baseline).
    cross_axis : 3-vector or None
        Second direction of a receive grid (required when ``N_v > 1``; not parallel to
        ``axis``).
    transmitter_axis, transmitter_cross_axis : 3-vector or None
        The transmitters' directions; default ``axis`` and ``cross_axis``.
    origin : 3-vector
        First receiver's phase centre, body frame [m].
    transmitter_origin : 3-vector or None
        First transmitter's phase centre [m]; default ``origin``.
    receiver_beam, transmitter_beam : dict or None
        Beam fields of :class:`~mitsar.model.elements.Element` (``azimuth_beamwidth_deg``,
        ``elevation_beamwidth_deg``, ``off_nadir_deg``, ``squint_deg``, ``boresight``) given
        to every element; ``None``: the radar's antenna.

    Examples
    --------
    >>> transmitters, receivers = UniformArray(receivers=4, transmitters=3).elements(0.004)
    >>> [round(e.position[2], 4) for e in receivers], [e.position[2] for e in transmitters]
    ([0.0, 0.002, 0.004, 0.006], [0.0, 0.008, 0.016])
    """

    receivers: int | tuple[int, int] = 1
    transmitters: int | tuple[int, int] | None = None
    spacing: float | tuple[float, float] | None = None
    spacing_wavelengths: float | tuple[float, float] | None = None
    transmitter_spacing: float | tuple[float, float] | None = None
    transmitter_spacing_wavelengths: float | tuple[float, float] | None = None
    axis: tuple[float, float, float] = (0.0, 0.0, 1.0)
    cross_axis: tuple[float, float, float] | None = None
    transmitter_axis: tuple[float, float, float] | None = None
    transmitter_cross_axis: tuple[float, float, float] | None = None
    origin: tuple[float, float, float] = (0.0, 0.0, 0.0)
    transmitter_origin: tuple[float, float, float] | None = None
    receiver_beam: dict[str, Any] | None = None
    transmitter_beam: dict[str, Any] | None = None

    def __post_init__(self) -> None:
        for name in ("receivers", "transmitters"):
            if name != "transmitters" or self.transmitters is not None:
                object.__setattr__(self, name, _counts(name, getattr(self, name)))
        for metres, wavelengths in (("spacing", "spacing_wavelengths"),
                                    ("transmitter_spacing", "transmitter_spacing_wavelengths")):
            for name, unit in ((metres, "m"), (wavelengths, "wavelengths")):
                if getattr(self, name) is not None:
                    object.__setattr__(self, name, _lengths(name, getattr(self, name), unit))
            if getattr(self, metres) is not None and getattr(self, wavelengths) is not None:
                raise ParameterError(_WHERE, wavelengths, f"None when {metres} [m] is given "
                                     "(one spacing: in metres or in wavelengths)",
                                     getattr(self, wavelengths))
        for name in ("axis", "cross_axis", "transmitter_axis", "transmitter_cross_axis"):
            value = getattr(self, name)
            if value is not None:
                vector = np.asarray(body_vector(_WHERE, name, value,
                                                "a non-zero body-frame 3-vector"))
                norm = float(np.linalg.norm(vector))
                if not norm > 0:
                    raise ParameterError(_WHERE, name, "a non-zero body-frame 3-vector", value)
                object.__setattr__(self, name, tuple(float(v) for v in vector / norm))
        for name in ("origin", "transmitter_origin"):
            value = getattr(self, name)
            if value is not None:
                object.__setattr__(self, name, body_vector(_WHERE, name, value,
                                                           "a body-frame 3-vector [m]"))
        for prefix, counts in (("", self.receivers), ("transmitter_", self.transmitters)):
            if counts is None:
                continue
            axis = getattr(self, f"{prefix}axis") or self.axis
            cross = getattr(self, f"{prefix}cross_axis") or self.cross_axis
            name = f"{prefix}cross_axis"
            if counts[1] > 1 and cross is None:
                kind = "transmit" if prefix else "receive"
                raise ParameterError(_WHERE, name, f"a body-frame 3-vector for a grid of "
                                     f"{counts[0]} x {counts[1]} {kind} elements (its second "
                                     "direction)", None)
            if counts[1] > 1 and np.linalg.norm(np.cross(axis, cross)) < 1e-6:
                raise ParameterError(_WHERE, name, "a direction not parallel to the axis (the "
                                     "grid's second direction)", cross)
        for name in ("receiver_beam", "transmitter_beam"):
            value = getattr(self, name)
            if value is None:
                continue
            unknown = sorted(set(value) - set(BEAM_FIELDS)) if isinstance(value, dict) else []
            if not isinstance(value, dict) or unknown:
                raise ParameterError(_WHERE, f"{name}.{unknown[0]}" if unknown else name,
                                     f"a table of the element beam fields {list(BEAM_FIELDS)}",
                                     value[unknown[0]] if unknown else value)

    def spacings(self, wavelength: float
                 ) -> tuple[tuple[float, float], tuple[float, float] | None]:
        """(receiver, transmitter) spacings along (axis, cross axis) [m] at ``wavelength``
        [m]; the transmitters' None when :attr:`transmitters` is."""
        receiver = (self.spacing if self.spacing is not None else tuple(
            wavelength * d for d in (self.spacing_wavelengths or (DEFAULT_SPACING_WAVELENGTHS,)
                                     * 2)))
        if self.transmitters is None:
            return receiver, None
        if self.transmitter_spacing is not None:
            return receiver, self.transmitter_spacing
        if self.transmitter_spacing_wavelengths is not None:
            return receiver, tuple(wavelength * d for d in self.transmitter_spacing_wavelengths)
        return receiver, (receiver[0] * self.receivers[0], receiver[1] * self.receivers[1])

    def elements(self, wavelength: float
                 ) -> tuple[tuple[Element, ...] | None, tuple[Element, ...]]:
        """(transmitters, receivers) as :class:`~mitsar.model.elements.Element` records at the
        radar's ``wavelength`` [m] (``transmitters`` None when :attr:`transmitters` is).

        Raises
        ------
        ParameterError
            Two phase centres of one line or grid closer than :data:`MIN_SPACING_WAVELENGTHS`
            wavelengths (naming the spacing as it was given), or an element beyond the
            body-frame bound of :class:`~mitsar.model.elements.Element`.
        """
        receiver_spacing, transmitter_spacing = self.spacings(wavelength)
        receivers = _grid(self.receivers, self.origin, self.axis, self.cross_axis,
                          receiver_spacing)
        self._check_spacing(receivers, wavelength, "")
        out = _elements(receivers, self.receiver_beam, "receiver_")
        if self.transmitters is None or transmitter_spacing is None:
            return None, out
        transmitters = _grid(self.transmitters, self.transmitter_origin or self.origin,
                             self.transmitter_axis or self.axis,
                             self.transmitter_cross_axis or self.cross_axis,
                             transmitter_spacing)
        self._check_spacing(transmitters, wavelength, "transmitter_")
        return _elements(transmitters, self.transmitter_beam, "transmitter_"), out

    def _check_spacing(self, positions: NDArray[np.float64], wavelength: float,
                       prefix: str) -> None:
        """Refuse two phase centres closer than the minimum (module docstring)."""
        if len(positions) < 2:
            return
        gaps = np.linalg.norm(positions[:, None, :] - positions[None, :, :], axis=-1)
        closest = float(gaps[np.triu_indices(len(positions), 1)].min())
        minimum = MIN_SPACING_WAVELENGTHS * wavelength
        if closest < minimum * (1.0 - 1e-12):
            name = (f"{prefix}spacing_wavelengths"
                    if getattr(self, f"{prefix}spacing_wavelengths") is not None
                    else f"{prefix}spacing")
            raise ParameterError(
                _WHERE, name, f"phase centres >= {MIN_SPACING_WAVELENGTHS:g} wavelengths = "
                f"{minimum * 1e3:.4g} mm apart at lambda = {wavelength * 1e3:.4g} mm (closer "
                "than an element's own size cannot be built); widen the spacing",
                f"two {closest * 1e3:.4g} mm apart")

    @classmethod
    def of(cls, value: Any) -> UniformArray:
        """A :class:`UniformArray` from itself or a dict of its fields."""
        if isinstance(value, UniformArray):
            return value
        if not isinstance(value, dict):
            raise ParameterError("Radar", "array", "a UniformArray or a dict of its fields "
                                 "(receivers, transmitters, spacing, axis, ...)", value)
        return cls(**value)


def _counts(name: str, value: Any) -> tuple[int, int]:
    """An element count N or a grid (N_u, N_v) as a pair, each >= 1, at most 64 in all."""
    expected = (f"a number of elements, or [N_u, N_v] of a grid, with 1 to {MAX_ELEMENTS} "
                "elements in all")
    items = value if isinstance(value, list | tuple) else [value, 1]
    if (len(items) != 2 or any(isinstance(v, bool) or not isinstance(v, int | np.integer)
                               or v < 1 for v in items)
            or items[0] * items[1] > MAX_ELEMENTS):
        raise ParameterError(_WHERE, name, expected, value)
    return int(items[0]), int(items[1])


def _lengths(name: str, value: Any, unit: str) -> tuple[float, float]:
    """A spacing, or one per axis, as a pair of finite numbers > 0."""
    items = value if isinstance(value, list | tuple) else [value, value]
    if len(items) != 2 or not all(is_real(v) and math.isfinite(v) and v > 0 for v in items):
        raise ParameterError(_WHERE, name, f"None or a spacing > 0 [{unit}], or one per axis",
                             value)
    return float(items[0]), float(items[1])


def _grid(counts: tuple[int, int], origin: tuple[float, ...], axis: tuple[float, ...],
          cross: tuple[float, ...] | None, spacing: tuple[float, float]
          ) -> NDArray[np.float64]:
    """Positions ``origin + j_u d_u a + j_v d_v c``, ``j_u`` fastest, shape (N_u N_v, 3)."""
    j_v, j_u = np.divmod(np.arange(counts[0] * counts[1]), counts[0])
    positions = (np.asarray(origin, dtype=float)[None, :]
                 + (spacing[0] * j_u)[:, None] * np.asarray(axis, dtype=float)[None, :])
    if cross is not None:
        positions = positions + (spacing[1] * j_v)[:, None] * np.asarray(cross)[None, :]
    return positions


def _elements(positions: NDArray[np.float64], beam: dict[str, Any] | None,
              prefix: str) -> tuple[Element, ...]:
    """An :class:`Element` at each position with ``beam``'s fields; errors name the field."""
    elements = []
    for i, position in enumerate(positions):
        try:
            elements.append(Element(position=tuple(float(v) for v in position), **(beam or {})))
        except ParameterError as error:
            if error.name != "position":
                raise ParameterError(_WHERE, f"{prefix}beam.{error.name}", error.expected,
                                     error.found) from None
            origin = "origin" if prefix == "receiver_" else "transmitter_origin"
            raise ParameterError(_WHERE, origin, f"a layout (origin + j spacing axis) whose "
                                 f"element {i} has {error.expected}", error.found) from None
    return tuple(elements)
