"""Numba kernels of the triangulation (private; see :mod:`fringe3d.reconstruct.triangulate`)."""
from __future__ import annotations

import math

import numba
import numpy as np

from fringe3d.phase._kernels import fast_atan2


@numba.njit(parallel=True, cache=True)
def lsq_kernel(cu, cv, valid, Pc, Pp, up, vp, use_up, use_vp, check_front, out):  # pragma: no cover
    H, W = cu.shape
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        A = np.empty((4, 3))
        b = np.empty(4)
        for j in range(W):
            out[i, j, 0] = nan
            out[i, j, 1] = nan
            out[i, j, 2] = nan
            if not valid[i, j]:
                continue
            n = 0
            for r, (x, P, k) in enumerate(((cu[i, j], Pc, 0), (cv[i, j], Pc, 1), (up[i, j], Pp, 0),
                                           (vp[i, j], Pp, 1))):
                if (r == 2 and not use_up) or (r == 3 and not use_vp):
                    continue
                for c in range(3):
                    A[n, c] = x * P[2, c] - P[k, c]
                b[n] = P[k, 3] - x * P[2, 3]
                n += 1
            if n == 3:
                X0, X1, X2, ok = solve3(A[0, 0], A[0, 1], A[0, 2], A[1, 0], A[1, 1], A[1, 2],
                                         A[2, 0], A[2, 1], A[2, 2], b[0], b[1], b[2])
            else:  # normal equations, Eq. (2.37)
                M = np.zeros((3, 3))
                v = np.zeros(3)
                for r in range(n):
                    for c in range(3):
                        v[c] += A[r, c] * b[r]
                        for d in range(3):
                            M[c, d] += A[r, c] * A[r, d]
                X0, X1, X2, ok = solve3(M[0, 0], M[0, 1], M[0, 2], M[1, 0], M[1, 1], M[1, 2],
                                         M[2, 0], M[2, 1], M[2, 2], v[0], v[1], v[2])
            if not ok:
                continue
            if check_front and not (Pc[2, 0] * X0 + Pc[2, 1] * X1 + Pc[2, 2] * X2 + Pc[2, 3] > 0.0):
                continue  # behind the pinhole camera
            out[i, j, 0] = X0
            out[i, j, 1] = X1
            out[i, j, 2] = X2


@numba.njit(cache=True, inline="always")
def solve3(a, b, c, d, e, f, g, h, k, r0, r1, r2):  # pragma: no cover - compiled
    """Solve the 3x3 system [[a b c] [d e f] [g h k]] x = r by Cramer's rule."""
    c0 = e * k - f * h
    c1 = f * g - d * k
    c2 = d * h - e * g
    det = a * c0 + b * c1 + c * c2
    if det == 0.0 or not math.isfinite(det):
        return 0.0, 0.0, 0.0, False
    x0 = (r0 * c0 + b * (f * r2 - r1 * k) + c * (r1 * h - e * r2)) / det
    x1 = (a * (r1 * k - f * r2) + r0 * c1 + c * (d * r2 - r1 * g)) / det
    x2 = (a * (e * r2 - r1 * h) + b * (r1 * g - d * r2) + r0 * c2) / det
    return x0, x1, x2, True


_FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}  # fastmath without the no-NaN/no-inf assumptions


#: -2**63 as float64: what a float64 -> int64 conversion gives on x86-64 for NaN, +-inf and any
#: value out of the int64 range (``cvttsd2si``'s "integer indefinite")
_INT_INDEFINITE = -9.223372036854775808e18


@numba.njit(fastmath=_FAST, cache=True, inline="always")
def ceil_as_int(v):  # pragma: no cover - compiled
    """``math.ceil(v)`` (an int64 in numba) as float64 again, without the conversion to int64 that
    AVX2 has no packed instruction for (it kept the fused kernel's pixel loop scalar): the float
    ceiling where it fits int64, else the x86-64 conversion's value for NaN, +-inf and values
    out of range (-2**63), so the kernel's outputs are the bits they were."""
    return np.ceil(v) if abs(v) < 9.223372036854775808e18 else _INT_INDEFINITE


