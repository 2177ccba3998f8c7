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

from fringe3d.phase._noise_kernel import laplacian_ring_step, laplacian_rows_between

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


#: :func:`saturation_test` modes: no value is saturated, every value is, ``value >= threshold`` in
#: the frames' dtype, ``float64(value) >= sat_level``.
SAT_NEVER, SAT_ALWAYS, SAT_NATIVE, SAT_FLOAT64 = 0, 1, 2, 3
#: Frame dtypes whose values float64 holds exactly (so a comparison in the dtype is the float64 one).
_EXACT_KINDS = {np.dtype(t) for t in (np.uint8, np.uint16, np.uint32, np.int8, np.int16, np.int32, np.float32,
                                      np.float64)}


def saturation_test(dtype: np.dtype, sat_level: float) -> tuple[int, np.ndarray]:
    """``(mode, threshold)``: the test ``float64(x) >= sat_level`` of a frame value ``x`` of
    ``dtype`` as a comparison in that dtype, ``x >= threshold[0]`` (mode :data:`SAT_NATIVE`;
    ``threshold`` a (1,) array of ``dtype``), or a constant answer (:data:`SAT_NEVER`,
    :data:`SAT_ALWAYS`), or the float64 test itself (:data:`SAT_FLOAT64`, dtypes float64 does not
    hold exactly). An integer ``x >= s`` is ``x >= ceil(s)``; a float32 ``x >= s`` is ``x >= c``
    with ``c`` the least float32 not below ``s``; NaN compares False either way."""
    dtype = np.dtype(dtype)
    if dtype not in _EXACT_KINDS:
        return SAT_FLOAT64, np.zeros(1, dtype)
    if math.isnan(sat_level):
        return SAT_NEVER, np.zeros(1, dtype)
    if dtype.kind in "ui":
        info = np.iinfo(dtype)
        if sat_level > info.max:
            return SAT_NEVER, np.zeros(1, dtype)
        if sat_level <= info.min:
            return SAT_ALWAYS, np.zeros(1, dtype)
        return SAT_NATIVE, np.array([math.ceil(sat_level)], dtype)
    if dtype == np.float32:
        top = float(np.finfo(np.float32).max)
        if sat_level > top or sat_level < -top:  # inf, or beyond every finite float32
            c = np.float32(np.inf if sat_level > top else (-np.inf if sat_level == -np.inf else -top))
        else:
            c = np.float32(sat_level)  # the nearest float32, then up to >= sat_level
            if float(c) < sat_level:
                c = np.nextafter(c, np.float32(np.inf))
        return SAT_NATIVE, np.array([c], dtype)
    return SAT_NATIVE, np.array([sat_level], dtype)


#: atan2's constants as an argument (float32): a constant in the loop is a 64-bit address load and
#: a broadcast each vector iteration (numba's code model), an argument is a register or a folded load.
ATAN_CONSTANTS = np.array([_A0, _A1, _A2, _A3, _A4, _A5, _A6, _A7, 0.5 * math.pi, math.pi], np.float32)


@njit(cache=True, parallel=True)
def psp_kernel(frames, index, coef, sat_level, sat_mode, threshold, phase, average, modulation, saturated,
             min_modulation, valid, masked, invalid, sums, counts, kc):
    """Least-squares N-step phase (Eq. 2.4) for frames ``frames[index]``.

    frames (F, H, W) any real dtype; index (N,) int64; coef (3, N) float64 pseudo-inverse
    (float64 sums, float32 atan2/sqrt); sat_level: a pixel is flagged saturated when any of its N values
    >= sat_level (pass ``inf`` to disable). Outputs (H, W): phase float32 rad in (-pi, pi],
    average and modulation float32 in the frames' units, saturated bool (written, not or-ed in). With
    ``valid`` (H, W) bool and ``masked`` (H, W) float32 (else pass (0, 0) arrays): also
    ``valid = (modulation >= min_modulation) & ~saturated & isfinite(phase)`` (float32
    ``min_modulation``) and the phase with NaN outside it, from the same pass. With ``valid``
    and ``invalid`` (H, W) uint8, ``sums`` (H,) float64 and ``counts`` (H,) int64, all zero
    (else (0, 0) and (0,) arrays): also ``invalid = ~valid`` (0/1) and each row's Laplacian
    noise sums of the average over ``valid`` (those of
    :func:`fringe3d.phase._noise_kernel.interior_laplacian`, by the same row code, while the
    rows are in the cache).

    ``sat_mode`` and ``threshold``: the test ``>= sat_level`` as :func:`saturation_test` gives it
    (in the frames' own dtype where it can: 32 uint8 values a vector, not 4 float64); ``kc``:
    :data:`ATAN_CONSTANTS`. Three frames (the 3-step set) take one float64 loop for the three sums
    (the expressions of :func:`accumulate_chunk`'s first pass, so the same roundings). The
    parallel loop only hands row ranges to :func:`psp_rows` (serial): numba's parallel lowering
    then works on a call, not on the loops (a frame dtype's compilation ~20 % shorter).
    """
    h = frames.shape[1]
    with_noise = valid.shape == phase.shape and h > 0 and invalid.shape == phase.shape and sums.shape[0] == h
    rows = LAPLACIAN_BLOCK if with_noise else PSP_ROWS
    nblk = (h + rows - 1) // rows
    for blk in prange(nblk):
        psp_rows(frames, index, coef, sat_level, sat_mode, threshold, phase, average, modulation, saturated,
                 min_modulation, valid, masked, invalid, sums, counts, kc, blk * rows, min(h, blk * rows + rows))
    if with_noise:  # each item's first and last row: their neighbours are written now
        laplacian_rows_between(average, valid, rows, sums, counts)


