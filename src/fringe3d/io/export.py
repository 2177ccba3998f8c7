"""Write point clouds and meshes in the format their file name asks for.

:func:`write_points` (``.ply``, ``.vtp``, ``.e57``, ``.las``, ``.laz``, ``.mat``) and :func:`write_mesh`
(``.stl``, ``.obj``, ``.glb``, ``.ply``) choose the writer by suffix (case-insensitive); an
unknown suffix is a ValueError naming the file and the suffixes supported. Units and what each
format keeps: ``docs/file-formats.md`` and each writer's module.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Callable

import numpy as np

from .e57_points import write_e57
from .las_points import write_las
from .mat_points import write_mat
from .mesh_formats import write_glb, write_obj, write_ply_mesh, write_stl
from .ply_standard import Scalars, write_standard_ply
from .point_set import PointSet, point_set
from .vtk_points import write_vtp


#: suffix -> writer of a point set.
POINT_WRITERS: dict[str, Callable[[str | os.PathLike, PointSet], Path]] = {
    ".vtp": write_vtp, ".e57": write_e57, ".las": write_las, ".laz": write_las, ".mat": write_mat}
POINT_SUFFIXES = (".ply", *POINT_WRITERS)
MESH_SUFFIXES = (".stl", ".obj", ".glb", ".ply")


def check_suffix(path, supported, what: str) -> str:
    """``path``'s suffix, lower-case; ValueError naming the file and the ``supported`` suffixes."""
    s = Path(path).suffix.lower()
    if s not in supported:
        raise ValueError(f"cannot write {what} to {path}: unknown suffix {s or '(none)'!r}; "
                         f"supported: {', '.join(supported)}")
    return s


def write_points(path: str | os.PathLike, points, attributes: Scalars | None = None, *, colors=None,
                 normals: bool = True, mask=None) -> Path:
    """Write a point cloud in the format of ``path``'s suffix.

    Parameters
    ----------
    path : output file, ``.ply``, ``.vtp``, ``.e57``, ``.las``, ``.laz`` or ``.mat``
    points : (H, W, 3) organized map or (N, 3) list, float, mm, NaN = no point
    attributes : ``name -> (values of the points' leading shape, description with units)``, optional
    colors : grey or RGB texture of the points' leading shape, float [0, 1] or uint8, optional
    normals : write grid normals of an organized map (finite at every point written)
    mask : bool array of the points' leading shape, optional

    Returns the path written. ValueError for an unknown suffix, no valid point or a shape mismatch.
    """
    s = check_suffix(path, POINT_SUFFIXES, "points")
    if s == ".ply":
        P = np.asarray(points, np.float32)
        return write_standard_ply(path, P, colors, scalars=attributes, normals=normals and P.ndim == 3, mask=mask)
    return POINT_WRITERS[s](path, point_set(path, points, attributes, colors=colors, normals=normals, mask=mask))


def write_mesh(path: str | os.PathLike, vertices, faces, *, colors=None, attributes: Scalars | None = None) -> Path:
    """Write a triangle mesh in the format of ``path``'s suffix.

    Parameters
    ----------
    path : output file, ``.stl``, ``.obj``, ``.glb`` or ``.ply``
    vertices : (V, 3) float, mm
    faces : (F, 3) int vertex indices
    colors : per-vertex grey (V,) or RGB (V, 3), optional (OBJ, GLB, PLY; STL has none)
    attributes : per-vertex scalars ``name -> ((V,), description)`` (PLY only)
    """
    s = check_suffix(path, MESH_SUFFIXES, "a mesh")
    if attributes and s != ".ply":
        raise ValueError(f"per-vertex attributes {sorted(attributes)} cannot be stored in {path}; "
                         "only .ply meshes keep scalar fields")
    if s == ".stl":
        return write_stl(path, vertices, faces)
    if s == ".obj":
        return write_obj(path, vertices, faces, colors)
    if s == ".glb":
        return write_glb(path, vertices, faces, colors)
    return write_ply_mesh(path, vertices, faces, colors, attributes)
