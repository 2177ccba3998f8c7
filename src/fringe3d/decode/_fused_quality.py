"""The one-direction quality map of :func:`fringe3d.decode.edges.quality_map` in three numba
passes (private; the fused 3-step path of long sequences, :mod:`fringe3d.reconstruct.fast_quality`).

``quality_map`` builds the map from a dozen whole-image passes (the neighbourhood filters of
:mod:`fringe3d.decode._stencils` and numpy temporaries for every comparison and bit). Here:

1. per row, the jump of ``w`` to its valid 4-neighbours (GRADIENT's input) into a copy padded
   by two replicated pixels, and the fringe contrast ``B / A`` (MOD_DROP's) with its largest
   value over five columns;
2. GRADIENT's test per pixel, ``jump > max(ratio * median, floor)`` with the median of the
   jumps over 5 x 5 pixels, without the median: the 25 values ``ratio * v`` are ordered as the
   ``v`` (a monotone map, rounding included, keeps the 13th of 25 the middle one), so ``jump >
   ratio * median`` exactly when at least 13 of them are below ``jump`` (a count of 25
   comparisons, about 4x faster than the 113 compare-exchanges of the median network,
   :func:`fringe3d.decode._median_network._median_kernel`, which a non-finite ratio still takes);
3. per row, every bit: INVALID, EDGE, GRADIENT (the jump test OR-ed over the 3 x 3
   neighbourhood: the one-pixel growth), MOD_DROP (the largest contrast over five rows of the
   five-column maxima) and RIM.

Every comparison is made in the dtype numpy makes it in (float32 maps, the Python thresholds
cast to float32), so the map equals ``quality_map``'s bit for bit (``tests/test_fused_quality.py``).
"""
from __future__ import annotations

import math

import numba
import numpy as np

from fringe3d.decode._median_network import _median_kernel
from fringe3d.decode._stencils import erode_cross

INVALID, EDGE, INCONSISTENT, GRADIENT, MOD_DROP, RIM, ORDER, SATURATED = 1, 2, 4, 8, 16, 32, 64, 128


@numba.njit(parallel=True, cache=True, nogil=True)
def _jump_contrast_kernel(w, valid, modulation, average, gp, hmax):  # pragma: no cover - compiled
    H, W = w.shape
    zero = np.float32(0.0)
    for i in numba.prange(H):
        # a missing neighbour (outside the image) is the pixel itself: its jump 0 leaves the max
        # alone; the row padded by its end pixels, so the pixel loop is branch-free and vectorises
        u, d = max(i - 1, 0), min(i + 1, H - 1)
        wr = np.empty(W + 2, np.float32)
        vr = np.empty(W + 2, np.bool_)
        for j in range(W):
            wr[j + 1] = w[i, j]
            vr[j + 1] = valid[i, j]
        wr[0], vr[0], wr[W + 1], vr[W + 1] = wr[1], vr[1], wr[W], vr[W]
        c = np.empty(W + 4, np.float32)
        for j in range(W):
            a = wr[j + 1]
            v = vr[j + 1]
            g1 = abs(a - w[u, j]) if (v & valid[u, j]) else zero
            g2 = abs(a - w[d, j]) if (v & valid[d, j]) else zero
            g3 = abs(a - wr[j]) if (v & vr[j]) else zero
            g4 = abs(a - wr[j + 2]) if (v & vr[j + 2]) else zero
            gp[i + 2, j + 2] = max(max(g1, g2), max(g3, g4))
            A = average[i, j]
            c[j + 2] = np.float32(modulation[i, j] / A) if (v & (A > 0)) else zero
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


@numba.njit(parallel=True, cache=True, nogil=True)
def _jump_test_kernel(valid, gp, ref, g_ratio, g_floor, t):  # pragma: no cover - compiled
    """GRADIENT's test per pixel, once: ``t[i, j + 1] = valid & jump > max(ratio * median, floor)``
    (``t`` (H, W + 2) uint8, its first and last columns 0; ``ref`` the 5 x 5 median)."""
    H, W = valid.shape
    for i in numba.prange(H):
        t[i, 0] = 0
        t[i, W + 1] = 0
        for j in range(W):
            t[i, j + 1] = valid[i, j] & (gp[i + 2, j + 2] > max(g_ratio * ref[i, j], g_floor))


@numba.njit(parallel=True, cache=True, nogil=True)
def _jump_count_kernel(valid, gp, g_ratio, g_floor, t):  # pragma: no cover - compiled
    """:func:`_jump_test_kernel` without the median: ``jump > ratio * median`` of the 25 jumps
    ``v`` around the pixel exactly when ``ratio * v < jump`` for at least 13 of them (``ratio``
    finite). Per row: each of the five rows of ``v`` scaled once, then its five comparisons
    counted for the whole row (branch-free, contiguous: the loops vectorise)."""
    H, W = valid.shape
    for i in numba.prange(H):
        t[i, 0] = 0
        t[i, W + 1] = 0
        n = np.zeros(W, np.int32)  # 32-bit counts, the float32 lanes' width (uint8 counts were 1.5x slower)
        s = np.empty(W + 4, np.float32)
        c = gp[i + 2, 2:W + 2]
        for a in range(5):
            row = gp[i + a]
            for j in range(W + 4):
                s[j] = g_ratio * row[j]
            for j in range(W):
                cj = c[j]
                n[j] += (np.int32(s[j] < cj) + np.int32(s[j + 1] < cj) + np.int32(s[j + 2] < cj)
                         + np.int32(s[j + 3] < cj) + np.int32(s[j + 4] < cj))
        for j in range(W):
            t[i, j + 1] = valid[i, j] & (c[j] > g_floor) & (n[j] >= 13)


