"""Brown-Conrady lens distortion, Eq. (2.12)-(2.16), in normalised image coordinates.

Coefficients follow OpenCV's order ``(k1, k2, p1, p2, k3)``. Points are normalised
coordinates ``(x, y) = (X/Z, Y/Z)`` with shape ``(..., 2)``.
"""
from __future__ import annotations

import numpy as np


def as_coeffs(dist) -> np.ndarray:
    """Return distortion coefficients as a float64 array of 5 (missing ones are zero)."""
    d = np.zeros(5)
    if dist is not None:
        dist = np.asarray(dist, dtype=float).ravel()
        if dist.size > 5:
            raise ValueError(f"expected at most 5 distortion coefficients (k1 k2 p1 p2 k3), got {dist.size}")
        d[: dist.size] = dist
    return d


def distort(xy: np.ndarray, dist) -> np.ndarray:
    """Apply radial + tangential distortion to normalised points, Eq. (2.12)-(2.16).

    ``x_d = x(1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)`` and likewise for y.
    """
    k1, k2, p1, p2, k3 = as_coeffs(dist)
    x, y = xy[..., 0], xy[..., 1]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=-1)


def undistort(xy_d: np.ndarray, dist, iterations: int = 30, tol: float = 1e-14) -> np.ndarray:
    """Invert :func:`distort` by Newton iteration on normalised points.

    Converges to ~1e-15 in a handful of steps for realistic lenses (|k1| < 1); returns the
    undistorted normalised points with the same shape as ``xy_d``.

    Examples
    --------
    >>> import numpy as np
    >>> xy, dist = np.array([[0.1, -0.2]]), [-0.1, 0.01, 0.0, 0.0, 0.0]
    >>> bool(np.allclose(undistort(distort(xy, dist), dist), xy, atol=1e-12))
    True
    """
    d = as_coeffs(dist)
    xy_d = np.asarray(xy_d, dtype=float)
    if not d.any():
        return xy_d.copy()
    k1, k2, p1, p2, k3 = d
    xy = xy_d.copy()
    for _ in range(iterations):
        x, y = xy[..., 0], xy[..., 1]
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        dradial = k1 + r2 * (2 * k2 + 3 * k3 * r2)  # d(radial)/d(r2)
        fx = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) - xy_d[..., 0]
        fy = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y - xy_d[..., 1]
        # Jacobian of the distortion map
        jxx = radial + 2 * x * x * dradial + 2 * p1 * y + 6 * p2 * x
        jxy = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
        jyx = 2 * x * y * dradial + 2 * p1 * x + 2 * p2 * y
        jyy = radial + 2 * y * y * dradial + 6 * p1 * y + 2 * p2 * x
        det = jxx * jyy - jxy * jyx
        dx = (jyy * fx - jxy * fy) / det
        dy = (-jyx * fx + jxx * fy) / det
        xy = np.stack([x - dx, y - dy], axis=-1)
        if np.nanmax(np.abs(dx) + np.abs(dy), initial=0.0) < tol:
            break
    return xy
