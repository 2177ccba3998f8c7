"""Point clouds as PLY files (via trimesh), written atomically.

:func:`write_ply` takes an organized point map ``(H, W, 3)`` (NaN = no point) or an ``(N, 3)``
list in mm, with optional per-point colour (a grey texture ``(H, W)``, an RGB image
``(H, W, 3)``, float in [0, 1] or uint8) and normals (given, or estimated from the organized
map with ``normals=True``). The file appears only once it is complete: an exception midway
leaves no file behind (:func:`fringe3d.utils.atomic.atomic_path`).
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path
from typing import Any

import numpy as np

from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.output_folder import provenance_comments


@dataclass
class PointCloudData:
    """A point cloud read back: ``points (N, 3)`` float32 mm, ``colors (N, 3)`` uint8 or None,
    ``normals (N, 3)`` float32 or None."""

    points: np.ndarray
    colors: np.ndarray | None = None
    normals: np.ndarray | None = None


def organized_normals(points: np.ndarray) -> np.ndarray:
    """Unit normals ``(H, W, 3)`` float32 of an organized point map from central differences
    (``dP/du x dP/dv``), oriented towards the camera at the origin; NaN where a neighbour is
    missing."""
    P = np.asarray(points, np.float64)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"normals need an organized point map (H, W, 3), got {P.shape}")
    du = np.full_like(P, np.nan)
    dv = np.full_like(P, np.nan)
    du[:, 1:-1] = P[:, 2:] - P[:, :-2]
    dv[1:-1] = P[2:] - P[:-2]
    n = np.cross(du, dv)
    with np.errstate(invalid="ignore", divide="ignore"):
        n /= np.linalg.norm(n, axis=-1, keepdims=True)
        flip = np.sum(n * P, axis=-1) > 0
    n[flip] *= -1
    return n.astype(np.float32)


def _colors(colors, shape) -> np.ndarray:
    c = np.asarray(colors)
    if c.shape == shape:
        c = np.repeat(c[..., None], 3, axis=-1)
    if c.shape != shape + (3,):
        raise ValueError(f"colours must be a grey image {shape} or an RGB image {shape + (3,)} matching the points, "
                         f"got {c.shape}")
    if c.dtype.kind == "f":
        c = np.clip(np.nan_to_num(c) * 255.0 + 0.5, 0, 255)
    return c.astype(np.uint8)


def with_provenance_header(ply: bytes) -> bytes:
    """``ply`` (a PLY file's bytes) with ``comment units: mm`` and the fringe3d version and command
    line (:func:`fringe3d.utils.output_folder.provenance_comments`) after its ``format`` line."""
    lines = ["units: mm", *provenance_comments()]
    extra = "".join(f"comment {' '.join(c.split())}\n" for c in lines).encode("ascii", "replace")
    first = ply.index(b"\n", ply.index(b"format")) + 1
    return ply[:first] + extra + ply[first:]


def write_ply(path: str | os.PathLike, points, colors=None, normals=None, mask=None, binary: bool = True) -> Path:
    """Write the valid points (finite, and ``mask`` where given) as a PLY file, atomically.

    Parameters
    ----------
    path : output ``.ply`` file
    points : (H, W, 3) or (N, 3) float, mm
    colors : grey (H, W) / (N,) or RGB (..., 3) image, float [0, 1] or uint8, optional
    normals : (..., 3) float, or True to estimate them from an organized map, optional
    mask : bool array of the points' leading shape, optional
    binary : binary little-endian (default) or ASCII PLY

    Returns the path. Raises ValueError when no point is valid or shapes disagree.
    """
    import trimesh  # optional heavy dependency: loaded only when a PLY file is written
    from trimesh.exchange.ply import export_ply

    P = np.asarray(points, np.float32)
    if P.ndim < 2 or P.shape[-1] != 3:
        raise ValueError(f"points must be (H, W, 3) or (N, 3) in mm, got shape {P.shape}")
    lead = P.shape[:-1]
    valid = np.all(np.isfinite(P), axis=-1)
    if mask is not None:
        m = np.asarray(mask, bool)
        if m.shape != lead:
            raise ValueError(f"mask has shape {m.shape} but the points are {lead}")
        valid &= m
    if not valid.any():
        raise ValueError(f"no valid point to write to {path} (all NaN or masked); expected at least one finite point")
    if normals is True:
        normals = organized_normals(P)
    N = None
    if normals is not None:
        N = np.asarray(normals, np.float32)
        if N.shape != P.shape:
            raise ValueError(f"normals must have the points' shape {P.shape}, got {N.shape}")
        valid &= np.all(np.isfinite(N), axis=-1)
    C = None if colors is None else _colors(colors, lead)
    v = P[valid]
    if N is not None:
        mesh = trimesh.Trimesh(vertices=v, faces=np.zeros((0, 3), np.int64), vertex_normals=N[valid],
                               vertex_colors=None if C is None else C[valid], process=False)
        data = export_ply(mesh, encoding="binary" if binary else "ascii", vertex_normal=True)
    else:
        cloud = trimesh.PointCloud(v, colors=None if C is None else C[valid])
        data = export_ply(cloud, encoding="binary" if binary else "ascii")
    path = Path(path)
    with atomic_path(path) as tmp:
        _write_bytes(tmp, with_provenance_header(data))
    return path


def _write_bytes(path: Path, data: bytes) -> None:
    with open(path, "wb") as f:
        f.write(data)


def read_ply(path: str | os.PathLike) -> PointCloudData:
    """Read a PLY point cloud (points, and colours / normals when present)."""
    import trimesh  # optional heavy dependency: loaded only when a PLY file is read

    path = Path(path)
    if not path.exists():
        raise FileNotFoundError(f"no PLY file at {path}")
    try:
        obj: Any = trimesh.load(path, file_type="ply", process=False)  # PointCloud or Trimesh
    except Exception as e:  # trimesh raises many types on malformed files
        raise ValueError(f"{path} is not a readable PLY file: {e}") from None
    pts = np.asarray(obj.vertices, np.float32)
    raw = obj.metadata.get("_ply_raw", {}).get("vertex", {}).get("data")
    if raw is None:
        names = ()
    elif isinstance(raw, dict):  # ASCII files: one array per property
        names = tuple(raw)
    else:  # binary files: a structured array
        names = raw.dtype.names
    normals = None
    if {"nx", "ny", "nz"} <= set(names):
        normals = np.stack([np.ravel(raw[k]) for k in ("nx", "ny", "nz")], axis=-1).astype(np.float32)
    colors = None
    if {"red", "green", "blue"} <= set(names):
        colors = np.stack([np.ravel(raw[k]) for k in ("red", "green", "blue")], axis=-1).astype(np.uint8)
    return PointCloudData(pts, colors, normals)