@numba.njit(parallel=True, cache=True, nogil=True)
def _bits_kernel(w, valid, t, hmax, lo, hi, m_ratio, rim1, q):  # pragma: no cover - compiled
    """Every bit of row ``i`` from row-clamped neighbours (a repeated row leaves an OR or a max
    alone); each condition is made a 0/1 integer times its bit, so the pixel loops
    are branch-free and vectorise."""
    H, W = w.shape
    for i in numba.prange(H):
        u1, d1 = max(i - 1, 0), min(i + 1, H - 1)
        u2, d2 = max(i - 2, 0), min(i + 2, H - 1)
        vo = np.empty(W + 2, np.uint8)  # GRADIENT: the jump test OR-ed over rows i-1..i+1 ...
        for j in range(W + 2):
            vo[j] = t[u1, j] | t[i, j] | t[d1, j]
        b = np.empty(W, np.uint8)
        for j in range(W):  # ... and columns j-1..j+1; EDGE; MOD_DROP: the contrast's largest
            # value over rows i-2..i+2 of the five-column maxima
            top = max(max(max(hmax[u2, j], hmax[u1, j]), max(hmax[i, j], hmax[d1, j])), hmax[d2, j])
            x = w[i, j]
            b[j] = ((np.uint8((x < lo) | (x > hi)) * np.uint8(EDGE))
                    | ((vo[j] | vo[j + 1] | vo[j + 2]) * np.uint8(GRADIENT))
                    | (np.uint8(hmax[i + H, j] < m_ratio * top) * np.uint8(MOD_DROP)))
        if rim1:  # RIM: a 4-neighbour invalid; the row padded by its own end pixels (the outside counts as valid)
            vp = np.empty(W + 2, np.uint8)
            for j in range(W):
                vp[j + 1] = valid[i, j]
            vp[0] = valid[i, 0]
            vp[W + 1] = valid[i, W - 1]
            for j in range(W):
                inside = vp[j] & vp[j + 1] & vp[j + 2] & np.uint8(valid[u1, j]) & np.uint8(valid[d1, j])
                b[j] |= (inside ^ np.uint8(1)) * np.uint8(RIM)
        for j in range(W):  # the bits where valid (v = 1: a mask of ones), else INVALID alone
            v = np.uint8(valid[i, j])
            q[i, j] = (b[j] & (np.uint8(0) - v)) | ((v ^ np.uint8(1)) * np.uint8(INVALID))


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
    lo, hi = extent
    f32 = np.float32
    t = np.empty((H, W + 2), np.uint8)
    if math.isfinite(f32(gradient_ratio)):
        _jump_count_kernel(valid, gp, f32(gradient_ratio), f32(gradient_floor), t)
    else:  # inf * 0 is NaN: the median itself
        ref = np.empty((H, W), np.float32)
        _median_kernel(gp, ref)
        _jump_test_kernel(valid, gp, ref, f32(gradient_ratio), f32(gradient_floor), t)
    q = np.empty((H, W), np.uint8)
    _bits_kernel(w, valid, t, hmax, f32(lo + margin), f32(hi - margin), f32(modulation_ratio), rim == 1, q)
    if rim > 1:  # wider rims: the iterated erosion of edges.rim_of_invalid
        q |= (valid & ~erode_cross(valid, int(rim))).astype(np.uint8) * np.uint8(RIM)
    return q


@numba.njit(parallel=True, cache=True)
def _finish_kernel(q, mask, order, saturated, residual, thr, has_order, has_sat, has_res):  # pragma: no cover
    """The bits ``fused_quality_map`` does not set, in place: ``q`` was made from ``mask & ~order``."""
    H, W = q.shape
    for i in numba.prange(H):
        for j in range(W):
            if not mask[i, j]:
                q[i, j] = np.uint8(INVALID | SATURATED) if (has_sat and saturated[i, j]) else np.uint8(INVALID)
            elif has_order and order[i, j]:
                q[i, j] = np.uint8(ORDER)
            elif has_res and residual[i, j] > thr:
                q[i, j] |= np.uint8(INCONSISTENT)


def finish_quality_map(q: np.ndarray, mask: np.ndarray, order: np.ndarray | None, saturated: np.ndarray | None,
                       residual: np.ndarray | None, max_disagreement: float) -> None:
    """Add ORDER, SATURATED and INCONSISTENT to ``q`` (H, W) uint8 in place, ``q`` the
    :func:`fused_quality_map` of ``mask & ~order``: the pixels of ``order`` (in ``mask``) become
    ORDER alone, the pixels outside ``mask`` INVALID (with SATURATED where ``saturated``), the
    valid ones get INCONSISTENT where ``residual > max_disagreement`` (compared in the
    residual's dtype, as numpy does); one pass."""
    m = np.ascontiguousarray(mask, bool)
    has_order, has_sat = order is not None, saturated is not None
    has_res = residual is not None and math.isfinite(max_disagreement)
    o = np.ascontiguousarray(order, bool) if order is not None else m
    s = np.ascontiguousarray(saturated, bool) if saturated is not None else m
    r = (np.ascontiguousarray(residual) if residual is not None and has_res else np.zeros((1, 1), np.float32))
    if r.dtype not in (np.float32, np.float64):
        r = r.astype(np.float64)
    _finish_kernel(q, m, o, s, r, r.dtype.type(max_disagreement), has_order, has_sat, has_res)
