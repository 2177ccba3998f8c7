"""The one-direction quality map of :func:`fringe3d.decode.edges.quality_map` in one numba
pass over blocks of rows (private; the fused 3-step path of long sequences,
:mod:`fringe3d.reconstruct.fast_quality`, and the decoder's :func:`~fringe3d.decode.edges.quality_map`).

``quality_map`` builds the map from a dozen whole-image passes (the neighbourhood filters of
:mod:`fringe3d.decode._stencils` and numpy temporaries for every comparison and bit). Here
:func:`_quality_rows_kernel` takes :data:`BLOCK` rows at a time and makes, in buffers of the
block that stay in cache (no whole-image temporary), for the block and the few rows either side
its stencils need:

1. per row, the jump of ``w`` to its valid 4-neighbours (GRADIENT's input) into a copy padded
   by two replicated pixels, and the fringe contrast ``B / A`` (MOD_DROP's) with its largest
   value over five columns;
2. GRADIENT's test per pixel, ``jump > max(ratio * median, floor)`` with the median of the
   jumps over 5 x 5 pixels, without the median: the 25 values ``ratio * v`` are ordered as the
   ``v`` (a monotone map, rounding included, keeps the 13th of 25 the middle one), so ``jump >
   ratio * median`` exactly when at least 13 of them are below ``jump`` (a count of 25
   comparisons, about 4x faster than the 113 compare-exchanges of the median network,
   :func:`fringe3d.decode._median_network._median_kernel`, which a non-finite ratio still takes
   in whole-image passes), counted only in column chunks holding a candidate (a valid pixel
   whose jump passes the floor);
3. per row, every bit: INVALID, EDGE, GRADIENT (the jump test OR-ed over the 3 x 3
   neighbourhood: the one-pixel growth), MOD_DROP (the largest contrast over five rows of the
   five-column maxima) and RIM.

The masks are read as uint8 bytes and every condition made a 0/1 byte (or a select on one), so
the pixel loops are branch-free and vectorise. :func:`finish_quality_map` adds the remaining
bits in one branch-free pass. Every comparison is made in the dtype numpy makes it in (float32
maps, the Python thresholds cast to float32), so the map equals ``quality_map``'s bit for bit,
and the previous kernels' (``tests/test_fused_quality.py``).
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
    finite); ``gp`` whole (the tests' entry: :func:`_quality_rows_kernel` makes it a block at a time)."""
    H, W = valid.shape
    v8 = valid.view(np.uint8)
    for i in numba.prange(H):
        s = np.empty((5, W + 4), np.float32)
        for a in range(5):
            for j in range(W + 4):
                s[a, j] = g_ratio * gp[i + a, j]
        _count_row(s, (0, 1, 2, 3, 4), gp[i + 2], v8[i], g_floor, np.empty(W, np.int32), t[i])


#: Columns per chunk of :func:`_count_row`: a chunk without a candidate pixel skips the count.
COUNT_CHUNK = 128


@numba.njit(cache=True, nogil=True)
def _count_span(s0, s1, s2, s3, s4, c, v, g_floor, n, t):  # pragma: no cover - compiled
    """:func:`_count_row` on a span of ``m = len(v)`` columns: ``s0 .. s4`` (m + 4) and ``c`` (m) from
    its first column's, ``t`` (m) its tests."""
    m = v.shape[0]
    for j in range(m):
        n[j] = 0
    for sa in (s0, s1, s2, s3, s4):
        for j in range(m):
            cj = c[j]
            n[j] += (np.int32(sa[j] < cj) + np.int32(sa[j + 1] < cj) + np.int32(sa[j + 2] < cj)
                     + np.int32(sa[j + 3] < cj) + np.int32(sa[j + 4] < cj))
    for j in range(m):
        t[j] = v[j] & np.uint8(c[j] > g_floor) & np.uint8(n[j] >= 13)


@numba.njit(cache=True, nogil=True)
def _any_candidate(c, v, g_floor):  # pragma: no cover - compiled
    """Whether a pixel of ``v`` (mask bytes) has ``c > g_floor`` (branch-free: it vectorises)."""
    hit = np.uint8(0)
    for j in range(v.shape[0]):
        hit |= v[j] & np.uint8(c[j] > g_floor)
    return hit != 0


