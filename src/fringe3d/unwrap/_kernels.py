"""Fused per-pixel numba kernels for temporal unwrapping (hierarchical, heterodyne, the fused
three-frequency decode and Gray/binary code orders).

Every kernel walks the image once, rows in parallel (``prange``), reads its inputs in their own
dtype and writes only its (H, W) outputs. The shared inline helpers (float32 atan2, the
least-squares sums of one phase-shifted group, rounding, mod 2 pi) are those of
:mod:`fringe3d.phase._kernels`; the plain-NumPy references these kernels are tested against
live in ``tests/reference_engine.py``. The fringe order is ``floor(x + 0.5)`` (ties up) as in
:func:`fringe3d.patterns.conventions.coarse_to_fine_order` with ``ties="up"`` (Eq. 1.5).
"""
from __future__ import annotations

import math

import numpy as np
from numba import njit, prange

from fringe3d.phase._kernels import (COL_CHUNK, F2PI, FASTMATH, FINV2PI, ROW_BLOCK, TWO_PI, accumulate_chunk,
                                     fast_atan2_f32, mod_2pi_f32, round_half_up, round_half_up_f32)


@njit(cache=True, parallel=True)
def hierarchical_kernel(wrapped, periods, lower, order_out, phase_out, residual_out):
    """Hierarchical temporal unwrapping, Eq. (1.5): the coarser absolute phase unwraps the finer.

    wrapped (M, H, W) float32 wrapped phases, narrowest period first; periods (M,) float64;
    lower: the coarsest phase is placed in [lower, lower + 2 pi). Outputs (H, W): fringe order
    of the narrowest phase (int32), its absolute phase (float32) and the largest rounding
    residual ``|x - k|`` over the steps (float32, periods of each step's finer phase; 0 to 1/2).
    ``x_i = ((T_{i+1}/T_i) Phi_{i+1} - phi_i) / 2pi``, ``k_i = floor(x_i + 1/2)``,
    ``Phi_i = phi_i + 2 pi k_i``.
    """
    m = wrapped.shape[0]
    h = wrapped.shape[1]
    w = wrapped.shape[2]
    for i in prange(h):
        for j in range(w):
            phi = np.float64(wrapped[m - 1, i, j])
            big = lower + (phi - lower) % TWO_PI
            k = 0.0
            res = 0.0
            for q in range(m - 2, -1, -1):
                phi = np.float64(wrapped[q, i, j])
                x = (big * (periods[q + 1] / periods[q]) - phi) / TWO_PI
                k = round_half_up(x)
                res = max(res, abs(x - k))
                big = phi + TWO_PI * k
            if m == 1:
                k = round_half_up((big - phi) / TWO_PI)
            order_out[i, j] = np.int32(k)
            phase_out[i, j] = big
            residual_out[i, j] = res


@njit(cache=True, inline="always")
def _beat(phi_a, phi_b, sign):
    """Wrapped beat phase sign*(phi_a - phi_b) in [0, 2 pi)."""
    return (sign * (phi_a - phi_b)) % TWO_PI


