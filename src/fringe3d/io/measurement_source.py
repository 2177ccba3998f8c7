"""A measurement read back for export (:mod:`fringe3d.io.export`): a ``reconstruct`` output folder
(``points.npy``, ``texture.tif``, ``sigma_z.tif``), one frame of a sequence's point store
(``points.zarr``, :mod:`fringe3d.io.store`) or a PLY point cloud / mesh (any tool's).

Attributes carried: from a folder, ``sigma_z_mm`` (predicted depth σ, mm, NaN unknown) and
``roughness_mm`` (:func:`fringe3d.io.grid_mesh.local_roughness`); from a PLY, every float vertex
property beyond x, y, z, normals and colours (``scalar_<name>`` read as ``<name>``).
"""
from __future__ import annotations

import os
from dataclasses import dataclass, field
from pathlib import Path
from typing import Any

import numpy as np

from .arrays import load_array
from .grid_mesh import grid_faces
from .images import read_image
from .ply_standard import measurement_scalars
from .store import PointMapStore


@dataclass
class Measurement:
    """``points``: (H, W, 3) organized map or (N, 3) list, mm, NaN = no point; ``colors`` of the
    same leading shape (grey float or RGB uint8) or None; ``attributes``: ``name -> (values,
    description)``; ``faces``: (F, 3) vertex indices of a PLY mesh, or None."""

    points: np.ndarray
    colors: np.ndarray | None = None
    attributes: dict[str, tuple[np.ndarray, str]] = field(default_factory=dict)
    faces: np.ndarray | None = None

    def mesh(self, path) -> tuple[np.ndarray, np.ndarray, np.ndarray | None]:
        """``vertices (V, 3)``, ``faces (F, 3)`` and per-vertex colours: a PLY's own faces, or the
        pixel grid's triangles of an organized map (valid points only). ValueError naming ``path``."""
        if self.faces is not None:
            return self.points, self.faces, self.colors
        if self.points.ndim != 3:
            raise ValueError(f"cannot write a mesh to {path}: the input is a point list without faces; "
                             "export a reconstruct folder (its pixel grid gives the triangles) or a PLY mesh")
        valid = np.all(np.isfinite(self.points), axis=-1)
        remap = np.full(valid.size, -1, np.int64)
        remap[valid.ravel()] = np.arange(int(valid.sum()))
        faces = remap[grid_faces(self.points)]
        colors = None if self.colors is None else self.colors[valid]
        return self.points[valid], faces, colors


def read_measurement(path: str | os.PathLike, frame: int | None = None) -> Measurement:
    """A ``reconstruct`` output folder, frame ``frame`` of a point store or a ``.ply`` file (module
    docstring). FileNotFoundError / ValueError naming the file and what was expected."""
    path = Path(path)
    if path.is_dir() and (path / "zarr.json").is_file():
        return _read_store_frame(path, frame)
    if frame is not None:
        raise ValueError(f"a frame number is for a point store (points.zarr); {path} is not one")
    if path.is_dir():
        return _read_folder(path)
    if path.suffix.lower() == ".ply":
        return _read_ply(path)
    if not path.exists():
        raise FileNotFoundError(f"no measurement at {path}; expected a reconstruct output folder or a .ply file")
    raise ValueError(f"cannot export {path}: expected a reconstruct output folder (points.npy) or a .ply file")


def _read_folder(folder: Path) -> Measurement:
    P = np.asarray(load_array(folder / "points.npy", "point map (reconstruct output)"), np.float64)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"point map {folder / 'points.npy'} has shape {P.shape}; expected (H, W, 3) in mm")
    out = Measurement(P)
    if (folder / "texture.tif").is_file():
        out.colors = _matching(folder / "texture.tif", P.shape[:2])
    sigma = _matching(folder / "sigma_z.tif", P.shape[:2]) if (folder / "sigma_z.tif").is_file() else None
    out.attributes = measurement_attributes(P, sigma)
    return out


def measurement_attributes(points: np.ndarray, sigma_z: np.ndarray | None) -> dict[str, tuple[np.ndarray, str]]:
    """The exported attributes of an organized point map (H, W, 3) mm: ``sigma_z_mm`` (when
    given, mm, NaN unknown) and ``roughness_mm``; the same as the PLY's
    (:func:`fringe3d.io.ply_standard.measurement_scalars`)."""
    return measurement_scalars(points, sigma_z)


def _read_store_frame(path: Path, frame: int | None) -> Measurement:
    st = PointMapStore.open_existing(path)
    if frame is None:
        raise ValueError(f"{path} is a point store of {st.frames} frames; choose one frame (0..{st.frames - 1})")
    if not 0 <= frame < st.frames:
        raise ValueError(f"frame {frame} is outside the point store {path} (0..{st.frames - 1})")
    if not st.is_done(frame):
        raise ValueError(f"frame {frame} of {path} was never completely written (an interrupted run); resume it first")
    P = np.asarray(st.points(frame), np.float64)
    return Measurement(P, attributes=measurement_attributes(P, st.sigma_z(frame) if st.has_sigma else None))


def _matching(path: Path, shape) -> np.ndarray:
    img = read_image(path, grey=False)
    if img.shape[:2] != shape:
        raise ValueError(f"{path} is {img.shape[:2]} pixels; expected {shape} like points.npy beside it")
    return img


def _read_ply(path: Path) -> Measurement:
    import trimesh  # heavy: loaded only when a PLY is read

    if not path.is_file():
        raise FileNotFoundError(f"no PLY file at {path}")
    try:
        obj: Any = trimesh.load(path, file_type="ply", process=False)
    except Exception as e:  # trimesh raises many types on malformed files
        raise ValueError(f"{path} is not a readable PLY file: {e}") from None
    raw = obj.metadata.get("_ply_raw", {}).get("vertex", {}).get("data")
    names = () if raw is None else (tuple(raw) if isinstance(raw, dict) else raw.dtype.names)
    out = Measurement(np.asarray(obj.vertices, np.float64))
    if len(out.points) == 0:
        raise ValueError(f"PLY file {path} holds no vertex; expected a point cloud or mesh")
    if {"red", "green", "blue"} <= set(names):
        out.colors = np.stack([np.ravel(raw[k]) for k in ("red", "green", "blue")], -1).astype(np.uint8)
    fixed = {"x", "y", "z", "nx", "ny", "nz", "red", "green", "blue", "alpha"}
    for name in names:
        values = np.ravel(raw[name])
        if name not in fixed and values.dtype.kind == "f":
            key = name.removeprefix("scalar_")
            out.attributes[key] = (values.astype(np.float32), f"{name} from {path.name}")
    faces = getattr(obj, "faces", None)
    if faces is not None and len(faces):
        out.faces = np.asarray(faces, np.int64)
    return out