@numba.njit(cache=True, nogil=True)
def _count_row(s, rows, c, v, g_floor, n, t):  # pragma: no cover - compiled
    """``t[j + 1] = v[j] & (c[j + 2] > floor) & (count of ratio * jumps below c[j + 2] >= 13)``
    for one row, ``s[rows[0]] .. s[rows[4]]`` the five rows of scaled jumps (padded, W + 4);
    ``t[0] = t[W + 1] = 0``; ``n`` (W) int32 scratch: the counts (32-bit, the float32 lanes'
    width), a row of ``s`` at a time (branch-free, contiguous: the loops vectorise). The count is
    made only in chunks of :data:`COUNT_CHUNK` columns that hold a valid pixel with a jump above
    the floor (on a smooth surface, few), elsewhere the test is 0 without it."""
    W = v.shape[0]
    t[0] = 0
    t[W + 1] = 0
    s0, s1, s2, s3, s4 = s[rows[0]], s[rows[1]], s[rows[2]], s[rows[3]], s[rows[4]]
    nchunks = (W + COUNT_CHUNK - 1) // COUNT_CHUNK
    hits = np.empty(nchunks, np.bool_)
    for k in range(nchunks):
        j0, j1 = k * COUNT_CHUNK, min((k + 1) * COUNT_CHUNK, W)
        hits[k] = _any_candidate(c[j0 + 2:j1 + 2], v[j0:j1], g_floor)
    if 2 * hits.sum() > nchunks:  # mostly candidates: the whole row at once (a span's slices cost too)
        _count_span(s0, s1, s2, s3, s4, c[2:W + 2], v, g_floor, n, t[1:W + 1])
        return
    for k in range(nchunks):
        j0, j1 = k * COUNT_CHUNK, min((k + 1) * COUNT_CHUNK, W)
        if hits[k]:
            _count_span(s0[j0:j1 + 4], s1[j0:j1 + 4], s2[j0:j1 + 4], s3[j0:j1 + 4], s4[j0:j1 + 4],
                        c[j0 + 2:j1 + 2], v[j0:j1], g_floor, n, t[j0 + 1:j1 + 1])
        else:
            t[j0 + 1:j1 + 1] = 0


@numba.njit(cache=True, nogil=True)
def _jump_row(w, v8, r, wr, vr, g):  # pragma: no cover - compiled
    """``g`` (W + 4): the jump of row ``r`` of ``w`` to its valid 4-neighbours (0 where the pixel
    is invalid), padded by two replicated pixels; a missing neighbour (outside the image) is the
    pixel itself. ``wr``, ``vr`` (W + 2) scratch: the row padded by its end pixels, so the pixel
    loop is branch-free and vectorises (``v8`` the mask's bytes: selects on uint8, not bool)."""
    H, W = w.shape
    zero = np.float32(0.0)
    wu, wd = w[max(r - 1, 0)], w[min(r + 1, H - 1)]
    vu, vd = v8[max(r - 1, 0)], v8[min(r + 1, H - 1)]
    wi, vi = w[r], v8[r]
    for j in range(W):
        wr[j + 1] = wi[j]
        vr[j + 1] = vi[j]
    wr[0], vr[0], wr[W + 1], vr[W + 1] = wr[1], vr[1], wr[W], vr[W]
    for j in range(W):
        a = wr[j + 1]
        v = vr[j + 1]
        g1 = abs(a - wu[j]) if (v & vu[j]) != 0 else zero
        g2 = abs(a - wd[j]) if (v & vd[j]) != 0 else zero
        g3 = abs(a - wr[j]) if (v & vr[j]) != 0 else zero
        g4 = abs(a - wr[j + 2]) if (v & vr[j + 2]) != 0 else zero
        g[j + 2] = max(max(g1, g2), max(g3, g4))
    g[0] = g[2]
    g[1] = g[2]
    g[W + 2] = g[W + 1]
    g[W + 3] = g[W + 1]


@numba.njit(cache=True, nogil=True, error_model="numpy")  # IEEE division: no zero test, so it vectorises
def _contrast_row(v, modulation, average, c, hmax, hc):  # pragma: no cover - compiled
    """``hc[j]`` the contrast ``B / A`` of one row (0 where invalid or ``A <= 0``), ``hmax[j]`` its
    largest value over columns j-2..j+2; ``c`` (W + 4) scratch."""
    W = v.shape[0]
    zero = np.float32(0.0)
    for j in range(W):
        A = average[j]
        c[j + 2] = np.float32(modulation[j] / A) if ((v[j] != 0) & (A > 0)) else zero
    c[0] = c[1] = c[W + 2] = c[W + 3] = zero  # contrast >= 0: a zero pad leaves the maxima alone
    for j in range(W):
        hmax[j] = max(max(max(c[j], c[j + 1]), max(c[j + 2], c[j + 3])), c[j + 4])
        hc[j] = c[j + 2]