@njit(cache=True, inline="always", fastmath=FASTMATH)
def sums3_chunk(frames, index, coef, i, j0, n, bf, cf, av):
    """The three least-squares sums of 3 frames over columns ``j0 .. j0 + n - 1`` of row ``i``,
    float64, written rounded to float32: ``bf``, ``cf`` (scratch) and ``av`` (the average's
    row). The expressions of :func:`accumulate_chunk`'s first pass (same roundings, contracted
    alike), in one loop with no float64 buffer."""
    r0 = frames[index[0], i, j0:j0 + n]
    r1 = frames[index[1], i, j0:j0 + n]
    r2 = frames[index[2], i, j0:j0 + n]
    a0, a1, a2 = coef[0, 0], coef[0, 1], coef[0, 2]
    b0, b1, b2 = coef[1, 0], coef[1, 1], coef[1, 2]
    c0, c1, c2 = coef[2, 0], coef[2, 1], coef[2, 2]
    for j in range(n):
        x0 = np.float64(r0[j])
        x1 = np.float64(r1[j])
        x2 = np.float64(r2[j])
        bf[j] = np.float32(b0 * x0 + b1 * x1 + b2 * x2)
        cf[j] = np.float32(c0 * x0 + c1 * x1 + c2 * x2)
        av[j] = np.float32(a0 * x0 + a1 * x1 + a2 * x2)


@njit(cache=True, inline="always")
def saturated3_chunk(frames, index, sat_level, sat_mode, threshold, i, j0, n, sa):
    """``sa[j] = max_k frames[index[k], i, j0 + j] >= sat_level`` for 3 frames, by
    :func:`saturation_test`'s mode (the max as :func:`accumulate_chunk` takes it)."""
    if sat_mode == SAT_NEVER or sat_mode == SAT_ALWAYS:
        flag = sat_mode == SAT_ALWAYS
        for j in range(n):
            sa[j] = flag
        return
    r0 = frames[index[0], i, j0:j0 + n]
    r1 = frames[index[1], i, j0:j0 + n]
    r2 = frames[index[2], i, j0:j0 + n]
    if sat_mode == SAT_NATIVE:
        t = threshold[0]
        for j in range(n):
            sa[j] = max(r0[j], max(r1[j], r2[j])) >= t
    else:
        for j in range(n):
            sa[j] = np.float64(max(r0[j], max(r1[j], r2[j]))) >= sat_level


@njit(cache=True, inline="always", fastmath=FASTMATH)
def atan2_f32(y, x, kc):
    """float32 ``atan2(y, x)`` (|error| < 3e-7 rad) by the polynomial ``a * P(a**2)`` of
    ``a = min(|x|, |y|) / max(|x|, |y|)`` on [0, 1], with its constants from ``kc`` (a tuple or
    :data:`ATAN_CONSTANTS`: an argument, not a constant in the loop, is a register or a folded
    load, where numba reloads a constant from its 64-bit address every vector iteration)."""
    zero = np.float32(0.0)
    ax = abs(x)
    ay = abs(y)
    mx = max(ax, ay)
    mn = min(ax, ay)
    a = mn / mx if mx > zero else zero
    s = a * a
    r = a * (kc[0] + s * (kc[1] + s * (kc[2] + s * (kc[3] + s * (kc[4] + s * (kc[5] + s * (kc[6]
                                                                                      + s * kc[7])))))))
    r = (kc[8] - r) if ay > ax else r
    r = (kc[9] - r) if x < zero else r
    return -r if y < zero else r


