"""Point targets and the fluctuating background of paper §3.1 (eq. 4).

The background is a patch of at least nine point scatterers per resolution cell whose complex
reflectivities are circular Gaussian: Rayleigh amplitude, uniform phase, mean power per cell
``sigma_cell`` (paper eq. 4; Ulaby & Dobson). In ``"pulse"`` mode (as the paper) the
reflectivities are drawn anew for every sweep; in ``"frozen"`` mode once per acquisition, which
is coherent speckle that focuses.
"""

from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Literal

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.checks import check_units, integer, level_db, rcs, vector
from mitsar.errors import ParameterError


def _vector3(where: str, name: str, value: ArrayLike) -> tuple[float, float, float]:
    """A 3-vector parameter as a tuple of floats (:func:`mitsar.checks.vector`)."""
    return tuple(float(v) for v in vector(where, name, value))


@dataclass(frozen=True)
class PointTarget:
    """An ideal point scatterer.

    Parameters
    ----------
    position : array_like, shape (3,)
        Position at slow time 0 [m].
    rcs : float
        Radar cross section sigma [m^2].
    velocity : array_like, shape (3,)
        Constant velocity [m/s].
    """

    position: tuple[float, float, float]
    rcs: float = 1.0
    velocity: tuple[float, float, float] = (0.0, 0.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "position", _vector3("PointTarget", "position", self.position))
        object.__setattr__(self, "velocity", _vector3("PointTarget", "velocity", self.velocity))
        object.__setattr__(self, "rcs", rcs("PointTarget", "rcs", self.rcs))
        check_units("PointTarget", self, {"position": "m", "velocity": "m/s"})  # issue 27


@dataclass(frozen=True)
class Background:
    """A rectangular patch of fluctuating background (paper eq. 4).

    Parameters
    ----------
    center : array_like, shape (3,)
        Centre of the patch [m].
    size : array_like, shape (2,)
        Extent along ``axis_u`` and ``axis_v`` [m].
    cell_rcs_db : float
        Mean RCS of one resolution cell [dBsm]; the paper uses -10 and -20 dB below a 1 m^2
        target.
    scatterers_per_cell : int
        Scatterers per resolution cell (paper: at least 9).
    mode : {"pulse", "frozen"}
        Redraw reflectivities every sweep (paper) or once.
    axis_u, axis_v : array_like, shape (3,)
        Orthonormal axes of the patch plane (default the ground plane).
    """

    center: tuple[float, float, float]
    size: tuple[float, float]
    cell_rcs_db: float = -20.0
    scatterers_per_cell: int = 9
    mode: Literal["pulse", "frozen"] = "pulse"
    axis_u: tuple[float, float, float] = (1.0, 0.0, 0.0)
    axis_v: tuple[float, float, float] = (0.0, 1.0, 0.0)

    def __post_init__(self) -> None:
        object.__setattr__(self, "center", _vector3("Background", "center", self.center))
        object.__setattr__(self, "axis_u", _vector3("Background", "axis_u", self.axis_u))
        object.__setattr__(self, "axis_v", _vector3("Background", "axis_v", self.axis_v))
        size = vector("Background", "size", self.size, 2, "2 extents > 0 m")
        if not np.all(size > 0):
            raise ParameterError("Background", "size", "2 extents > 0 m", self.size)
        object.__setattr__(self, "size", (float(size[0]), float(size[1])))
        level_db("Background", "cell_rcs_db", self.cell_rcs_db)
        check_units("Background", self, {"center": "m", "size": "m", "cell_rcs_db": "dB"})
        if self.mode not in ("pulse", "frozen"):
            raise ParameterError("Background", "mode", "'pulse' or 'frozen'", self.mode)
        integer("Background", "scatterers_per_cell", self.scatterers_per_cell, 1,
                "an integer >= 1 (paper: 9)")
        u, v = np.asarray(self.axis_u), np.asarray(self.axis_v)
        if abs(np.linalg.norm(u) - 1) > 1e-6 or abs(np.linalg.norm(v) - 1) > 1e-6 \
                or abs(u @ v) > 1e-6:
            raise ParameterError("Background", "axis_u/axis_v", "orthonormal unit vectors",
                                 (self.axis_u, self.axis_v))

    @property
    def cell_rcs(self) -> float:
        """Mean RCS of a resolution cell [m^2]."""
        return 10 ** (self.cell_rcs_db / 10)

    def scatterer_count(self, cell_area: float) -> int:
        """Number of scatterers for resolution cells of ``cell_area`` m^2 in the patch."""
        cells = self.size[0] * self.size[1] / cell_area
        return int(math.ceil(self.scatterers_per_cell * cells))

    def draw_positions(self, count: int, rng: np.random.Generator) -> NDArray[np.float64]:
        """Uniform scatterer positions over the patch; shape (count, 3) [m]."""
        uv = (rng.random((count, 2)) - 0.5) * np.asarray(self.size)
        return (np.asarray(self.center) + uv[:, :1] * np.asarray(self.axis_u)
                + uv[:, 1:] * np.asarray(self.axis_v))

    def draw_reflectivities(self, shape: tuple[int, ...], rng: np.random.Generator,
                            cell_area: float) -> NDArray[np.complex128]:
        """Circular Gaussian reflectivities sqrt(RCS) per scatterer (paper eq. 4).

        Each has mean power ``sigma_cell / n_per_cell`` so that a cell holds ``sigma_cell`` on
        average; the amplitude is Rayleigh and the phase uniform on [-pi, pi).

        Parameters
        ----------
        shape : tuple of int
            ``(count,)`` for frozen mode, ``(sweeps, count)`` for pulse mode.
        rng : numpy.random.Generator
        cell_area : float
            Area of one resolution cell [m^2].
        """
        count = shape[-1]
        cells = self.size[0] * self.size[1] / cell_area
        mean_power = self.cell_rcs * cells / count
        gaussian = rng.standard_normal(shape + (2,))
        return np.sqrt(mean_power / 2) * (gaussian[..., 0] + 1j * gaussian[..., 1])
