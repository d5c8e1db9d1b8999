"""Building materials of ITU-R P.2040-3 (Table 3): permittivity and conductivity against frequency.

Recommendation ITU-R P.2040-3, "Effects of building materials and structures on radiowave
propagation above about 100 MHz", §2.1.4 and Table 3, models a material by four
coefficients fitted to measurements,

    ε_r' = a f_GHz^b,        σ = c f_GHz^d   [S/m],

valid over a stated frequency range; the complex relative permittivity is
``η = ε_r' − j σ/(2π f ε₀)`` (P.2040-3: ``ε_r'' = 17.98 σ / f_GHz``), with the
``exp(+jωt)`` convention. The coefficients below are the 1–100 GHz rows of Table 3 as Sionna RT
tabulates them for its ``itu-radio-material`` (Sionna RT documentation, "Radio Materials");
the rows ITU-R P.2040-4 added above 100 GHz are not included (mitsar's carrier is 94 GHz).
"""

from __future__ import annotations

import math
from typing import NamedTuple

from mitsar.errors import ParameterError

__all__ = ["ITU_MATERIALS", "ItuCoefficients", "VACUUM_PERMITTIVITY", "complex_permittivity",
           "itu_material_names", "itu_properties"]

VACUUM_PERMITTIVITY = 8.8541878128e-12
"""ε₀ [F/m] (CODATA 2018)."""


class ItuCoefficients(NamedTuple):
    """One row of ITU-R P.2040-3 Table 3."""

    a: float
    """ε_r' at 1 GHz [-]."""
    b: float
    """Frequency exponent of ε_r' [-]."""
    c: float
    """σ at 1 GHz [S/m]."""
    d: float
    """Frequency exponent of σ [-]."""
    f_min_ghz: float
    """Lowest frequency of validity [GHz]."""
    f_max_ghz: float
    """Highest frequency of validity [GHz]."""


ITU_MATERIALS: dict[str, ItuCoefficients] = {
    "vacuum": ItuCoefficients(1.0, 0.0, 0.0, 0.0, 0.001, 100.0),
    "concrete": ItuCoefficients(5.24, 0.0, 0.0462, 0.7822, 1.0, 100.0),
    "brick": ItuCoefficients(3.91, 0.0, 0.0238, 0.16, 1.0, 40.0),
    "plasterboard": ItuCoefficients(2.73, 0.0, 0.0085, 0.9395, 1.0, 100.0),
    "wood": ItuCoefficients(1.99, 0.0, 0.0047, 1.0718, 0.001, 100.0),
    "glass": ItuCoefficients(6.31, 0.0, 0.0036, 1.3394, 0.1, 100.0),
    "ceiling_board": ItuCoefficients(1.48, 0.0, 0.0011, 1.0750, 1.0, 100.0),
    "chipboard": ItuCoefficients(2.58, 0.0, 0.0217, 0.7800, 1.0, 100.0),
    "plywood": ItuCoefficients(2.71, 0.0, 0.33, 0.0, 1.0, 40.0),
    "marble": ItuCoefficients(7.074, 0.0, 0.0055, 0.9262, 1.0, 60.0),
    "floorboard": ItuCoefficients(3.66, 0.0, 0.0044, 1.3515, 50.0, 100.0),
    "metal": ItuCoefficients(1.0, 0.0, 1.0e7, 0.0, 1.0, 100.0),
    "very_dry_ground": ItuCoefficients(3.0, 0.0, 0.00015, 2.52, 1.0, 10.0),
    "medium_dry_ground": ItuCoefficients(15.0, -0.1, 0.035, 1.63, 1.0, 10.0),
    "wet_ground": ItuCoefficients(30.0, -0.4, 0.15, 1.30, 1.0, 10.0),
}
"""ITU-R P.2040-3 Table 3 (name as Sionna RT's ``itu-radio-material`` ``type``)."""


def itu_material_names() -> list[str]:
    """Names of the ITU materials, sorted."""
    return sorted(ITU_MATERIALS)


def itu_properties(name: str, frequency: float, where: str = "itu_properties"
                   ) -> tuple[float, float]:
    """``(ε_r', σ)`` of an ITU-R P.2040-3 material at ``frequency``.

    Parameters
    ----------
    name : str
        Material name (:func:`itu_material_names`).
    frequency : float
        Frequency [Hz], inside the material's range of validity.
    where : str
        Caller named in errors (e.g. the XML element).

    Returns
    -------
    relative_permittivity : float
        ``a f_GHz^b`` [-].
    conductivity : float
        ``c f_GHz^d`` [S/m].

    Raises
    ------
    ParameterError
        For an unknown name, or a frequency outside the row's range (Table 3 gives no value
        there; use ``radio-material`` with explicit values instead).
    """
    if name not in ITU_MATERIALS:
        raise ParameterError(where, "type", f"one of the ITU-R P.2040-3 materials "
                             f"{itu_material_names()}", name)
    row = ITU_MATERIALS[name]
    f_ghz = float(frequency) / 1e9
    if not row.f_min_ghz <= f_ghz <= row.f_max_ghz:
        raise ParameterError(
            where, "frequency",
            f"a frequency within {row.f_min_ghz:g}-{row.f_max_ghz:g} GHz, where ITU-R P.2040-3 "
            f"Table 3 defines '{name}' (or a 'radio-material' with explicit "
            f"relative_permittivity and conductivity)", frequency)
    return row.a * f_ghz**row.b, row.c * f_ghz**row.d


def complex_permittivity(relative_permittivity: float, conductivity: float,
                         frequency: float) -> complex:
    """Complex relative permittivity ``η = ε_r' − j σ/(2π f ε₀)`` (ITU-R P.2040-3 §2.1.4).

    Parameters
    ----------
    relative_permittivity : float
        Real part ε_r' [-].
    conductivity : float
        σ [S/m].
    frequency : float
        f [Hz].

    Returns
    -------
    complex
        η [-], imaginary part <= 0 (``exp(+jωt)`` convention).
    """
    return complex(relative_permittivity,
                   -conductivity / (2.0 * math.pi * frequency * VACUUM_PERMITTIVITY))
