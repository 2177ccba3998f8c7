"""Figures of a multi-view result against a reference surface (the simulator's truth, or a
reference scan): pose errors, point-to-surface RMS, Hausdorff distance and coverage."""
from __future__ import annotations

import numpy as np
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation


def pose_errors(estimated, true, centre) -> tuple[np.ndarray, np.ndarray]:
    """Per view: rotation error (mrad, angle of ``T_true⁻¹ T_est``) and translation error (µm, how far
    that error moves ``centre`` (3,) mm, the object's centre), after both sets are tied to view 0
    (the model frame is only defined up to one rigid motion; view 0's error is 0 by construction)."""
    T, S = np.asarray(true, float), np.asarray(estimated, float)
    S = T[0] @ np.linalg.inv(S[0]) @ S
    E = np.linalg.inv(T) @ S
    rot = 1e3 * np.linalg.norm(Rotation.from_matrix(E[:, :3, :3]).as_rotvec(), axis=1)
    c = np.asarray(centre, float)
    tra = 1e3 * np.linalg.norm(np.einsum("vij,j->vi", E[:, :3, :3], c) + E[:, :3, 3] - c, axis=1)
    return rot, tra


def surface_distances(points, truth_points, truth_normals) -> np.ndarray:
    """Signed point-to-plane distance (mm) of each of ``points`` (N, 3) to the tangent plane of its
    nearest truth point (a dense sample of the surface with unit normals)."""
    P = np.asarray(points, float)
    _, idx = cKDTree(truth_points).query(P)
    return np.einsum("ij,ij->i", P - truth_points[idx], truth_normals[idx])


def rms(d) -> float:
    return float(np.sqrt(np.mean(np.square(d))))


def hausdorff(a, b) -> float:
    """Symmetric Hausdorff distance (mm) between point sets ``a`` and ``b`` (e.g. mesh vertices and
    the truth sample)."""
    return float(max(cKDTree(b).query(a)[0].max(), cKDTree(a).query(b)[0].max()))


def coverage(points, truth_points, radius: float) -> float:
    """Share of ``truth_points`` (the visible surface) with a measured point within ``radius`` mm."""
    d, _ = cKDTree(np.asarray(points, float)).query(truth_points, distance_upper_bound=radius)
    return float(np.isfinite(d).mean())


def merge_truth_figures(fused_points, poses, true_poses, centre, truth_points, truth_normals,
                        names: list[str]) -> dict:
    """Figures of a merge against the truth: per view (``names``) the pose errors of ``poses``
    (V, 4, 4) against ``true_poses`` (:func:`pose_errors` at ``centre``), the largest of each, the
    fused cloud's point-to-plane RMS to the true surface (``truth_points`` / ``truth_normals``,
    model frame, mm) and the coverage of that surface within twice the fused cloud's median point
    spacing (``coverage_radius_mm``)."""
    P = np.asarray(fused_points, float)
    rot, tra = (np.round(e, 9) for e in pose_errors(poses, true_poses, centre))  # view 0: 0, not 1e-30
    spacing = float(np.median(cKDTree(P).query(P, k=2)[0][:, 1])) if len(P) > 1 else float("nan")
    radius = 2.0 * spacing
    return {"views": [{"name": n, "rotation_error_mrad": float(r), "translation_error_um": float(t)}
                      for n, r, t in zip(names, rot, tra)],
            "rotation_error_max_mrad": float(rot.max()), "translation_error_max_um": float(tra.max()),
            "fused_rms_mm": rms(surface_distances(P, truth_points, truth_normals)),
            "coverage": coverage(P, truth_points, radius), "coverage_radius_mm": radius,
            "truth_points": int(len(truth_points))}