@njit(cache=True, parallel=True)
def heterodyne_kernel(wrapped, signs, beat_periods, periods, lower, order_out, phase_out, residual_out):
    """Multi-frequency heterodyne unwrapping (three-frequency: 18, 21, 144 -> 126 -> 1008).

    wrapped (M, H, W) float32, M >= 2, narrowest first; beat chain
    ``b_1 = beat(phi_0, phi_1)``, ``b_q = beat(b_{q-1}, phi_q)`` with equivalent periods
    ``beat_periods[q-1]`` and signs making each beat increase with w. The last beat is taken
    in [lower, lower + 2 pi) as absolute, then each beat unwraps the previous one and the first
    beat unwraps phi_0. Outputs as :func:`hierarchical_kernel` (residual in periods of each
    step's finer beat or phase).
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
            res = 0.0
            for q in range(nb - 2, -1, -1):
                x = (big * (beat_periods[q + 1] / beat_periods[q]) - beats_local[q]) / TWO_PI
                kq = round_half_up(x)
                res = max(res, abs(x - kq))
                big = beats_local[q] + TWO_PI * kq
            phi = np.float64(wrapped[0, i, j])
            x = (big * (beat_periods[0] / periods[0]) - phi) / TWO_PI
            k = round_half_up(x)
            order_out[i, j] = np.int32(k)
            phase_out[i, j] = phi + TWO_PI * k
            residual_out[i, j] = max(res, abs(x - k))


@njit(cache=True, inline="always", fastmath=FASTMATH)
def heterodyne_pixel(b1, c1, b2, c2, b3, c3, peak, s12, s123, r_top, r_mid, lower, min_mod2, sat_level,
                     max_res):  # pragma: no cover - compiled
    """One pixel of the three-frequency heterodyne (float32; :func:`three_frequency_kernel`'s
    parameters): from the groups' ``b, c`` sums and the brightest frame ``peak``, the wrapped
    phase ``p1`` of group 1, its modulation, whether the pixel is valid, its absolute phase, the
    wrapped phases ``p2``, ``p3`` of groups 2 and 3 and the squared modulation ``m3`` of group 3
    (the last three for the assessment; a caller that drops them does not compute them twice).
    Inlined into the kernels' column loops, which stay branch-free (vectorised)."""
    m1 = b1 * b1 + c1 * c1
    m2 = b2 * b2 + c2 * c2
    m3 = b3 * b3 + c3 * c3
    p1 = fast_atan2_f32(-c1, b1)
    p2 = fast_atan2_f32(-c2, b2)
    p3 = fast_atan2_f32(-c3, b3)
    x12 = mod_2pi_f32(s12 * (p1 - p2))
    x123 = mod_2pi_f32(s123 * (x12 - p3))
    big = lower + mod_2pi_f32(x123 - lower)
    d1 = big * r_top - x12
    k1 = round_half_up_f32(d1 * FINV2PI)
    big = x12 + F2PI * k1
    d2 = big * r_mid - p1
    k2 = round_half_up_f32(d2 * FINV2PI)
    absolute = p1 + F2PI * k2
    # non-short-circuit '&' so the loop stays branch-free (vectorised)
    consistent = (abs(d1 - F2PI * k1) <= max_res) & (abs(d2 - F2PI * k2) <= max_res)
    ok = (min(m1, min(m2, m3)) >= min_mod2) & (peak < sat_level) & consistent
    return p1, math.sqrt(m1), ok, absolute, p2, p3, m3


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
                accumulate_chunk(frames, idx1, coef1, i, j0, n, a1, b1, c1, peak, True, True, True)
                accumulate_chunk(frames, idx2, coef2, i, j0, n, a2, b2, c2, peak, True, False, False)
                accumulate_chunk(frames, idx3, coef3, i, j0, n, a2, b3, c3, peak, True, False, False)
                ph = phase[i, j0:j0 + n]
                wr = wrapped[i, j0:j0 + n]
                mo = modulation[i, j0:j0 + n]
                av = average[i, j0:j0 + n]
                ma = mask[i, j0:j0 + n]
                tx = texture[i, j0:j0 + n]
                for j in range(n):
                    p1, bm, ok, absolute, _, _, _ = heterodyne_pixel(b1[j], c1[j], b2[j], c2[j], b3[j], c3[j],
                                                                     peak[j], s12, s123, r_top, r_mid, lower,
                                                                     min_mod2, sat_level, max_res)
                    wr[j] = p1
                    mo[j] = bm
                    av[j] = a1[j]
                    tx[j] = a1[j] + bm
                    ma[j] = ok
                    ph[j] = absolute if ok else nan


