"""Human axis labels with units for the keys and quantities of campaigns (``mitsar sweep``).

A sweep varies experiment keys (``radar.bandwidth``, ``background.cell_rcs_db``; their units
are those of docs/experiments.md) and measures quantities (``range_irw_cells``,
``peak_offset_m``; docs/experiments.md "mitsar sweep"). Figures label them
"radar bandwidth [Hz]" and "range IRW [cells]" instead of the raw names.
"""

from __future__ import annotations

__all__ = ["key_label", "quantity_label"]

_WORDS = {"rcs": "RCS", "prf": "PRF", "irw": "IRW", "pslr": "PSLR", "islr": "ISLR",
          "bpa": "BPA", "ffbp": "FFBP", "wda": "WDA", "rda": "RDA", "fsa": "FSA",
          "cfar": "CFAR", "mimo": "MIMO", "pga": "PGA", "u": "u", "v": "v"}
"""Words written as acronyms."""

_SUFFIX_UNITS = (("_db", "dB"), ("_deg", "deg"), ("_cells", "cells"), ("_hz", "Hz"),
                 ("_m", "m"), ("_s", "s"), ("_rad", "rad"))
"""Unit suffixes of mitsar's key and quantity names (``off_nadir_deg``, ``peak_offset_m``)."""

_KEY_UNITS = {
    "carrier_frequency": "Hz", "bandwidth": "Hz", "sampling_frequency": "Hz", "prf": "Hz",
    "max_range": "m", "antenna_width": "m", "antenna_length": "m", "transmit_power": "W",
    "duration": "s", "speed": "m/s", "velocity": "m/s", "start": "m", "points": "m",
    "position": "m", "center": "m", "size": "m", "origin": "m", "rcs": "m²",
    "azimuth_resolution": "m", "along_track": "m", "slant_range": "m", "spacing": "m",
    "required_resolution": "m", "noise_figure": "dB", "temperature": "K",
    "sample_rate": "Hz", "frequency": "Hz", "amplitude": "m", "phase": "rad",
    "position_random_walk": "m/√s", "position_noise": "m", "position_offset": "m",
    "lever_arm": "m", "correlation_time": "s", "position_correlation_time": "s",
    "attitude_correlation_time": "s", "tau": "m"}
"""Units of experiment keys without a unit suffix (docs/experiments.md's tables)."""


def _words(name: str) -> str:
    return " ".join(_WORDS.get(word, word) for word in name.split("_") if word)


def _split_unit(name: str, keys: bool = True) -> tuple[str, str | None]:
    """A name without its unit suffix, and the unit (of the suffix, else of an experiment key
    when ``keys``)."""
    for suffix, unit in _SUFFIX_UNITS:
        if name.endswith(suffix) and len(name) > len(suffix):
            return name[: -len(suffix)], unit
    return name, _KEY_UNITS.get(name) if keys else None


def key_label(key: str) -> str:
    """An axis label for an experiment key: its path in words and its unit.

    ``"radar.bandwidth"`` -> ``"radar bandwidth [Hz]"``, ``"background.cell_rcs_db"`` ->
    ``"background cell RCS [dB]"``, ``"look.off_nadir_deg"`` -> ``"look off nadir [deg]"``,
    ``"simulation.seed"`` -> ``"simulation seed"`` (no unit). Indices of arrays of tables
    (``targets.0.rcs``) are kept as numbers.
    """
    parts = key.split(".")
    name, unit = _split_unit(parts[-1])
    text = " ".join([_words(p) for p in parts[:-1]] + [_words(name)])
    return f"{text} [{unit}]" if unit else text


def quantity_label(quantity: str, units: str | None = None) -> str:
    """An axis label for a measured quantity: ``"range_irw_cells"`` -> ``"range IRW
    [cells]"``, ``"peak_offset_m"`` -> ``"peak offset [m]"``, ``"peak_db"`` -> ``"peak level
    [dB]"``; ``units`` (e.g. a table variable's ``units`` attribute) overrides the unit the
    name carries."""
    name, unit = _split_unit(quantity, keys=False)
    unit = units or unit
    text = "peak level" if name == "peak" else _words(name)
    return f"{text} [{unit}]" if unit else text
