"""Numba kernels of the closed-form ray triangulation (private; see :mod:`fringe3d.optics.rays`).

Along the camera ray ``X = O + s*D`` the projector row ``w*(P3.X~) = Q.X~`` gives
``s = (Q.O~ - w P3.O~) / (w P3.D - Q.D)`` (Eq. 2.37 solved along the ray).
"""
from __future__ import annotations

import math

import numba
import numpy as np


@numba.njit(parallel=True, cache=True)
def central_kernel(w, mask, O, D, Q, P3, out):  # pragma: no cover - compiled
    """Pinhole rays: O (3,) centre, D (3, H, W) ray planes; out (H, W, 3)."""
    H, W = w.shape
    qo = Q[0] * O[0] + Q[1] * O[1] + Q[2] * O[2] + Q[3]
    po = P3[0] * O[0] + P3[1] * O[1] + P3[2] * O[2] + P3[3]
    for i in numba.prange(H):
        srow = np.empty(W, np.float64)
        for j in range(W):  # contiguous planes: this loop vectorises
            wij = np.float64(w[i, j])
            dx = np.float64(D[0, i, j])
            dy = np.float64(D[1, i, j])
            dz = np.float64(D[2, i, j])
            s = (qo - wij * po) / (wij * (P3[0] * dx + P3[1] * dy + P3[2] * dz) - (Q[0] * dx + Q[1] * dy + Q[2] * dz))
            srow[j] = s if (mask[i, j] and s > 0.0 and s < np.inf) else np.nan
        write_row(out, i, srow, O[0], O[1], O[2], D[0, i], D[1, i], D[2, i])


@numba.njit(parallel=True, cache=True)
def depth_kernel(s, O, D, out):  # pragma: no cover - compiled
    """Pinhole rays: ``out[i, j] = O + s[i, j] * D[:, i, j]`` from the (H, W) float32 ray parameters."""
    H, W = s.shape
    for i in numba.prange(H):
        write_row(out, i, s[i], O[0], O[1], O[2], D[0, i], D[1, i], D[2, i])


@numba.njit(parallel=True, cache=True)
def fringe_kernel(s, qo, po, qd, pd, out):  # pragma: no cover - compiled
    """Pinhole rays: ``out = (qo + s*qd) / (po + s*pd)``, the fringe coordinate ``w`` of the point at ``s``."""
    H, W = s.shape
    for i in numba.prange(H):
        for j in range(W):
            sij = np.float64(s[i, j])
            out[i, j] = (qo + sij * qd[i, j]) / (po + sij * pd[i, j])


@numba.njit(parallel=True, cache=True)
def sigma_kernel(w, sigma_w, mask, qo, po, qd, pd, D, out):  # pragma: no cover - compiled
    """Pinhole rays: ``out[i, j, k] = |D_k ds/dw| sigma_w`` with ``ds/dw = (po*qd - qo*pd) / (pd*w - qd)^2``."""
    H, W = w.shape
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            wij = np.float64(w[i, j])
            den = pd[i, j] * wij - qd[i, j]
            g = abs((po * qd[i, j] - qo * pd[i, j]) / (den * den)) * np.float64(sigma_w[i, j])
            for k in range(3):
                out[i, j, k] = np.float32(g * abs(np.float64(D[k, i, j]))) if mask[i, j] else nan


@numba.njit(cache=True, inline="always")
def write_row(out, i, srow, ox, oy, oz, dx, dy, dz):  # pragma: no cover - compiled
    """Row ``i`` of the point map: ``out[i, j] = O + srow[j] * D[:, i, j]``."""
    for j in range(srow.shape[0]):
        s = np.float64(srow[j])
        out[i, j, 0] = ox + s * dx[j]
        out[i, j, 1] = oy + s * dy[j]
        out[i, j, 2] = oz + s * dz[j]


@numba.njit(parallel=True, cache=True)
def parallel_kernel(w, mask, O, D, Q, P3, out):  # pragma: no cover - compiled
    """Telecentric rays: O (3, H, W) origin planes, D (3,) common direction; out (H, W, 3)."""
    H, W = w.shape
    qd = Q[0] * D[0] + Q[1] * D[1] + Q[2] * D[2]
    pd = P3[0] * D[0] + P3[1] * D[1] + P3[2] * D[2]
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            wij = np.float64(w[i, j])
            ox = np.float64(O[0, i, j])
            oy = np.float64(O[1, i, j])
            oz = np.float64(O[2, i, j])
            num = (Q[0] * ox + Q[1] * oy + Q[2] * oz + Q[3]) - wij * (P3[0] * ox + P3[1] * oy + P3[2] * oz + P3[3])
            s = num / (wij * pd - qd)
            if mask[i, j] and math.isfinite(s):
                out[i, j, 0] = ox + s * D[0]
                out[i, j, 1] = oy + s * D[1]
                out[i, j, 2] = oz + s * D[2]
            else:
                out[i, j, 0] = nan
                out[i, j, 1] = nan
                out[i, j, 2] = nan


@numba.njit(parallel=True, cache=True, nogil=True)
def sigma_z_kernel(w, modulation, mask, c_sigma, t_scale, num, qd, pd, Dz, out):  # pragma: no cover - compiled
    """Pinhole rays: ``out[i, j] = |Dz ds/dw| sigma_w`` with ``sigma_w = (c_sigma / B) t_scale``
    (float32, inf where ``B <= 0``) and ``ds/dw = num / (pd*w - qd)^2``, ``num = po*qd - qo*pd``;
    NaN where ``mask`` is False. The same operations in the same precision as ``phase_sigma``
    followed by :func:`sigma_kernel`'s z, so the two give the same bits."""
    H, W = w.shape
    nan = np.float32(np.nan)
    inf = np.float32(np.inf)
    for i in numba.prange(H):
        for j in range(W):
            b = modulation[i, j]
            q = np.float32(np.float32(c_sigma / b) * t_scale)
            sw = q if b > 0 else inf
            den = pd[i, j] * np.float64(w[i, j]) - qd[i, j]
            g = abs(num[i, j] / (den * den)) * np.float64(sw)
            v = np.float32(g * abs(np.float64(Dz[i, j])))
            out[i, j] = v if mask[i, j] else nan
