"""CUDA kernels of the fused 3-step path's per-pixel outputs besides the points: the quality
bits and the mask they make, the texture and ``sigma_z``; one thread per pixel and cycle.

Ports of the CPU passes the fused path runs after its kernel, in the same order and precision:

1. :func:`three_step_fields_kernel` - the fused kernel
   (:func:`fringe3d.reconstruct._kernels.three_step_fields_kernel`): ray parameter ``s``, fringe
   coordinate ``w``, average ``A``, modulation ``B`` and the texture ``A + B`` as a fraction of
   full scale (:func:`fringe3d.decode.texture.as_fraction`).
2. :func:`jump_contrast_kernel`, :func:`gradient_test_kernel`, :func:`quality_bits_kernel` - the
   one-direction quality map of :func:`fringe3d.decode._fused_quality.fused_quality_map` (INVALID,
   EDGE, GRADIENT, MOD_DROP, RIM) and :func:`fringe3d.reconstruct._kernels.mask_flagged`
   (``s`` NaN where a bit is set); without the edge tests INVALID alone.
3. :func:`laplacian_partials_kernel`, :func:`noise_kernel`, :func:`sigma_z_kernel` - the noise
   of the average image over the kept pixels' interior (:func:`fringe3d.phase.noise.laplacian_noise`,
   summed per block, then per cycle) and ``sigma_z``
   (:func:`fringe3d.optics._ray_kernels.sigma_z_kernel`).

Neighbourhoods are clamped to the image as the CPU kernels' replicated padding. Layout: ``(C, P)``
maps, ``P = H*W``; ``H`` and ``W`` are passed. The bit values are
:mod:`fringe3d.decode.edges`'s (``tests/test_cuda_quality.py`` checks them).
"""
from __future__ import annotations

import math

import numpy as np
from numba import cuda

from fringe3d.gpu.device_math import F0, larger
from fringe3d.gpu.median_network import median5x5
from fringe3d.gpu.streaming import THREADS
from fringe3d.gpu.triangulate_kernels import three_step_pixel

INVALID, EDGE, GRADIENT, MOD_DROP, RIM = 1, 2, 8, 16, 32
F1 = np.float32(1.0)
FNAN = np.float32(math.nan)
FINF = np.float32(math.inf)
SQRT_HALF_PI = math.sqrt(math.pi / 2.0)


@cuda.jit
def three_step_fields_kernel(frames, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3, full_scale, s_out,
                             w_out, avg_out, mod_out, want_texture, tex_out):
    """The fused 3-step kernel's fields: ``s`` (NaN invalid, mm), ``w`` (px), ``A``, ``B``
    (frames' units) each (C, P) float32 (``w``, ``A``, ``B`` also where ``s`` is NaN) and, when
    ``want_texture``, ``tex_out`` = ``(A + B) / full_scale`` in float32, NaN to 0, clipped to
    [0, 1]. The other arguments are :func:`~fringe3d.gpu.triangulate_kernels.three_step_kernel`'s."""
    p, cyc = cuda.grid(2)
    if p >= frames.shape[2] or cyc >= frames.shape[0]:
        return
    s, w, a, b2, ok = three_step_pixel(frames, cyc, p, idx, coef, phi_min, sign, scale, O, D, Q, P3)
    s_out[cyc, p] = np.float32(s) if (b2 >= min_mod2) and ok else FNAN
    w_out[cyc, p] = np.float32(w)
    A = np.float32(a)
    B = np.float32(math.sqrt(b2))
    avg_out[cyc, p] = A
    mod_out[cyc, p] = B
    if want_texture:
        t = (A + B) / full_scale
        t = F0 if t != t else t
        tex_out[cyc, p] = F0 if t < F0 else (F1 if t > F1 else t)


@cuda.jit(device=True)
def is_valid(s, cyc, q):
    """Pixel ``q`` of cycle ``cyc`` has a point (finite ``s``)."""
    return math.isfinite(s[cyc, q])


