"""CUDA kernels of the decoder's default three-frequency (15-frame) temporal decode with every
per-pixel output of its assessment: the quality bits, the phase sigma and the texture; one thread
per pixel of one cycle.

Ports of the CPU passes, in their order and precision:

1. :func:`three_frequency_assess_kernel` - :func:`fringe3d.unwrap._kernels.three_frequency_assess_kernel`
   (the decode, each group's clipping flags, group 1's fit-residual variance, the
   multi-frequency disagreement and group 3's modulation from one read of the frames), with the
   CPU's polynomial ``atan2`` (:func:`~fringe3d.gpu.device_math.fast_atan2_f32`) and its order of
   the least-squares sums (frames in passes of three, :func:`fringe3d.phase._kernels.accumulate_chunk`).
2. :func:`apply_broken_kernel` - the mask less the pixels clipping broke (the decoder's
   :func:`fringe3d.decode.context.clipping_broken`, computed on the CPU where a sample clipped).
3. :func:`strided_sample_kernel`, :func:`line_moments_kernel` - the noise model
   ``sigma^2 = c0 + c1 A`` fitted to the variance (:func:`fringe3d.phase.noise.fit_noise_model`):
   its reference point's sample and the float64 moments, summed per block.
4. :func:`ratio_kernel`, :func:`radix_histogram_kernel` - the median of the modulation ratio of
   the blur estimate (:func:`fringe3d.decode.edges.estimate_blur`) by radix selection on the
   float32 bits (exact: the same order statistic as ``np.median``).
5. :func:`w_kernel`, then :mod:`fringe3d.gpu.quality_kernels`' jump, gradient and bits kernels (the
   fused quality map of the valid pixels), then :func:`finish_kernel` - INVALID, SATURATED,
   INCONSISTENT (:func:`fringe3d.decode._fused_quality.finish_quality_map`) and the phase and mask
   less the flagged pixels (:func:`fringe3d.decode._finish_kernels.quality_masked_phase`).
6. :func:`phase_sigma_kernel` - ``sigma_phi`` of the noise model
   (:func:`fringe3d.phase._noise_kernel.model_phase_sigma`) and the texture fraction
   (:func:`fringe3d.decode._finish_kernels.texture_fraction`).

Layout: frames ``(F, P)``, maps ``(P,)``, ``P = H*W`` (one cycle: the noise model and the blur are
per cycle, found on the host between launches from a few numbers).
"""
from __future__ import annotations

import math

import numpy as np
from numba import cuda

from fringe3d.gpu.device_math import (F0, F2PI, FHALF, FINV2PI, TWO_PI, fast_atan2_f32, floor_f32, larger,
                                      mod_2pi_f32, rint64, smaller)
from fringe3d.gpu.streaming import THREADS

INVALID, INCONSISTENT, SATURATED = 1, 4, 128
F1 = np.float32(1.0)
FNAN = np.float32(math.nan)
FINF = np.float32(math.inf)


@cuda.jit(device=True)
def sums_f32(frames, idx, coef, p):
    """``(a, b, c, peak)`` float32 of the group ``frames[idx[k], p]`` in the CPU's order: frames in
    passes of three, each pass's products summed left to right, then added to the sums."""
    a = F0
    b = F0
    c = F0
    peak = F0
    nf = idx.shape[0]
    k = 0
    while k < nf:
        m = nf - k if nf - k < 3 else 3
        x0 = np.float32(frames[idx[k], p])
        x1 = np.float32(frames[idx[k + 1 if m > 1 else k], p])
        x2 = np.float32(frames[idx[k + 2 if m > 2 else k], p])
        a1 = coef[0, k + 1] if m > 1 else F0
        b1 = coef[1, k + 1] if m > 1 else F0
        c1 = coef[2, k + 1] if m > 1 else F0
        a2 = coef[0, k + 2] if m > 2 else F0
        b2 = coef[1, k + 2] if m > 2 else F0
        c2 = coef[2, k + 2] if m > 2 else F0
        sa = coef[0, k] * x0 + a1 * x1 + a2 * x2
        sb = coef[1, k] * x0 + b1 * x1 + b2 * x2
        sc = coef[2, k] * x0 + c1 * x1 + c2 * x2
        pk = larger(x0, larger(x1, x2))
        if k == 0:
            a = sa
            b = sb
            c = sc
            peak = pk
        else:
            a += sa
            b += sb
            c += sc
            peak = larger(peak, pk)
        k += m
    return a, b, c, peak


