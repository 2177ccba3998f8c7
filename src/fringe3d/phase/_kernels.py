"""Fused per-pixel numba kernels for the wrapped phase, and the inline helpers the temporal
unwrapping kernels (:mod:`fringe3d.unwrap._kernels`) share with them.

Every kernel walks the image once, rows in parallel (``prange``), reads the camera frames in
their own dtype (uint8, uint16 or float) and writes only its (H, W) outputs: no full-size
float temporaries. The plain-NumPy references these kernels are tested against live in the
tests (``tests/reference_engine.py``).

Phase-shift model (Eq. 2.3-2.4): ``I_k = A + B cos(phi + delta_k)``. Writing
``I_k = a + b cos(delta_k) + c sin(delta_k)`` with ``b = B cos(phi)``, ``c = -B sin(phi)``,
the least-squares solution is ``(a, b, c) = P @ I`` for the (3, N) pseudo-inverse ``P`` of the
design matrix ``[1, cos delta_k, sin delta_k]``; then ``phi = atan2(-c, b)``, ``B = hypot(b, c)``,
``A = a``. For equally spaced shifts ``P`` reduces to Eq. (2.4):
``phi = atan2(-sum I_k sin delta_k, sum I_k cos delta_k)``, ``B = (2/N)|sum I_k e^{-i delta_k}|``.
"""
from __future__ import annotations

import math
import os

# numba's default threading layer here is GNU OpenMP, whose idle workers spin-wait after each
# parallel region; on a shared or oversubscribed machine the spinning worker and the next
# region's threads fight for the cores (2 threads, load 5 on 2 cores: a 2.4 ms kernel took
# 16 ms). Passive waiting costs a futex wake-up (microseconds) per kernel call. libgomp reads
# this when numba first starts its thread pool; a value set by the user is kept.
os.environ.setdefault("OMP_WAIT_POLICY", "PASSIVE")

import numpy as np
from numba import njit, prange


TWO_PI = 2.0 * math.pi

# atan(x) ~= x * P(x^2) on [0, 1]: least-squares fit at 4001 Chebyshev nodes (weighted to
# absolute error), degree 7 in x^2; max |error| 4.1e-8 rad. tests/test_phase_kernels.py
# checks fast_atan2 against numpy.arctan2.
_A0 = 0.99999944
_A1 = -0.33330106
_A2 = 0.19948505
_A3 = -0.1391578
_A4 = 0.09656195
_A5 = -0.05606228
_A6 = 0.02194596
_A7 = -0.00407312


@njit(cache=True, inline="always", fastmath=True)
def fast_atan2(y, x):
    """atan2(y, x) in (-pi, pi] with |error| < 1e-7 rad; branch-free so loops vectorise.

    ``fast_atan2(0, 0)`` is 0.
    """
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    mn = min(ax, ay)
    a = mn / mx if mx > 0.0 else 0.0
    s = a * a
    r = a * (_A0 + s * (_A1 + s * (_A2 + s * (_A3 + s * (_A4 + s * (_A5 + s * (_A6 + s * _A7)))))))
    r = (0.5 * math.pi - r) if ay > ax else r
    r = (math.pi - r) if x < 0.0 else r
    return -r if y < 0.0 else r


@njit(cache=True, inline="always")
def round_half_up(x):
    return math.floor(x + 0.5)


#: Rows per parallel work item of the row-blocked kernels.
ROW_BLOCK = 8
#: Columns per chunk in the fused kernels: a chunk's running sums (up to 9 x 256 x 4 bytes, or
#: 4 x 256 x 8) stay in the L1 cache while the frames stream through.
COL_CHUNK = 256
#: Columns per chunk of :func:`psp_rows` (its loop's setup, the runtime tests that its 14 arrays
#: do not overlap, runs once a chunk; four float32 buffers of it stay in the L1 cache).
PSP_CHUNK = 1024
#: Rows per parallel work item of :func:`psp_kernel`: a call of :func:`psp_rows`, which allocates
#: its scratch buffers per call (32 rows: a quarter of the calls of 8-row items, 32 items for
#: 1024 rows).
PSP_ROWS = 32
#: Rows per parallel work item of :func:`psp_kernel` when it also sums the Laplacian noise
#: (the item's first and last rows, whose neighbours another item writes, are summed after the
#: parallel loop: 2 rows in 64).
LAPLACIAN_BLOCK = 64
#: Fast-math flags that allow vectorisation but keep NaN/inf semantics.
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}


