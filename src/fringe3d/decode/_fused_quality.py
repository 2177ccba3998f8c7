"""The one-direction quality map of :func:`fringe3d.decode.edges.quality_map` in three numba
passes (private; the fused 3-step path of long sequences, :mod:`fringe3d.reconstruct.fast_quality`).

``quality_map`` builds the map from a dozen whole-image passes (the neighbourhood filters of
:mod:`fringe3d.decode._stencils` and numpy temporaries for every comparison and bit). Here:

1. per row, the jump of ``w`` to its valid 4-neighbours (GRADIENT's input) into a copy padded
   by two replicated pixels, and the fringe contrast ``B / A`` (MOD_DROP's) with its largest
   value over five columns;
2. the 5 x 5 median of the jumps (:func:`fringe3d.decode._median_network._median_kernel`);
3. per row, every bit: INVALID, EDGE, GRADIENT (the jump test OR-ed over the 3 x 3
   neighbourhood: the one-pixel growth), MOD_DROP (the largest contrast over five rows of the
   five-column maxima) and RIM.

Every comparison is made in the dtype numpy makes it in (float32 maps, the Python thresholds
cast to float32), so the map equals ``quality_map``'s bit for bit (``tests/test_fused_quality.py``).
"""
from __future__ import annotations

import numba
import numpy as np

from fringe3d.decode._median_network import _median_kernel
from fringe3d.decode._stencils import erode_cross

INVALID, EDGE, GRADIENT, MOD_DROP, RIM = 1, 2, 8, 16, 32


@numba.njit(parallel=True, cache=True)
def _jump_contrast_kernel(w, valid, modulation, average, gp, hmax):  # pragma: no cover - compiled
    H, W = w.shape
    zero = np.float32(0.0)
    for i in numba.prange(H):
        # the row and its neighbours padded by an invalid pixel each side: branch-free inner loops
        wr = np.zeros(W + 2, np.float32)
        vr = np.zeros(W + 2, np.bool_)
        wu = np.zeros(W, np.float32)
        vu = np.zeros(W, np.bool_)
        wd = np.zeros(W, np.float32)
        vd = np.zeros(W, np.bool_)
        for j in range(W):
            wr[j + 1] = w[i, j]
            vr[j + 1] = valid[i, j]
        if i > 0:
            for j in range(W):
                wu[j] = w[i - 1, j]
                vu[j] = valid[i - 1, j]
        if i < H - 1:
            for j in range(W):
                wd[j] = w[i + 1, j]
                vd[j] = valid[i + 1, j]
        c = np.empty(W + 4, np.float32)
        for j in range(W):
            a = wr[j + 1]
            v = vr[j + 1]
            g = max(max(zero, abs(a - wu[j]) if (v and vu[j]) else zero),
                    abs(a - wd[j]) if (v and vd[j]) else zero)
            g = max(max(g, abs(a - wr[j]) if (v and vr[j]) else zero),
                    abs(a - wr[j + 2]) if (v and vr[j + 2]) else zero)
            gp[i + 2, j + 2] = g
            A = average[i, j]
            c[j + 2] = np.float32(modulation[i, j] / A) if (v and A > 0) else zero
        c[0] = c[1] = c[W + 2] = c[W + 3] = zero  # contrast >= 0: a zero pad leaves the maxima alone
        for j in range(W):  # the contrast's largest value over columns j-2..j+2
            hmax[i, j] = max(max(max(c[j], c[j + 1]), max(c[j + 2], c[j + 3])), c[j + 4])
            hmax[i + H, j] = c[j + 2]  # the contrast itself, below
        gp[i + 2, 0] = gp[i + 2, 2]
        gp[i + 2, 1] = gp[i + 2, 2]
        gp[i + 2, W + 2] = gp[i + 2, W + 1]
        gp[i + 2, W + 3] = gp[i + 2, W + 1]
    for j in range(W + 4):  # the replicated top and bottom rows
        gp[0, j] = gp[2, j]
        gp[1, j] = gp[2, j]
        gp[H + 2, j] = gp[H + 1, j]
        gp[H + 3, j] = gp[H + 1, j]


