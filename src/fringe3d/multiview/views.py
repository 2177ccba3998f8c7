"""Reconstructed views as point lists: what :func:`fringe3d.multiview.merge.merge_views` reads.

A view is a reconstruct output folder: ``points.npy`` ((H, W, 3) float mm, NaN invalid, camera
frame) and, when present, ``sigma_z.tif`` ((H, W) mm, the per-point depth uncertainty).
"""
from __future__ import annotations

import os
from dataclasses import dataclass
from pathlib import Path

import numpy as np

from fringe3d.io.arrays import load_array
from fringe3d.io.images import read_image


@dataclass
class View:
    """One view: ``points`` (N, 3) mm in its camera frame, ``sigma`` (N,) mm (NaN: unknown)."""

    name: str
    points: np.ndarray
    sigma: np.ndarray


def view_from_map(name: str, points, sigma=None) -> View:
    """A :class:`View` from an organised map (H, W, 3) and optional σ map (H, W), dropping NaNs."""
    P = np.asarray(points, float).reshape(-1, 3)
    s = np.full(len(P), np.nan) if sigma is None else np.asarray(sigma, float).reshape(-1)
    ok = np.all(np.isfinite(P), axis=1)
    return View(name, P[ok], s[ok])


def read_view(folder: str | os.PathLike) -> View:
    """The view in ``folder`` (named after it); ValueError naming the file when unreadable."""
    folder = Path(folder)
    f = folder / "points.npy"
    if not f.is_file():
        raise ValueError(f"view {folder}: no points.npy (expected a reconstruct output folder)")
    P = load_array(f, "points file")
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"view {f}: expected an (H, W, 3) point map, got shape {P.shape}")
    sig = None
    if (folder / "sigma_z.tif").is_file():
        sig = read_image(folder / "sigma_z.tif")
        if sig.shape != P.shape[:2]:
            raise ValueError(f"view {folder / 'sigma_z.tif'}: shape {sig.shape} differs from points.npy {P.shape[:2]}")
    v = view_from_map(folder.name, P, sig)
    if len(v.points) < 100:
        raise ValueError(f"view {f}: only {len(v.points)} valid points (need >= 100 to register)")
    return v
