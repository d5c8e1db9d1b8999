"""The phase centres of ``[radar]``: ``receivers`` / ``transmitters`` lists or tables, and the
``[radar.array]`` table (docs/experiments.md "[radar]", "[radar.array]";
docs/interferometry.md §8).

:func:`parse_phase_centres` reads one list (positions, or ``[[radar.receivers]]`` tables with
an element's own beam: :class:`mitsar.model.elements.Element`), :func:`parse_array` the uniform
array (:class:`mitsar.model.arrays.UniformArray`); :func:`mitsar.experiment.parsers.parse_radar`
builds the :class:`~mitsar.model.radar.Radar` from them.
"""

from __future__ import annotations

from typing import Any

from mitsar.experiment.table import Table

__all__ = ["parse_array", "parse_phase_centres"]


def parse_array(t: Table) -> dict[str, Any] | None:
    """``[radar.array]``: a uniform transmit/receive array
    (:class:`mitsar.model.arrays.UniformArray`'s fields, docs/experiments.md); None when
    absent."""
    a = t.table("array")
    if a is None:
        return None
    fields: dict[str, Any] = {"receivers": _count(a, "receivers", required=True),
                              "transmitters": _count(a, "transmitters", required=False)}
    for name in ("spacing", "transmitter_spacing"):
        for key, unit in ((name, "m"), (f"{name}_wavelengths", "")):
            fields[key] = (a.vector(key, 2, None, unit=unit) if isinstance(a.data.get(key), list)
                           else a.number(key, None, unit=unit, gt=0))
    for name in ("axis", "cross_axis", "transmitter_axis", "transmitter_cross_axis"):
        fields[name] = a.vector(name, 3, None, unit="body frame")
    for name in ("origin", "transmitter_origin"):
        fields[name] = a.vector(name, 3, None, unit="m, body frame")
    for name in ("receiver_beam", "transmitter_beam"):
        beam = a.table(name)
        if beam is not None:
            fields[name] = _beam_fields(beam)
            beam.finish()
    a.finish()
    return {k: v for k, v in fields.items() if v is not None}


def _count(t: Table, name: str, required: bool) -> int | tuple[int, int] | None:
    """An element count: an integer, or ``[N_u, N_v]`` of a planar grid (their bounds are
    :class:`mitsar.model.arrays.UniformArray`'s)."""
    expected = "an integer >= 1, or an array of two integers [N_u, N_v] (a planar grid)"
    t.seen.add(name)
    if name not in t.data:
        if required:
            raise t.error(name, f"{expected} (required key)", "nothing")
        return None
    value = t.data[name]
    items = value if isinstance(value, list) else [value]
    if len(items) not in (1, 2) or isinstance(value, list) and len(items) != 2 or any(
            isinstance(v, bool) or not isinstance(v, int) or v < 1 for v in items):
        raise t.error(name, expected, value)
    t.out[name] = value
    return tuple(items) if isinstance(value, list) else value


def _beam_fields(t: Table) -> dict[str, Any]:
    """An element's own pattern and boresight (:data:`mitsar.model.elements.BEAM_FIELDS`)."""
    fields: dict[str, Any] = {"boresight": t.vector("boresight", 3, None, unit="body frame")}
    for key in ("azimuth_beamwidth_deg", "elevation_beamwidth_deg", "off_nadir_deg",
                "squint_deg"):
        fields[key] = t.number(key, None, unit="deg")
    return {k: v for k, v in fields.items() if v is not None}


def parse_phase_centres(t: Table, name: str) -> list[tuple[float, ...]] | None:
    """``[radar] receivers = [[x, y, z], ...]`` or ``[[radar.receivers]]`` tables, each with
    ``position = [x, y, z]`` (body frame [m]) and optionally the element's own pattern and
    boresight (:class:`mitsar.model.elements.Element`'s fields); None when absent."""
    value = t.data.get(name)
    if isinstance(value, list) and value and all(isinstance(item, dict) for item in value):
        centres = []
        for element in t.tables(name):  # an Element: position, own beam (mitsar.model.elements)
            fields = {"position": element.vector("position", 3, unit="m, body frame"),
                      **_beam_fields(element)}
            element.finish()
            centres.append(fields)
        return centres
    return t.vectors(name, 3, default=None, unit="m, body frame")