@cuda.jit
def jump_contrast_kernel(s, w, avg, mod, H, W, jump, contrast):
    """GRADIENT's and MOD_DROP's inputs: ``jump`` the largest ``|w - w_n|`` over the valid
    4-neighbours ``n`` in the image (0 where none or the pixel is invalid) and ``contrast``
    ``B / A`` where valid and ``A > 0`` (else 0), (C, P) float32."""
    p, cyc = cuda.grid(2)
    if p >= s.shape[1] or cyc >= s.shape[0]:
        return
    i = p // W
    j = p - i * W
    v = is_valid(s, cyc, p)
    g = F0
    if v:
        x = w[cyc, p]
        if i > 0 and is_valid(s, cyc, p - W):
            g = larger(g, abs(x - w[cyc, p - W]))
        if i < H - 1 and is_valid(s, cyc, p + W):
            g = larger(g, abs(x - w[cyc, p + W]))
        if j > 0 and is_valid(s, cyc, p - 1):
            g = larger(g, abs(x - w[cyc, p - 1]))
        if j < W - 1 and is_valid(s, cyc, p + 1):
            g = larger(g, abs(x - w[cyc, p + 1]))
    jump[cyc, p] = g
    A = avg[cyc, p]
    contrast[cyc, p] = np.float32(mod[cyc, p] / A) if (v and A > F0) else F0


@cuda.jit
def gradient_test_kernel(s, jump, H, W, g_ratio, g_floor, t):
    """GRADIENT's test per pixel: ``t = valid & jump > max(g_ratio * median5x5(jump), g_floor)``
    ((C, P) bool; float32 thresholds)."""
    p, cyc = cuda.grid(2)
    if p >= s.shape[1] or cyc >= s.shape[0]:
        return
    i = p // W
    j = p - i * W
    ref = median5x5(jump, cyc, i, j, H, W)
    t[cyc, p] = is_valid(s, cyc, p) and jump[cyc, p] > larger(g_ratio * ref, g_floor)


@cuda.jit(device=True)
def inside_rim(s, cyc, i, j, H, W, rim):
    """Every pixel of the image within city-block distance ``rim`` of ``(i, j)`` is valid (the
    mask eroded ``rim`` times by its 4-neighbours, the outside counting as valid)."""
    for di in range(-rim, rim + 1):
        r = i + di
        if r < 0 or r >= H:
            continue
        reach = rim - (di if di > 0 else -di)
        for dj in range(-reach, reach + 1):
            c = j + dj
            if c >= 0 and c < W and not is_valid(s, cyc, r * W + c):
                return False
    return True


@cuda.jit(device=True)
def pixel_bits(s, w, t, contrast, cyc, p, H, W, lo, hi, m_ratio, rim):
    """EDGE, GRADIENT, MOD_DROP and RIM of valid pixel ``p`` (an int)."""
    i = p // W
    j = p - i * W
    x = w[cyc, p]
    bits = EDGE if (x < lo or x > hi) else 0
    top = F0  # the contrast's largest value over the 5 x 5 neighbourhood (contrast >= 0)
    grad = False  # the jump test anywhere in the 3 x 3 neighbourhood
    for di in range(-2, 3):
        r = i + di
        if r < 0 or r >= H:
            continue
        for dj in range(-2, 3):
            c = j + dj
            if c < 0 or c >= W:
                continue
            q = r * W + c
            top = larger(top, contrast[cyc, q])
            if di >= -1 and di <= 1 and dj >= -1 and dj <= 1 and t[cyc, q]:
                grad = True
    if grad:
        bits |= GRADIENT
    if contrast[cyc, p] < m_ratio * top:
        bits |= MOD_DROP
    if rim > 0 and not inside_rim(s, cyc, i, j, H, W, rim):
        bits |= RIM
    return bits


@cuda.jit
def quality_bits_kernel(s, w, t, contrast, H, W, lo, hi, m_ratio, rim, edge_tests, quality, depth):
    """The quality map (C, P) uint8: INVALID where ``s`` is NaN, else (when ``edge_tests``)
    EDGE (``w`` outside ``[lo, hi]``), GRADIENT, MOD_DROP (contrast below ``m_ratio`` times the
    5 x 5 largest) and RIM (an invalid pixel within ``rim`` steps); ``depth`` = ``s`` where the
    map is 0, else NaN (C, P) float32."""
    p, cyc = cuda.grid(2)
    if p >= s.shape[1] or cyc >= s.shape[0]:
        return
    v = is_valid(s, cyc, p)
    bits = INVALID
    if v:
        bits = pixel_bits(s, w, t, contrast, cyc, p, H, W, lo, hi, m_ratio, rim) if edge_tests else 0
    quality[cyc, p] = np.uint8(bits)
    depth[cyc, p] = s[cyc, p] if bits == 0 else FNAN