@numba.njit(fastmath=_FAST, cache=True, inline="always")
def _three_step_pixel(frames, i, j, i0, i1, i2, coef, phi_min, sign, scale, qo, po, D, Q, P3):  # pragma: no cover
    """One pixel of the fused path: ``(s, w, b^2 + c^2, sg, a0, a1, a2)`` (see :func:`three_step_kernel`)."""
    two_pi = 2.0 * math.pi
    a0 = np.float64(frames[i0, i, j])
    a1 = np.float64(frames[i1, i, j])
    a2 = np.float64(frames[i2, i, j])
    b = coef[1, 0] * a0 + coef[1, 1] * a1 + coef[1, 2] * a2
    c = coef[2, 0] * a0 + coef[2, 1] * a1 + coef[2, 2] * a2
    phi = fast_atan2(-c, b)
    sg = np.float64(sign[i, j])
    x = (np.float64(phi_min[i, j]) - phi) * (1.0 / two_pi)
    w = (phi + two_pi * (sg * ceil_as_int(sg * x))) * scale
    dx = np.float64(D[0, i, j])
    dy = np.float64(D[1, i, j])
    dz = np.float64(D[2, i, j])
    s = (qo - w * po) / (w * (P3[0] * dx + P3[1] * dy + P3[2] * dz) - (Q[0] * dx + Q[1] * dy + Q[2] * dz))
    return s, w, b * b + c * c, sg, a0, a1, a2


@numba.njit(parallel=True, fastmath=_FAST, cache=True, nogil=True)
def three_step_kernel(frames, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3, out):  # pragma: no cover
    """3 frames -> wrapped phase (Eq. 2.4) -> k (Eq. 4.21) -> w (Eq. 4.13) -> ray parameter ``s``
    of ``X = O + s*D`` (Eq. 2.37 along the camera ray), written as (H, W) float32 (NaN invalid).

    Branch-free per pixel so the row loop vectorises: ``k = sg*ceil(sg*x)`` is ceil for a
    rising and floor for a falling phase. The points are :func:`fringe3d.optics.rays.ray_points`
    of ``out`` (one code path, so a store of ``s`` gives back the same points bit for bit).
    """
    H = frames.shape[1]
    W = frames.shape[2]
    qo = Q[0] * O[0] + Q[1] * O[1] + Q[2] * O[2] + Q[3]
    po = P3[0] * O[0] + P3[1] * O[1] + P3[2] * O[2] + P3[3]
    i0, i1, i2 = idx[0], idx[1], idx[2]
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            s, w, b2, sg, a0, a1, a2 = _three_step_pixel(frames, i, j, i0, i1, i2, coef, phi_min, sign, scale, qo,
                                                         po, D, Q, P3)
            ok = (b2 >= min_mod2) & (sg != 0.0) & (s > 0.0)
            out[i, j] = np.float32(s) if ok else nan


@numba.njit(parallel=True, fastmath=_FAST, cache=True, nogil=True)
def three_step_fields_kernel(frames, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3, out, w_out,
                             avg_out, mod_out):  # pragma: no cover - compiled
    """:func:`three_step_kernel` that also writes what the quality tests read, in the same pass:
    the fringe coordinate ``w`` (Eq. 4.13, px), the average ``A = coef[0].I`` and the modulation
    ``B = sqrt(b^2 + c^2)`` (Eq. 2.4, frames' units), each (H, W) float32 (also where ``s`` is NaN)."""
    H = frames.shape[1]
    W = frames.shape[2]
    qo = Q[0] * O[0] + Q[1] * O[1] + Q[2] * O[2] + Q[3]
    po = P3[0] * O[0] + P3[1] * O[1] + P3[2] * O[2] + P3[3]
    i0, i1, i2 = idx[0], idx[1], idx[2]
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            s, w, b2, sg, a0, a1, a2 = _three_step_pixel(frames, i, j, i0, i1, i2, coef, phi_min, sign, scale, qo,
                                                         po, D, Q, P3)
            ok = (b2 >= min_mod2) & (sg != 0.0) & (s > 0.0)
            out[i, j] = np.float32(s) if ok else nan
            w_out[i, j] = np.float32(w)
            avg_out[i, j] = np.float32(coef[0, 0] * a0 + coef[0, 1] * a1 + coef[0, 2] * a2)
            mod_out[i, j] = np.float32(math.sqrt(b2))


@numba.njit(parallel=True, cache=True, nogil=True)
def mask_flagged(depth, quality, keep):  # pragma: no cover - compiled
    """``depth[quality != 0] = NaN`` in place and ``keep = quality == 0``, one pass (no boolean
    temporaries)."""
    H, W = depth.shape
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            k = quality[i, j] == 0
            keep[i, j] = k
            depth[i, j] = depth[i, j] if k else nan