@njit(cache=True, parallel=True, fastmath=FASTMATH)
def three_frequency_assess_kernel(frames, idx1, coef1, idx2, coef2, idx3, coef3, params, design1, scales,
                                  phase, wrapped, modulation, average, mask, coordinate,
                                  clipped, variance, residual, modulation3, nonfinite, clip_rows):  # pragma: no cover
    """:func:`three_frequency_kernel` with what the decoder's assessment needs from the same pass.

    Inputs and the first five outputs as :func:`three_frequency_kernel` (equal bit for bit: the
    same float32 arithmetic; no texture, which is ``average + modulation``), ``params`` with a
    ninth entry, the saturation level of the per-group clipping flags. ``design1`` (N_1, 3)
    float32 ``[1, cos d_k, sin d_k]`` of group 1 (N_1 >= 4 for a variance; else ``variance``
    may be (1, 1) and is left alone); ``scales`` float64 ``(T_1 / T_2, T_1 / T_3, 1 / (N_1 -
    3), T_1 / 2 pi)``. Extra outputs:

    * ``coordinate`` (H, W) float32: the fringe coordinate ``w = Phi (T_1 / 2 pi)`` of the
      absolute phase (NaN where invalid), the float32 product of
      :func:`fringe3d.patterns.conventions.phase_to_w`;
    * ``clipped`` (H, W) uint8: bit ``g`` (value ``1 << g``) set where a frame of group g is at or
      above the saturation level; ``clip_rows`` (3, H) int32: how many pixels of each row have
      that bit (a caller unpacks only the groups that clip; most captures clip nowhere);
    * ``variance`` (H, W) float32: group 1's least-squares fit residual
      ``sum_k (I_k - a - b cos d_k - c sin d_k)^2 / (N_1 - 3)`` (float32 sums);
    * ``residual`` (H, W) float32: the multi-frequency disagreement
      ``max_g |wrap(phi_g - Phi T_1 / T_g)|`` (rad, in float64) over groups 2 and 3, 0 where the
      pixel is invalid;
    * ``modulation3`` (H, W) float32: the modulation of group 3;
    * ``nonfinite`` (H,) uint8: 1 where the row has a valid pixel whose absolute phase is not
      finite (possible only for frames holding inf or NaN), else 0.

    ``phi_2``, ``phi_3`` and the modulation of group 3 are the decode's own (its float32 sums,
    float32 atan2 and sqrt, kept from :func:`heterodyne_pixel`), not
    :func:`fringe3d.phase._kernels.psp_kernel`'s float64 sums: a second, float64 pass over the
    coarser groups' rows cost a quarter of the kernel. They differ from the separate passes' by
    float32 rounding of the sums (``tests/test_fused_assess.py`` bounds it; the decoder's quality
    bits are unchanged).
    """
    s12 = params[0]
    s123 = params[1]
    r_top = params[2]
    r_mid = params[3]
    lower = params[4]
    min_mod2 = params[5] * params[5]
    sat_level = params[6]
    max_res = params[7]
    clip_level = params[8]
    sc2 = scales[0]
    sc3 = scales[1]
    vscale = np.float32(scales[2])
    wscale = np.float32(scales[3])
    inf = np.float32(np.inf)
    n1 = idx1.shape[0]
    with_var = n1 >= 4
    h = frames.shape[1]
    w = frames.shape[2]
    nan = np.float32(np.nan)
    nblk = (h + ROW_BLOCK - 1) // ROW_BLOCK
    for blk in prange(nblk):
        acc = np.empty((12, COL_CHUNK), np.float32)
        a1, b1, c1, a2, b2, c2, b3, c3 = acc[0], acc[1], acc[2], acc[3], acc[4], acc[5], acc[6], acc[7]
        pk1, pk2, pk3, ss = acc[8], acc[9], acc[10], acc[11]
        for i in range(blk * ROW_BLOCK, min(h, (blk + 1) * ROW_BLOCK)):
            bad = np.uint8(0)
            nc1 = np.int32(0)
            nc2 = np.int32(0)
            nc3 = np.int32(0)
            for j0 in range(0, w, COL_CHUNK):
                n = min(COL_CHUNK, w - j0)
                accumulate_chunk(frames, idx1, coef1, i, j0, n, a1, b1, c1, pk1, True, True, True)
                accumulate_chunk(frames, idx2, coef2, i, j0, n, a2, b2, c2, pk2, True, True, False)
                accumulate_chunk(frames, idx3, coef3, i, j0, n, a2, b3, c3, pk3, True, True, False)
                if with_var:  # the group's rows again, from the cache: the fit residual
                    for k in range(n1):
                        row = frames[idx1[k], i, j0:j0 + n]
                        d0 = design1[k, 0]
                        d1 = design1[k, 1]
                        d2 = design1[k, 2]
                        for j in range(n):
                            r = np.float32(row[j]) - (d0 * a1[j] + d1 * b1[j] + d2 * c1[j])
                            ss[j] = r * r if k == 0 else ss[j] + r * r
                    va = variance[i, j0:j0 + n]
                    for j in range(n):
                        va[j] = ss[j] * vscale
                ph = phase[i, j0:j0 + n]
                wr = wrapped[i, j0:j0 + n]
                mo = modulation[i, j0:j0 + n]
                av = average[i, j0:j0 + n]
                ma = mask[i, j0:j0 + n]
                co = coordinate[i, j0:j0 + n]
                cl = clipped[i, j0:j0 + n]
                re = residual[i, j0:j0 + n]
                m3o = modulation3[i, j0:j0 + n]
                # three loops, each with few arrays: one loop storing to all eleven outputs has too
                # many possibly-aliasing pointers for LLVM's runtime checks and does not vectorise.
                # phi_2, phi_3 go to the free rows b2, c2 (each read before it is written)
                for j in range(n):
                    peak = max(pk1[j], max(pk2[j], pk3[j]))
                    p1, bm, ok, absolute, p2, p3, m3 = heterodyne_pixel(b1[j], c1[j], b2[j], c2[j], b3[j], c3[j],
                                                                        peak, s12, s123, r_top, r_mid, lower,
                                                                        min_mod2, sat_level, max_res)
                    wr[j] = p1
                    mo[j] = bm
                    av[j] = a1[j]
                    ma[j] = ok
                    ph[j] = absolute if ok else nan
                    b2[j] = p2
                    c2[j] = p3
                    m3o[j] = math.sqrt(m3)
                for j in range(n):  # one packed byte, not three bool planes; branch-free counts
                    q1 = np.uint8(pk1[j] >= clip_level)
                    q2 = np.uint8(pk2[j] >= clip_level)
                    q3 = np.uint8(pk3[j] >= clip_level)
                    cl[j] = q1 | (q2 << np.uint8(1)) | (q3 << np.uint8(2))
                    nc1 += np.int32(q1)
                    nc2 += np.int32(q2)
                    nc3 += np.int32(q3)
                mb = ma.view(np.uint8)  # the mask as bytes: a select on a bool load kept this loop scalar (4x)
                for j in range(n):
                    f = ph[j]
                    co[j] = f * wscale
                    bad |= mb[j] & np.uint8(not abs(f) < inf)  # branch-free: NaN compares False
                    big64 = np.float64(f)
                    e2 = np.float64(b2[j]) - big64 * sc2
                    e3 = np.float64(c2[j]) - big64 * sc3
                    e2 = abs(e2 - TWO_PI * np.rint(e2 / TWO_PI))
                    e3 = abs(e3 - TWO_PI * np.rint(e3 / TWO_PI))
                    e = np.float32(max(e2, e3))
                    re[j] = e if mb[j] != 0 else np.float32(0.0)
            nonfinite[i] = bad
            clip_rows[0, i] = nc1
            clip_rows[1, i] = nc2
            clip_rows[2, i] = nc3