@numba.njit(cache=True, nogil=True)
def _bits_row(wi, vu, vi, vd, tu, ti, td, h, hc, lo, hi, m_ratio, rim1, vo, b, top, q):  # pragma: no cover - compiled
    """Every bit of one row into ``q`` (W): ``wi`` its ``w``; ``vu, vi,
    vd`` the mask bytes of the rows above, itself, below; ``tu, ti, td`` their GRADIENT tests
    (W + 2, zero-padded); ``h`` the five rows' five-column contrast maxima; ``hc`` its contrast;
    ``vo``, ``b`` (W + 2) uint8 and ``top`` (W) float32 scratch. Each condition is a 0/1 byte times its
    bit: the loops are branch-free and vectorise."""
    W = wi.shape[0]
    h0, h1, h2, h3, h4 = h
    for j in range(W):  # MOD_DROP's reference: the contrast's largest value over rows i-2..i+2 of the
        top[j] = max(max(max(h0[j], h1[j]), max(h2[j], h3[j])), h4[j])  # five-column maxima (few
        # arrays a loop: each pair that may overlap is a run-time test, and too many keep it scalar)
    for j in range(W + 2):  # GRADIENT: the jump test OR-ed over rows i-1..i+1 ...
        vo[j] = tu[j] | ti[j] | td[j]
    for j in range(W):  # ... and columns j-1..j+1; EDGE; MOD_DROP
        x = wi[j]
        b[j] = ((np.uint8((x < lo) | (x > hi)) * np.uint8(EDGE))
                | ((vo[j] | vo[j + 1] | vo[j + 2]) * np.uint8(GRADIENT))
                | (np.uint8(hc[j] < m_ratio * top[j]) * np.uint8(MOD_DROP)))
    if rim1:  # RIM: a 4-neighbour invalid; the row padded by its own end pixels (the outside counts as valid)
        vp = vo  # done with the test: the mask row padded by its end pixels
        for j in range(W):
            vp[j + 1] = vi[j]
        vp[0] = vi[0]
        vp[W + 1] = vi[W - 1]
        for j in range(W):
            inside = vp[j] & vp[j + 1] & vp[j + 2] & vu[j] & vd[j]
            b[j] |= (inside ^ np.uint8(1)) * np.uint8(RIM)
    for j in range(W):  # the bits where valid (v = 1: a mask of ones), else INVALID alone
        v = vi[j]
        q[j] = (b[j] & (np.uint8(0) - v)) | ((v ^ np.uint8(1)) * np.uint8(INVALID))


#: Rows per block of :func:`_quality_rows_kernel`: the jumps, their scaled copies, the GRADIENT
#: tests and the contrast are made for the block's rows and the few either side its bits need
#: (3, 1 and 2 rows), kept in block buffers that stay in cache, and never written whole.
BLOCK = 32


