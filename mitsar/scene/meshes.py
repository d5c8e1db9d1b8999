"""PLY triangle meshes for the bundled scenes (``scenes/meshes``)."""

from __future__ import annotations

import os
from pathlib import Path
from typing import Any

import numpy as np

from mitsar.errors import ParameterError

__all__ = ["box_mesh", "write_ply"]


def box_mesh(lo: Any, hi: Any, inward: bool = False) -> tuple[np.ndarray, np.ndarray]:
    """An axis-aligned box as 8 vertices and 12 triangles.

    Parameters
    ----------
    lo, hi : array_like, shape (3,)
        Opposite corners [m].
    inward : bool
        Wind the triangles so that the normals point into the box (a room) instead of out.

    Returns
    -------
    vertices : numpy.ndarray, shape (8, 3)
    faces : numpy.ndarray, shape (12, 3), int32
        Counter-clockwise seen from the side the normal points to.
    """
    lo = np.asarray(lo, dtype=np.float64)
    hi = np.asarray(hi, dtype=np.float64)
    if lo.shape != (3,) or hi.shape != (3,) or not np.all(hi > lo):
        raise ParameterError("box_mesh", "lo/hi", "two corners with hi > lo on every axis",
                             (lo.tolist(), hi.tolist()))
    corners = np.array([[x, y, z] for z in (0, 1) for y in (0, 1) for x in (0, 1)], dtype=float)
    vertices = lo + corners * (hi - lo)
    # Outward-facing quads (vertex index = x + 2y + 4z), counter-clockwise from outside.
    quads = [(0, 2, 3, 1), (4, 5, 7, 6), (0, 1, 5, 4), (2, 6, 7, 3), (0, 4, 6, 2), (1, 3, 7, 5)]
    faces = []
    for a, b, c, d in quads:
        tris = [(a, b, c), (a, c, d)]
        faces += [(t[0], t[2], t[1]) for t in tris] if inward else tris
    return vertices, np.array(faces, dtype=np.int32)


def write_ply(path: str | os.PathLike, vertices: Any, faces: Any, normals: Any = None,
              binary: bool = True) -> Path:
    """Write a triangle mesh as PLY (binary little-endian or ASCII) that Mitsuba reads.

    Parameters
    ----------
    path : path-like
        Output file (parent directories are created).
    vertices : array_like, shape (n, 3)
        Vertex positions [m] (stored as float32).
    faces : array_like, shape (m, 3)
        Vertex indices, counter-clockwise seen from the side the normal points to.
    normals : array_like, shape (n, 3), optional
        Vertex normals. Without them, set ``<boolean name="face_normals" value="true"/>`` in the
        XML for flat faces (otherwise Mitsuba smooths normals across edges).
    binary : bool
        Binary little-endian (default) or ASCII.

    Returns
    -------
    pathlib.Path
    """
    v = np.asarray(vertices, dtype=np.float32)
    f = np.asarray(faces, dtype=np.int32)
    if v.ndim != 2 or v.shape[1] != 3 or f.ndim != 2 or f.shape[1] != 3:
        raise ParameterError("write_ply", "vertices/faces", "arrays of shape (n, 3) and (m, 3)",
                             (v.shape, f.shape))
    if f.size and (f.min() < 0 or f.max() >= v.shape[0]):
        raise ParameterError("write_ply", "faces", f"indices in [0, {v.shape[0]})",
                             (int(f.min()), int(f.max())))
    columns = [v]
    props = ["x", "y", "z"]
    if normals is not None:
        nrm = np.asarray(normals, dtype=np.float32)
        if nrm.shape != v.shape:
            raise ParameterError("write_ply", "normals", f"shape {v.shape}", nrm.shape)
        columns.append(nrm)
        props += ["nx", "ny", "nz"]
    data = np.concatenate(columns, axis=1)
    header = ["ply", "format " + ("binary_little_endian" if binary else "ascii") + " 1.0",
              "comment written by mitsar.scene.write_ply", f"element vertex {v.shape[0]}"]
    header += [f"property float {p}" for p in props]
    header += [f"element face {f.shape[0]}", "property list uchar int vertex_indices",
               "end_header"]
    path = Path(path)
    path.parent.mkdir(parents=True, exist_ok=True)
    with path.open("wb") as out:
        out.write(("\n".join(header) + "\n").encode("ascii"))
        if binary:
            out.write(data.astype("<f4").tobytes())
            face_dtype = np.dtype([("n", "u1"), ("i", "<i4", (3,))])
            rec = np.empty(f.shape[0], dtype=face_dtype)
            rec["n"] = 3
            rec["i"] = f
            out.write(rec.tobytes())
        else:
            for row in data:
                out.write((" ".join(f"{x:.9g}" for x in row) + "\n").encode("ascii"))
            for tri in f:
                out.write(f"3 {tri[0]} {tri[1]} {tri[2]}\n".encode("ascii"))
    return path
