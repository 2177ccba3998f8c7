"""CUDA kernels of the closed-form triangulation along the camera rays (pinhole camera), alone
and fused with the 3-step phase and the geometric constraint; one thread per pixel and cycle.

Along the ray ``X = O + s*D`` the projector row ``w (P3 . X~) = Q . X~`` gives
``s = (Q.O~ - w P3.O~) / (w P3.D - Q.D)`` (Eq. 2.37 solved along the ray), as
:func:`fringe3d.optics._ray_kernels.central_kernel` and
:func:`fringe3d.reconstruct._kernels.three_step_kernel` (float64 arithmetic, float32 points).
``D`` is (3, P) float32 ray planes, ``O`` (3,), ``Q`` and ``P3`` (4,) float64.
"""
from __future__ import annotations

import math

import numpy as np
from numba import cuda

from fringe3d.gpu.device_math import TWO_PI, ceil_f, group_sums64


@cuda.jit(device=True)
def store_point(out, cyc, p, s, O, D):
    """``out[cyc, p] = O + s * D[:, p]`` in float32 (NaN when ``s`` is NaN)."""
    out[cyc, p, 0] = np.float32(O[0] + s * np.float64(D[0, p]))
    out[cyc, p, 1] = np.float32(O[1] + s * np.float64(D[1, p]))
    out[cyc, p, 2] = np.float32(O[2] + s * np.float64(D[2, p]))


@cuda.jit(device=True)
def ray_parameter(w, p, O, D, Q, P3):
    """``s`` of the point along pixel ``p``'s ray whose projector coordinate is ``w``."""
    qo = Q[0] * O[0] + Q[1] * O[1] + Q[2] * O[2] + Q[3]
    po = P3[0] * O[0] + P3[1] * O[1] + P3[2] * O[2] + P3[3]
    dx = np.float64(D[0, p])
    dy = np.float64(D[1, p])
    dz = np.float64(D[2, p])
    return (qo - w * po) / (w * (P3[0] * dx + P3[1] * dy + P3[2] * dz) - (Q[0] * dx + Q[1] * dy + Q[2] * dz))


@cuda.jit
def central_points_kernel(w, mask, O, D, Q, P3, out):
    """w (C, P) projector coordinate (px); mask (C, P) bool; out (C, P, 3) float32 mm, NaN where
    masked, ``w`` NaN, or the point lies behind the camera."""
    p, cyc = cuda.grid(2)
    if p >= w.shape[1] or cyc >= w.shape[0]:
        return
    s = ray_parameter(np.float64(w[cyc, p]), p, O, D, Q, P3)
    ok = mask[cyc, p] and s > 0.0 and s < math.inf
    store_point(out, cyc, p, s if ok else math.nan, O, D)


@cuda.jit(device=True)
def three_step_pixel(frames, cyc, p, idx, coef, phi_min, sign, scale, O, D, Q, P3):
    """3 frames -> wrapped phase (Eq. 2.4) -> k (Eq. 4.21) -> w (Eq. 4.13) -> ray parameter ``s``
    (Eq. 2.37 along the ray) of pixel ``p`` in cycle ``cyc``: ``(s, w, a, b^2 + c^2, ok)``, float64,
    ``a`` the average, ``b^2 + c^2`` the squared modulation, ``ok`` the sign and ``s > 0`` tests
    (the modulation test is the caller's)."""
    a, b, c, peak = group_sums64(frames, cyc, idx, coef, p)
    phi = math.atan2(-c, b)
    sg = np.float64(sign[p])
    x = (np.float64(phi_min[p]) - phi) / TWO_PI
    w = (phi + TWO_PI * (sg * ceil_f(sg * x))) * scale
    s = ray_parameter(w, p, O, D, Q, P3)
    return s, w, a, b * b + c * c, (sg != 0.0) and (s > 0.0)


@cuda.jit(device=True)
def three_step_s(frames, cyc, p, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3):
    """:func:`three_step_pixel`'s ray parameter ``s``; NaN where invalid."""
    s, w, a, b2, ok = three_step_pixel(frames, cyc, p, idx, coef, phi_min, sign, scale, O, D, Q, P3)
    return s if (b2 >= min_mod2) and ok else math.nan


@cuda.jit
def three_step_kernel(frames, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3, out):
    """The fused 3-step + geometric + triangulation kernel (:func:`three_step_s`) -> points.

    frames (C, F, P); idx (3,) int64; coef (3, 3) float64; min_mod2 the squared modulation
    threshold; phi_min (P,) float32; sign (P,) int8; scale = T / 2pi. out (C, P, 3) float32."""
    p, cyc = cuda.grid(2)
    if p >= frames.shape[2] or cyc >= frames.shape[0]:
        return
    store_point(out, cyc, p, three_step_s(frames, cyc, p, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3),
                O, D)


@cuda.jit
def three_step_depth_kernel(frames, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3, out):
    """As :func:`three_step_kernel`, writing only the ray parameters: out (C, P) float32 mm (a
    quarter of the points' bytes; :func:`fringe3d.optics.rays.ray_points` makes the points)."""
    p, cyc = cuda.grid(2)
    if p >= frames.shape[2] or cyc >= frames.shape[0]:
        return
    out[cyc, p] = np.float32(three_step_s(frames, cyc, p, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3))
