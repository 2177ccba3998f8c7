"""Lens distortion in normalised image coordinates: Brown-Conrady, Eq. (2.12)-(2.16), and
OpenCV's extensions.

Coefficients follow OpenCV's order ``(k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4, tau_x,
tau_y)`` (``cv2.projectPoints``): radial ``k1 k2 k3``, tangential ``p1 p2``, the rational
denominator ``k4 k5 k6``, thin prism ``s1 .. s4`` and the sensor tilt ``tau_x tau_y`` (rad).
With ``r^2 = x^2 + y^2``:

``x'' = x (1 + k1 r^2 + k2 r^4 + k3 r^6) / (1 + k4 r^2 + k5 r^4 + k6 r^6) + 2 p1 x y
+ p2 (r^2 + 2 x^2) + s1 r^2 + s2 r^4`` (and ``y''`` with ``p1 <-> p2``, ``s3 s4``), then the
tilt homography ``(x_d, y_d, 1) ~ T(tau_x, tau_y) (x'', y'', 1)`` of OpenCV's
``computeTiltProjectionMatrix``. Vectors of at most five coefficients (or longer ones whose
extra terms are zero) take the five-coefficient path of Eq. (2.12)-(2.16) unchanged. Points
are normalised coordinates ``(x, y) = (X/Z, Y/Z)`` with shape ``(..., 2)``.
"""
from __future__ import annotations

import numpy as np

#: Names of OpenCV's distortion coefficients, in order.
COEFFICIENT_NAMES = ("k1", "k2", "p1", "p2", "k3", "k4", "k5", "k6", "s1", "s2", "s3", "s4", "tau_x", "tau_y")
#: OpenCV's distortion vector lengths.
OPENCV_LENGTHS = (4, 5, 8, 12, 14)


def as_coeffs(dist) -> np.ndarray:
    """Distortion coefficients as float64: 5 (``k1 k2 p1 p2 k3``, missing ones zero) when at
    most five are given or every term beyond ``k3`` is zero, else OpenCV's full 14."""
    d = np.zeros(5)
    if dist is not None:
        dist = np.asarray(dist, dtype=float).ravel()
        if dist.size > len(COEFFICIENT_NAMES):
            raise ValueError(f"expected at most 14 distortion coefficients ({' '.join(COEFFICIENT_NAMES)}), "
                             f"got {dist.size}")
        if dist.size > 5 and dist[5:].any():
            d = np.zeros(len(COEFFICIENT_NAMES))
        d[: min(dist.size, d.size)] = dist[: d.size]
    return d


def tilt_matrix(tau_x: float, tau_y: float) -> np.ndarray:
    """(3, 3) sensor-tilt homography of OpenCV's ``computeTiltProjectionMatrix`` (angles in rad)."""
    cx, sx, cy, sy = np.cos(tau_x), np.sin(tau_x), np.cos(tau_y), np.sin(tau_y)
    rot = np.array([[cy, 0.0, -sy], [0.0, 1.0, 0.0], [sy, 0.0, cy]]) @ np.array([[1.0, 0.0, 0.0], [0.0, cx, sx],
                                                                                   [0.0, -sx, cx]])
    proj_z = np.array([[rot[2, 2], 0.0, -rot[0, 2]], [0.0, rot[2, 2], -rot[1, 2]], [0.0, 0.0, 1.0]])
    return proj_z @ rot


def _homography(xy: np.ndarray, H: np.ndarray) -> np.ndarray:
    """Points ``(..., 2)`` through the homography ``H`` (3, 3)."""
    x, y = xy[..., 0], xy[..., 1]
    w = H[2, 0] * x + H[2, 1] * y + H[2, 2]
    return np.stack([(H[0, 0] * x + H[0, 1] * y + H[0, 2]) / w, (H[1, 0] * x + H[1, 1] * y + H[1, 2]) / w], axis=-1)


def _lens_full(xy: np.ndarray, d: np.ndarray) -> np.ndarray:
    """Rational radial + tangential + thin-prism terms (before the tilt) of a 14-vector ``d``."""
    k1, k2, p1, p2, k3, k4, k5, k6, s1, s2, s3, s4 = d[:12]
    x, y = xy[..., 0], xy[..., 1]
    r2 = x * x + y * y
    r4 = r2 * r2
    radial = (1 + r2 * (k1 + r2 * (k2 + r2 * k3))) / (1 + r2 * (k4 + r2 * (k5 + r2 * k6)))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x) + s1 * r2 + s2 * r4
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y + s3 * r2 + s4 * r4
    return np.stack([xd, yd], axis=-1)


