"""Registration of views on Open3D: coarse, fine and global.

- coarse: the stage poses when given, else FPFH features + RANSAC between consecutive views
  (``registration_ransac_based_on_feature_matching``), chained;
- fine: point-to-plane ICP with a Tukey robust kernel at three shrinking correspondence
  distances, on every pair of views at most ``reach`` apart (cyclically);
- global: pose-graph optimisation (Levenberg–Marquardt, ``global_optimization``) over all views
  with view 0 fixed.

Per-point σ enters twice: points with σ above 3× the view's median are left out of registration
and the Tukey scale at the last ICP stage is at least 3× the median σ.
Conventions: ``P_i`` maps view ``i`` (its camera frame, mm) into the model frame (view 0's);
a pair transform ``T_ij`` maps view ``i`` onto view ``j`` (``P_i = P_j T_ij``).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree

from .views import View

reg = o3d.pipelines.registration


@dataclass
class Registration:
    """Result of :func:`register_views`: poses (V, 4, 4) view → model, per view residual RMS (mm,
    point-to-plane to the other views), 1σ rotation (mrad) and translation (µm) uncertainty of
    each pose from the summed ICP information matrices, and the graph's edges."""

    poses: np.ndarray
    residual_rms_mm: np.ndarray
    rotation_sigma_mrad: np.ndarray
    translation_sigma_um: np.ndarray
    edges: list[dict] = field(default_factory=list)


def cloud(view: View, voxel: float) -> o3d.geometry.PointCloud:
    """``view``'s well-measured points (σ ≤ 3× median) downsampled to ``voxel`` mm, normals
    facing the camera (the view frame's origin)."""
    P = view.points
    s = view.sigma
    if np.isfinite(s).any():
        P = P[~(s > 3 * np.nanmedian(s))]
    pc = o3d.geometry.PointCloud(o3d.utility.Vector3dVector(P))
    pc = pc.voxel_down_sample(voxel)
    pc.estimate_normals(o3d.geometry.KDTreeSearchParamHybrid(radius=3 * voxel, max_nn=30))
    pc.orient_normals_towards_camera_location(np.zeros(3))
    return pc


def global_pair(src, tgt, voxel: float, seed: int = 0) -> np.ndarray:
    """FPFH + RANSAC transform mapping ``src`` onto ``tgt`` (no initial guess needed)."""
    o3d.utility.random.seed(seed)
    param = o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100)
    fs = reg.compute_fpfh_feature(src, param)  # type: ignore[call-arg]  # open3d's stub: indices is optional
    ft = reg.compute_fpfh_feature(tgt, param)  # type: ignore[call-arg]
    d = 1.5 * voxel
    r = reg.registration_ransac_based_on_feature_matching(
        src, tgt, fs, ft, True, d, reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9), reg.CorrespondenceCheckerBasedOnDistance(d)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    return np.asarray(r.transformation)


def icp_pair(src, tgt, init, voxel: float, sigma: float = 0.0):
    """Point-to-plane ICP (Tukey kernel) from ``init`` at distances 3, 1.5, 0.75 voxel:
    ``(T (4, 4), information (6, 6), fitness, inlier RMS mm)``."""
    T = np.asarray(init, float)
    for d in (3 * voxel, 1.5 * voxel, 0.75 * voxel):
        est = reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=max(d, 3 * sigma)))
        r = reg.registration_icp(src, tgt, d, T, est, reg.ICPConvergenceCriteria(max_iteration=40))
        T = np.asarray(r.transformation)
    info = reg.get_information_matrix_from_point_clouds(src, tgt, 0.75 * voxel, T)
    return T, np.asarray(info), float(r.fitness), float(r.inlier_rmse)


def coarse_poses(clouds, voxel: float, seed: int = 0) -> list[np.ndarray]:
    """Free-hand start: chained global registrations of view ``i`` onto view ``i − 1``."""
    P = [np.eye(4)]
    for i in range(1, len(clouds)):
        P.append(P[-1] @ global_pair(clouds[i], clouds[i - 1], voxel, seed + i))
    return P


def _pairs(n: int, reach: int) -> list[tuple[int, int]]:
    out = set()
    for i in range(n):
        for k in range(1, reach + 1):
            j = (i + k) % n
            if j != i:
                out.add((min(i, j), max(i, j)))
    return sorted(out)


