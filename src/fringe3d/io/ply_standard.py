"""The one PLY writer of fringe3d: every point cloud (``reconstruct``, sequences, the demo,
:meth:`fringe3d.pipeline.Reconstruction.save_ply`, :func:`fringe3d.io.pointcloud.write_ply`)
goes through :func:`write_standard_ply`.

Layout (binary little-endian, or ASCII)::

    ply
    format binary_little_endian 1.0
    comment units: mm
    comment fringe3d <version>
    comment command: <the fringe3d command line, or "none (Python API)">
    comment <caller's comments: frame, normals, one line per scalar field ...>
    element vertex N
    property float x / y / z          # mm
    property float nx / ny / nz       # unit normal towards the camera (organized maps)
    property uchar red / green / blue # texture (when given)
    property float scalar_<name>      # per-point scalars (sigma_z_mm, roughness_mm); a comment says what each is
    element face F                    # only with faces
    property list uchar int vertex_indices
    end_header

Normals are finite at every point written (:func:`fringe3d.io.point_attributes.grid_normals`:
one-sided differences at borders and holes, the line of sight for a lone point), so a point map
and its PLY hold the same points and no reader turns a NaN normal into a made-up one. Scalar
fields are named ``scalar_<name>`` (CloudCompare's convention, shown as ``<name>``; Open3D's
tensor reader, meshio and trimesh keep any name). Two importers drop them whatever their name or
type: VTK's PLY reader (ParaView, PyVista) keeps only points, normals, colours and texture
coordinates (read the ``.vtp`` of :mod:`fringe3d.io.vtk_points` there), and MeshLab's (pymeshlab)
keeps one vertex scalar only, a property named ``quality`` (a word fringe3d reserves for its mask
reason bits), and no custom attribute (hand them over with :func:`fringe3d.io.pointcloud.read_ply`).
``docs/file-formats.md`` has the reader-by-reader table. A scalar is NaN where it is unknown.
"""
from __future__ import annotations

import os
from pathlib import Path
from typing import Mapping

import numpy as np

from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.output_folder import provenance_comments

from .grid_mesh import grid_faces, local_roughness
from .point_attributes import NORMALS_NOTE, colors_u8, grid_normals

#: ``name -> (values, description with units)``; written as ``scalar_<name>``.
Scalars = Mapping[str, tuple[np.ndarray, str]]


def _header(n: int, fields: list[tuple[str, str]], n_faces: int | None, comments, binary: bool) -> bytes:
    lines = ["ply", f"format {'binary_little_endian' if binary else 'ascii'} 1.0", "comment units: mm"]
    lines += [f"comment {' '.join(str(c).split())}" for c in comments]
    lines.append(f"element vertex {n}")
    lines += [f"property {t} {name}" for name, t in fields]
    if n_faces is not None:
        lines += [f"element face {n_faces}", "property list uchar int vertex_indices"]
    return ("\n".join(lines) + "\nend_header\n").encode("ascii", "replace")


def _valid_points(path, points, mask) -> tuple[np.ndarray, np.ndarray]:
    P = np.asarray(points, np.float32)
    if P.ndim not in (2, 3) or P.shape[-1] != 3:
        raise ValueError(f"points must be an organized map (H, W, 3) or a list (N, 3) in mm, got {P.shape}")
    valid = np.all(np.isfinite(P), axis=-1)
    if mask is not None:
        m = np.asarray(mask, bool)
        if m.shape != P.shape[:-1]:
            raise ValueError(f"mask has shape {m.shape} but the points are {P.shape[:-1]}")
        valid &= m
    if not valid.any():
        raise ValueError(f"no valid point to write to {path} (all NaN or masked); expected at least one finite point")
    return P, valid