@cuda.jit(device=True)
def sums_bc64(frames, idx, coef, col, p):
    """``(b, c)`` float64 of the group ``frames[idx[k], p]`` with the coefficients
    ``coef[:, col + k]``, in :func:`sums_f32`'s order."""
    b = 0.0
    c = 0.0
    nf = idx.shape[0]
    k = 0
    while k < nf:
        m = nf - k if nf - k < 3 else 3
        x0 = np.float64(frames[idx[k], p])
        x1 = np.float64(frames[idx[k + 1 if m > 1 else k], p])
        x2 = np.float64(frames[idx[k + 2 if m > 2 else k], p])
        b1 = coef[1, col + k + 1] if m > 1 else 0.0
        c1 = coef[2, col + k + 1] if m > 1 else 0.0
        b2 = coef[1, col + k + 2] if m > 2 else 0.0
        c2 = coef[2, col + k + 2] if m > 2 else 0.0
        sb = coef[1, col + k] * x0 + b1 * x1 + b2 * x2
        sc = coef[2, col + k] * x0 + c1 * x1 + c2 * x2
        if k == 0:
            b = sb
            c = sc
        else:
            b += sb
            c += sc
        k += m
    return b, c


@cuda.jit(device=True)
def wrap_residual(phi, big, scale):
    """``|wrap(phi - big * scale)|`` (rad, float64), ``wrap(x) = x - 2 pi rint(x / 2 pi)``."""
    e = np.float64(phi) - big * scale
    return abs(e - TWO_PI * rint64(e / TWO_PI))


@cuda.jit
def three_frequency_assess_kernel(frames, idx1, coef1, idx2, coef2, idx3, coef3, params, design1, scales, coef64,
                                  phase, wrapped, modulation, average, mask, texture, clipped, variance, residual,
                                  modulation3):
    """The fused three-frequency decode with its assessment maps, one pixel per thread.

    frames (F, P); ``idx_g`` (N_g,) int64 and ``coef_g`` (3, N_g) float32 per group (narrowest
    period first); ``params`` float32 ``(s12, s123, r_top, r_mid, lower, min_modulation,
    sat_level, max_residual, clip_level)``; ``design1`` (N_1, 3) float32; ``scales`` float64
    ``(T_1/T_2, T_1/T_3, 1/(N_1 - 3))``; ``coef64`` (3, N_2 + N_3) float64 (the CPU kernel's
    arguments). Outputs (P,): absolute phase (NaN invalid), wrapped phase, modulation, average
    of group 1, mask, texture ``A + B``; clipped (3, P) bool; variance (P,) float32 when
    ``N_1 >= 4`` (else (1,), untouched); residual float32 (0 where invalid); modulation3 float32.
    """
    p = cuda.grid(1)
    if p >= frames.shape[1]:
        return
    a1, b1, c1, pk1 = sums_f32(frames, idx1, coef1, p)
    a2, b2, c2, pk2 = sums_f32(frames, idx2, coef2, p)
    a3, b3, c3, pk3 = sums_f32(frames, idx3, coef3, p)
    n1 = idx1.shape[0]
    if n1 >= 4:  # group 1's fit residual, its frames again
        ss = F0
        for k in range(n1):
            r = np.float32(frames[idx1[k], p]) - (design1[k, 0] * a1 + design1[k, 1] * b1 + design1[k, 2] * c1)
            ss = r * r if k == 0 else ss + r * r
        variance[p] = ss * np.float32(scales[2])
    m1 = b1 * b1 + c1 * c1
    m2 = b2 * b2 + c2 * c2
    m3 = b3 * b3 + c3 * c3
    p1 = fast_atan2_f32(-c1, b1)
    p2 = fast_atan2_f32(-c2, b2)
    p3 = fast_atan2_f32(-c3, b3)
    x12 = mod_2pi_f32(params[0] * (p1 - p2))
    x123 = mod_2pi_f32(params[1] * (x12 - p3))
    lower = params[4]
    big = lower + mod_2pi_f32(x123 - lower)
    d1 = big * params[2] - x12
    k1 = floor_f32(d1 * FINV2PI + FHALF)
    big = x12 + F2PI * k1
    d2 = big * params[3] - p1
    k2 = floor_f32(d2 * FINV2PI + FHALF)
    absolute = p1 + F2PI * k2
    max_res = params[7]
    consistent = (abs(d1 - F2PI * k1) <= max_res) and (abs(d2 - F2PI * k2) <= max_res)
    peak = larger(pk1, larger(pk2, pk3))
    ok = (smaller(m1, smaller(m2, m3)) >= params[5] * params[5]) and (peak < params[6]) and consistent
    bm = math.sqrt(m1)
    wrapped[p] = p1
    modulation[p] = bm
    average[p] = a1
    texture[p] = a1 + bm
    mask[p] = ok
    phase[p] = absolute if ok else FNAN
    clip = params[8]
    clipped[0, p] = pk1 >= clip
    clipped[1, p] = pk2 >= clip
    clipped[2, p] = pk3 >= clip
    n2 = idx2.shape[0]
    e_b2, e_c2 = sums_bc64(frames, idx2, coef64, 0, p)
    e_b3, e_c3 = sums_bc64(frames, idx3, coef64, n2, p)
    f_b3 = np.float32(e_b3)
    f_c3 = np.float32(e_c3)
    phi2 = fast_atan2_f32(-np.float32(e_c2), np.float32(e_b2))
    phi3 = fast_atan2_f32(-f_c3, f_b3)
    modulation3[p] = math.sqrt(f_b3 * f_b3 + f_c3 * f_c3)
    if ok:
        big64 = np.float64(absolute)
        residual[p] = np.float32(larger(wrap_residual(phi2, big64, scales[0]), wrap_residual(phi3, big64, scales[1])))
    else:
        residual[p] = F0