@njit(cache=True, inline="always")
def _edge_fades(diff, amp, fl, fh, el, eh):
    """(d_lo, d_hi): how far the bits that change at the stripe's lower / upper edge are from
    fading (counts; 0 at that edge, ``amp`` inside the stripe or without a neighbour there).

    ``diff`` (B,) the bits' ``|D_q|``, ``amp`` a clear bit's (at least their largest); fl, fh the masks of the bits
    that change at the lower / upper edge, el, eh those that change there only. Every bit of
    an edge fades at it, so an edge's value is the largest of its bits'. Where one edge's bits
    all change at the other edge too (a binary code's last bit), that edge is told apart by the
    other's own bits being clear: ``d_hi = max(d_hi, amp - min_el |D|)``.
    """
    d_lo = 0.0 if fl else amp
    d_hi = 0.0 if fh else amp
    e_lo = amp
    e_hi = amp
    nb = diff.shape[0]
    for q in range(nb):
        bit = np.int64(1) << (nb - 1 - q)
        a = diff[q]
        if fl & bit:
            d_lo = max(d_lo, a)
        if fh & bit:
            d_hi = max(d_hi, a)
        if el & bit:
            e_lo = min(e_lo, a)
        if eh & bit:
            e_hi = min(e_hi, a)
    if fl and fh:
        if not eh:
            d_hi = max(d_hi, amp - e_lo)
        if not el:
            d_lo = max(d_lo, amp - e_hi)
    return d_lo, d_hi