def write_standard_ply(path: str | os.PathLike, points, texture=None, *, scalars: Scalars | None = None,
                       normals: bool = True, mask=None, faces: bool = False, comments=(),
                       binary: bool = True) -> Path:
    """Write the valid points (finite, and ``mask`` where given) as a PLY file, atomically.

    Parameters
    ----------
    path : output ``.ply``
    points : (H, W, 3) organized map or (N, 3) list, float, mm, NaN invalid
    texture : grey (H, W) / (N,) or RGB (..., 3), float [0, 1] or uint8, optional
    scalars : mapping ``name -> (values of the points' leading shape, description)``, optional
        Written as float ``scalar_<name>`` with a ``comment scalar_<name>: <description>``.
    normals : bool
        Write grid normals (organized maps only; finite at every point written).
    mask : bool array of the points' leading shape, optional
    faces : bool
        Also write the grid's triangles (:func:`fringe3d.io.grid_mesh.grid_faces`; organized maps).
    comments : iterable of str
        Extra header comments (one line each) after the units, version and command.
    binary : binary little-endian (default) or ASCII

    Returns the path; ValueError when no point is valid or shapes disagree.
    """
    P, valid = _valid_points(path, points, mask)
    lead = P.shape[:-1]
    organized = P.ndim == 3
    if (normals or faces) and not organized:
        raise ValueError(f"normals and faces need an organized point map (H, W, 3), got {P.shape}")
    if organized:
        P = np.where(valid[..., None], P, np.nan)  # masked points are not neighbours either
    fields = [(a, "float") for a in ("x", "y", "z")]
    cols = {"x": P[..., 0], "y": P[..., 1], "z": P[..., 2]}
    notes = [*provenance_comments(), *comments]
    if normals:
        N = grid_normals(P)
        fields += [(a, "float") for a in ("nx", "ny", "nz")]
        cols.update(nx=N[..., 0], ny=N[..., 1], nz=N[..., 2])
        notes.append(NORMALS_NOTE)
    if texture is not None:
        C = colors_u8(texture, lead)
        fields += [(a, "uchar") for a in ("red", "green", "blue")]
        cols.update(red=C[..., 0], green=C[..., 1], blue=C[..., 2])
    for name, (values, description) in (scalars or {}).items():
        q = np.asarray(values, np.float32)
        if q.shape != lead:
            raise ValueError(f"scalar {name!r} must be one value per point {lead}, got {q.shape}")
        fields.append((f"scalar_{name}", "float"))
        cols[f"scalar_{name}"] = q
        notes.append(f"scalar_{name}: {description}")
    dtype = np.dtype([(name, "<f4" if t == "float" else "u1") for name, t in fields])
    vert = np.empty(int(valid.sum()), dtype)
    for name, _ in fields:
        vert[name] = np.asarray(cols[name])[valid]
    F = None
    if faces:
        remap = np.full(valid.size, -1, np.int64)
        remap[valid.ravel()] = np.arange(int(valid.sum()))
        F = remap[grid_faces(P)]
    body = _body(vert, F, binary)
    path = Path(path)
    with atomic_path(path) as tmp:
        _write_bytes(tmp, _header(len(vert), fields, None if F is None else len(F), notes, binary) + body)
    return path


def _write_bytes(path: Path, data: bytes) -> None:
    with open(path, "wb") as f:
        f.write(data)


def _body(vert: np.ndarray, F: np.ndarray | None, binary: bool) -> bytes:
    if binary:
        out = vert.tobytes()
        if F is not None:
            fd = np.empty(len(F), np.dtype([("n", "u1"), ("v", "<i4", (3,))]))
            fd["n"] = 3
            fd["v"] = F
            out += fd.tobytes()
        return out
    rows = [" ".join(f"{v:.9g}" if isinstance(v, float) else str(v) for v in r) for r in vert.tolist()]
    if F is not None:
        rows += [f"3 {a} {b} {c}" for a, b, c in F.tolist()]
    return ("\n".join(rows) + "\n").encode("ascii")


#: The measurement PLY's scalars: ``scalar_sigma_z_mm`` (when known) and ``scalar_roughness_mm``.
ROUGHNESS_FIELD = "roughness_mm"
ROUGHNESS_NAME = ("local roughness (mm): RMS distance of the 3x3 neighbourhood to its best plane "
                  "(NaN with fewer than 5 neighbours)")
SIGMA_Z_FIELD = "sigma_z_mm"
SIGMA_Z_NAME = "predicted depth standard deviation (mm), NaN unknown"
CAMERA_FRAME = "frame: camera coordinates (camera centre at the origin, z along its axis)"