@njit(cache=True, inline="always", fastmath=FASTMATH)
def accumulate_chunk(frames, index, coef, i, j0, n, a, b, c, peak, init, init_peak, with_a):
    """Least-squares sums of one group over columns ``j0 .. j0 + n - 1`` of row ``i``:
    ``a/b/c[j] (+)= sum_k coef[:, k] * frames[index[k], i, j0 + j]`` and the running
    ``peak[j]`` (max over frames) in the buffers' dtype. ``init``: the sums start at this group (the first
    pass assigns instead of adding, no zeroing pass); ``init_peak``: likewise for ``peak``;
    ``with_a=False`` skips the average sum. Contiguous passes over the columns (vectorised),
    three frames per pass to cut the buffer loads and stores."""
    nf = index.shape[0]
    k = 0
    while k < nf:
        m = min(3, nf - k)  # frames in this pass: 3, or 1-2 at the end (their coefficients 0)
        r0 = frames[index[k], i, j0:j0 + n]
        r1 = frames[index[k + 1 if m > 1 else k], i, j0:j0 + n]
        r2 = frames[index[k + 2 if m > 2 else k], i, j0:j0 + n]
        a0 = coef[0, k]
        b0 = coef[1, k]
        c0 = coef[2, k]
        a1 = coef[0, k + 1] if m > 1 else coef.dtype.type(0)
        b1 = coef[1, k + 1] if m > 1 else coef.dtype.type(0)
        c1 = coef[2, k + 1] if m > 1 else coef.dtype.type(0)
        a2 = coef[0, k + 2] if m > 2 else coef.dtype.type(0)
        b2 = coef[1, k + 2] if m > 2 else coef.dtype.type(0)
        c2 = coef[2, k + 2] if m > 2 else coef.dtype.type(0)
        fresh = init and k == 0
        fresh_peak = init_peak and k == 0
        for j in range(n):
            x0 = b.dtype.type(r0[j])  # the buffers' dtype (float32 or float64) sets the precision
            x1 = b.dtype.type(r1[j])
            x2 = b.dtype.type(r2[j])
            sb = b0 * x0 + b1 * x1 + b2 * x2
            sc = c0 * x0 + c1 * x1 + c2 * x2
            pk = max(x0, max(x1, x2))
            if fresh:
                b[j] = sb
                c[j] = sc
                if with_a:
                    a[j] = a0 * x0 + a1 * x1 + a2 * x2
            else:
                b[j] += sb
                c[j] += sc
                if with_a:
                    a[j] += a0 * x0 + a1 * x1 + a2 * x2
            peak[j] = pk if fresh_peak else max(peak[j], pk)
        k += m


