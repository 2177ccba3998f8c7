"""Triangle meshes as the files CAD, printing and web tools open: STL, OBJ, GLB (written by
trimesh) and PLY (the project's own writer, :mod:`fringe3d.io.ply_standard`).

Units: fringe3d works in millimetres. STL and OBJ carry no unit field; the STL's 80-byte header
and the OBJ's first comment say ``units: mm`` and the coordinates are mm. glTF (GLB) defines its
unit as the metre (glTF 2.0 specification, section 3.5.1), so GLB vertices are written in metres
(mm / 1000) and the file's ``asset.extras`` records ``{"units": "m", "source_units": "mm"}``.
Every file appears only once complete (:func:`fringe3d.utils.atomic.atomic_path`).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path

from .ply_standard import Scalars, write_mesh_ply
from .point_attributes import colors_u8

#: The 80-byte binary STL header fringe3d writes (the format has no unit field).
STL_HEADER = b"fringe3d mesh; units: mm".ljust(80, b" ")


def mesh_arrays(path, vertices, faces) -> tuple[np.ndarray, np.ndarray]:
    """``vertices (V, 3)`` float64 mm and ``faces (F, 3)`` int64, checked: finite vertices,
    indices in range. ValueError naming ``path`` otherwise."""
    V = np.asarray(vertices, np.float64)
    F = np.asarray(faces)
    if V.ndim != 2 or V.shape[1] != 3 or len(V) == 0:
        raise ValueError(f"mesh for {path}: vertices must be (V, 3) in mm with V > 0, got {V.shape}")
    if not np.all(np.isfinite(V)):
        raise ValueError(f"mesh for {path}: vertices hold NaN or inf; expected finite coordinates in mm")
    if F.ndim != 2 or F.shape[1] != 3 or F.dtype.kind not in "iu":
        raise ValueError(f"mesh for {path}: faces must be (F, 3) integer vertex indices, got {F.shape} {F.dtype}")
    if len(F) and (F.min() < 0 or F.max() >= len(V)):
        raise ValueError(f"mesh for {path}: face indices must lie in [0, {len(V) - 1}], "
                         f"got [{F.min()}, {F.max()}]")
    return V, F.astype(np.int64)


def _trimesh(V, F, colors):
    import trimesh  # heavy: loaded only when a mesh is written

    mesh = trimesh.Trimesh(V, F, process=False)
    if colors is not None:
        c = colors_u8(colors, (len(V),))
        mesh.visual.vertex_colors = np.concatenate([c, np.full((len(V), 1), 255, np.uint8)], axis=1)
    return mesh


def write_stl(path: str | os.PathLike, vertices, faces) -> Path:
    """Binary STL (mm; ``units: mm`` in the 80-byte header). Colours and scalars have no place
    in STL and are not written."""
    V, F = mesh_arrays(path, vertices, faces)
    data = bytearray(_trimesh(V, F, None).export(file_type="stl"))
    data[:80] = STL_HEADER
    return _write(path, bytes(data))


def write_obj(path: str | os.PathLike, vertices, faces, colors=None) -> Path:
    """Wavefront OBJ (mm; a ``# units: mm`` comment), vertex colours as ``v x y z r g b`` when given."""
    import trimesh

    V, F = mesh_arrays(path, vertices, faces)
    text = trimesh.exchange.obj.export_obj(_trimesh(V, F, colors), include_normals=False, digits=9,
                                           header="fringe3d mesh; units: mm")
    return _write(path, text.encode("utf-8"))


def write_glb(path: str | os.PathLike, vertices, faces, colors=None) -> Path:
    """Binary glTF (metres, as glTF requires; ``asset.extras`` says so), vertex colours when given."""
    import trimesh

    V, F = mesh_arrays(path, vertices, faces)
    scene = trimesh.Scene(_trimesh(V / 1000.0, F, colors))
    scene.metadata["units"] = "m"
    scene.metadata["source_units"] = "mm"
    data = trimesh.exchange.gltf.export_glb(scene, include_normals=False)
    return _write(path, data)


def write_ply_mesh(path: str | os.PathLike, vertices, faces, colors=None, scalars: Scalars | None = None) -> Path:
    """PLY mesh through the project's writer (mm, ``scalar_<name>`` fields, units in the header)."""
    V, F = mesh_arrays(path, vertices, faces)
    return write_mesh_ply(path, V, F, colors, scalars=scalars)


def _write(path, data: bytes) -> Path:
    path = Path(path)
    with atomic_path(path) as tmp, open(tmp, "wb") as f:
        f.write(data)
    return path
