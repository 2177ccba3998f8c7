"""PLY files for other tools: points with normals, colour, a per-point quality scalar and,
optionally, the triangle faces of the pixel grid; units and provenance in header comments.

Layout (binary little-endian, or ASCII)::

    ply
    format binary_little_endian 1.0
    comment units: mm
    comment <caller's comments: fringe3d version, command, frame ...>
    element vertex N
    property float x / y / z          # mm
    property float nx / ny / nz       # unit normal towards the camera (from the grid)
    property uchar red / green / blue # texture (when given)
    property float quality            # per-point quality (when given; the comment names it)
    element face F                    # only with faces
    property list uchar int vertex_indices
    end_header

MeshLab, CloudCompare, Open3D and trimesh read it (``quality`` is MeshLab's per-vertex quality
name). Points without a normal (grid border, lone pixels) get NaN normals rather than being
dropped, so a point map and its PLY hold the same points.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.output_folder import provenance_comments

from .grid_mesh import grid_faces, local_roughness
from .pointcloud import _colors, organized_normals


def _header(n: int, fields: list[tuple[str, str]], n_faces: int | None, comments, binary: bool) -> bytes:
    lines = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", "comment units: mm"]
    lines += [f"comment {' '.join(str(c).split())}" for c in comments]
    lines.append(f"element vertex {n}")
    lines += [f"property {t} {name}" for name, t in fields]
    if n_faces is not None:
        lines += [f"element face {n_faces}", "property list uchar int vertex_indices"]
    return ("\n".join(lines) + "\nend_header\n").encode("ascii")


def write_standard_ply(path: str | os.PathLike, points, texture=None, *, quality=None, quality_name: str = "",
                       faces: bool = False, comments=(), binary: bool = True) -> Path:
    """Write an organized point map ``(H, W, 3)`` (mm, NaN invalid) as a PLY file, atomically.

    Parameters
    ----------
    path : output ``.ply``
    points : (H, W, 3) float, mm
    texture : (H, W) grey or (H, W, 3) RGB, float [0, 1] or uint8, optional
    quality : (H, W) float, optional
        Per-point scalar written as ``quality``; ``quality_name`` says what it is (a comment).
    faces : bool
        Also write the grid's triangles (:func:`fringe3d.io.grid_mesh.grid_faces`).
    comments : iterable of str
        Extra header comments (one line each), e.g. version and command.
    binary : binary little-endian (default) or ASCII

    Returns the path; ValueError when no point is valid or shapes disagree.
    """
    P = np.asarray(points, np.float32)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"a PLY with normals needs an organized point map (H, W, 3) in mm, got {P.shape}")
    lead = P.shape[:2]
    valid = np.all(np.isfinite(P), axis=-1).ravel()
    if not valid.any():
        raise ValueError(f"no valid point to write to {path} (all NaN); expected at least one finite point")
    fields = [(a, "float") for a in ("x", "y", "z", "nx", "ny", "nz")]
    cols = {"x": P[..., 0], "y": P[..., 1], "z": P[..., 2]}
    N = organized_normals(P)
    cols.update(nx=N[..., 0], ny=N[..., 1], nz=N[..., 2])
    if texture is not None:
        C = _colors(texture, lead)
        fields += [(a, "uchar") for a in ("red", "green", "blue")]
        cols.update(red=C[..., 0], green=C[..., 1], blue=C[..., 2])
    comments = list(comments)
    if quality is not None:
        q = np.asarray(quality, np.float32)
        if q.shape != lead:
            raise ValueError(f"quality must be one value per pixel {lead}, got {q.shape}")
        fields.append(("quality", "float"))
        cols["quality"] = q
        comments.append(f"quality: {quality_name or 'per-point quality'}")
    dtype = np.dtype([(name, "<f4" if t == "float" else "u1") for name, t in fields])
    vert = np.empty(int(valid.sum()), dtype)
    for name, _ in fields:
        vert[name] = np.asarray(cols[name]).ravel()[valid]
    F = None
    if faces:
        remap = np.full(valid.size, -1, np.int64)
        remap[valid] = np.arange(int(valid.sum()))
        F = remap[grid_faces(P)]
    body = _body(vert, F, binary)
    path = Path(path)
    with atomic_path(path) as tmp:
        with open(tmp, "wb") as f:
            f.write(_header(len(vert), fields, None if F is None else len(F), comments, binary))
            f.write(body)
    return path


def _body(vert: np.ndarray, F: np.ndarray | None, binary: bool) -> bytes:
    if binary:
        out = vert.tobytes()
        if F is not None:
            fd = np.empty(len(F), np.dtype([("n", "u1"), ("v", "<i4", (3,))]))
            fd["n"] = 3
            fd["v"] = F
            out += fd.tobytes()
        return out
    rows = [" ".join(f"{v:.9g}" if isinstance(v, np.floating) else str(v) for v in r) for r in vert.tolist()]
    if F is not None:
        rows += [f"3 {a} {b} {c}" for a, b, c in F.tolist()]
    return ("\n".join(rows) + "\n").encode("ascii")


ROUGHNESS_NAME = "local roughness (mm): RMS distance of the 3x3 neighbourhood to its best plane"
CAMERA_FRAME = "frame: camera coordinates (camera centre at the origin, z along its axis)"


def write_measurement_ply(path: str | os.PathLike, points, texture=None, faces: bool = False) -> Path:
    """A reconstructed point map as a standard PLY: normals, texture colour, ``quality`` = local
    roughness (mm, :func:`fringe3d.io.grid_mesh.local_roughness`), the version and command in the
    header and, with ``faces``, the grid's triangles."""
    return write_standard_ply(path, points, texture, quality=local_roughness(points), quality_name=ROUGHNESS_NAME,
                              faces=faces, comments=[*provenance_comments(), CAMERA_FRAME])