@njit(cache=True, parallel=True)
def psp_kernel(frames, index, coef, sat_level, phase, average, modulation, saturated, min_modulation, valid,
               masked, invalid, sums, counts):
    """Least-squares N-step phase (Eq. 2.4) for frames ``frames[index]``.

    frames (F, H, W) any real dtype; index (N,) int64; coef (3, N) float32 pseudo-inverse (the
    frames read as float32, float32 sums, atan2 and sqrt); sat_level float32: a pixel is flagged
    saturated when any of its N values (as float32) >= sat_level (pass ``inf`` to disable).
    Outputs (H, W): phase float32 rad in (-pi, pi], average and modulation float32 in the
    frames' units, saturated bool. With ``valid`` (H, W) bool and ``masked`` (H, W)
    float32 (else pass (0, 0) arrays): also ``valid = (modulation >= min_modulation) &
    ~saturated & isfinite(phase)`` (float32 ``min_modulation``) and the phase with NaN outside
    it, from the same pass. With ``valid`` and ``invalid`` (H, W) uint8, ``sums`` (H,) float64
    and ``counts`` (H,) int64, all zero (else (0, 0) and (0,) arrays): also ``invalid = ~valid``
    (0/1) and each row's Laplacian noise sums of the average over ``valid``
    (:func:`laplacian_row32`, while the rows are in the cache).

    The parallel loop only hands row ranges to :func:`psp_rows` (serial): numba's parallel
    lowering then works on a call, not on the loops (a shorter compilation per frame dtype).
    """
    h = frames.shape[1]
    with_noise = valid.shape == phase.shape and h > 0 and invalid.shape == phase.shape and sums.shape[0] == h
    rows = LAPLACIAN_BLOCK if with_noise else PSP_ROWS
    nblk = (h + rows - 1) // rows
    for blk in prange(nblk):
        psp_rows(frames, index, coef, sat_level, phase, average, modulation, saturated, min_modulation, valid,
                 masked, invalid, sums, counts, blk * rows, min(h, blk * rows + rows))
    if with_noise:  # each item's first and last row: their neighbours are written now
        laplacian_item_edges(average, valid, rows, sums, counts)


@njit(cache=True, nogil=True)
def laplacian_item_edges(average, valid, rows, sums, counts):
    """``sums[i], counts[i]`` of :func:`laplacian_row32` for the first and last row ``i`` of each
    ``rows``-row item of :func:`psp_kernel` (the image's first and last rows excepted): the rows
    an item could not sum before its neighbours were written (compiled once, not per frame dtype)."""
    h = average.shape[0]
    resp = np.empty(COL_CHUNK, np.float32)
    for r0 in range(0, h, rows):
        for i in (r0, min(h, r0 + rows) - 1):
            if 1 <= i <= h - 2:
                sums[i], counts[i] = laplacian_row32(average, valid, i, resp)


