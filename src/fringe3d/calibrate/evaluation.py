"""Measuring test objects with a (calibrated) rig in simulation: render, decode, map phase to
projector coordinates, triangulate. Used by the calibration experiments to judge a
calibration by what it measures (sphere, plane, board diagonals, stage steps)."""
from __future__ import annotations

import numpy as np

from .phase_mapping import FringeDirection, projector_maps


def directions_of(decoded, patterns) -> list[FringeDirection]:
    """The decoder's per-direction maps as :class:`FringeDirection` (plan order)."""
    return [FringeDirection(phase=np.asarray(decoded.phase[p.direction]), angle=float(decoded.angle[p.direction]),
                            period=float(decoded.period[p.direction]),
                            modulation=np.asarray(decoded.modulation[p.direction]),
                            mask=np.asarray(decoded.mask[p.direction])) for p in patterns.plans]


def render_and_decode(scene, rig, patterns, settings):
    """Render ``scene`` through the true ``rig`` and decode: returns (frames, truth, directions)."""
    from fringe3d.decode import decode
    from fringe3d.sim import render
    frames, truth = render(scene, rig, patterns, settings, progress=False)
    dec = decode(frames, patterns)
    return frames, truth, directions_of(dec, patterns)


def measure_points(rig, directions: list[FringeDirection]) -> np.ndarray:
    """(H, W, 3) float64 points (mm) from a calibrated rig and decoded directions: the two
    projector coordinates (any two fringe angles, Eq. 2.30-2.34) and least-squares
    triangulation (``reconstruct.triangulate``: Eq. 2.37, and Eq. 3.3-3.4 for telecentric rigs;
    ``calibrate.telecentric.triangulate_telecentric`` is the sub-pixel point version)."""
    up, vp = (np.ascontiguousarray(a) for a in projector_maps(directions))
    from fringe3d.reconstruct.triangulate import triangulate
    return np.asarray(triangulate(rig, up=up, vp=vp), np.float64)


def inner_mask(mask: np.ndarray, border: int = 2) -> np.ndarray:
    """``mask`` eroded by ``border`` pixels (drops silhouette pixels that mix object and background)."""
    from scipy.ndimage import binary_erosion
    return binary_erosion(np.asarray(mask, bool), iterations=border) if border > 0 else np.asarray(mask, bool)


def robust_fit(fit_fn, pts: np.ndarray, mask: np.ndarray, k: float = 5.0, passes: int = 2):
    """Fit (``analyze.fits.fit_sphere`` or ``fit_plane``) after discarding gross outliers
    (isolated fringe-order errors): points whose residual exceeds ``k`` robust sigmas
    (1.4826 MAD) of the previous fit are dropped. Returns ``(fit, used_mask, dropped_fraction)``."""
    used = np.asarray(mask, bool) & np.all(np.isfinite(pts), -1)
    n0 = int(used.sum())
    fit = fit_fn(pts, used)
    for _ in range(passes):
        res = fit.residual_map
        mad = np.nanmedian(np.abs(res[used] - np.nanmedian(res[used])))
        keep = used & (np.abs(res) <= k * 1.4826 * max(mad, 1e-12))
        if keep.sum() == used.sum():
            break
        used = keep
        fit = fit_fn(pts, used)
    return fit, used, 1.0 - used.sum() / max(n0, 1)


def rotation_angle_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle (degrees) of the rotation ``Ra Rb^T`` (robust near zero)."""
    return float(np.degrees(2 * np.arcsin(min(1.0, np.linalg.norm(np.asarray(Ra) - np.asarray(Rb)) / (2 * np.sqrt(2))))))


def compare_to_truth(est, true) -> dict:
    """Calibrated vs true pinhole rig: relative focal-length errors, principal-point errors (px),
    projector translation error (mm, max abs component and norm) and rotation error (deg)."""
    out = {}
    for name in ("camera", "projector"):
        e, t = getattr(est, name), getattr(true, name)
        if not hasattr(e, "K"):
            continue
        out[f"{name}_focal_rel_error"] = float(max(abs(e.K[0, 0] / t.K[0, 0] - 1), abs(e.K[1, 1] / t.K[1, 1] - 1)))
        out[f"{name}_principal_point_error_px"] = float(np.abs(e.K[:2, 2] - t.K[:2, 2]).max())
    if not est.telecentric:
        out["translation_error_mm"] = float(np.abs(est.projector.t - true.projector.t).max())
        out["translation_error_norm_mm"] = float(np.linalg.norm(est.projector.t - true.projector.t))
        out["rotation_error_deg"] = rotation_angle_deg(est.projector.R, true.projector.R)
    return out
