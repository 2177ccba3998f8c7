"""Compiled Newton inversion of the five-coefficient distortion (:func:`fringe3d.optics.distortion.undistort`).

One pass over the points per Newton step instead of about 40 NumPy temporaries: a camera's whole
pixel grid (its ray table) is undistorted when a capture is first reconstructed.
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(cache=True, nogil=True)
def undistort5(xy_d, k1, k2, p1, p2, k3, iterations, tol, xy):  # pragma: no cover - compiled
    """Newton steps of ``undistort`` on ``xy_d`` (N, 2) into ``xy`` (N, 2): every float operation
    of the NumPy loop in its order (the same points, bit for bit), all points stepped together
    until the largest step ``|dx| + |dy|`` (NaN ignored) falls below ``tol``."""
    n = xy_d.shape[0]
    for i in range(n):
        xy[i, 0] = xy_d[i, 0]
        xy[i, 1] = xy_d[i, 1]
    for _ in range(iterations):
        most = 0.0
        for i in range(n):
            x = xy[i, 0]
            y = xy[i, 1]
            r2 = x * x + y * y
            radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
            dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2)
            fx = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) - xy_d[i, 0]
            fy = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y - xy_d[i, 1]
            jxx = radial + 2 * x * x * dradial + 2 * p1 * y + 6 * p2 * x
            jxy = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
            jyx = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
            jyy = radial + 2 * y * y * dradial + 6 * p1 * y + 2 * p2 * x
            det = jxx * jyy - jxy * jyx
            dx = (jyy * fx - jxy * fy) / det
            dy = (-jyx * fx + jxx * fy) / det
            xy[i, 0] = x - dx
            xy[i, 1] = y - dy
            step = np.abs(dx) + np.abs(dy)
            if step > most:  # False for NaN: nanmax
                most = step
        if most < tol:
            break
    return xy