@numba.njit(parallel=True, cache=True, nogil=True)
def _quality_rows_kernel(w, v8, modulation, average, g_ratio, g_floor, lo, hi, m_ratio, rim1, q,
                         sat8, residual, thr, has_sat, has_res):  # pragma: no cover - compiled
    """The map ``q`` (H, W) uint8 of :func:`fused_quality_map` (a finite ``ratio``) in one pass
    over blocks of :data:`BLOCK` rows: the jumps (:func:`_jump_row`) of rows ``i0 - 3 .. i1 + 2``,
    each scaled by ``ratio`` once; GRADIENT's count test (:func:`_count_row`) of rows
    ``i0 - 1 .. i1``; the contrast (:func:`_contrast_row`) of rows ``i0 - 2 .. i1 + 1``; then the
    bits of rows ``i0 .. i1 - 1`` (:func:`_bits_row`). Rows outside the image are not made: a
    neighbour row is clamped to the image (the replicated border), then looked up in the block.
    With ``has_sat`` or ``has_res`` each row is then finished as :func:`_finish_kernel` finishes
    it without ``order`` (``v8`` the mask, ``sat8`` the saturated bytes, ``residual`` (H, W) the
    disagreement tested ``> thr``), while it is in the cache."""
    H, W = w.shape
    fs = np.uint8(1) if has_sat else np.uint8(0)
    nblocks = (H + BLOCK - 1) // BLOCK
    for bk in numba.prange(nblocks):
        i0 = bk * BLOCK
        i1 = min(i0 + BLOCK, H)
        g0, g1 = max(i0 - 3, 0), min(i1 + 3, H)  # jump rows made: image rows g0 .. g1 - 1
        t0, t1 = max(i0 - 1, 0), min(i1 + 1, H)  # GRADIENT test rows
        c0, c1 = max(i0 - 2, 0), min(i1 + 2, H)  # contrast rows
        g = np.empty((g1 - g0, W + 4), np.float32)
        s = np.empty((g1 - g0, W + 4), np.float32)
        t = np.empty((t1 - t0, W + 2), np.uint8)
        hm = np.empty((c1 - c0, W), np.float32)
        hc = np.empty((c1 - c0, W), np.float32)
        wr = np.empty(W + 2, np.float32)
        vr = np.empty(W + 2, np.uint8)
        c = np.empty(W + 4, np.float32)
        n = np.empty(W, np.int32)
        b = np.empty(W + 2, np.uint8)
        top = np.empty(W, np.float32)
        inc = np.zeros(W, np.uint8)
        for r in range(g0, g1):
            gk = g[r - g0]
            sk = s[r - g0]
            _jump_row(w, v8, r, wr, vr, gk)
            for j in range(W + 4):
                sk[j] = g_ratio * gk[j]
        for r in range(t0, t1):
            rows = (max(r - 2, 0) - g0, max(r - 1, 0) - g0, r - g0, min(r + 1, H - 1) - g0, min(r + 2, H - 1) - g0)
            _count_row(s, rows, g[r - g0], v8[r], g_floor, n, t[r - t0])
        for r in range(c0, c1):
            _contrast_row(v8[r], modulation[r], average[r], c, hm[r - c0], hc[r - c0])
        for i in range(i0, i1):
            u1, d1 = max(i - 1, 0), min(i + 1, H - 1)
            u2, d2 = max(i - 2, 0), min(i + 2, H - 1)
            h = (hm[u2 - c0], hm[u1 - c0], hm[i - c0], hm[d1 - c0], hm[d2 - c0])
            _bits_row(w[i], v8[u1], v8[i], v8[d1], t[u1 - t0], t[i - t0], t[d1 - t0], h, hc[i - c0],
                      lo, hi, m_ratio, rim1, vr, b, top, q[i])
            if has_sat or has_res:
                if has_res:
                    ri = residual[i]
                    for j in range(W):
                        inc[j] = np.uint8(ri[j] > thr)
                _finish_row(q[i], v8[i], v8[i], sat8[i], inc, np.uint8(0), fs)


@numba.njit(parallel=True, cache=True, nogil=True)
def _bits_kernel(w, valid, t, hmax, lo, hi, m_ratio, rim1, q):  # pragma: no cover - compiled
    """Every bit of row ``i`` (:func:`_bits_row`) from whole-image maps, row-clamped neighbours
    (a repeated row leaves an OR or a max alone): ``t`` (H, W + 2) GRADIENT tests, ``hmax``
    (2H, W) the five-column contrast maxima then the contrast (the median path of
    :func:`fused_quality_map`)."""
    H, W = w.shape
    v8 = valid.view(np.uint8)
    for i in numba.prange(H):
        u1, d1 = max(i - 1, 0), min(i + 1, H - 1)
        u2, d2 = max(i - 2, 0), min(i + 2, H - 1)
        _bits_row(w[i], v8[u1], v8[i], v8[d1], t[u1], t[i], t[d1], (hmax[u2], hmax[u1], hmax[i], hmax[d1], hmax[d2]),
                  hmax[i + H], lo, hi, m_ratio, rim1, np.empty(W + 2, np.uint8), np.empty(W + 2, np.uint8),
                  np.empty(W, np.float32), q[i])


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
    lo, hi = extent
    f32 = np.float32
    q = np.empty((H, W), np.uint8)
    if math.isfinite(f32(gradient_ratio)):
        v8 = valid.view(np.uint8)
        _quality_rows_kernel(w, v8, modulation, average, f32(gradient_ratio), f32(gradient_floor),
                             f32(lo + margin), f32(hi - margin), f32(modulation_ratio), rim == 1, q,
                             v8, _NO_RESIDUAL, f32(0.0), False, False)
    else:  # inf * 0 is NaN: the median itself, in whole-image passes
        gp = np.empty((H + 4, W + 4), np.float32)
        hmax = np.empty((2 * H, W), np.float32)  # the contrast's row-wise 5-max, then the contrast
        _jump_contrast_kernel(w, valid, modulation, average, gp, hmax)
        ref = np.empty((H, W), np.float32)
        _median_kernel(gp, ref)
        t = np.empty((H, W + 2), np.uint8)
        _jump_test_kernel(valid, gp, ref, f32(gradient_ratio), f32(gradient_floor), t)
        _bits_kernel(w, valid, t, hmax, f32(lo + margin), f32(hi - margin), f32(modulation_ratio), rim == 1, q)
    if rim > 1:  # wider rims: the iterated erosion of edges.rim_of_invalid
        q |= (valid & ~erode_cross(valid, int(rim))).astype(np.uint8) * np.uint8(RIM)
    return q


