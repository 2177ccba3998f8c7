"""Optimal fringe angle (ch. 2.2.1 (3), Eq. 2.5-2.7) and the matching calibration angles.

A depth change moves a camera pixel's projector correspondence along the epipolar line.
Fringes whose coordinate ``w = v_p cos(alpha) + u_p sin(alpha)`` runs along that line are the
most depth sensitive. Measuring a step-height object and a reference plane with horizontal
(alpha = 0, encodes ``v_p``) and vertical (alpha = pi/2, encodes ``u_p``) fringes gives the
difference maps ``Phi_hd = Phi_ho - Phi_hr`` (2.5) and ``Phi_vd = Phi_vo - Phi_vr`` (2.6); the
step in each, ``dPhi_h`` and ``dPhi_v``, gives ``alpha_opt = arctan(dPhi_v / dPhi_h)`` (2.7).
Calibration then uses the two equally sensitive angles ``alpha_opt -/+ pi/4`` (ch. 2.2.5).
"""
from __future__ import annotations

import numpy as np

from fringe3d.patterns.conventions import projector_coordinates


def _wrap_angle(a: float) -> float:
    """Fringe angles live in [0, pi)."""
    a = float(np.mod(a, np.pi))
    return 0.0 if np.isclose(a, np.pi) else a


def step_regions(diff_h: np.ndarray, diff_v: np.ndarray, valid: np.ndarray | None = None,
                 iterations: int = 20) -> tuple[np.ndarray, np.ndarray]:
    """Split the step-height difference maps into the two step levels (2-means on the
    vector ``(diff_h, diff_v)`` per pixel). Returns ``(low, high)`` bool masks (H, W); the
    "high" cluster is the one with the larger difference magnitude."""
    ok = np.isfinite(diff_h) & np.isfinite(diff_v)
    if valid is not None:
        ok &= valid
    if ok.sum() < 20:
        raise ValueError("step-height difference maps have fewer than 20 valid pixels")
    X = np.stack([diff_h[ok], diff_v[ok]], 1)
    mag = np.hypot(X[:, 0], X[:, 1])
    c = np.array([X[mag <= np.median(mag)].mean(0), X[mag > np.median(mag)].mean(0)]) if np.ptp(mag) > 0 else None
    if c is None:
        raise ValueError("step-height difference maps show no step (flat difference)")
    for _ in range(iterations):
        lab = np.argmin(((X[:, None] - c[None]) ** 2).sum(-1), axis=1)
        if lab.min() == lab.max():
            raise ValueError("step-height difference maps show no step (one cluster)")
        c = np.array([X[lab == 0].mean(0), X[lab == 1].mean(0)])
    hi_lab = int(np.argmax(np.hypot(c[:, 0], c[:, 1])))
    low = np.zeros(diff_h.shape, bool)
    high = np.zeros(diff_h.shape, bool)
    low[ok] = lab != hi_lab
    high[ok] = lab == hi_lab
    return low, high


def optimal_angle(phi_h_obj, phi_h_ref, phi_v_obj, phi_v_ref, period_h: float = 1.0, period_v: float = 1.0,
                  low: np.ndarray | None = None, high: np.ndarray | None = None) -> dict:
    """Optimal fringe angle from step-height and reference-plane phase maps, Eq. (2.5)-(2.7).

    Parameters
    ----------
    phi_h_obj, phi_h_ref, phi_v_obj, phi_v_ref : (H, W) absolute phase (radians), NaN invalid
    period_h, period_v : fringe periods of the two directions (only their ratio matters; with
        equal periods this is exactly Eq. 2.7)
    low, high : optional masks of the two step levels; found by :func:`step_regions` if None

    Returns
    -------
    dict with ``alpha_opt`` (radians in [0, pi)), ``dphi_h``, ``dphi_v`` (radians, medians of
    the high level minus the low level), ``alpha_1 = alpha_opt - pi/4`` and
    ``alpha_2 = alpha_opt + pi/4`` (wrapped to [0, pi)).
    """
    shapes = {np.shape(a) for a in (phi_h_obj, phi_h_ref, phi_v_obj, phi_v_ref)}
    if len(shapes) != 1:
        raise ValueError(f"phase maps have different shapes {sorted(shapes)}")
    d_h = np.asarray(phi_h_obj, float) - np.asarray(phi_h_ref, float)   # Eq. (2.5)
    d_v = np.asarray(phi_v_obj, float) - np.asarray(phi_v_ref, float)   # Eq. (2.6)
    if low is None or high is None:
        low, high = step_regions(d_h, d_v)
    dh = float(np.nanmedian(d_h[high]) - np.nanmedian(d_h[low])) * period_h
    dv = float(np.nanmedian(d_v[high]) - np.nanmedian(d_v[low])) * period_v
    if not (np.isfinite(dh) and np.isfinite(dv)) or (dh == 0 and dv == 0):
        raise ValueError("the step is not visible in the phase difference maps")
    alpha = _wrap_angle(np.arctan2(dv, dh))  # Eq. (2.7), direction-agnostic (fringe angles mod pi)
    return {"alpha_opt": alpha, "dphi_h": dh / period_h, "dphi_v": dv / period_v,
            "alpha_1": _wrap_angle(alpha - np.pi / 4), "alpha_2": _wrap_angle(alpha + np.pi / 4)}


def epipolar_angle(rig, point, depth_step: float = 1.0) -> float:
    """The true optimal fringe angle of a pinhole rig at a world point (radians, [0, pi)):
    the direction in which the projector correspondence of the camera pixel seeing ``point``
    moves when depth changes along that pixel's ray.

    Parameters
    ----------
    rig : Rig
        A pinhole rig (world frame, mm).
    point : (3,) array_like
        World point, mm.
    depth_step : float
        Step along the camera ray used for the finite difference, mm.

    Returns
    -------
    float
        The fringe angle, radians in [0, pi).
    """
    X = np.asarray(point, float)
    ray = X - rig.camera.center
    ray = ray / np.linalg.norm(ray)
    p0 = rig.projector.project(X)
    p1 = rig.projector.project(X + depth_step * ray)
    du, dv = p1 - p0
    return _wrap_angle(np.arctan2(du, dv))


def rotate_axes(uv_rot: np.ndarray, alpha_opt: float) -> np.ndarray:
    """Rotate projector coordinates measured along the fringe axes ``alpha_opt -/+ pi/4`` back
    to pixel axes, Eq. (2.32)-(2.34).

    ``uv_rot (N, 2)`` holds ``(w_2, w_1)`` with ``w_k = v_p cos(alpha_k) + u_p sin(alpha_k)``
    for ``alpha_1 = alpha_opt - pi/4`` and ``alpha_2 = alpha_opt + pi/4``. Returns ``(N, 2)``
    ``(u_p, v_p)``. (The general solver is ``phase_mapping.projector_points``; this closed
    form is the dissertation's.)
    """
    a1, a2 = alpha_opt - np.pi / 4, alpha_opt + np.pi / 4
    return projector_coordinates(uv_rot, [a2, a1], solver="inv")
