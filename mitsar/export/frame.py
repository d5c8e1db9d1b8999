"""The lab frame on the Earth: indoor metres (x, y, z up) to WGS-84 Earth-centred, Earth-fixed.

NGA products (SICD, CPHD) state every position in WGS-84 ECF metres. mitsar's scenes are
indoors, in a lab frame with z up (docs/conventions.md, units and frames). :class:`LabOrigin`
places that frame on the Earth: its origin at a geodetic latitude, longitude and height above
the ellipsoid, z along the ellipsoid normal (local up), and x at a compass azimuth (clockwise
from north); y = z × x completes a right-handed frame. The map is the rigid motion

``X_ecf = O_ecf + M (x, y, z)``, ``M = [x_hat | y_hat | z_hat]`` in ECF,

with the local east/north/up vectors of WGS-84 (NGA.STND.0036, WGS 84 definition; the same
relations as NGA.STND.0024-1 SICD Vol. 1 §2 and NGA.STND.0068-1 CPHD §2). It is exact and
invertible: a lab point stays a flat-Earth point, so its ellipsoidal height differs from
``height_m + z`` by the Earth's curvature, ``d² / (2 R)`` (70 µm 30 m from the origin).
"""

from __future__ import annotations

import math
from dataclasses import dataclass

import numpy as np
from numpy.typing import ArrayLike, NDArray

from mitsar.checks import finite
from mitsar.errors import ParameterError

__all__ = ["DEFAULT_ORIGIN", "LabOrigin", "WGS84_A", "WGS84_E2", "geodetic_to_ecf"]

WGS84_A = 6378137.0
"""WGS-84 semi-major axis [m]."""

WGS84_E2 = 6.69437999014e-3
"""WGS-84 first eccentricity squared."""


def geodetic_to_ecf(latitude_deg: float, longitude_deg: float, height_m: float
                    ) -> NDArray[np.float64]:
    """ECF position [m] of a geodetic point on WGS-84 (closed form)."""
    lat, lon = math.radians(latitude_deg), math.radians(longitude_deg)
    normal = WGS84_A / math.sqrt(1.0 - WGS84_E2 * math.sin(lat) ** 2)
    return np.array([(normal + height_m) * math.cos(lat) * math.cos(lon),
                     (normal + height_m) * math.cos(lat) * math.sin(lon),
                     (normal * (1.0 - WGS84_E2) + height_m) * math.sin(lat)])


@dataclass(frozen=True)
class LabOrigin:
    """Where the lab frame sits on the Earth (module docstring).

    Parameters
    ----------
    latitude_deg, longitude_deg : float
        Geodetic latitude and longitude of the lab origin (WGS-84) [deg].
    height_m : float
        Height of the lab origin above the WGS-84 ellipsoid [m].
    azimuth_deg_of_x : float
        Compass azimuth of the lab x axis, clockwise from north [deg]: 90 puts x east and y
        north (the lab frame is then local east-north-up).
    """

    latitude_deg: float = 40.8279
    longitude_deg: float = 14.1931
    height_m: float = 0.0
    azimuth_deg_of_x: float = 90.0

    def __post_init__(self) -> None:
        lat = finite("LabOrigin", "latitude_deg", self.latitude_deg)
        if not -90.0 < lat < 90.0:
            raise ParameterError("LabOrigin", "latitude_deg", "a latitude in (-90, 90) deg", lat)
        for name in ("latitude_deg", "longitude_deg", "height_m", "azimuth_deg_of_x"):
            object.__setattr__(self, name, finite("LabOrigin", name, getattr(self, name)))

    @property
    def ecf(self) -> NDArray[np.float64]:
        """ECF position of the lab origin [m]."""
        return geodetic_to_ecf(self.latitude_deg, self.longitude_deg, self.height_m)

    @property
    def rotation(self) -> NDArray[np.float64]:
        """``M``: columns are the lab x, y, z unit vectors in ECF."""
        lat, lon = math.radians(self.latitude_deg), math.radians(self.longitude_deg)
        east = np.array([-math.sin(lon), math.cos(lon), 0.0])
        north = np.array([-math.sin(lat) * math.cos(lon), -math.sin(lat) * math.sin(lon),
                          math.cos(lat)])
        up = np.array([math.cos(lat) * math.cos(lon), math.cos(lat) * math.sin(lon),
                       math.sin(lat)])
        azimuth = math.radians(self.azimuth_deg_of_x)
        x_axis = math.sin(azimuth) * east + math.cos(azimuth) * north
        y_axis = np.cross(up, x_axis)
        return np.column_stack([x_axis, y_axis, up])

    def to_ecf(self, points: ArrayLike) -> NDArray[np.float64]:
        """Lab positions [m], shape (..., 3), to ECF [m]."""
        return self.ecf + np.asarray(points, dtype=float) @ self.rotation.T

    def vectors_to_ecf(self, vectors: ArrayLike) -> NDArray[np.float64]:
        """Lab directions or velocities, shape (..., 3), to ECF (rotation only)."""
        return np.asarray(vectors, dtype=float) @ self.rotation.T

    def from_ecf(self, points: ArrayLike) -> NDArray[np.float64]:
        """ECF positions [m], shape (..., 3), to the lab frame [m]."""
        return (np.asarray(points, dtype=float) - self.ecf) @ self.rotation

    def vectors_from_ecf(self, vectors: ArrayLike) -> NDArray[np.float64]:
        """ECF directions or velocities, shape (..., 3), to the lab frame."""
        return np.asarray(vectors, dtype=float) @ self.rotation

    def to_parameters(self) -> dict[str, str]:
        """The mapping as name/value strings, recorded in the NGA products."""
        return {"mitsar.lab_origin.latitude_deg": repr(self.latitude_deg),
                "mitsar.lab_origin.longitude_deg": repr(self.longitude_deg),
                "mitsar.lab_origin.height_m": repr(self.height_m),
                "mitsar.lab_origin.azimuth_deg_of_x": repr(self.azimuth_deg_of_x)}

    @classmethod
    def from_parameters(cls, parameters: dict[str, str]) -> LabOrigin | None:
        """Inverse of :meth:`to_parameters` (None when the mapping is not recorded)."""
        keys = ("latitude_deg", "longitude_deg", "height_m", "azimuth_deg_of_x")
        names = [f"mitsar.lab_origin.{key}" for key in keys]
        if not all(name in parameters for name in names):
            return None
        return cls(*(float(parameters[name]) for name in names))


DEFAULT_ORIGIN = LabOrigin()
"""The default lab origin: 40.8279 N, 14.1931 E, 0 m above the ellipsoid, x east — roughly the
University of Naples Federico II, Fuorigrotta (the paper's authors' institution). Arbitrary but
fixed, so exported products are reproducible; pass your lab's own origin for real data."""
