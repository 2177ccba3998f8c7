"""Least-squares shape fits for evaluating 3D measurements: plane, sphere, 3D circle.

Each fit accepts an organized point map ``(H, W, 3)`` (NaN = invalid, optional ``mask``) or an
``(N, 3)`` point list, in mm, and returns a result with the parameters, the RMS of the
geometric residuals, the residuals themselves and, for organized input, a residual map
``(H, W)`` (NaN where no point). The dissertation reports accuracy exactly this way: RMS of the
difference between the measured points and the fitted ideal shape (sphere RMS, plane RMS).

* Plane: total least squares (SVD of the centred points); residual = signed distance.
* Sphere: algebraic (linear) initialisation, then geometric Levenberg-Marquardt on
  ``|p - c| - r`` (``scipy.optimize.least_squares`` with the analytic Jacobian
  ``[-(p - c)/|p - c|, -1]``); residual = radial distance. :func:`sphere_residuals` gives the
  radial residuals of the algebraic fit alone (one linear solve, used to classify shapes).
* Circle in 3D: plane fit, then an algebraic + geometric LM circle fit in that plane;
  residual = in-plane radial distance (the out-of-plane part is the plane's residual).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
from scipy.ndimage import binary_erosion
from scipy.optimize import least_squares


@dataclass
class FitPoints:
    """Valid points of a fit input: ``xyz (N, 3)`` float64, and where they came from
    (``index``: flat indices into an organized map of ``shape``, or None for a list)."""

    xyz: np.ndarray
    shape: tuple | None = None
    index: np.ndarray | None = None

    def to_map(self, values: np.ndarray) -> np.ndarray | None:
        """Scatter per-point ``values (N,)`` back into an ``(H, W)`` float32 map (NaN elsewhere)."""
        if self.shape is None:
            return None
        out = np.full(int(np.prod(self.shape)), np.nan, np.float32)
        out[self.index] = values
        return out.reshape(self.shape)


def collect_points(points, mask=None, minimum: int = 1, what: str = "fit") -> FitPoints:
    """Validate and gather the finite points of ``points`` ((H, W, 3) or (N, 3)) under ``mask``.

    Raises ValueError for a wrong shape, a mask of a different size, or fewer than ``minimum``
    valid points (e.g. an empty mask).
    """
    P = np.asarray(points, dtype=np.float64)
    if P.ndim < 2 or P.shape[-1] != 3:
        raise ValueError(f"{what}: expected points of shape (H, W, 3) or (N, 3) in mm, got {P.shape}")
    organized = P.ndim == 3
    flat = P.reshape(-1, 3)
    valid = np.all(np.isfinite(flat), axis=1)
    if mask is not None:
        m = np.asarray(mask, bool)
        if m.shape != P.shape[:-1]:
            raise ValueError(f"{what}: mask has shape {m.shape} but the points are {P.shape[:-1]}; "
                             "expected one mask value per point")
        valid &= m.ravel()
    n = int(valid.sum())
    if n < minimum:
        raise ValueError(f"{what}: {n} valid points under the mask, need at least {minimum} "
                         "(is the mask empty or the point map all NaN?)")
    idx = np.flatnonzero(valid)
    return FitPoints(flat[idx], P.shape[:-1] if organized else None, idx if organized else None)


def _rms(r: np.ndarray) -> float:
    return float(np.sqrt(np.mean(r * r)))


# ----------------------------------------------------------------------------- plane
@dataclass
class PlaneFit:
    """Plane ``normal . x = offset`` (unit normal, mm).

    Attributes: ``normal (3,)`` (oriented towards -z, i.e. facing a camera at the origin when
    possible), ``offset`` (mm), ``centroid (3,)``, ``rms`` (mm), ``residuals (N,)`` signed
    distances (mm), ``residual_map (H, W)`` or None, ``n_points``.
    """

    normal: np.ndarray
    offset: float
    centroid: np.ndarray
    rms: float
    residuals: np.ndarray
    residual_map: np.ndarray | None = None
    n_points: int = 0

    def distance(self, xyz) -> np.ndarray:
        """Signed distances of points ``(..., 3)`` to the plane (mm)."""
        return np.asarray(xyz, float) @ self.normal - self.offset


def fit_plane(points, mask=None) -> PlaneFit:
    """Total-least-squares plane through the valid points (SVD of the centred cloud).

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) array_like
        Organized point map or point list, mm; points with a NaN coordinate are ignored.
    mask : (H, W) or (N,) bool array, optional
        Points to use (one value per point); default every finite point.

    Returns
    -------
    PlaneFit
        Unit normal (towards -z), offset, centroid, RMS and signed residuals (mm); a residual
        map for organized input. Raises ValueError for fewer than 3 valid or collinear points.

    Examples
    --------
    >>> v, u = np.mgrid[0:4, 0:5].astype(float)
    >>> fit = fit_plane(np.dstack([u, v, 300.0 + 0.5 * u]))
    >>> round(fit.rms, 9), fit.n_points
    (0.0, 20)
    """
    fp = collect_points(points, mask, 3, "plane fit")
    c = fp.xyz.mean(axis=0)
    _, sv, vt = np.linalg.svd(fp.xyz - c, full_matrices=False)
    if sv[1] <= 1e-12 * max(sv[0], 1e-300):
        raise ValueError("plane fit: the points are collinear (or identical); a plane needs a 2D spread of points")
    n = vt[2]
    if n[2] > 0:
        n = -n
    r = (fp.xyz - c) @ n
    return PlaneFit(n, float(c @ n), c, _rms(r), r, fp.to_map(r), len(r))


# ----------------------------------------------------------------------------- sphere
@dataclass
class SphereFit:
    """Sphere: ``center (3,)`` mm, ``radius`` mm, ``rms`` of radial residuals (mm),
    ``residuals (N,)`` = ``|p - c| - r``, ``residual_map (H, W)`` or None, ``n_points``,
    ``algebraic`` the linear initial estimate ``(center, radius)``."""

    center: np.ndarray
    radius: float
    rms: float
    residuals: np.ndarray
    residual_map: np.ndarray | None = None
    n_points: int = 0
    algebraic: tuple = field(default=None, repr=False)

    @property
    def diameter(self) -> float:
        return 2.0 * self.radius


def algebraic_fit(p: np.ndarray, what: str) -> tuple[np.ndarray, float]:
    """Linear (Kasa-type) circle/sphere fit in any dimension: ``|p|^2 = 2 c.p + (r^2 - |c|^2)``
    in least squares. ``p`` (N, D); returns ``(center (D,), radius)``; ``what`` names the shape
    in the error raised when the points determine none."""
    d = p.shape[1]
    A = np.hstack([2 * p, np.ones((len(p), 1))])
    b = np.sum(p * p, axis=1)
    sol, *_ = np.linalg.lstsq(A, b, rcond=None)
    c = sol[:d]
    r2 = sol[d] + c @ c
    if not r2 > 0:
        raise ValueError(f"{what} fit: the points do not determine a {what} (degenerate algebraic fit)")
    return c, float(np.sqrt(r2))


def sphere_algebraic(xyz: np.ndarray) -> tuple[np.ndarray, float]:
    """Linear sphere fit (:func:`algebraic_fit` in 3D)."""
    return algebraic_fit(xyz, "sphere")


def sphere_algebraic_rms(xyz: np.ndarray) -> tuple[np.ndarray, float, float]:
    """Algebraic sphere and the RMS of its geometric residuals, without iterating.

    Parameters
    ----------
    xyz : (N, 3) float, mm

    Returns
    -------
    ``(center (3,), radius, rms)`` in mm, with ``rms = sqrt(mean((|p - c| - r)^2))`` for the
    Kasa solution of ``|p|^2 = 2 c.p + (r^2 - |c|^2)`` (exact on noise-free sphere points; biased
    by at most O(sigma^2 / r) with noise, enough to tell a sphere from a plane).
    """
    o = xyz.mean(axis=0)
    c, r = algebraic_fit(xyz - o, "sphere")
    resid = np.linalg.norm(xyz - o - c, axis=1) - r
    return c + o, r, _rms(resid)


def fit_sphere(points, mask=None, radius: float | None = None) -> SphereFit:
    """Geometric least-squares sphere (Levenberg-Marquardt from the algebraic fit).

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) float, mm
    mask : bool map, optional
    radius : float, optional
        Fix the radius (mm) and fit only the centre (e.g. VDI/VDE sphere spacing with a
        calibrated sphere).

    Returns
    -------
    SphereFit
        Centre and radius (mm), RMS and radial residuals ``|p - c| - r`` (mm), a residual map
        for organized input and the algebraic initial estimate. Needs at least 4 valid points.

    Examples
    --------
    >>> rng = np.random.default_rng(0)
    >>> d = rng.normal(size=(200, 3))
    >>> xyz = [1.0, 2.0, 300.0] + 10.0 * d / np.linalg.norm(d, axis=1, keepdims=True)
    >>> fit = fit_sphere(xyz)
    >>> round(fit.radius, 6), np.round(fit.center, 6).tolist()
    (10.0, [1.0, 2.0, 300.0])
    """
    fp = collect_points(points, mask, 4, "sphere fit")
    xyz = fp.xyz
    c0, r0 = sphere_algebraic(xyz)
    # centre the cloud: better conditioned normal equations, same solution
    o = xyz.mean(axis=0)
    q = xyz - o
    if radius is None:
        def res(p):
            return np.linalg.norm(q - p[:3], axis=1) - p[3]

        def jac(p):
            # d(|q - c| - r)/dc = -(q - c)/|q - c|, d/dr = -1 (analytic: one pass per iteration)
            d = q - p[:3]
            u = d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]
            return np.hstack([-u, -np.ones((len(q), 1))])

        sol = least_squares(res, np.r_[c0 - o, r0], jac=jac, method="lm", xtol=1e-14, ftol=1e-14)
        c, r = sol.x[:3] + o, float(sol.x[3])
    else:
        if not radius > 0:
            raise ValueError(f"sphere fit: a fixed radius must be positive (mm), got {radius}")

        def res(p):
            return np.linalg.norm(q - p, axis=1) - radius

        def jac(p):
            d = q - p
            return -d / np.maximum(np.linalg.norm(d, axis=1), 1e-300)[:, None]

        sol = least_squares(res, c0 - o, jac=jac, method="lm", xtol=1e-14, ftol=1e-14)
        c, r = sol.x + o, float(radius)
    resid = np.linalg.norm(xyz - c, axis=1) - r
    return SphereFit(c, abs(r), _rms(resid), resid, fp.to_map(resid), len(resid), (c0, r0))


# ----------------------------------------------------------------------------- circle
@dataclass
class CircleFit:
    """A circle in 3D: ``center (3,)``, ``radius`` (mm), ``normal (3,)`` of its plane,
    ``rms`` of the in-plane radial residuals (mm), ``residuals (N,)``, ``plane_rms`` (mm,
    out-of-plane scatter), ``residual_map`` or None, ``n_points``, ``axes (2, 3)`` the in-plane
    basis used for 2D coordinates."""

    center: np.ndarray
    radius: float
    normal: np.ndarray
    rms: float
    residuals: np.ndarray
    plane_rms: float
    residual_map: np.ndarray | None = None
    n_points: int = 0
    axes: np.ndarray | None = field(default=None, repr=False)


def circle_2d(xy: np.ndarray) -> tuple[np.ndarray, float]:
    """Geometric 2D circle fit (algebraic init + LM): returns ``(center (2,), radius)``."""
    c0, r0 = algebraic_fit(xy, "circle")

    def res(p):
        return np.linalg.norm(xy - p[:2], axis=1) - p[2]

    s = least_squares(res, np.r_[c0, r0], method="lm", xtol=1e-14, ftol=1e-14)
    return s.x[:2], float(abs(s.x[2]))


def fit_circle(points, mask=None, normal=None) -> CircleFit:
    """3D circle: best plane (or the given plane ``normal``), then a geometric circle fit of the
    points projected into it. Use for cross sections of a sphere (a row or column of an
    organized map lies in a plane through the camera centre).

    Parameters
    ----------
    points : (H, W, 3) or (N, 3) array_like
        Organized point map or point list, mm; points with a NaN coordinate are ignored.
    mask : (H, W) or (N,) bool array, optional
        Points to use (one value per point); default every finite point.
    normal : (3,) array_like, optional
        Normal of the circle's plane (normalised here); default the normal of :func:`fit_plane`.

    Returns
    -------
    CircleFit
        Centre (3,) and radius (mm), the plane normal, RMS and in-plane radial residuals (mm),
        the out-of-plane RMS ``plane_rms`` (mm, about the points' centroid), a residual map for
        organized input and the in-plane axes. Needs at least 3 valid points.
    """
    fp = collect_points(points, mask, 3, "circle fit")
    xyz = fp.xyz
    c = xyz.mean(axis=0)
    if normal is None:
        pl = fit_plane(xyz)
        n = pl.normal
    else:
        n = np.asarray(normal, float)
        n = n / np.linalg.norm(n)
    a1 = np.cross(n, [1.0, 0, 0] if abs(n[0]) < 0.9 else [0, 1.0, 0])
    a1 /= np.linalg.norm(a1)
    a2 = np.cross(n, a1)
    d = xyz - c
    xy = np.stack([d @ a1, d @ a2], axis=1)
    c2, r = circle_2d(xy)
    centre = c + c2[0] * a1 + c2[1] * a2
    resid = np.linalg.norm(xy - c2, axis=1) - r
    out_of_plane = d @ n
    return CircleFit(centre, r, n, _rms(resid), resid, _rms(out_of_plane), fp.to_map(resid), len(resid),
                     np.stack([a1, a2]))


def inner_mask(mask: np.ndarray, border: int = 2) -> np.ndarray:
    """``mask`` eroded by ``border`` pixels (drops silhouette pixels that mix object and background).

    Parameters
    ----------
    mask : (H, W) array_like of bool
        Pixels of an object.
    border : int
        Erosion iterations (3x3 cross structuring element), pixels; 0 or less returns the mask.

    Returns
    -------
    (H, W) ndarray of bool
        The eroded mask.

    Examples
    --------
    >>> inner_mask(np.ones((5, 5), bool), border=1).sum()
    np.int64(9)
    """
    return binary_erosion(np.asarray(mask, bool), iterations=border) if border > 0 else np.asarray(mask, bool)


def keep_smallest(residuals: np.ndarray, share: float) -> np.ndarray:
    """Sorted indices of the residuals kept after dropping the ``share`` (0..1) of them with the
    largest ``|r|`` (``floor(share * N)`` points).

    >>> keep_smallest(np.array([0.1, -3.0, 0.2, 0.0]), 0.25).tolist()
    [0, 2, 3]
    """
    r = np.asarray(residuals, float)
    n_drop = int(np.floor(share * r.size))
    return np.sort(np.argsort(np.abs(r))[: r.size - n_drop])


def fit_residuals(fit, xyz: np.ndarray) -> np.ndarray:
    """Residuals of points ``xyz (N, 3)`` against a :class:`PlaneFit` (signed distance) or a
    :class:`SphereFit` (``|p - c| - r``), mm."""
    if isinstance(fit, SphereFit):
        return np.linalg.norm(xyz - fit.center, axis=1) - fit.radius
    return fit.distance(xyz)


def robust_fit(fit_fn, pts: np.ndarray, mask: np.ndarray | None, k: float = 5.0, passes: int = 2, *,
               drop_share: float | None = None):
    """Fit (:func:`fit_sphere` or :func:`fit_plane`) after discarding gross outliers.

    Parameters
    ----------
    fit_fn : callable ``(points, mask) -> fit`` with ``residuals`` (and ``residual_map``)
    pts : (H, W, 3) or (N, 3) float, mm
    mask : bool map or None (every finite point)
    k, passes : default mode: points whose residual from the previous fit is farther than ``k``
        robust sigmas from the median, ``|r - med(r)| > k * 1.4826 * MAD``, are dropped and the
        model refitted, up to ``passes`` times (isolated fringe-order errors); each pass judges
        all candidate points again.
    drop_share : float, optional
        Instead, fit once, drop this share of the points with the largest ``|residual|``
        (:func:`keep_smallest`) and fit once more (the outlier rule of VDI/VDE 2634-2);
        0 keeps the first fit.

    Returns
    -------
    ``(fit, used_mask, dropped_fraction)``
    """
    if drop_share is not None:
        fit = fit_fn(pts, mask)
        used = np.all(np.isfinite(pts), -1)
        if mask is not None:
            used = used & np.asarray(mask, bool)
        n0 = int(used.sum())
        if drop_share > 0:
            keep = np.zeros(used.size, bool)
            keep[np.flatnonzero(used)[keep_smallest(fit.residuals, drop_share)]] = True
            used = keep.reshape(used.shape)
            fit = fit_fn(pts, used)
        return fit, used, 1.0 - used.sum() / max(n0, 1)
    first = np.all(np.isfinite(pts), -1)
    if mask is not None:
        first = first & np.asarray(mask, bool)
    n0 = int(first.sum())
    fit = fit_fn(pts, first)
    used = first
    xyz = np.asarray(pts, np.float64)[first]
    for _ in range(passes):
        # every candidate point is judged against the latest fit, so a point dropped while gross
        # outliers still tilted the fit comes back once they are gone
        res = fit_residuals(fit, xyz)
        med = np.median(res[used[first]])
        mad = np.median(np.abs(res[used[first]] - med))
        ok = np.abs(res - med) <= k * 1.4826 * max(mad, 1e-12)
        keep = np.zeros(first.shape, bool)
        keep[first] = ok
        if np.array_equal(keep, used):
            break
        used = keep
        fit = fit_fn(pts, used)
    return fit, used, 1.0 - used.sum() / max(n0, 1)
