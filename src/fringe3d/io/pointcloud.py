"""Point clouds as PLY files (written by :mod:`fringe3d.io.ply_standard`, read via trimesh).

:func:`write_ply` takes an organized point map ``(H, W, 3)`` (NaN = no point) or an ``(N, 3)``
list in mm, with optional per-point colour (a grey texture ``(H, W)``, an RGB image
``(H, W, 3)``, float in [0, 1] or uint8) and normals (estimated from the organized map with
``normals=True``; finite at every point). The file appears only once it is complete: an exception midway
leaves no file behind (:func:`fringe3d.utils.atomic.atomic_path`).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .ply_standard import write_standard_ply
from .point_attributes import colors_u8 as _colors
from .point_attributes import organized_normals

__all__ = ["PointCloudData", "write_ply", "read_ply", "organized_normals", "_colors"]


@dataclass
class PointCloudData:
    """A point cloud read back: ``points (N, 3)`` float32 mm, ``colors (N, 3)`` uint8 or None,
    ``normals (N, 3)`` float32 or None, ``scalars`` every other float vertex property
    (``name -> (N,)`` float32; ``scalar_<name>`` read as ``<name>``)."""

    points: np.ndarray
    colors: np.ndarray | None = None
    normals: np.ndarray | None = None
    scalars: dict[str, np.ndarray] = field(default_factory=dict)


def write_ply(path: str | os.PathLike, points, colors=None, normals: bool = False, mask=None,
              binary: bool = True) -> Path:
    """Write the valid points (finite, and ``mask`` where given) as a PLY file, atomically, through
    the one PLY writer (:func:`fringe3d.io.ply_standard.write_standard_ply`: units, version and
    command in the header).

    Parameters
    ----------
    path : output ``.ply`` file
    points : (H, W, 3) or (N, 3) float, mm
    colors : grey (H, W) / (N,) or RGB (..., 3) image, float [0, 1] or uint8, optional
    normals : bool
        Estimate finite normals from an organized map (:func:`fringe3d.io.point_attributes.grid_normals`).
    mask : bool array of the points' leading shape, optional
    binary : binary little-endian (default) or ASCII PLY

    Returns the path. Raises ValueError when no point is valid or shapes disagree.
    """
    return write_standard_ply(path, points, colors, normals=bool(normals), mask=mask, binary=binary)


def read_ply(path: str | os.PathLike) -> PointCloudData:
    """Read a PLY point cloud: points, colours and normals when present, and every other float
    vertex property as a scalar field (:class:`PointCloudData`; also a way to hand fringe3d's
    fields to a reader whose PLY importer drops them, e.g. pymeshlab's custom attributes)."""
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
    fixed = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "alpha"}
    scalars: dict[str, np.ndarray] = {}
    for k in map(str, names):
        if k not in fixed and np.asarray(raw[k]).dtype.kind == "f":
            scalars[k.removeprefix("scalar_")] = np.ravel(raw[k]).astype(np.float32)
    return PointCloudData(pts, colors, normals, scalars)