@njit(cache=True, nogil=True, fastmath=FASTMATH)
def psp_rows(frames, index, coef, sat_level, phase, average, modulation, saturated, min_modulation, valid,
             masked, invalid, sums, counts, r0, r1):
    """Rows ``r0 .. r1 - 1`` of :func:`psp_kernel` (its arguments, serial); the Laplacian sums of
    rows ``r0 + 1 .. r1 - 2``, whose neighbours are in the range."""
    w = frames.shape[2]
    nf = index.shape[0]
    last = 3 * ((nf - 1) // 3)  # the first of the last 1 to 3 frames (last_pass); those before: add_frame
    with_valid = valid.shape == phase.shape
    with_noise = with_valid and invalid.shape == phase.shape and sums.shape[0] == phase.shape[0]
    acc = np.empty((4, PSP_CHUNK), np.float32)
    a, b, c, peak = acc[0], acc[1], acc[2], acc[3]
    acc[:3] = 0.0  # every pass adds to the sums (one loop for every pass; zeroed again per chunk when N > 3)
    peak[:] = -np.inf
    # the mask outputs of a plain pass (no valid) go to scratch chunks: one branch-free loop
    scratch = np.empty((3, PSP_CHUNK if not with_noise else 0), np.uint8)
    no_masked = np.empty(PSP_CHUNK if not with_valid else 0, np.float32)
    resp = np.empty(COL_CHUNK, np.float32)
    for i in range(r0, r1):
        for j0 in range(0, w, PSP_CHUNK):
            n = min(PSP_CHUNK, w - j0)
            if last > 0:  # every pass but the last into the buffers
                acc[:3, :n] = 0.0
                peak[:n] = -np.inf
                for k in range(last):
                    add_frame(frames[index[k], i, j0:j0 + n], coef[0, k], coef[1, k], coef[2, k], a, b, c, peak)
            last_pass(frames, index, coef, last, sat_level, i, j0, n, a, b, c, peak, phase[i, j0:j0 + n],
                      average[i, j0:j0 + n], modulation[i, j0:j0 + n], saturated[i, j0:j0 + n], min_modulation,
                      valid[i, j0:j0 + n] if with_valid else scratch[0, :n].view(np.bool_),
                      masked[i, j0:j0 + n] if with_valid else no_masked[:n],
                      invalid[i, j0:j0 + n] if with_noise else scratch[1, :n])
        if with_noise and i >= r0 + 2:  # row i - 1 once row i is written
            sums[i - 1], counts[i - 1] = laplacian_row32(average, valid, i - 1, resp)


@njit(cache=True, inline="always", fastmath=FASTMATH)
def add_frame(row, ak, bk, ck, a, b, c, peak):
    """One frame's ``row`` (a chunk of its columns) added to the float32 sums ``a, b, c``
    (coefficients ``ak, bk, ck``) and the running ``peak``: the passes before :func:`last_pass`
    of an N > 3 group (one small loop a frame: less code to compile than passes of three)."""
    for j in range(row.shape[0]):
        x = np.float32(row[j])
        a[j] += ak * x
        b[j] += bk * x
        c[j] += ck * x
        peak[j] = max(peak[j], x)


@njit(cache=True, inline="always", fastmath=FASTMATH)
def last_pass(frames, index, coef, k, sat_level, i, j0, n, a, b, c, peak, ph, av, mo, sa, min_modulation, va, ma,
              iv):
    """The last 1 to 3 frames (``index[k:]``) of the least-squares sums over columns ``j0 .. j0 +
    n - 1`` of row ``i`` (frames read as float32, float32 sums; a missing frame's coefficients
    0), added to the buffers ``a, b, c, peak`` of the frames before (zero and -inf where ``k ==
    0``), and from them, in the same loop (float32, 8 lanes), the outputs of
    :func:`psp_kernel`: ``ph, av, mo``, ``sa = peak >= sat_level``, ``va``, ``ma`` and ``iv``."""
    nf = index.shape[0]
    m = nf - k
    r0 = frames[index[k], i, j0:j0 + n]
    r1 = frames[index[k + 1 if m > 1 else k], i, j0:j0 + n]
    r2 = frames[index[k + 2 if m > 2 else k], i, j0:j0 + n]
    zero = np.float32(0.0)
    a0 = coef[0, k]
    b0 = coef[1, k]
    c0 = coef[2, k]
    a1 = coef[0, k + 1] if m > 1 else zero
    b1 = coef[1, k + 1] if m > 1 else zero
    c1 = coef[2, k + 1] if m > 1 else zero
    a2 = coef[0, k + 2] if m > 2 else zero
    b2 = coef[1, k + 2] if m > 2 else zero
    c2 = coef[2, k + 2] if m > 2 else zero
    inf = np.float32(np.inf)
    nan = np.float32(np.nan)
    for j in range(n):
        x0 = np.float32(r0[j])
        x1 = np.float32(r1[j])
        x2 = np.float32(r2[j])
        sa_ = a[j] + (a0 * x0 + a1 * x1 + a2 * x2)
        sb = b[j] + (b0 * x0 + b1 * x1 + b2 * x2)
        sc = c[j] + (c0 * x0 + c1 * x1 + c2 * x2)
        pk = max(peak[j], max(x0, max(x1, x2)))
        p = fast_atan2_f32(-sc, sb)
        mj = math.sqrt(sb * sb + sc * sc)
        s = pk >= sat_level
        v = (mj >= min_modulation) & (not s) & (abs(p) < inf)
        ph[j] = p
        av[j] = sa_
        mo[j] = mj
        sa[j] = s
        va[j] = v
        ma[j] = p if v else nan
        iv[j] = np.uint8(0) if v else np.uint8(1)


@njit(cache=True, nogil=True, fastmath=FASTMATH)
def laplacian_row32(image, mask, i, resp):
    """``(sum |L|, count)`` of row ``i`` (``1 <= i <= H - 2``) of the (H, W) float32 ``image`` over
    the pixels of the bool ``mask`` whose four neighbours are in it (the mask eroded once; the
    image's first and last columns excepted), ``L = [[1, -2, 1], [-2, 4, -2], [1, -2, 1]]``
    (:func:`fringe3d.phase._noise_kernel.interior_laplacian`'s sums) as the vertical second
    difference of the rows' horizontal ones, in float32 (8 lanes), each 256 columns' sum then
    added in float64 (``resp`` a (COL_CHUNK,) float32 scratch row)."""
    w = image.shape[1]
    two = np.float32(2.0)
    zero = np.float32(0.0)
    total = 0.0
    n = 0
    for j0 in range(0, w - 2, COL_CHUNK):  # columns j0 + 1 .. j0 + m
        m = min(COL_CHUNK, w - 2 - j0)
        # slices by column offset (-1, 0, +1): the loop's indices are never negative (no wraparound test)
        ul, uc, ur = image[i - 1, j0:j0 + m], image[i - 1, j0 + 1:j0 + 1 + m], image[i - 1, j0 + 2:j0 + 2 + m]
        cl, cc, cr = image[i, j0:j0 + m], image[i, j0 + 1:j0 + 1 + m], image[i, j0 + 2:j0 + 2 + m]
        dl, dc_, dr = image[i + 1, j0:j0 + m], image[i + 1, j0 + 1:j0 + 1 + m], image[i + 1, j0 + 2:j0 + 2 + m]
        ml, mc, mr = mask[i, j0:j0 + m], mask[i, j0 + 1:j0 + 1 + m], mask[i, j0 + 2:j0 + 2 + m]
        mu, md = mask[i - 1, j0 + 1:j0 + 1 + m], mask[i + 1, j0 + 1:j0 + 1 + m]
        for j in range(m):  # the responses first: summed under the mask, their loads became masked loads
            du = (ul[j] + ur[j]) - two * uc[j]
            dc = (cl[j] + cr[j]) - two * cc[j]
            dd = (dl[j] + dr[j]) - two * dc_[j]
            resp[j] = abs((du + dd) - two * dc)
        acc = zero
        cnt = zero  # a float32 count (exact below 2^24): an integer one would make the loop 4 lanes wide
        for j in range(m):
            ins = mc[j] & mu[j] & md[j] & ml[j] & mr[j]
            acc += resp[j] if ins else zero
            cnt += np.float32(1.0) if ins else zero
        total += np.float64(acc)
        n += int(cnt)
    return total, n


F2PI = np.float32(TWO_PI)
FINV2PI = np.float32(1.0 / TWO_PI)
_FHALF = np.float32(0.5)
_FPI = np.float32(math.pi)
_FHALFPI = np.float32(0.5 * math.pi)
_FZERO = np.float32(0.0)
_FB = (np.float32(_A0), np.float32(_A1), np.float32(_A2), np.float32(_A3), np.float32(_A4), np.float32(_A5),
       np.float32(_A6), np.float32(_A7))


@njit(cache=True, inline="always", fastmath=FASTMATH)
def fast_atan2_f32(y, x):
    """float32 version of :func:`fast_atan2` (|error| < 3e-7 rad)."""
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    mn = min(ax, ay)
    a = mn / mx if mx > _FZERO else _FZERO
    s = a * a
    r = a * (_FB[0] + s * (_FB[1] + s * (_FB[2] + s * (_FB[3] + s * (_FB[4] + s * (_FB[5] + s * (_FB[6]
                                                                                          + s * _FB[7])))))))
    r = (_FHALFPI - r) if ay > ax else r
    r = (_FPI - r) if x < _FZERO else r
    return -r if y < _FZERO else r


@njit(cache=True, inline="always", fastmath=FASTMATH)
def mod_2pi_f32(x):
    # np.floor keeps float32 (math.floor returns int64, which would promote the products to float64
    # and stop the loop vectorising in float32)
    return x - F2PI * np.floor(x * FINV2PI)


@njit(cache=True, inline="always", fastmath=FASTMATH)
def round_half_up_f32(x):
    return np.floor(x + _FHALF)