@numba.njit(parallel=True, cache=True)
def _bits_kernel(w, valid, gp, ref, hmax, lo, hi, g_ratio, g_floor, m_ratio, rim1, q):  # pragma: no cover
    H, W = w.shape
    for i in numba.prange(H):
        vo = np.zeros(W + 2, np.bool_)  # GRADIENT: the jump test OR-ed over rows i-1..i+1 ...
        for r in range(max(i - 1, 0), min(i + 2, H)):
            for j in range(W):
                vo[j + 1] |= valid[r, j] and gp[r + 2, j + 2] > max(g_ratio * ref[r, j], g_floor)
        top = np.empty(W, np.float32)  # MOD_DROP: the contrast's largest value over rows i-2..i+2
        for j in range(W):
            top[j] = hmax[i, j]
        for r in range(max(i - 2, 0), min(i + 3, H)):
            for j in range(W):
                top[j] = max(top[j], hmax[r, j])
        # RIM: an invalid 4-neighbour inside the image (the outside counts as valid)
        nb = np.ones(W + 2, np.bool_)
        for j in range(W):
            nb[j + 1] = valid[i, j]
        if rim1:
            if i > 0:
                for j in range(W):
                    nb[j + 1] &= valid[i - 1, j]
            if i < H - 1:
                for j in range(W):
                    nb[j + 1] &= valid[i + 1, j]
        for j in range(W):
            x = np.float32(w[i, j])
            b = ((EDGE if (x < lo or x > hi) else 0)
                 | (GRADIENT if (vo[j] or vo[j + 1] or vo[j + 2]) else 0)
                 | (MOD_DROP if hmax[i + H, j] < m_ratio * top[j] else 0)
                 | (RIM if (rim1 and not (nb[j + 1] and valid[i, max(j - 1, 0)] and valid[i, min(j + 1, W - 1)]))
                    else 0))
            q[i, j] = b if valid[i, j] else INVALID


def fused_quality_map(mask: np.ndarray, w: np.ndarray, extent: tuple[float, float], margin: float,
                      modulation: np.ndarray, average: np.ndarray, gradient_ratio: float = 4.0,
                      gradient_floor: float = 1.0, modulation_ratio: float = 0.5, rim: int = 1) -> np.ndarray:
    """(H, W) uint8: ``fringe3d.decode.edges.quality_map(mask, w, extent, margin, modulation,
    average, None, gradient_ratio=..., gradient_floor=..., modulation_ratio=..., rim=...)``
    (one direction, no multi-frequency residual); ``w``, ``modulation``, ``average`` (H, W)
    float32 (px, grey levels), ``mask`` (H, W) bool."""
    valid = np.ascontiguousarray(mask, bool)
    w = np.ascontiguousarray(w, np.float32)
    modulation = np.ascontiguousarray(modulation, np.float32)
    average = np.ascontiguousarray(average, np.float32)
    H, W = valid.shape
    gp = np.empty((H + 4, W + 4), np.float32)
    hmax = np.empty((2 * H, W), np.float32)  # the contrast's row-wise 5-max, then the contrast
    _jump_contrast_kernel(w, valid, modulation, average, gp, hmax)
    ref = np.empty((H, W), np.float32)
    _median_kernel(gp, ref)
    lo, hi = extent
    f32 = np.float32
    q = np.empty((H, W), np.uint8)
    _bits_kernel(w, valid, gp, ref, hmax, f32(lo + margin), f32(hi - margin), f32(gradient_ratio),
                 f32(gradient_floor), f32(modulation_ratio), rim == 1, q)
    if rim > 1:  # wider rims: the iterated erosion of edges.rim_of_invalid
        q |= (valid & ~erode_cross(valid, int(rim))).astype(np.uint8) * np.uint8(RIM)
    return q