@cuda.jit
def apply_broken_kernel(broken, mask, phase):
    """``mask &= ~broken`` and the phase NaN where that drops a pixel, (P,)."""
    p = cuda.grid(1)
    if p >= mask.shape[0]:
        return
    if broken[p] and mask[p]:
        mask[p] = False
        phase[p] = FNAN


@cuda.jit
def strided_sample_kernel(x, y, mask, H, W, step, xs, ys, ms):
    """The pixels of every ``step``-th row and column of (P,) maps ``x``, ``y``, ``mask`` into the
    (ceil(H/step) * ceil(W/step),) ``xs``, ``ys``, ``ms`` (row-major), as ``x[::step, ::step]``."""
    q = cuda.grid(1)
    if q >= xs.shape[0]:
        return
    ws = (W + step - 1) // step
    i = (q // ws) * step
    j = (q - (q // ws) * ws) * step
    p = i * W + j
    xs[q] = x[p]
    ys[q] = y[p]
    ms[q] = mask[p]


@cuda.jit
def line_moments_kernel(x, y, mask, c0, c1, limit, ref_x, ref_y, partials):
    """:func:`fringe3d.phase._noise_kernel.line_moments` per block of :data:`THREADS` pixels:
    ``partials[block] = (n, sum dx, sum dy, sum dx^2, sum dx dy)`` float64 over the pixels of
    ``mask`` where ``x``, ``y`` are finite and (``limit > 0``) ``y < limit * max(c0 + c1 x,
    1e-12)``; ``dx = x - ref_x``, ``dy = y - ref_y`` (launch with THREADS threads)."""
    p = cuda.grid(1)
    tid = cuda.threadIdx.x
    acc = cuda.shared.array((5, THREADS), np.float64)
    for r in range(5):
        acc[r, tid] = 0.0
    if p < x.shape[0]:
        xv = np.float64(x[p])
        yv = np.float64(y[p])
        ok = mask[p] and abs(xv) < math.inf and abs(yv) < math.inf
        if ok and limit > 0.0:
            ok = yv < limit * larger(c0 + c1 * xv, 1e-12)
        if ok:
            dx = xv - ref_x
            dy = yv - ref_y
            acc[0, tid] = 1.0
            acc[1, tid] = dx
            acc[2, tid] = dy
            acc[3, tid] = dx * dx
            acc[4, tid] = dx * dy
    cuda.syncthreads()
    step = THREADS // 2
    while step > 0:  # tree sum in shared memory; every thread reaches every barrier
        if tid < step:
            for r in range(5):
                acc[r, tid] += acc[r, tid + step]
        cuda.syncthreads()
        step //= 2
    if tid == 0:
        for r in range(5):
            partials[cuda.blockIdx.x, r] = acc[r, 0]


@cuda.jit
def ratio_kernel(fine, coarse, mask, out, counts):
    """The blur estimate's ratios: ``out = float32(fine / coarse)`` where ``mask & coarse > 0``,
    NaN elsewhere (sorted above every ratio by the radix selection); ``counts[block] = (ratios,
    NaN ratios)`` int32 (launch with THREADS threads)."""
    p = cuda.grid(1)
    tid = cuda.threadIdx.x
    acc = cuda.shared.array((2, THREADS), np.int32)
    acc[0, tid] = 0
    acc[1, tid] = 0
    if p < fine.shape[0]:
        d = coarse[p]
        ok = mask[p] and d > F0
        r = np.float32(fine[p] / d) if ok else FNAN
        out[p] = r
        if ok:
            acc[0, tid] = 1
            if r != r:
                acc[1, tid] = 1
    cuda.syncthreads()
    step = THREADS // 2
    while step > 0:
        if tid < step:
            acc[0, tid] += acc[0, tid + step]
            acc[1, tid] += acc[1, tid + step]
        cuda.syncthreads()
        step //= 2
    if tid == 0:
        counts[cuda.blockIdx.x, 0] = acc[0, 0]
        counts[cuda.blockIdx.x, 1] = acc[1, 0]


#: Bins of a radix selection pass: 11-bit digits, three passes over a 32-bit key.
RADIX_BINS = 2048


@cuda.jit
def radix_histogram_kernel(keys, prefix, high, shift, hist):
    """One pass of a radix selection: ``hist[b]`` += the keys (P,) uint32 with ``key & high ==
    prefix`` whose digit ``(key >> shift) & (RADIX_BINS - 1)`` is ``b`` (a block's histogram in
    shared memory, then one atomic add per bin; launch with THREADS threads)."""
    p = cuda.grid(1)
    tid = cuda.threadIdx.x
    local = cuda.shared.array(RADIX_BINS, np.int32)
    for b in range(tid, RADIX_BINS, THREADS):
        local[b] = 0
    cuda.syncthreads()
    if p < keys.shape[0]:
        k = keys[p]
        if (k & high) == prefix:
            cuda.atomic.add(local, (k >> shift) & (RADIX_BINS - 1), 1)
    cuda.syncthreads()
    for b in range(tid, RADIX_BINS, THREADS):
        if local[b] > 0:
            cuda.atomic.add(hist, b, local[b])


@cuda.jit
def w_kernel(phase, scale, w):
    """``w = phase * scale`` in float32 (the fringe coordinate, px; NaN where the phase is)."""
    p = cuda.grid(1)
    if p < phase.shape[0]:
        w[p] = phase[p] * scale


@cuda.jit
def finish_kernel(q, mask, phase, broken, has_broken, residual, thr, has_residual, drop):
    """The bits the fused quality map does not set, in place (``q`` made from ``mask``): INVALID
    (with SATURATED where ``broken``, when ``has_broken``) outside ``mask``, INCONSISTENT where
    ``residual > thr`` (float32; when ``has_residual``); then, when ``drop``, ``mask`` less the
    flagged pixels and the phase NaN there."""
    p = cuda.grid(1)
    if p >= q.shape[0]:
        return
    if not mask[p]:
        q[p] = np.uint8(INVALID | SATURATED) if (has_broken and broken[p]) else np.uint8(INVALID)
    elif has_residual and residual[p] > thr:
        q[p] = q[p] | np.uint8(INCONSISTENT)
    if drop and mask[p] and q[p] != 0:
        mask[p] = False
        phase[p] = FNAN


@cuda.jit
def phase_sigma_kernel(average, modulation, raw_texture, c0, c1, k, ks, with_sigma, full_scale, sigma, fraction):
    """``sigma = k sqrt(max(c1 A + c0, 0)) / B`` float32 rad (``ks = k sqrt(c0)`` when ``> 0``:
    the constant model; inf where ``B <= 0``; NaN everywhere without ``with_sigma``) and
    ``fraction = clip(nan_to_num(raw_texture / full_scale), 0, 1)`` float32, (P,)."""
    p = cuda.grid(1)
    if p >= average.shape[0]:
        return
    b = modulation[p]
    if not with_sigma:
        sigma[p] = FNAN
    elif ks > F0:
        s = ks if abs(average[p]) < FINF else FNAN
        sigma[p] = s / b if b > F0 else FINF
    else:
        v = c1 * average[p] + c0
        s = math.sqrt(F0 if v < F0 else v)
        sigma[p] = k * s / b if b > F0 else FINF
    t = raw_texture[p] / full_scale
    fraction[p] = F0 if t != t else (F0 if t < F0 else (F1 if t > F1 else t))


@cuda.jit
def count_rows_kernel(flags, counts):
    """``counts[block, r]`` int32: the set flags of row ``r`` of ``flags`` (R, P) bool (R <= 4)
    over a block of :data:`THREADS` pixels (launch with THREADS threads)."""
    p = cuda.grid(1)
    tid = cuda.threadIdx.x
    acc = cuda.shared.array((4, THREADS), np.int32)
    for r in range(4):
        acc[r, tid] = 0
    if p < flags.shape[1]:
        for r in range(flags.shape[0]):
            acc[r, tid] = 1 if flags[r, p] else 0
    cuda.syncthreads()
    step = THREADS // 2
    while step > 0:
        if tid < step:
            for r in range(4):
                acc[r, tid] += acc[r, tid + step]
        cuda.syncthreads()
        step //= 2
    if tid == 0:
        for r in range(flags.shape[0]):
            counts[cuda.blockIdx.x, r] = acc[r, 0]
