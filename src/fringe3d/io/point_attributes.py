"""Per-point attributes of an organized point map ``(H, W, 3)`` (mm, NaN = no point): unit
normals from the pixel grid and 8-bit colours from a texture.

Normals (:func:`grid_normals`): the cross product of the grid tangents ``dP/du x dP/dv``,
oriented towards the camera at the origin. Each tangent is a central difference where both
neighbours exist, a one-sided difference where only one does (grid border, edge of a hole), so
every point with at least one neighbour along each grid direction gets a normal. A point with no
neighbour along a direction (a lone pixel, a one-pixel-wide strand) has no surface to speak of:
its normal is the line of sight ``-P / |P|`` (towards the camera), never NaN.
"""
from __future__ import annotations

import numpy as np

#: Header comment of PLY files saying how the normals were made.
NORMALS_NOTE = ("normals: unit, towards the camera, from the pixel grid (central differences; one-sided "
                "at borders and holes; the line of sight where a point has no grid neighbour)")


def organized_normals(points: np.ndarray) -> np.ndarray:
    """Unit normals ``(H, W, 3)`` float32 of an organized point map from central differences
    (``dP/du x dP/dv``), oriented towards the camera at the origin; NaN where a neighbour is
    missing (:func:`grid_normals` fills those)."""
    P = _organized(points)
    du = np.full_like(P, np.nan)
    dv = np.full_like(P, np.nan)
    du[:, 1:-1] = P[:, 2:] - P[:, :-2]
    dv[1:-1] = P[2:] - P[:-2]
    return _oriented(np.cross(du, dv), P).astype(np.float32)


def grid_normals(points: np.ndarray) -> np.ndarray:
    """Unit normals ``(H, W, 3)`` float32, finite at every finite point (module docstring):
    central, else one-sided grid differences, else the line of sight; NaN only where the point
    itself is NaN."""
    P = _organized(points)
    n = _oriented(np.cross(_tangent(P, 1), _tangent(P, 0)), P)
    ok = np.all(np.isfinite(P), axis=-1)
    bad = ok & ~np.all(np.isfinite(n), axis=-1)
    if bad.any():
        n[bad] = -P[bad] / np.linalg.norm(P[bad], axis=-1, keepdims=True)
        still = ok & ~np.all(np.isfinite(n), axis=-1)  # a point at the camera centre itself
        n[still] = (0.0, 0.0, -1.0)
    return n.astype(np.float32)


def _organized(points) -> np.ndarray:
    P = np.asarray(points, np.float64)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"normals need an organized point map (H, W, 3), got {P.shape}")
    return P


def _tangent(P: np.ndarray, axis: int) -> np.ndarray:
    """Grid difference along ``axis`` (0 rows, 1 columns): central, else forward, else backward."""
    fwd = np.full_like(P, np.nan)
    bwd = np.full_like(P, np.nan)
    n = P.shape[axis]
    if n > 1:
        hi = [slice(None)] * 3
        lo = [slice(None)] * 3
        hi[axis], lo[axis] = slice(1, n), slice(0, n - 1)
        d = P[tuple(hi)] - P[tuple(lo)]
        fwd[tuple(lo)] = d
        bwd[tuple(hi)] = d
    central = 0.5 * (fwd + bwd)
    out = np.where(np.isfinite(central), central, fwd)
    return np.where(np.isfinite(out), out, bwd)


def _oriented(n: np.ndarray, P: np.ndarray) -> np.ndarray:
    with np.errstate(invalid="ignore", divide="ignore"):
        n = n / np.linalg.norm(n, axis=-1, keepdims=True)
        flip = np.sum(n * P, axis=-1) > 0
    n[flip] *= -1
    return n


def colors_u8(colors, shape) -> np.ndarray:
    """RGB ``shape + (3,)`` uint8 from a grey ``shape`` or RGB ``shape + (3,)`` image (float in
    [0, 1], NaN -> 0, or uint8)."""
    c = np.asarray(colors)
    if c.shape == shape:
        c = np.repeat(c[..., None], 3, axis=-1)
    if c.shape != shape + (3,):
        raise ValueError(f"colours must be a grey image {shape} or an RGB image {shape + (3,)} matching the points, "
                         f"got {c.shape}")
    if c.dtype.kind == "f":
        c = np.clip(np.nan_to_num(c) * 255.0 + 0.5, 0, 255)
    return c.astype(np.uint8)
