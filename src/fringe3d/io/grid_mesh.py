"""Quantities of an organized point map that come from its pixel grid: triangle faces between
neighbouring valid pixels and a per-point local roughness (mm).

Faces: each 2 x 2 pixel cell ``(i, j), (i, j+1), (i+1, j), (i+1, j+1)`` gives up to two
triangles ``(a, c, b)`` and ``(b, c, d)`` (a = top-left, b = top-right, c = bottom-left,
d = bottom-right), kept when all three corners are valid and every edge is shorter than
``max_edge`` (default 8x the median neighbour spacing), so the mesh does not bridge a depth jump
between an object and the background.

Roughness (mm): RMS distance of the 3 x 3 neighbourhood of a point to its own total-least-
squares plane, ``sqrt(lambda_min(cov))`` of the valid neighbours (at least 5; NaN otherwise).
On a smooth surface it estimates the measurement noise; it is large at edges and on outliers.
"""
from __future__ import annotations

import numpy as np


def _edge(P: np.ndarray, a: np.ndarray, b: np.ndarray) -> np.ndarray:
    return np.linalg.norm(P[a] - P[b], axis=-1)


def grid_faces(points: np.ndarray, max_edge: float | None = None) -> np.ndarray:
    """Triangles ``(F, 3)`` int64 of flat pixel indices ``i * W + j`` (module docstring).

    Parameters
    ----------
    points : (H, W, 3) float, mm, NaN invalid
    max_edge : float, optional
        Longest edge kept (mm).
    """
    P = np.asarray(points, np.float64)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"faces need an organized point map (H, W, 3), got {P.shape}")
    H, W = P.shape[:2]
    flat = P.reshape(-1, 3)
    valid = np.all(np.isfinite(flat), axis=1)
    idx = np.arange(H * W).reshape(H, W)
    a, b, c, d = (idx[:-1, :-1].ravel(), idx[:-1, 1:].ravel(), idx[1:, :-1].ravel(), idx[1:, 1:].ravel())
    if max_edge is None:
        ok = valid[a] & valid[b]
        spacing = _edge(flat, a[ok], b[ok])
        max_edge = 8.0 * float(np.median(spacing)) if spacing.size else np.inf
    tris = []
    for t in ((a, c, b), (b, c, d)):
        keep = valid[t[0]] & valid[t[1]] & valid[t[2]]
        for u, v in ((0, 1), (1, 2), (2, 0)):
            with np.errstate(invalid="ignore"):
                keep &= _edge(flat, t[u], t[v]) < max_edge
        tris.append(np.stack([t[0][keep], t[1][keep], t[2][keep]], axis=1))
    return np.concatenate(tris).astype(np.int64)


def local_roughness(points: np.ndarray) -> np.ndarray:
    """Per-point RMS distance (mm) of the 3 x 3 neighbourhood to its best plane, ``(H, W)``
    float32 (module docstring)."""
    P = np.asarray(points, np.float64)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"roughness needs an organized point map (H, W, 3), got {P.shape}")
    finite = np.all(np.isfinite(P), axis=-1)
    out = np.full(P.shape[:2], np.nan, np.float32)
    rows, cols = np.flatnonzero(finite.any(axis=1)), np.flatnonzero(finite.any(axis=0))
    if rows.size:  # every point outside the box around the valid ones is invalid, NaN: the box alone
        box = (slice(rows[0], rows[-1] + 1), slice(cols[0], cols[-1] + 1))
        out[box] = _roughness(P[box])
    return out


def _roughness(P: np.ndarray) -> np.ndarray:
    """:func:`local_roughness` of a map ``P`` (H, W, 3) float64 with no valid point beyond its
    border (an object's bounding box: its NaN padding is what the whole map holds there)."""
    H, W = P.shape[:2]
    pad = np.pad(P, ((1, 1), (1, 1), (0, 0)), constant_values=np.nan)
    nb = np.stack([pad[i:i + H, j:j + W] for i in range(3) for j in range(3)], axis=2)  # (H, W, 9, 3)
    ok = np.all(np.isfinite(nb), axis=-1)
    n = ok.sum(axis=2)
    x = np.where(ok[..., None], nb, 0.0)
    mean = x.sum(axis=2) / np.maximum(n, 1)[..., None]
    d = np.where(ok[..., None], nb - mean[:, :, None], 0.0)
    cov = np.einsum("hwki,hwkj->hwij", d, d) / np.maximum(n, 1)[..., None, None]
    lam = np.linalg.eigvalsh(cov)[..., 0]
    out = np.sqrt(np.clip(lam, 0, None))
    out[(n < 5) | ~np.all(np.isfinite(P), axis=-1)] = np.nan
    return out.astype(np.float32)
