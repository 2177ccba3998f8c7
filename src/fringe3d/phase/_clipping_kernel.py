"""Per-pixel clipping bias in numba (private; see :func:`fringe3d.phase.clipping.clipping_bias`)."""
from __future__ import annotations

import math

from numba import njit, prange


@njit(cache=True)
def _angle_between(re1, im1, re0, im0):
    """``arg((re1 + i im1) / (re0 + i im0))`` in (-pi, pi]."""
    return math.atan2(im1 * re0 - re1 * im0, re1 * re0 + im1 * im0)


@njit(cache=True)
def _estimate(s, m, cos_d, sin_d, clipped, level, wr, wi, zr, zi):
    """Bias, restored modulation and success of the estimate from the unclipped samples of pixel
    ``m``: the sinusoid ``a + b cos d + c sin d`` fitted to them (3 x 3 normal equations, by
    Cramer's rule) predicts each clipped sample (bit ``k`` of ``clipped``); its signed deficit
    restores ``z``."""
    g00 = g01 = g02 = g11 = g12 = g22 = 0.0
    r0 = r1 = r2 = 0.0
    for k in range(s.shape[0]):
        if (clipped >> k) & 1:
            continue
        c, t, v = cos_d[k], sin_d[k], s[k, m]
        g00 += 1.0
        g01 += c
        g02 += t
        g11 += c * c
        g12 += c * t
        g22 += t * t
        r0 += v
        r1 += c * v
        r2 += t * v
    m00 = g11 * g22 - g12 * g12
    m01 = g01 * g22 - g12 * g02
    m02 = g01 * g12 - g11 * g02
    det = g00 * m00 - g01 * m01 + g02 * m02
    if abs(det) <= 1e-9 * g00 ** 3:
        return 0.0, 0.0, False
    a = (r0 * m00 - g01 * (r1 * g22 - g12 * r2) + g02 * (r1 * g12 - g11 * r2)) / det
    b = (g00 * (r1 * g22 - g12 * r2) - r0 * m01 + g02 * (g01 * r2 - r1 * g02)) / det
    cc = (g00 * (g11 * r2 - r1 * g12) - g01 * (g01 * r2 - r1 * g02) + r0 * m02) / det
    tr, ti = zr, zi
    for k in range(s.shape[0]):
        if (clipped >> k) & 1:
            deficit = a + b * cos_d[k] + cc * sin_d[k] - level
            tr += wr[k] * deficit
            ti += wi[k] * deficit
    return _angle_between(tr, ti, zr, zi), math.hypot(tr, ti), True


@njit(cache=True)
def _bound(s, m, clipped, n_clipped, wr, wi, zr, zi, p0):
    """Bias bound of pixel ``m`` from non-negative deficits: the cone of the clipped samples'
    weights (pi when it is pi wide or more), with one clipped sample also the trough bound."""
    lo, hi = math.inf, -math.inf
    last = -1
    for k in range(s.shape[0]):
        if (clipped >> k) & 1:
            t = _angle_between(wr[k], wi[k], zr, zi)
            lo = min(lo, t)
            hi = max(hi, t)
            last = k
    bound = max(abs(lo), abs(hi)) if hi - lo < math.pi else math.pi
    if n_clipped == 1:
        a = 0.0
        for k in range(s.shape[0]):
            a += p0[k] * s[k, m]
        pk = p0[last]
        qa = wr[last] ** 2 + wi[last] ** 2 - pk * pk
        qb = 2.0 * (zr * wr[last] + zi * wi[last]) - 2.0 * a * pk
        qc = zr * zr + zi * zi - a * a
        disc = qb * qb - 4.0 * qa * qc
        if qa > 0 and qc <= 0 and disc >= 0:
            d_max = (-qb + math.sqrt(disc)) / (2.0 * qa)
            t = abs(_angle_between(zr + d_max * wr[last], zi + d_max * wi[last], zr, zi))
            bound = min(bound, t)
    return bound


@njit(cache=True, parallel=True)
def clipping_bias_kernel(s, cos_d, sin_d, coef, level, bias, estimated, modulation):
    """s (N, M) float64 samples (N <= 63); cos_d, sin_d (N,) of the shifts; coef (3, N)
    least-squares coefficients of all samples; outputs (M,) bias (rad), estimated (bool),
    modulation."""
    n, mm = s.shape
    wr = coef[1]
    wi = -coef[2]
    for m in prange(mm):
        zr = 0.0
        zi = 0.0
        clipped = 0  # bit k: sample k clipped (N <= 63)
        n_clipped = 0
        for k in range(n):
            zr += wr[k] * s[k, m]
            zi += wi[k] * s[k, m]
            if s[k, m] >= level:
                clipped |= 1 << k
                n_clipped += 1
        bias[m] = 0.0
        estimated[m] = False
        modulation[m] = math.hypot(zr, zi)
        if n_clipped == 0:
            continue
        if n - n_clipped >= 3:
            b, mod, ok = _estimate(s, m, cos_d, sin_d, clipped, level, wr, wi, zr, zi)
            if ok:
                bias[m] = b
                modulation[m] = mod
                estimated[m] = True
                continue
        bias[m] = _bound(s, m, clipped, n_clipped, wr, wi, zr, zi, coef[0])