def register_views(views: list[View], poses=None, voxel: float = 2.0, reach: int = 2,
                   min_fitness: float = 0.1, seed: int = 0) -> Registration:
    """Register ``views`` (≥ 2). ``poses`` (V, 4, 4) view → model start values (stage), or None
    for free-hand (global feature step); ``voxel`` mm the registration sampling. Pairs up to
    ``reach`` views apart become graph edges (loop closures uncertain) when their ICP fitness
    reaches ``min_fitness``; consecutive views always do."""
    if len(views) < 2:
        raise ValueError(f"registration needs at least 2 views, got {len(views)}")
    clouds = [cloud(v, voxel) for v in views]
    sig = [float(np.nanmedian(v.sigma)) if np.isfinite(v.sigma).any() else 0.0 for v in views]
    P0 = list(poses) if poses is not None else coarse_poses(clouds, voxel, seed)
    graph = reg.PoseGraph()
    for p in P0:
        graph.nodes.append(reg.PoseGraphNode(np.asarray(p, float)))
    edges, infos = [], [np.zeros((6, 6)) for _ in views]
    for i, j in _pairs(len(views), reach):
        init = np.linalg.inv(P0[j]) @ P0[i]
        T, info, fit, rmse = icp_pair(clouds[i], clouds[j], init, voxel, max(sig[i], sig[j]))
        if fit < min_fitness and j != i + 1:  # consecutive views always keep their edge: the graph stays connected
            continue
        graph.edges.append(reg.PoseGraphEdge(i, j, T, info, uncertain=j != i + 1))
        edges.append({"source": i, "target": j, "fitness": fit, "inlier_rms_mm": rmse})
        infos[i] += info
        infos[j] += info
    reg.global_optimization(graph, reg.GlobalOptimizationLevenbergMarquardt(),
                            reg.GlobalOptimizationConvergenceCriteria(),
                            reg.GlobalOptimizationOption(max_correspondence_distance=0.75 * voxel,
                                                         edge_prune_threshold=0.25, reference_node=0))
    P = np.stack([np.asarray(n.pose) for n in graph.nodes])
    res = residuals(clouds, P, 1.5 * voxel)
    rot, tra = pose_sigmas(infos, res)
    return Registration(P, res, rot, tra, edges)


def residuals(clouds, P, dmax: float) -> np.ndarray:
    """Per view: RMS (mm) of point-to-plane distances to the nearest point of the other views
    (pairs closer than ``dmax``) once all are placed by ``P``."""
    placed = []
    for c, p in zip(clouds, P):
        q = o3d.geometry.PointCloud(c)
        q.transform(p)
        placed.append(q)
    out = np.full(len(placed), np.nan)
    for i, c in enumerate(placed):
        others = o3d.geometry.PointCloud()
        for j, o in enumerate(placed):
            if j != i:
                others += o
        Q, N = np.asarray(others.points), np.asarray(others.normals)
        p = np.asarray(c.points)
        dist, idx = cKDTree(Q).query(p, distance_upper_bound=dmax)
        ok = np.isfinite(dist)
        if ok.any():
            d = np.einsum("ij,ij->i", p[ok] - Q[idx[ok]], N[idx[ok]])
            out[i] = float(np.sqrt(np.mean(d ** 2)))
    return out


def pose_sigmas(infos, res) -> tuple[np.ndarray, np.ndarray]:
    """1σ of each pose from ``Σ = s² (Σ_edges Λ)⁻¹`` (Λ Open3D's 6×6 information matrix, order
    rx ry rz tx ty tz; s the view's residual RMS): the largest rotation std (mrad) and
    translation std (µm, at the camera frame's origin)."""
    rot, tra = np.full(len(infos), np.nan), np.full(len(infos), np.nan)
    for i, (L, s) in enumerate(zip(infos, res)):
        if not np.isfinite(s) or np.linalg.matrix_rank(L) < 6:
            continue
        C = s ** 2 * np.linalg.inv(L)
        rot[i] = 1e3 * np.sqrt(np.linalg.eigvalsh(C[:3, :3]).max())
        tra[i] = 1e3 * np.sqrt(np.linalg.eigvalsh(C[3:, 3:]).max())
    return rot, tra
