"""Ground truth given as plain surface points (not the simulator's per-pixel truth).

Format (``fringe3d evaluate --truth FILE``): a ``.npy`` array of shape ``(N, 3)`` (float, mm,
same frame as the measurement; NaN rows ignored) or a ``.ply`` point cloud (vertices x, y, z in
mm). The points should sample the true surface more densely than the measured points.

The error of a measured point ``p`` is its distance to the true surface near its nearest true
point ``q``: ``|(p - q) . n|``, with ``n`` the normal of the plane through the ``K`` true
points nearest ``p`` (smallest-eigenvalue eigenvector of their covariance), i.e. a
point-to-local-plane distance that does not grow with the truth's sampling step.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

import numpy as np
from scipy.spatial import cKDTree

from fringe3d.io.arrays import load_array
from fringe3d.io.pointcloud import read_ply

from .fits import fit_sphere

K_NEIGHBOURS = 6


@dataclass(eq=False)
class TruthPoints:
    """True surface points ``xyz (N, 3)`` mm and a k-d tree over them."""

    xyz: np.ndarray
    source: str = ""

    def __post_init__(self) -> None:
        self.tree = cKDTree(self.xyz)


def load_truth_points(path: Path) -> TruthPoints:
    """Read a ``.npy`` ``(N, 3)`` or ``.ply`` file of true surface points (mm)."""
    path = Path(path)
    if path.suffix == ".npy":
        xyz = np.asarray(load_array(path, "truth points"), np.float64)
    elif path.suffix == ".ply":
        xyz = np.asarray(read_ply(path).points, np.float64)
    else:
        raise ValueError(f"{path}: truth points must be a .npy (N, 3) array in mm or a .ply point cloud")
    if xyz.ndim != 2 or xyz.shape[1] != 3:
        raise ValueError(f"{path}: expected truth points of shape (N, 3) in mm, got {xyz.shape}")
    xyz = xyz[np.all(np.isfinite(xyz), axis=1)]
    if len(xyz) < K_NEIGHBOURS:
        raise ValueError(f"{path}: only {len(xyz)} finite truth points, need at least {K_NEIGHBOURS}")
    return TruthPoints(xyz, str(path))


def surface_distance(tp: TruthPoints, p: np.ndarray) -> np.ndarray:
    """Point-to-local-plane distance (mm) of ``p (M, 3)`` to the true surface (module docstring)."""
    _, idx = tp.tree.query(p, k=K_NEIGHBOURS)
    nb = tp.xyz[idx]                                   # (M, K, 3)
    d = nb - nb.mean(axis=1, keepdims=True)
    _, vec = np.linalg.eigh(np.einsum("mki,mkj->mij", d, d))
    n = vec[..., 0]                                    # (M, 3) local normal
    return np.abs(np.einsum("mi,mi->m", p - nb[:, 0], n))


def truth_point_errors(points: np.ndarray, tp: TruthPoints, chunk: int = 200_000) -> dict:
    """3D error of every finite measured point against true surface points (mm)."""
    p = np.asarray(points, np.float64).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    if not len(p):
        raise ValueError("no finite measured point to compare with the truth points")
    e = np.concatenate([surface_distance(tp, p[i:i + chunk]) for i in range(0, len(p), chunk)])
    return {"rms_mm": float(np.sqrt(np.mean(e ** 2))), "mean_mm": float(e.mean()), "median_mm": float(np.median(e)),
            "max_mm": float(e.max()), "share_over_1mm": float(np.mean(e > 1.0)), "points": int(len(p)),
            "truth_points": int(len(tp.xyz)), "definition": "distance to the local plane of the 6 nearest truth points"}


def true_sphere(tp: TruthPoints, measured: np.ndarray):
    """Sphere fitted to the true points nearest the measured points ``(M, 3)`` of one sphere
    (its true size and centre); a :class:`~fringe3d.analyze.fits.SphereFit`."""
    p = np.asarray(measured, np.float64).reshape(-1, 3)
    p = p[np.all(np.isfinite(p), axis=1)]
    _, idx = tp.tree.query(p[:: max(1, len(p) // 50_000)], k=1)
    return fit_sphere(tp.xyz[np.unique(idx)])