@njit(cache=True, nogil=True, fastmath=FASTMATH)
def psp_rows(frames, index, coef, sat_level, sat_mode, threshold, phase, average, modulation, saturated,
             min_modulation, valid, masked, invalid, sums, counts, kc, r0, r1):
    """Rows ``r0 .. r1 - 1`` of :func:`psp_kernel` (its arguments, serial); the Laplacian sums of
    rows ``r0 + 1 .. r1 - 2``, whose neighbours are in the range."""
    w = frames.shape[2]
    with_valid = valid.shape == phase.shape
    with_noise = with_valid and invalid.shape == phase.shape and sums.shape[0] == phase.shape[0]
    three = index.shape[0] == 3
    nan = np.float32(np.nan)
    acc = np.empty((4, 0 if three else COL_CHUNK))  # float64 sums of more than 3 frames
    a, b, c, peak = acc[0], acc[1], acc[2], acc[3]
    acc32 = np.empty((2, COL_CHUNK), np.float32)
    bf, cf = acc32[0], acc32[1]
    d = np.empty((3, w if with_noise else 0))  # second differences of three rows (a ring)
    inside = np.empty(w if with_noise else 0, np.uint8)
    k = (kc[0], kc[1], kc[2], kc[3], kc[4], kc[5], kc[6], kc[7], kc[8], kc[9])
    for i in range(r0, r1):
        for j0 in range(0, w, COL_CHUNK):
            n = min(COL_CHUNK, w - j0)
            ph = phase[i, j0:j0 + n]
            av = average[i, j0:j0 + n]
            mo = modulation[i, j0:j0 + n]
            sa = saturated[i, j0:j0 + n]
            # sums in float64 (exact for integer frames), rounded to float32 in bf, cf (and av)
            if three:
                sums3_chunk(frames, index, coef, i, j0, n, bf, cf, av)
                saturated3_chunk(frames, index, sat_level, sat_mode, threshold, i, j0, n, sa)
            else:
                accumulate_chunk(frames, index, coef, i, j0, n, a, b, c, peak, True, True, True)
                for j in range(n):
                    bf[j] = np.float32(b[j])
                    cf[j] = np.float32(c[j])
                    av[j] = a[j]
                    sa[j] = peak[j] >= sat_level
            # atan2 and sqrt in float32 (error < 3e-7 rad after rounding b, c to float32: no
            # float64 divide), 8 lanes wide; the mask from the values in registers
            if not with_valid:
                for j in range(n):
                    bj = bf[j]
                    cj = cf[j]
                    ph[j] = atan2_f32(-cj, bj, k)
                    mo[j] = math.sqrt(bj * bj + cj * cj)
            elif not with_noise:
                va = valid[i, j0:j0 + n]
                ma = masked[i, j0:j0 + n]
                for j in range(n):
                    bj = bf[j]
                    cj = cf[j]
                    p = atan2_f32(-cj, bj, k)
                    q = math.sqrt(bj * bj + cj * cj)
                    ph[j] = p
                    mo[j] = q
                    m = (q >= min_modulation) & (not sa[j]) & (p == p)  # atan2's p: finite or NaN
                    va[j] = m
                    ma[j] = p if m else nan
            else:
                va = valid[i, j0:j0 + n]
                ma = masked[i, j0:j0 + n]
                iv = invalid[i, j0:j0 + n]
                for j in range(n):
                    bj = bf[j]
                    cj = cf[j]
                    p = atan2_f32(-cj, bj, k)
                    q = math.sqrt(bj * bj + cj * cj)
                    ph[j] = p
                    mo[j] = q
                    m = (q >= min_modulation) & (not sa[j]) & (p == p)
                    va[j] = m
                    ma[j] = p if m else nan
                    iv[j] = np.uint8(0) if m else np.uint8(1)
        if with_noise:  # row i - 1's Laplacian once row i has its second difference
            laplacian_ring_step(average, valid, d, inside, i, r0, sums, counts)


F2PI = np.float32(TWO_PI)
FINV2PI = np.float32(1.0 / TWO_PI)
_FHALF = np.float32(0.5)
_FPI = np.float32(math.pi)
_FHALFPI = np.float32(0.5 * math.pi)
_FZERO = np.float32(0.0)
_FB = (np.float32(_A0), np.float32(_A1), np.float32(_A2), np.float32(_A3), np.float32(_A4), np.float32(_A5),
       np.float32(_A6), np.float32(_A7))
_FK = _FB + (_FHALFPI, _FPI)  # atan2_f32's constants, as ATAN_CONSTANTS


@njit(cache=True, inline="always", fastmath=FASTMATH)
def fast_atan2_f32(y, x):
    """float32 version of :func:`fast_atan2` (|error| < 3e-7 rad): :func:`atan2_f32` with the
    module's constants (folded into the code where the caller's loop keeps them)."""
    return atan2_f32(y, x, _FK)


@njit(cache=True, inline="always", fastmath=FASTMATH)
def mod_2pi_f32(x):
    # np.floor keeps float32 (math.floor returns int64, which would promote the products to float64
    # and stop the loop vectorising in float32)
    return x - F2PI * np.floor(x * FINV2PI)


@njit(cache=True, inline="always", fastmath=FASTMATH)
def round_half_up_f32(x):
    return np.floor(x + _FHALF)
