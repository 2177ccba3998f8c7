"""CUDA kernels of the temporal and geometric unwrapping: the fused three-frequency heterodyne
decode and the geometric constraint (Eq. 4.20-4.21), one thread per pixel and cycle.

Ports of :func:`fringe3d.unwrap._kernels.three_frequency_kernel` (float32 arithmetic) and of
:func:`fringe3d.unwrap.geometric.geometric_unwrap` (float64 order, float32 phase). Layout:
``(C, F, P)`` frames or ``(C, P)`` maps, ``P = H*W`` pixels.
"""
from __future__ import annotations

import math

import numpy as np
from numba import cuda

from fringe3d.gpu.device_math import (F2PI, FHALF, FINV2PI, TWO_PI, ceil_f, floor_f, floor_f32, group_sums32, larger,
                                      mod_2pi_f32, smaller)


@cuda.jit
def geometric_kernel(wrapped, phi_min, sign, mask, use_mask, phase, valid):
    """Absolute phase by the minimum phase map: ``k = ceil((Phi_min - phi)/2pi)`` where the
    phase rises with depth (``sign`` +1), ``floor`` where it falls (-1), undefined where 0;
    ``Phi = phi + 2 pi k`` (Eq. 4.21). wrapped (C, P) float; phi_min (P,) float32; sign (P,)
    int8; mask (C, P) bool (read when ``use_mask``). Outputs (C, P): phase float32 (NaN
    invalid), valid bool."""
    p, cyc = cuda.grid(2)
    if p >= wrapped.shape[1] or cyc >= wrapped.shape[0]:
        return
    phi = np.float64(wrapped[cyc, p])
    sg = sign[p]
    x = (np.float64(phi_min[p]) - phi) / TWO_PI
    k = ceil_f(x) if sg > 0 else floor_f(x)
    big = np.float32(phi + TWO_PI * k)
    ok = (sg != 0) and math.isfinite(big)
    if use_mask:
        ok = ok and mask[cyc, p]
    valid[cyc, p] = ok
    phase[cyc, p] = big if ok else np.float32(math.nan)


@cuda.jit
def three_frequency_kernel(frames, idx1, coef1, idx2, coef2, idx3, coef3, params,
                           phase, wrapped, modulation, average, mask, texture):
    """Fused three-frequency decode per pixel (see the CPU kernel for the method and
    ``params`` = ``(s12, s123, r_top, r_mid, lower, min_modulation, sat_level, max_residual)``
    float32). frames (C, F, P); outputs (C, P): absolute phase (NaN invalid), wrapped phase,
    modulation and average of group 1, mask, texture (average + modulation)."""
    p, cyc = cuda.grid(2)
    if p >= frames.shape[2] or cyc >= frames.shape[0]:
        return
    s12 = params[0]
    s123 = params[1]
    r_top = params[2]
    r_mid = params[3]
    lower = params[4]
    min_mod2 = params[5] * params[5]
    sat_level = params[6]
    max_res = params[7]
    a1, b1, c1, pk1 = group_sums32(frames, cyc, idx1, coef1, p)
    a2, b2, c2, pk2 = group_sums32(frames, cyc, idx2, coef2, p)
    a3, b3, c3, pk3 = group_sums32(frames, cyc, idx3, coef3, p)
    m1 = b1 * b1 + c1 * c1
    m2 = b2 * b2 + c2 * c2
    m3 = b3 * b3 + c3 * c3
    p1 = math.atan2(-c1, b1)
    p2 = math.atan2(-c2, b2)
    p3 = math.atan2(-c3, b3)
    x12 = mod_2pi_f32(s12 * (p1 - p2))
    x123 = mod_2pi_f32(s123 * (x12 - p3))
    big = lower + mod_2pi_f32(x123 - lower)
    d1 = big * r_top - x12
    k1 = floor_f32(d1 * FINV2PI + FHALF)
    big = x12 + F2PI * k1
    d2 = big * r_mid - p1
    k2 = floor_f32(d2 * FINV2PI + FHALF)
    absolute = p1 + F2PI * k2
    consistent = (abs(d1 - F2PI * k1) <= max_res) and (abs(d2 - F2PI * k2) <= max_res)
    ok = (smaller(m1, smaller(m2, m3)) >= min_mod2) and (larger(pk1, larger(pk2, pk3)) < sat_level) and consistent
    bm = math.sqrt(m1)
    wrapped[cyc, p] = p1
    modulation[cyc, p] = bm
    average[cyc, p] = a1
    texture[cyc, p] = a1 + bm
    mask[cyc, p] = ok
    phase[cyc, p] = absolute if ok else np.float32(math.nan)
