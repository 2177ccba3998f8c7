"""Fused per-pixel numba kernels for wrapped phase and temporal unwrapping.

Every kernel walks the image once, rows in parallel (``prange``), reads the camera frames in
their own dtype (uint8, uint16 or float) and writes only its (H, W) outputs: no full-size
float temporaries. The plain-NumPy references these kernels are tested against live next to
the public functions (:mod:`fringe3d.phase.psp`, :mod:`fringe3d.unwrap.temporal`).

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
def _round(x):
    return math.floor(x + 0.5)


#: Rows per parallel work item of the row-blocked kernels.
ROW_BLOCK = 8
#: Columns per chunk in the fused kernels: a chunk's running sums (up to 9 x 256 x 4 bytes, or
#: 4 x 256 x 8) stay in the L1 cache while the frames stream through.
COL_CHUNK = 256
#: Fast-math flags that allow vectorisation but keep NaN/inf semantics.
FASTMATH = {"nsz", "arcp", "contract", "afn", "reassoc"}


@njit(cache=True, inline="always", fastmath=FASTMATH)
def _accumulate_chunk(frames, index, coef, i, j0, n, a, b, c, peak, init, init_peak, with_a):
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


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def psp_kernel(frames, index, coef, sat_level, phase, average, modulation, saturated):
    """Least-squares N-step phase (Eq. 2.4) for frames ``frames[index]``.

    frames (F, H, W) any real dtype; index (N,) int64; coef (3, N) float64 pseudo-inverse
    (float64 sums, float32 atan2/sqrt); sat_level: a pixel is flagged saturated when any of its N values
    >= sat_level (pass ``inf`` to disable). Outputs (H, W): phase float32 rad in (-pi, pi],
    average and modulation float32 in the frames' units, saturated bool (or-ed in).
    """
    h = frames.shape[1]
    w = frames.shape[2]
    nblk = (h + ROW_BLOCK - 1) // ROW_BLOCK
    for blk in prange(nblk):
        acc = np.empty((4, COL_CHUNK))
        a, b, c, peak = acc[0], acc[1], acc[2], acc[3]
        for i in range(blk * ROW_BLOCK, min(h, (blk + 1) * ROW_BLOCK)):
            for j0 in range(0, w, COL_CHUNK):
                n = min(COL_CHUNK, w - j0)
                _accumulate_chunk(frames, index, coef, i, j0, n, a, b, c, peak, True, True, True)
                ph = phase[i, j0:j0 + n]
                av = average[i, j0:j0 + n]
                mo = modulation[i, j0:j0 + n]
                sa = saturated[i, j0:j0 + n]
                for j in range(n):
                    # sums in float64 (exact for integer frames); atan2 and sqrt in float32 (error
                    # < 3e-7 rad after rounding b, c to float32: twice the SIMD lanes, no float64 divide)
                    bj = np.float32(b[j])
                    cj = np.float32(c[j])
                    ph[j] = fast_atan2_f32(-cj, bj)
                    av[j] = a[j]
                    mo[j] = math.sqrt(bj * bj + cj * cj)
                    sa[j] = sa[j] | (peak[j] >= sat_level)


@njit(cache=True, parallel=True)
def hierarchical_kernel(wrapped, periods, lower, order_out, phase_out):
    """Hierarchical temporal unwrapping, Eq. (1.5): the coarser absolute phase unwraps the finer.

    wrapped (M, H, W) float32 wrapped phases, narrowest period first; periods (M,) float64;
    lower: the coarsest phase is placed in [lower, lower + 2 pi). Outputs (H, W): fringe order
    of the narrowest phase (int32) and its absolute phase (float32).
    ``k_i = round(((T_{i+1}/T_i) Phi_{i+1} - phi_i) / 2pi)``, ``Phi_i = phi_i + 2 pi k_i``.
    """
    m = wrapped.shape[0]
    h = wrapped.shape[1]
    w = wrapped.shape[2]
    for i in prange(h):
        for j in range(w):
            phi = np.float64(wrapped[m - 1, i, j])
            big = lower + (phi - lower) % TWO_PI
            k = 0.0
            for q in range(m - 2, -1, -1):
                phi = np.float64(wrapped[q, i, j])
                k = _round((big * (periods[q + 1] / periods[q]) - phi) / TWO_PI)
                big = phi + TWO_PI * k
            if m == 1:
                k = _round((big - phi) / TWO_PI)
            order_out[i, j] = np.int32(k)
            phase_out[i, j] = big


@njit(cache=True, inline="always")
def _beat(phi_a, phi_b, sign):
    """Wrapped beat phase sign*(phi_a - phi_b) in [0, 2 pi)."""
    return (sign * (phi_a - phi_b)) % TWO_PI


@njit(cache=True, parallel=True)
def heterodyne_kernel(wrapped, signs, beat_periods, periods, lower, order_out, phase_out):
    """Multi-frequency heterodyne unwrapping (three-frequency: 18, 21, 144 -> 126 -> 1008).

    wrapped (M, H, W) float32, M >= 2, narrowest first; beat chain
    ``b_1 = beat(phi_0, phi_1)``, ``b_q = beat(b_{q-1}, phi_q)`` with equivalent periods
    ``beat_periods[q-1]`` and signs making each beat increase with w. The last beat is taken
    in [lower, lower + 2 pi) as absolute, then each beat unwraps the previous one and the first
    beat unwraps phi_0. Outputs as :func:`hierarchical_kernel`.
    """
    m = wrapped.shape[0]
    h = wrapped.shape[1]
    w = wrapped.shape[2]
    nb = m - 1
    for i in prange(h):
        beats_local = np.empty(nb)
        for j in range(w):
            b = _beat(np.float64(wrapped[0, i, j]), np.float64(wrapped[1, i, j]), signs[0])
            beats_local[0] = b
            for q in range(1, nb):
                b = _beat(b, np.float64(wrapped[q + 1, i, j]), signs[q])
                beats_local[q] = b
            big = lower + (b - lower) % TWO_PI
            for q in range(nb - 2, -1, -1):
                kq = _round((big * (beat_periods[q + 1] / beat_periods[q]) - beats_local[q]) / TWO_PI)
                big = beats_local[q] + TWO_PI * kq
            phi = np.float64(wrapped[0, i, j])
            k = _round((big * (beat_periods[0] / periods[0]) - phi) / TWO_PI)
            order_out[i, j] = np.int32(k)
            phase_out[i, j] = phi + TWO_PI * k


_F2PI = np.float32(TWO_PI)
_FINV2PI = np.float32(1.0 / TWO_PI)
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
def _mod_2pi_f32(x):
    # np.floor keeps float32 (math.floor returns int64, which would promote the products to float64
    # and stop the loop vectorising in float32)
    return x - _F2PI * np.floor(x * _FINV2PI)


@njit(cache=True, inline="always", fastmath=FASTMATH)
def _round_f32(x):
    return np.floor(x + _FHALF)


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def three_frequency_kernel(frames, idx1, coef1, idx2, coef2, idx3, coef3, params,
                           phase, wrapped, modulation, average, mask, texture):
    """Fused three-frequency heterodyne decode: wrapped phases of the three groups, the two
    beats, absolute phase, modulation, average and validity mask in one pass per pixel
    (float32 arithmetic; rows in parallel, columns vectorised).

    frames (F, H, W) uint8/uint16/float; idx_g (N_g,) int64 frame indices and coef_g (3, N_g)
    float32 least-squares coefficients of group g (narrowest period first). ``params`` float32
    ``(s12, s123, r_top, r_mid, lower, min_modulation, sat_level, max_residual)``: beat
    signs, period ratios ``r_top = T123/T12`` and ``r_mid = T12/T1``, the start of the
    absolute window of the final beat (rad), the modulation threshold, the saturation level
    and the largest accepted unwrapping residual (rad): at each of the two unwrapping steps
    ``e = scaled coarse phase - fine phase - 2 pi k`` lies in [-pi, pi]; a consistent pixel
    has ``|e|`` of a few noise sigmas, an inconsistent one (mixed silhouette pixel, glint)
    near pi, where the fringe order is a coin toss, so it is masked. Outputs (H, W):
    absolute phase float32 (NaN where invalid), wrapped phase of group 1 float32, its
    modulation and average float32, mask bool (modulation of every group >= min_modulation
    and no frame >= sat_level and both unwrapping residuals <= max_residual), texture float32
    (average + modulation of group 1, the fringe-free intensity ``A + B``).
    """
    s12 = params[0]
    s123 = params[1]
    r_top = params[2]
    r_mid = params[3]
    lower = params[4]
    min_mod2 = params[5] * params[5]
    sat_level = params[6]
    max_res = params[7]
    h = frames.shape[1]
    w = frames.shape[2]
    nan = np.float32(np.nan)
    nblk = (h + ROW_BLOCK - 1) // ROW_BLOCK
    for blk in prange(nblk):
        acc = np.empty((9, COL_CHUNK), np.float32)  # a2 is a dummy: groups 2, 3 need no average
        a1, b1, c1, a2, b2, c2, b3, c3, peak = acc[0], acc[1], acc[2], acc[3], acc[4], acc[5], acc[6], acc[7], acc[8]
        for i in range(blk * ROW_BLOCK, min(h, (blk + 1) * ROW_BLOCK)):
            for j0 in range(0, w, COL_CHUNK):
                n = min(COL_CHUNK, w - j0)
                _accumulate_chunk(frames, idx1, coef1, i, j0, n, a1, b1, c1, peak, True, True, True)
                _accumulate_chunk(frames, idx2, coef2, i, j0, n, a2, b2, c2, peak, True, False, False)
                _accumulate_chunk(frames, idx3, coef3, i, j0, n, a2, b3, c3, peak, True, False, False)
                ph = phase[i, j0:j0 + n]
                wr = wrapped[i, j0:j0 + n]
                mo = modulation[i, j0:j0 + n]
                av = average[i, j0:j0 + n]
                ma = mask[i, j0:j0 + n]
                tx = texture[i, j0:j0 + n]
                for j in range(n):
                    m1 = b1[j] * b1[j] + c1[j] * c1[j]
                    m2 = b2[j] * b2[j] + c2[j] * c2[j]
                    m3 = b3[j] * b3[j] + c3[j] * c3[j]
                    p1 = fast_atan2_f32(-c1[j], b1[j])
                    p2 = fast_atan2_f32(-c2[j], b2[j])
                    p3 = fast_atan2_f32(-c3[j], b3[j])
                    x12 = _mod_2pi_f32(s12 * (p1 - p2))
                    x123 = _mod_2pi_f32(s123 * (x12 - p3))
                    big = lower + _mod_2pi_f32(x123 - lower)
                    d1 = big * r_top - x12
                    k1 = _round_f32(d1 * _FINV2PI)
                    big = x12 + _F2PI * k1
                    d2 = big * r_mid - p1
                    k2 = _round_f32(d2 * _FINV2PI)
                    absolute = p1 + _F2PI * k2
                    # non-short-circuit '&' so the loop stays branch-free (vectorised)
                    consistent = (abs(d1 - _F2PI * k1) <= max_res) & (abs(d2 - _F2PI * k2) <= max_res)
                    ok = (min(m1, min(m2, m3)) >= min_mod2) & (peak[j] < sat_level) & consistent
                    bm = math.sqrt(m1)
                    wr[j] = p1
                    mo[j] = bm
                    av[j] = a1[j]
                    tx[j] = a1[j] + bm
                    ma[j] = ok
                    ph[j] = absolute if ok else nan


@njit(cache=True, parallel=True)
def code_order_kernel(frames, code_idx, inverse_idx, threshold, wrapped, period, centers,
                      order_out, phase_out, valid_out):
    """Gray/binary code + phase: fringe order from the codeword, made robust with the phase.

    frames (F, H, W); code_idx (B,) frame indices of the code bits (most significant first);
    inverse_idx (B,) indices of the inverted frames or -1 (then ``threshold`` (H, W) is the
    per-pixel threshold); wrapped (H, W) float32; period T (px); centers (2**B,) float64
    centre w (px) of the projector interval each raw codeword covers (NaN = unused codeword).
    ``k = round((2 pi * center / T - phi) / 2 pi)``: exact while the true phase is within pi of
    the codeword's centre phase, so a code that resolves half a period tolerates stripe-edge
    misalignment of up to a quarter period. Outputs: order int32, absolute phase float32,
    valid bool (False for unused codewords).
    """
    nb = code_idx.shape[0]
    h = frames.shape[1]
    w = frames.shape[2]
    for i in prange(h):
        for j in range(w):
            code = 0
            for q in range(nb):
                v = np.float64(frames[code_idx[q], i, j])
                if inverse_idx[q] >= 0:
                    t = np.float64(frames[inverse_idx[q], i, j])
                else:
                    t = np.float64(threshold[i, j])
                code = code * 2 + (1 if v > t else 0)
            c = centers[code]
            phi = np.float64(wrapped[i, j])
            if math.isnan(c):
                valid_out[i, j] = False
                order_out[i, j] = 0
                phase_out[i, j] = np.nan
            else:
                k = _round((TWO_PI * c / period - phi) / TWO_PI)
                valid_out[i, j] = True
                order_out[i, j] = np.int32(k)
                phase_out[i, j] = phi + TWO_PI * k

