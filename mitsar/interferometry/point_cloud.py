"""Point clouds of an interferogram, and their PLY files.

:func:`point_cloud` keeps the pixels of an interferogram (:func:`mitsar.interferometry.
interferogram`) with a solved position and enough coherence, as a ("point",) dataset;
:func:`write_ply` writes it as a binary little-endian PLY (Turk's polygon file format, read by
CloudCompare, Open3D, MeshLab) through ``plyfile``, atomically (:func:`mitsar.io.atomic_output`:
a temporary file in the same folder, then :func:`os.replace`). docs/interferometry.md §6.
"""

from __future__ import annotations

import os

import numpy as np
import plyfile
import xarray as xr

from mitsar.errors import ParameterError
from mitsar.io import atomic_output

__all__ = ["POINT_VARIABLES", "point_cloud", "write_ply"]

POINT_VARIABLES: dict[str, tuple[str, str]] = {
    "x": ("m", "world x of the scatterer"),
    "y": ("m", "world y of the scatterer"),
    "z": ("m", "world z of the scatterer"),
    "amplitude": ("1", "geometric mean amplitude of the two channels (image units)"),
    "coherence": ("1", "coherence estimate"),
    "height_std": ("m", "predicted height standard deviation (Cramer-Rao)"),
}
"""Variables of a point cloud: (CF units, long_name)."""


def point_cloud(ifg: xr.Dataset, min_coherence: float = 0.5) -> xr.Dataset:
    """The solved scatterers of an interferogram as points.

    Parameters
    ----------
    ifg : xarray.Dataset
        Output of :func:`mitsar.interferometry.interferogram`.
    min_coherence : float
        Pixels of lower coherence [1] are left out (as are pixels without a position).

    Returns
    -------
    xarray.Dataset
        Dims ("point",); variables of :data:`POINT_VARIABLES` (float64, CF units and
        long_name); the interferogram's attributes with ``product = "point_cloud"``.
    """
    needed = ("position", "amplitude", "coherence", "height_std")
    if not isinstance(ifg, xr.Dataset) or any(name not in ifg for name in needed):
        raise ParameterError("point_cloud", "ifg", f"an interferogram dataset with {needed}",
                             type(ifg).__name__ if not isinstance(ifg, xr.Dataset)
                             else sorted(map(str, ifg.variables)))
    if not 0.0 <= float(min_coherence) <= 1.0:
        raise ParameterError("point_cloud", "min_coherence", "a coherence in [0, 1]",
                             min_coherence)
    grid = tuple(d for d in ifg["position"].dims if d != "xyz")
    position = ifg["position"].transpose(*grid, "xyz").values.reshape(-1, 3)
    gamma = ifg["coherence"].transpose(*grid).values.reshape(-1)
    keep = np.isfinite(position).all(axis=-1) & (np.nan_to_num(gamma) >= min_coherence)
    columns = {"x": position[keep, 0], "y": position[keep, 1], "z": position[keep, 2],
               "amplitude": ifg["amplitude"].transpose(*grid).values.reshape(-1)[keep],
               "coherence": gamma[keep],
               "height_std": ifg["height_std"].transpose(*grid).values.reshape(-1)[keep]}
    cloud = xr.Dataset({name: ("point", np.asarray(values, float))
                        for name, values in columns.items()})
    for name, (units, long_name) in POINT_VARIABLES.items():
        cloud[name].attrs.update(units=units, long_name=long_name)
    cloud.attrs.update(ifg.attrs)
    cloud.attrs.update(product="point_cloud", min_coherence=float(min_coherence))
    return cloud


def write_ply(cloud: xr.Dataset, path: str | os.PathLike, overwrite: bool = False) -> None:
    """Write a point cloud as a binary little-endian PLY file, atomically.

    The ``vertex`` element holds ``x``, ``y``, ``z`` (float64, metres, world frame) and the
    per-point ``amplitude``, ``coherence`` and ``height_std`` (float32); the header's comments
    name the units and mitsar.

    Parameters
    ----------
    cloud : xarray.Dataset
        Output of :func:`point_cloud`.
    path : path-like
        Output ``.ply`` file.
    overwrite : bool
        Replace an existing file.

    Raises
    ------
    mitsar.io.OutputExistsError
        If ``path`` exists and ``overwrite`` is false (a :class:`mitsar.errors.MitsarError`).
    """
    if not isinstance(cloud, xr.Dataset) or any(name not in cloud for name in POINT_VARIABLES):
        raise ParameterError("write_ply", "cloud", f"a point cloud with {tuple(POINT_VARIABLES)}",
                             type(cloud).__name__)
    dtype = [("x", "<f8"), ("y", "<f8"), ("z", "<f8"), ("amplitude", "<f4"),
             ("coherence", "<f4"), ("height_std", "<f4")]
    vertex = np.empty(cloud.sizes.get("point", 0), dtype=dtype)
    for name, _ in dtype:
        vertex[name] = cloud[name].values
    comments = ["mitsar interferometric point cloud; x y z [m] world frame (z up)",
                "amplitude [image units], coherence [1], height_std [m]"]
    data = plyfile.PlyData([plyfile.PlyElement.describe(vertex, "vertex")], text=False,
                           byte_order="<", comments=comments)
    with atomic_output(path, overwrite=overwrite) as tmp:
        data.write(str(tmp))
