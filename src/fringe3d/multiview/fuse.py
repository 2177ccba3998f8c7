"""σ-weighted voxel fusion of registered views.

Every view's points are placed in the model frame and binned into cubic voxels of ``voxel`` mm;
each occupied voxel gives one point, the inverse-variance weighted mean
``x̄ = Σ wᵢ xᵢ / Σ wᵢ`` with ``wᵢ = 1/σᵢ²`` and its σ ``(Σ wᵢ)^(−1/2)``, so where views overlap the
better-measured ones dominate. Views without σ weigh equally (σ = 1 for all).

Overlap: a voxel met by ≥ 2 views is seen twice; a view's overlap share is the share of the
voxels it meets that another view meets too, and the fused cloud's the share of its points seen
by ≥ 2 views.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .views import View


@dataclass
class Fused:
    """``points`` (M, 3) mm model frame, ``sigma`` (M,) mm, ``views`` (M,) how many views met;
    per input view ``view_points`` (V,) its points and ``view_overlap`` (V,) the share of the
    voxels it meets that another view meets too."""

    points: np.ndarray
    sigma: np.ndarray
    views: np.ndarray
    view_points: np.ndarray = field(default_factory=lambda: np.zeros(0, int))
    view_overlap: np.ndarray = field(default_factory=lambda: np.zeros(0))

    @property
    def overlap_share(self) -> float:
        """Share of the fused points seen by at least 2 views (NaN for an empty cloud)."""
        return float(np.mean(self.views >= 2)) if len(self.views) else float("nan")


def place(view: View, pose) -> np.ndarray:
    """``view``'s points (N, 3) in the model frame by ``pose`` (4, 4) view → model."""
    T = np.asarray(pose, float)
    return view.points @ T[:3, :3].T + T[:3, 3]


def voxel_index(points, voxel: float) -> np.ndarray:
    """Index (N,) of each point's occupied voxel (cubes of ``voxel`` mm), numbered in sorted
    order of the voxels' integer coordinates. The three coordinates are packed into one int64
    (21 bits each) when they span less than 2²¹ voxels, which sorts ~10× faster than rows."""
    key = np.floor(np.asarray(points, float) / voxel).astype(np.int64)
    key -= key.min(0)
    if len(key) and key.max() < 2 ** 21:
        _, inv = np.unique((key[:, 0] << 42) | (key[:, 1] << 21) | key[:, 2], return_inverse=True)
    else:
        _, inv = np.unique(key, axis=0, return_inverse=True)
    return inv.ravel()


def fuse_views(views: list[View], poses, voxel: float) -> Fused:
    """Fuse ``views`` placed by ``poses`` (V, 4, 4) into voxels of ``voxel`` mm."""
    if voxel <= 0:
        raise ValueError(f"voxel must be > 0 mm, got {voxel}")
    pts = np.concatenate([place(v, p) for v, p in zip(views, poses)])
    sig = np.concatenate([v.sigma for v in views])
    vid = np.concatenate([np.full(len(v.points), i) for i, v in enumerate(views)])
    if not np.isfinite(sig).all():
        sig = np.where(np.isfinite(sig), sig, np.nanmedian(sig) if np.isfinite(sig).any() else 1.0)
    w = 1.0 / np.maximum(sig, 1e-9) ** 2
    inv = voxel_index(pts, voxel)
    W = np.bincount(inv, w)
    X = np.stack([np.bincount(inv, w * pts[:, k]) for k in range(3)], axis=1) / W[:, None]
    pairs = np.unique(inv * len(views) + vid)  # (voxel, view) met
    n_views = np.bincount(pairs // len(views), minlength=len(W))
    pair_view = pairs % len(views)
    met = np.bincount(pair_view, minlength=len(views))
    shared = np.bincount(pair_view, n_views[pairs // len(views)] >= 2, minlength=len(views))
    overlap = np.divide(shared, met, out=np.full(len(views), np.nan), where=met > 0)
    return Fused(X, 1.0 / np.sqrt(W), n_views, np.array([len(v.points) for v in views]), overlap)