def measurement_scalars(points, sigma_z=None) -> dict[str, tuple[np.ndarray, str]]:
    """The scalar fields of a measurement's point files (PLY, VTP, LAS, ...).

    Parameters
    ----------
    points : (H, W, 3) organized map, float, mm, NaN = no point
    sigma_z : (H, W) predicted depth standard deviation (mm), optional

    Returns
    -------
    dict
        ``sigma_z_mm`` (when ``sigma_z`` is given) and ``roughness_mm``
        (:func:`fringe3d.io.grid_mesh.local_roughness`), each ``name -> (values (H, W), description)``.
    """
    P = np.asarray(points, np.float32)
    out: dict[str, tuple[np.ndarray, str]] = {}
    if sigma_z is not None:
        out[SIGMA_Z_FIELD] = (np.asarray(sigma_z, np.float32), SIGMA_Z_NAME)
    rough = local_roughness(P) if P.ndim == 3 else np.full(P.shape[:-1], np.nan, np.float32)
    out[ROUGHNESS_FIELD] = (rough, ROUGHNESS_NAME)
    return out


def write_measurement_ply(path: str | os.PathLike, points, texture=None, faces: bool = False, mask=None,
                          binary: bool = True, sigma_z=None) -> Path:
    """A reconstructed point map ``(H, W, 3)`` (mm, NaN invalid) as the standard PLY every path
    writes: normals, texture colour, ``scalar_sigma_z_mm`` (when ``sigma_z`` (H, W) mm is given),
    ``scalar_roughness_mm`` (:func:`fringe3d.io.grid_mesh.local_roughness`), the version and
    command in the header and, with ``faces``, the grid's triangles."""
    P = np.asarray(points, np.float32)
    if mask is not None and P.ndim == 3 and np.shape(mask) == P.shape[:2]:
        P = np.where(np.asarray(mask, bool)[..., None], P, np.nan)
    return write_standard_ply(path, P, texture, scalars=measurement_scalars(P, sigma_z), mask=mask,
                              faces=faces, comments=[CAMERA_FRAME], binary=binary)


def write_mesh_ply(path: str | os.PathLike, vertices, faces, colors=None, *, scalars: Scalars | None = None,
                   comments=(), binary: bool = True) -> Path:
    """A general triangle mesh (not a pixel grid) in the same PLY flavour, atomically.

    Parameters
    ----------
    path : output ``.ply``
    vertices : (V, 3) float, mm, finite
    faces : (F, 3) int vertex indices
    colors : grey (V,) or RGB (V, 3), float [0, 1] or uint8, optional
    scalars : ``name -> (values (V,), description)``, written as ``scalar_<name>``, optional
    comments : extra header comments
    binary : binary little-endian (default) or ASCII
    """
    V = np.asarray(vertices, np.float32)
    F = np.asarray(faces, np.int64)
    n = len(V)
    fields = [(a, "float") for a in ("x", "y", "z")]
    cols = {"x": V[:, 0], "y": V[:, 1], "z": V[:, 2]}
    notes = [*provenance_comments(), *comments]
    if colors is not None:
        C = colors_u8(colors, (n,))
        fields += [(a, "uchar") for a in ("red", "green", "blue")]
        cols.update(red=C[:, 0], green=C[:, 1], blue=C[:, 2])
    for name, (values, description) in (scalars or {}).items():
        q = np.asarray(values, np.float32)
        if q.shape != (n,):
            raise ValueError(f"scalar {name!r} for {path} must be one value per vertex ({n},), got {q.shape}")
        fields.append((f"scalar_{name}", "float"))
        cols[f"scalar_{name}"] = q
        notes.append(f"scalar_{name}: {description}")
    vert = np.empty(n, np.dtype([(name, "<f4" if t == "float" else "u1") for name, t in fields]))
    for name, _ in fields:
        vert[name] = cols[name]
    path = Path(path)
    with atomic_path(path) as tmp:
        _write_bytes(tmp, _header(n, fields, len(F), notes, binary) + _body(vert, F, binary))
    return path