def _distort_full(xy: np.ndarray, d: np.ndarray) -> np.ndarray:
    out = _lens_full(np.asarray(xy, dtype=float), d)
    return _homography(out, tilt_matrix(d[12], d[13])) if d[12] or d[13] else out


def _undistort_full(xy_d: np.ndarray, d: np.ndarray, iterations: int, tol: float) -> np.ndarray:
    """Invert :func:`_distort_full`: the tilt exactly (its inverse homography), then the lens
    terms by Newton iteration with a central-difference Jacobian."""
    target = _homography(xy_d, np.linalg.inv(tilt_matrix(d[12], d[13]))) if d[12] or d[13] else xy_d
    xy = target.copy()
    h = 1e-7
    ex, ey = np.array([h, 0.0]), np.array([0.0, h])
    for _ in range(iterations):
        f = _lens_full(xy, d) - target
        jx = (_lens_full(xy + ex, d) - _lens_full(xy - ex, d)) / (2 * h)  # d(x'', y'')/dx
        jy = (_lens_full(xy + ey, d) - _lens_full(xy - ey, d)) / (2 * h)  # d(x'', y'')/dy
        det = jx[..., 0] * jy[..., 1] - jy[..., 0] * jx[..., 1]
        dx = (jy[..., 1] * f[..., 0] - jy[..., 0] * f[..., 1]) / det
        dy = (-jx[..., 1] * f[..., 0] + jx[..., 0] * f[..., 1]) / det
        xy = np.stack([xy[..., 0] - dx, xy[..., 1] - dy], axis=-1)
        if np.nanmax(np.abs(dx) + np.abs(dy), initial=0.0) < tol:
            break
    return xy


def distort(xy: np.ndarray, dist) -> np.ndarray:
    """Apply lens distortion to normalised points ``(..., 2)``, Eq. (2.12)-(2.16).

    ``x_d = x(1 + k1 r^2 + k2 r^4 + k3 r^6) + 2 p1 x y + p2 (r^2 + 2 x^2)`` and likewise for y;
    with OpenCV's rational, thin-prism and tilt terms when ``dist`` has them (module docstring).

    Parameters
    ----------
    xy : (..., 2) ndarray
        Undistorted normalised image coordinates ``(X/Z, Y/Z)`` (unitless).
    dist : array_like or None
        Up to 14 distortion coefficients in OpenCV's order (``k1 k2 p1 p2 k3 ...``; tilt angles
        in rad); missing ones are zero, ``None`` means no distortion.

    Returns
    -------
    (..., 2) ndarray (float)
        Distorted normalised coordinates ``(x_d, y_d)``.
    """
    d = as_coeffs(dist)
    if d.size > 5:
        return _distort_full(xy, d)
    k1, k2, p1, p2, k3 = d
    x, y = xy[..., 0], xy[..., 1]
    r2 = x * x + y * y
    radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
    xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
    yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
    return np.stack([xd, yd], axis=-1)


def undistort(xy_d: np.ndarray, dist, iterations: int = 30, tol: float = 1e-14) -> np.ndarray:
    """Invert :func:`distort` by Newton iteration on normalised points (``dist`` of up to 14
    coefficients, OpenCV's order).

    Converges to ~1e-15 in a handful of steps for realistic lenses (|k1| < 1); returns the
    undistorted normalised points with the same shape as ``xy_d``.

    Parameters
    ----------
    xy_d : (..., 2) array_like
        Distorted normalised image coordinates (unitless).
    dist : array_like or None
        Up to 14 distortion coefficients in OpenCV's order, as in :func:`distort`.
    iterations : int
        Maximum number of Newton steps.
    tol : float
        Stop once the largest step ``|dx| + |dy|`` (normalised units) falls below ``tol``.

    Returns
    -------
    (..., 2) ndarray (float)
        Normalised points ``xy`` with ``distort(xy, dist) ~= xy_d``; a copy of ``xy_d`` when
        every coefficient is zero.

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
    if d.size > 5:
        return _undistort_full(xy_d, d, iterations, tol)
    k1, k2, p1, p2, k3 = d
    if not xy_d.ndim or xy_d.shape[-1] != 2:
        raise ValueError(f"undistort: points of shape (..., 2) expected, got shape {xy_d.shape}")
    from ._undistort_kernel import undistort5  # compiled Newton steps (the NumPy loop: tests' reference)

    flat = np.ascontiguousarray(xy_d).reshape(-1, 2)
    out = undistort5(flat, k1, k2, p1, p2, k3, int(iterations), float(tol), np.empty_like(flat))
    return out.reshape(xy_d.shape)