#: The residual of a :func:`_quality_rows_kernel` call that tests none.
_NO_RESIDUAL = np.zeros((1, 1), np.float32)


def finished_quality_map(mask: np.ndarray, w: np.ndarray, band: tuple[float, float], modulation: np.ndarray,
                         average: np.ndarray, saturated: np.ndarray | None, residual: np.ndarray | None,
                         thresholds: tuple[float, float, float, float]) -> np.ndarray:
    """``fused_quality_map(mask, w, ...)`` with ``rim=1`` then ``finish_quality_map(q, mask, None,
    saturated, residual, max_disagreement)``, each row finished in the one pass that makes it
    (equal bit for bit): ``band = (lo + margin, hi - margin)`` the EDGE band's inner bounds (px),
    ``thresholds = (gradient_ratio, gradient_floor, modulation_ratio, max_disagreement)``, the
    first finite; ``residual`` float32 or None."""
    g_ratio, g_floor, m_ratio, max_disagreement = thresholds
    f32 = np.float32
    if not math.isfinite(f32(g_ratio)) or (residual is not None and np.asarray(residual).dtype != np.float32):
        raise ValueError(f"finished_quality_map: expected a finite gradient ratio and a float32 residual, got "
                         f"{g_ratio!r} and {None if residual is None else np.asarray(residual).dtype}")
    valid = np.ascontiguousarray(mask, bool)
    v8 = valid.view(np.uint8)
    H, W = valid.shape
    q = np.empty((H, W), np.uint8)
    has_res = residual is not None and math.isfinite(max_disagreement)
    res = np.ascontiguousarray(residual, np.float32) if has_res else _NO_RESIDUAL
    sat8 = np.ascontiguousarray(saturated, bool).view(np.uint8) if saturated is not None else v8
    _quality_rows_kernel(np.ascontiguousarray(w, np.float32), v8, np.ascontiguousarray(modulation, np.float32),
                         np.ascontiguousarray(average, np.float32), f32(g_ratio), f32(g_floor), f32(band[0]),
                         f32(band[1]), f32(m_ratio), True, q, sat8, res, f32(max_disagreement), saturated is not None,
                         has_res)
    return q


@numba.njit(cache=True, nogil=True)
def _finish_row(q, m, o, s, r, fo, fs):  # pragma: no cover - compiled
    """:func:`_finish_kernel` on one row, branch-free (it vectorises): ``m, o, s`` the mask, order
    and saturated bytes, ``fo, fs`` 1 where ``order``, ``saturated`` are given, else 0; ``r`` the
    INCONSISTENT test bytes."""
    for j in range(q.shape[0]):
        keep = np.uint8(0) - m[j]  # 0xff on the mask
        isord = np.uint8(0) - (o[j] & fo)  # 0xff on ORDER
        inside = (np.uint8(ORDER) & isord) | ((q[j] | (r[j] * np.uint8(INCONSISTENT))) & ~isord)
        outside = np.uint8(INVALID) | ((s[j] & fs) * np.uint8(SATURATED))
        q[j] = (inside & keep) | (outside & ~keep)


@numba.njit(parallel=True, cache=True, nogil=True)
def _finish_kernel(q, mask, order, saturated, residual, thr, has_order, has_sat, has_res):  # pragma: no cover
    """The bits ``fused_quality_map`` does not set, in place: ``q`` was made from ``mask & ~order``
    (``mask``, ``order``, ``saturated`` as uint8 bytes). Per pixel: outside ``mask`` INVALID
    (with SATURATED where ``has_sat and saturated``), else ORDER alone where ``has_order and
    order``, else INCONSISTENT added where ``has_res and residual > thr``."""
    H, W = q.shape
    fo = np.uint8(1) if has_order else np.uint8(0)
    fs = np.uint8(1) if has_sat else np.uint8(0)
    for i in numba.prange(H):
        r = np.zeros(W, np.uint8)
        if has_res:
            ri = residual[i]
            for j in range(W):
                r[j] = np.uint8(ri[j] > thr)
        _finish_row(q[i], mask[i], order[i], saturated[i], r, fo, fs)


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
    _finish_kernel(q, m.view(np.uint8), o.view(np.uint8), s.view(np.uint8), r, r.dtype.type(max_disagreement),
                   has_order, has_sat, has_res)
