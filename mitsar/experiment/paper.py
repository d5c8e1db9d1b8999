"""The paper's published numbers that mitsar's runs are compared with.

Scannapieco, Renga & Moccia 2016, Tables 4 and 5: Monte Carlo means and variances of IRW
(cells), PSLR and ISLR (dB) of a unit point target on a fluctuating background of -20 dB and
-10 dB mean RCS per cell, for BPA, WDA, RDA and FSA, range and azimuth (paper §4.1).
"""

from __future__ import annotations

import math

__all__ = ["PAPER_TABLES", "paper_table"]

# (mean, variance) per algorithm, direction and metric, in the papers' row order.
_ROWS = {
    -20.0: {  # Table 4
        "bpa": ((0.865, 0.006, -13.192, 0.269, -10.686, 0.134),
                (0.823, 0.003, -12.682, 0.298, -9.695, 1.054)),
        "wda": ((0.887, 0.004, -13.102, 0.244, -10.217, 0.134),
                (0.809, 0.003, -12.670, 0.272, -10.258, 0.141)),
        "rda": ((0.883, 0.004, -13.145, 0.248, -10.335, 0.132),
                (0.799, 0.003, -12.632, 0.270, -10.037, 0.341)),
        "fsa": ((0.887, 0.011, -12.925, 0.216, -10.571, 0.153),
                (0.841, 0.005, -11.615, 0.233, -9.600, 1.035)),
    },
    -10.0: {  # Table 5
        "bpa": ((0.859, 0.081, -10.195, 1.850, -6.636, 1.309),
                (0.832, 0.020, -9.905, 1.312, -3.625, 3.356)),
        "wda": ((0.874, 0.038, -10.104, 1.839, -5.604, 1.268),
                (0.807, 0.033, -10.414, 1.356, -5.818, 1.287)),
        "rda": ((0.878, 0.053, -10.284, 1.887, -5.924, 1.213),
                (0.809, 0.020, -10.589, 1.264, -4.982, 1.551)),
        "fsa": ((0.873, 0.112, -9.691, 1.952, -6.125, 1.338),
                (0.809, 0.043, -7.068, 3.105, -5.395, 1.533)),
    },
}

_METRICS = ("irw_cells", "pslr_db", "islr_db")

PAPER_TABLES: dict[float, dict[str, dict[str, dict[str, tuple[float, float]]]]] = {
    level: {algorithm: {direction: {metric: (row[2 * i], row[2 * i + 1])
                                    for i, metric in enumerate(_METRICS)}
                        for direction, row in zip(("range", "azimuth"), rows, strict=True)}
            for algorithm, rows in table.items()}
    for level, table in _ROWS.items()}
"""``PAPER_TABLES[cell_rcs_db][algorithm][direction][metric] = (mean, variance)``."""


def paper_table(cell_rcs_db: float | None) -> dict | None:
    """The paper's table for a background level [dB] (Table 4 for -20, 5 for -10), else None."""
    if cell_rcs_db is None or not math.isfinite(cell_rcs_db):
        return None
    for level, table in PAPER_TABLES.items():
        if abs(level - cell_rcs_db) < 1e-9:
            return table
    return None
