"""The projector "captures" board corners through Gray code and local homographies (Moreno & Taubin 2012).

A Gray-code capture decodes to a projector column ``u_p`` and row ``v_p`` per camera pixel
(:mod:`fringe3d.decode.methods.code_only`: the stripe centre), quantised to the code's stripe.
A board corner lies between pixels, so instead of sampling the maps at it (the phase route,
Eq. 2.30-2.31 in :mod:`.phase_mapping`), for each corner the decoded pixels of a square
window around it (47 x 47 camera pixels by default) give a camera -> projector homography
``H``, fitted robustly (``cv2.findHomography`` with RANSAC, then least squares on the
inliers; a plane seen by two pinhole devices maps by a homography), and the corner's
projector position is ``H`` applied to the camera corner. The fit averages the
quantisation of thousands of pixels and ignores the wrongly decoded ones at stripe edges.

D. Moreno and G. Taubin, "Simple, accurate, and robust projector-camera calibration",
3DIMPVT 2012.
"""
from __future__ import annotations

import cv2
import numpy as np

from fringe3d.calibrate.phase_mapping import FringeDirection, projector_maps

#: Default window side (camera px) around each corner, as in Moreno & Taubin's software.
DEFAULT_WINDOW = 47


def corner_homography_points(up: np.ndarray, vp: np.ndarray, uv: np.ndarray, window: int = DEFAULT_WINDOW,
                             min_share: float = 0.25, ransac_px: float = 2.0) -> np.ndarray:
    """Projector pixels ``(N, 2)`` of camera points ``uv (N, 2)`` through local homographies.

    Parameters
    ----------
    up, vp : (H, W) float
        Decoded projector column and row per camera pixel (NaN = not decoded).
    uv : (N, 2) float
        Camera points ``(u, v)`` (px); NaN rows stay NaN.
    window : int
        Side (camera px) of the square window centred on each point.
    min_share : float
        Least share of the window's pixels that must be decoded; fewer gives a NaN row.
    ransac_px : float
        RANSAC inlier threshold (projector px).

    Returns
    -------
    (N, 2) float64 projector ``(u_p, v_p)``; NaN where the window is mostly undecoded or the
    fit failed.
    """
    up = np.asarray(up, np.float64)
    vp = np.asarray(vp, np.float64)
    if up.shape != vp.shape or up.ndim != 2:
        raise ValueError(f"projector maps must be two (H, W) arrays of one shape, got {up.shape} and {vp.shape}")
    if int(window) < 5:
        raise ValueError(f"homography window must be at least 5 camera px, got {window}")
    h, w = up.shape
    half = int(window) // 2
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    out = np.full((len(uv), 2), np.nan)
    need = max(8, int(np.ceil(min_share * (2 * half + 1) ** 2)))
    for k, (u, v) in enumerate(uv):
        if not (np.isfinite(u) and np.isfinite(v)):
            continue
        cu, cv = int(round(u)), int(round(v))
        u0, u1, v0, v1 = max(cu - half, 0), min(cu + half, w - 1), max(cv - half, 0), min(cv + half, h - 1)
        if u1 < u0 or v1 < v0:
            continue
        pu, pv = up[v0:v1 + 1, u0:u1 + 1], vp[v0:v1 + 1, u0:u1 + 1]
        ok = np.isfinite(pu) & np.isfinite(pv)
        if ok.sum() < need:
            continue
        rr, cc = np.nonzero(ok)
        # centred camera coordinates keep the fit well conditioned
        src = np.stack([cc + u0 - u, rr + v0 - v], -1).astype(np.float64)
        dst = np.stack([pu[ok], pv[ok]], -1)
        H, _ = cv2.findHomography(src, dst, cv2.RANSAC, float(ransac_px), maxIters=2000, confidence=0.999)
        if H is None or not np.all(np.isfinite(H)) or abs(H[2, 2]) < 1e-12:
            continue
        out[k] = H[:2, 2] / H[2, 2]  # the point itself is the origin of src
    return out


def code_projector_points(directions: list[FringeDirection], uv: np.ndarray, window: int = DEFAULT_WINDOW,
                          **kw) -> np.ndarray:
    """Projector pixels of camera points ``uv (N, 2)`` from decoded Gray-code directions (any two
    non-parallel fringe angles, :func:`fringe3d.calibrate.phase_mapping.projector_maps`) by
    :func:`corner_homography_points`. Returns ``(N, 2)`` float64, NaN rows where not found.

    Parameters
    ----------
    directions : list of FringeDirection
        Two or more decoded fringe directions of non-parallel angles (absolute phase, rad;
        angle, rad; period, projector px).
    uv : (N, 2) float
        Camera points ``(u, v)``, pixels.
    window : int
        Side of the square homography window, camera px (>= 5).
    **kw
        ``min_share`` and ``ransac_px`` of :func:`corner_homography_points`.

    Returns
    -------
    (N, 2) ndarray (float64)
        Projector ``(u_p, v_p)``, pixels; NaN rows where not found.
    """
    up, vp = projector_maps(directions)
    return corner_homography_points(up, vp, uv, window, **kw)