@njit(cache=True, inline="always")
def _stray_weak_bit(diff, own, edge_bits):
    """True when a bit outside ``edge_bits`` (those changing at the stripe edge the pixel is
    nearest) is weak, ``|D_q| < own / 2`` (``own`` the pixel's largest ``|D_q|``): the codeword
    is then no stripe the pixel can be next to (a binary code read on an edge where several bits
    change, some misread: the word of a stripe two away)."""
    nb = diff.shape[0]
    for q in range(nb):
        if diff[q] < 0.5 * own and not (edge_bits & (np.int64(1) << (nb - 1 - q))):
            return True
    return False


@njit(cache=True, parallel=True)
def code_order_kernel(frames, code_idx, inverse_idx, threshold, wrapped, period, centre, lower, upper,
                      lower_bits, upper_bits, contrast, coordinate, order_out, phase_out, valid_out, residual_out):
    """Gray/binary code + phase: the fringe order nearest the code's own projector coordinate.

    frames (F, H, W); code_idx (B,) frame indices of the code bits (most significant first);
    inverse_idx (B,) indices of the inverted frames or -1 (then ``threshold`` (H, W) is the
    per-pixel threshold); wrapped (H, W) float32; period T (px); centre, lower, upper (2**B,)
    float64 stripe centre and edges (px) per raw codeword (NaN = unused codeword); lower_bits,
    upper_bits (2**B,) int64 masks of the bits that change at the lower / upper edge; contrast
    (H, W) float32 the ``|D|`` of a clear bit (the pixel's largest ``|D|`` where larger) or (0, 0);
    coordinate (H, W) float64 code estimate of ``w`` replacing the stripe one where finite, or
    (0, 0) for none. Per pixel (:func:`fringe3d.unwrap.temporal.gray_code_order`):
    ``w_c = lo + (hi - lo) D_lo / (D_lo + D_hi)``, ``k = floor(w_c / T - phi / 2 pi + 1/2)``.
    Outputs: order int32, absolute phase float32, valid bool (False for unused codewords),
    residual float32 (periods; distance of ``w = T (phi / 2 pi + k)`` outside the stripe, from
    ``coordinate`` where used; inf for a stripe wider than T + 1 px without ``coordinate`` and
    for a codeword with a stray weak bit, :func:`_stray_weak_bit`).
    """
    nb = code_idx.shape[0]
    h = frames.shape[1]
    w = frames.shape[2]
    has_coord = coordinate.shape[0] > 0
    has_contrast = contrast.shape[0] > 0
    for i in prange(h):
        diff = np.empty(nb)
        for j in range(w):
            code = 0
            own = 0.0
            for q in range(nb):
                v = np.float64(frames[code_idx[q], i, j])
                if inverse_idx[q] >= 0:
                    t = np.float64(frames[inverse_idx[q], i, j])
                else:
                    t = np.float64(threshold[i, j])
                diff[q] = abs(v - t)
                own = max(own, diff[q])
                code = code * 2 + (1 if v > t else 0)
            c = centre[code]
            if math.isnan(c):
                valid_out[i, j] = False
                order_out[i, j] = 0
                phase_out[i, j] = np.nan
                residual_out[i, j] = np.nan
                continue
            lo = lower[code]
            hi = upper[code]
            fl = lower_bits[code]
            fh = upper_bits[code]
            amp = max(own, np.float64(contrast[i, j])) if has_contrast else own
            d_lo, d_hi = _edge_fades(diff, amp, fl, fh, fl & ~fh, fh & ~fl)
            stray = _stray_weak_bit(diff, own, fl if d_lo < d_hi else fh)
            wc = c if d_lo + d_hi <= 0.0 else lo + (hi - lo) * d_lo / (d_lo + d_hi)
            point = False
            if has_coord and not math.isnan(coordinate[i, j]):
                wc = coordinate[i, j]
                point = True
            phi = np.float64(wrapped[i, j])
            k = round_half_up(wc / period - phi / TWO_PI)
            big = phi + TWO_PI * k
            wu = big * (period / TWO_PI)
            if stray:
                res = np.inf
            elif point:
                res = abs(wu - wc) / period
            elif hi - lo > period * (1.0 + 1e-9) + 1.0:  # beyond the projector's outer pixel edges
                res = np.inf
            else:
                res = max(0.0, max(lo - wu, wu - hi)) / period
            valid_out[i, j] = True
            order_out[i, j] = np.int32(k)
            phase_out[i, j] = big
            residual_out[i, j] = res