@cuda.jit
def laplacian_partials_kernel(avg, quality, H, W, sums, counts):
    """Immerkaer's Laplacian ``|A * L|`` (float64) summed over the pixels whose quality and
    their 4-neighbours' are 0, away from the border, per block of :data:`THREADS` pixels:
    ``sums[cyc, block]`` float64 and ``counts[cyc, block]`` int32 (launch with THREADS threads)."""
    p, cyc = cuda.grid(2)
    tid = cuda.threadIdx.x
    acc = cuda.shared.array(THREADS, np.float64)
    cnt = cuda.shared.array(THREADS, np.int32)
    r = 0.0
    n = 0
    if p < avg.shape[1] and cyc < avg.shape[0]:
        i = p // W
        j = p - i * W
        if i >= 1 and i < H - 1 and j >= 1 and j < W - 1 and quality[cyc, p] == 0 and quality[cyc, p - W] == 0 \
                and quality[cyc, p + W] == 0 and quality[cyc, p - 1] == 0 and quality[cyc, p + 1] == 0:
            r = abs(4.0 * np.float64(avg[cyc, p])
                    - 2.0 * (np.float64(avg[cyc, p - W]) + np.float64(avg[cyc, p + W])
                             + np.float64(avg[cyc, p - 1]) + np.float64(avg[cyc, p + 1]))
                    + (np.float64(avg[cyc, p - W - 1]) + np.float64(avg[cyc, p - W + 1])
                       + np.float64(avg[cyc, p + W - 1]) + np.float64(avg[cyc, p + W + 1])))
            n = 1
    acc[tid] = r
    cnt[tid] = n
    cuda.syncthreads()
    step = THREADS // 2
    while step > 0:  # tree sum in shared memory; every thread reaches every barrier
        if tid < step:
            acc[tid] += acc[tid + step]
            cnt[tid] += cnt[tid + step]
        cuda.syncthreads()
        step //= 2
    if tid == 0 and cyc < sums.shape[0]:
        sums[cyc, cuda.blockIdx.x] = acc[0]
        counts[cyc, cuda.blockIdx.x] = cnt[0]


@cuda.jit
def noise_kernel(sums, counts, sqrt_steps, c_phase, c_sigma):
    """One thread per cycle: the camera noise ``sigma = sqrt(pi/2) sum / n / 6 * sqrt(N)``
    (float64; NaN where no pixel counts) and ``c_sigma[cyc, 0] = float32(c_phase) * float32(sigma)``
    (``c_phase = sqrt(2/N)``), the numerator of the phase noise ``sigma_phi = c_sigma / B``."""
    cyc = cuda.grid(1)
    if cyc >= sums.shape[0]:
        return
    total = 0.0
    n = 0
    for b in range(sums.shape[1]):
        total += sums[cyc, b]
        n += counts[cyc, b]
    sigma = (SQRT_HALF_PI * total / n / 6.0 if n > 0 else math.nan) * sqrt_steps
    c_sigma[cyc, 0] = np.float32(c_phase) * np.float32(sigma)


@cuda.jit
def sigma_z_kernel(w, mod, quality, c_sigma, t_scale, num, qd, pd, D, out):
    """``sigma_z = |Dz ds/dw| sigma_w`` (C, P) float32 mm with ``sigma_w = c_sigma / B * t_scale``
    (float32, inf where ``B <= 0``) and ``ds/dw = num / (pd*w - qd)^2`` (``num``, ``qd``, ``pd``
    (P,) float64); NaN where the quality is not 0."""
    p, cyc = cuda.grid(2)
    if p >= w.shape[1] or cyc >= w.shape[0]:
        return
    b = mod[cyc, p]
    sw = np.float32(np.float32(c_sigma[cyc, 0] / b) * t_scale) if b > F0 else FINF
    den = pd[p] * np.float64(w[cyc, p]) - qd[p]
    g = abs(num[p] / (den * den)) * np.float64(sw)
    v = np.float32(g * abs(np.float64(D[2, p])))
    out[cyc, p] = v if quality[cyc, p] == 0 else FNAN
