"""The ``radar`` integrator's XML name and parameters, and its launch sizes (pure Python).

The parameters themselves, their defaults and their validation are the fields of the one trace
request, :class:`mitsar.model.trace_options.TraceOptions` (the XML sets the fields
:data:`PARAMETERS`); this module keeps what only the plugin needs. It imports neither Mitsuba
nor Dr.Jit.
"""

from __future__ import annotations

from mitsar.model.trace_options import MULTIPATH_CHUNK_LANES, XML_PARAMETERS

__all__ = ["HISTOGRAM_CHUNK_ELEMENTS", "MULTIPATH_CHUNK_LANES", "PARAMETERS", "PLUGIN_NAME",
           "SWEEPS_PER_CHUNK", "histogram_buffer_length"]

PLUGIN_NAME = "radar"
"""XML type name."""

PARAMETERS: tuple[str, ...] = XML_PARAMETERS
"""Accepted XML parameters (fields of :class:`~mitsar.model.trace_options.TraceOptions`)."""

SWEEPS_PER_CHUNK = 128
"""Sweeps traced together (one histogram buffer, one chunk-level beam cull)."""

HISTOGRAM_CHUNK_ELEMENTS = 2**22
"""Bound on sweeps x orders x bins of the histogram buffer of one launch (2 x 32 MiB)."""


def histogram_buffer_length(size: int) -> int:
    """Length of a histogram buffer of ``size`` elements: the next power of two or 1.5 times a
    power of two, at least 2^16 (the length is a literal of the kernels: two lengths per
    octave, few compilations; at most a third of the buffer is unused)."""
    power = 1 << (max(int(size), 1) - 1).bit_length()
    return max(2**16, power * 3 // 4 if power * 3 // 4 >= size else power)
