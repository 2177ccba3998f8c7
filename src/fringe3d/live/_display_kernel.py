"""The compiled gather of :func:`fringe3d.live.display.display_points`: valid points and colours in one pass.

Private: :func:`gather_points` takes flat arguments (numba kernels take arrays, not settings).
"""
from __future__ import annotations

import numpy as np
from numba import njit


@njit(cache=True)
def gather_points(points, texture, use_texture, step, z0, scale, lut):  # pragma: no cover - compiled
    """Valid points of ``points[::step, ::step]`` (row-major) and their colours: ``lut`` (256, 3)
    indexed by ``(z - z0) * scale`` clipped to 0..255, or the grey of ``texture`` (in [0, 1])."""
    H, W = points.shape[0], points.shape[1]
    n = 0
    for v in range(0, H, step):
        for u in range(0, W, step):
            if np.isfinite(points[v, u, 2]):
                n += 1
    out = np.empty((n, 3), np.float32)
    col = np.empty((n, 3), np.uint8)
    i = 0
    for v in range(0, H, step):
        for u in range(0, W, step):
            z = points[v, u, 2]
            if not np.isfinite(z):
                continue
            out[i, 0] = points[v, u, 0]
            out[i, 1] = points[v, u, 1]
            out[i, 2] = z
            if use_texture:
                g = min(max(texture[v, u] * 255.0 + 0.5, 0.0), 255.0)
                col[i, 0] = col[i, 1] = col[i, 2] = np.uint8(g)
            else:
                t = min(max((z - z0) * scale + 0.5, 0.0), 255.0)
                k = int(t)
                col[i, 0], col[i, 1], col[i, 2] = lut[k, 0], lut[k, 1], lut[k, 2]
            i += 1
    return out, col


@njit(cache=True)
def colour_depth(points, quality, step, z0, scale, lut, invalid, other, invalid_bits,  # pragma: no cover - compiled
                 out):
    """Fill ``out[:h]`` with the colours of ``points[::step, ::step]``'s depths: ``lut`` indexed as in
    :func:`gather_points` where finite, else ``other`` where ``quality`` (same stride) is non-zero
    without a bit of ``invalid_bits`` (``INVALID``), else ``invalid``. A ``(1, 1)`` ``quality``
    means none."""
    H, W = points.shape[0], points.shape[1]
    has_quality = quality.shape[0] == H and quality.shape[1] == W
    r = 0
    for v in range(0, H, step):
        c = 0
        for u in range(0, W, step):
            z = points[v, u, 2]
            if np.isfinite(z):
                t = min(max((z - z0) * scale + 0.5, 0.0), 255.0)
                k = int(t)
                out[r, c, 0], out[r, c, 1], out[r, c, 2] = lut[k, 0], lut[k, 1], lut[k, 2]
            else:
                q = quality[v, u] if has_quality else invalid_bits
                rgb = other if q != 0 and (q & invalid_bits) == 0 else invalid
                out[r, c, 0], out[r, c, 1], out[r, c, 2] = rgb[0], rgb[1], rgb[2]
            c += 1
        r += 1
