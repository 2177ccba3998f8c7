"""Registration of views on Open3D: coarse, fine and global.

- coarse: the stage poses when given, else FPFH features + RANSAC between consecutive views
  (``registration_ransac_based_on_feature_matching``, several runs each refined by ICP), chained;
  refused (:class:`AmbiguousRegistration`) when the answer is not unique or fits too little,
  never silently wrong;
- fine: point-to-plane ICP with a Tukey robust kernel at three shrinking correspondence
  distances, on every pair of views at most ``reach`` apart (cyclically);
- global: pose-graph optimisation (Levenberg–Marquardt, ``global_optimization``) over all views
  with view 0 fixed.

Per-point σ enters twice: points with σ above 3× the view's median are left out of registration
and the Tukey scale at the last ICP stage is at least 3× the median σ.
Conventions: ``P_i`` maps view ``i`` (its camera frame, mm) into the model frame (view 0's);
a pair transform ``T_ij`` maps view ``i`` onto view ``j`` (``P_i = P_j T_ij``).

Stage prior. Poses from a stage come with the stage's stated 1σ (``stage_sigma``: rotation
mrad per axis, translation mm per axis at the view's object centre). Then (a) each pair is
registered by :func:`icp_prior_pair`, point-to-plane ICP whose Gauss–Newton steps carry the
stage's information on the pair's relative pose, so a direction the data cannot constrain (a
dumbbell's roll about its bar) stays where the stage put it instead of random-walking (plain
ICP drifts there by ~0.1 rad on such an artefact); (b) the pose graph gets one certain edge
per view to the fixed view 0 carrying the stage pose with the stage's information, i.e. the
prior ``‖log(P_stage⁻¹ P)‖²_Λ``. Edge information is point-to-plane
(:func:`plane_information`), scaled by ``1/s²`` (``s`` the pair's point-to-plane residual RMS,
mm) so they and the prior share units, and moved into the source view's frame, where Open3D's
pose graph measures an edge's error. The per-view pose 1σ comes from the inverse of the pose
graph's Gauss–Newton information at the solution (view 0 fixed): with the prior it is at most the
stage's σ; without it, a direction no data constrains leaves it undefined (NaN).
"""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np
import open3d as o3d
from scipy.spatial import cKDTree
from scipy.spatial.transform import Rotation

from fringe3d.devices.stage import rotation_about

from .views import View

reg = o3d.pipelines.registration


@dataclass
class Registration:
    """Result of :func:`register_views`: poses (V, 4, 4) view → model, per view residual RMS (mm,
    point-to-plane to the other views), 1σ rotation (mrad, largest over directions) and
    translation (µm, at the view's object centre, largest over directions) uncertainty of each
    pose from the pose graph (NaN where the data and prior leave a direction free), and the
    graph's edges."""

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


#: Free-hand global step: RANSAC runs per pair, the least ICP fitness of its answer, how close
#: (share of the best fitness) another answer may come before the pair is ambiguous, and how far
#: apart (rotation rad; centroid shift in voxels) two answers must be to count as different.
GLOBAL_TRIES = 6
GLOBAL_MIN_FITNESS = 0.25
GLOBAL_RIVAL_SHARE = 0.9
GLOBAL_DISTINCT = (np.deg2rad(3.0), 3.0)
#: Most point-to-plane RMS of the best global answer, as a multiple of the target's own
#: neighbour residual (:func:`neighbour_rms`): a correct match pairs points closer than the
#: sampling and stays below it; a surface slid onto another part of the object does not.
GLOBAL_MAX_RESIDUAL = 1.0


class AmbiguousRegistration(ValueError):
    """Free-hand registration (no poses) cannot tell the right relative pose of two views: several
    clearly different poses fit the data about equally well (a symmetric object: a ball bar's
    equal spheres and square bar), or the best fits too little of the data (too little overlap).
    Its message says which pair and why; the remedy is to give the poses (a stage, a robot, a
    calibrated turntable). ``pair`` is ``(source, target)`` view indices, ``candidates`` the
    refined answers ``(T (4, 4), fitness, plane RMS mm)``, best first."""

    def __init__(self, message: str, pair: tuple[int, int], candidates: list):
        super().__init__(message)
        self.pair = pair
        self.candidates = candidates


def _ransac(src, tgt, fs, ft, voxel: float, seed: int) -> np.ndarray:
    o3d.utility.random.seed(seed)
    d = 1.5 * voxel
    r = reg.registration_ransac_based_on_feature_matching(
        src, tgt, fs, ft, True, d, reg.TransformationEstimationPointToPoint(False), 3,
        [reg.CorrespondenceCheckerBasedOnEdgeLength(0.9), reg.CorrespondenceCheckerBasedOnDistance(d)],
        reg.RANSACConvergenceCriteria(100000, 0.999))
    return np.asarray(r.transformation)


def global_candidates(src, tgt, voxel: float, seed: int = 0, tries: int = GLOBAL_TRIES) -> list:
    """``tries`` FPFH + RANSAC answers mapping ``src`` onto ``tgt`` (no initial guess), each refined
    by point-to-plane ICP: ``[(T (4, 4), fitness, plane RMS mm), ...]``, best fitness first."""
    param = o3d.geometry.KDTreeSearchParamHybrid(radius=5 * voxel, max_nn=100)
    fs = reg.compute_fpfh_feature(src, param)  # type: ignore[call-arg]  # open3d's stub: indices is optional
    ft = reg.compute_fpfh_feature(tgt, param)  # type: ignore[call-arg]
    out: list = []
    starts: list = []
    centre = np.asarray(src.points).mean(0)
    for k in range(tries):
        T0 = _ransac(src, tgt, fs, ft, voxel, seed + 7919 * k)
        same = [c for s0, c in zip(starts, out) if not _distinct(T0, s0, centre, 0.5 * voxel)]
        if same:  # the answer of an earlier run: its refinement stands
            out.append(same[0])
        else:
            T, _, fit, _ = icp_pair(src, tgt, T0, voxel)
            out.append((T, fit, plane_rms(src, tgt, T, 0.75 * voxel)))
        starts.append(T0)
    return sorted(out, key=lambda c: -c[1])


def _distinct(A, B, centre, voxel: float) -> bool:
    """Whether rigid ``A`` and ``B`` differ by more than :data:`GLOBAL_DISTINCT` (rotation, or the
    shift of ``centre`` in voxels)."""
    E = np.linalg.inv(B) @ A
    ang = float(np.linalg.norm(Rotation.from_matrix(E[:3, :3]).as_rotvec()))
    shift = float(np.linalg.norm(E[:3, :3] @ centre + E[:3, 3] - centre))
    return ang > GLOBAL_DISTINCT[0] or shift > GLOBAL_DISTINCT[1] * voxel


def neighbour_rms(pc) -> float:
    """RMS (mm) of each point's distance to the tangent plane of its nearest other point in the
    same cloud: how well the surface predicts a point one sample away."""
    P, N = np.asarray(pc.points), np.asarray(pc.normals)
    if len(P) < 2:
        return float("nan")
    _, idx = cKDTree(P).query(P, k=2)
    j = idx[:, 1]
    return float(np.sqrt(np.mean(np.einsum("ij,ij->i", P - P[j], N[j]) ** 2)))


def symmetry_probes(src, tgt, T, voxel: float) -> list:
    """ICP answers from ``T`` turned by 90°, 180° and 270° about each principal axis of ``src``
    (through its centroid): an object symmetric under such a turn (a ball bar, a cylinder, a
    box) fits there as well as at ``T``, whichever answer RANSAC happened to find first. A turned
    start is refined only when it already fits, within 5 % of the cloud's extent (at least 3
    ``voxel``), at least half as many points as ``T`` does (an asymmetric object's turns do not,
    and cost nothing). Returns ``[(T (4, 4), fitness, plane RMS mm), ...]``."""
    P = np.asarray(src.points)
    c = P.mean(0)
    _, axes = np.linalg.eigh(np.cov((P - c).T))
    reach = max(3 * voxel, 0.05 * float(np.ptp(P, axis=0).max()))
    base = reg.evaluate_registration(src, tgt, reach, T).fitness
    out = []
    for a in axes.T:
        for ang in (0.5 * np.pi, np.pi, 1.5 * np.pi):
            start = T @ rotation_about(a, ang, c)
            if reg.evaluate_registration(src, tgt, reach, start).fitness < 0.5 * base:
                continue
            Tk, _, fk, _ = icp_pair(src, tgt, start, voxel)
            out.append((Tk, fk, plane_rms(src, tgt, Tk, 0.75 * voxel)))
    return out


def global_pair(src, tgt, voxel: float, seed: int = 0, pair: tuple[int, int] = (1, 0)) -> np.ndarray:
    """The transform mapping ``src`` onto ``tgt`` from the global step alone (FPFH + RANSAC,
    :data:`GLOBAL_TRIES` runs, each ICP-refined), or :class:`AmbiguousRegistration` when the best
    answer's ICP fitness is below :data:`GLOBAL_MIN_FITNESS` or its residual above
    :data:`GLOBAL_MAX_RESIDUAL` × the target's :func:`neighbour_rms`, or when a clearly different answer
    (of the other RANSAC runs, or of :func:`symmetry_probes`)
    (:data:`GLOBAL_DISTINCT`) reaches :data:`GLOBAL_RIVAL_SHARE` of the best fitness with a
    comparable residual (at most 1.5× the best's): the data cannot say which is right.
    ``pair`` names the views in the message."""
    cands = global_candidates(src, tgt, voxel, seed)
    T, fit, rms_ = cands[0]
    cands = [cands[0], *symmetry_probes(src, tgt, T, voxel), *cands[1:]]
    where = f"views {pair[0]} and {pair[1]}"
    remedy = "give the views' poses (a stage, robot or calibrated turntable) instead of free-hand registration"
    if fit < GLOBAL_MIN_FITNESS:
        raise AmbiguousRegistration(
            f"free-hand registration of {where}: the best global match explains only {100 * fit:.0f} % of the "
            f"points (need >= {100 * GLOBAL_MIN_FITNESS:.0f} %): too little overlap or too little shape to "
            f"trust it; {remedy}, or take views closer together", pair, cands)
    own = neighbour_rms(tgt)
    if not rms_ <= GLOBAL_MAX_RESIDUAL * own:
        raise AmbiguousRegistration(
            f"free-hand registration of {where}: the best global match leaves a point-to-plane residual of "
            f"{rms_:.3f} mm, more than the {own:.3f} mm between the target's own neighbouring samples: the "
            f"surfaces were slid onto each other where they do not overlap; {remedy}, or take views closer "
            "together", pair, cands)
    centre = np.asarray(src.points).mean(0)
    for Tk, fk, rk in cands[1:]:
        if fk >= GLOBAL_RIVAL_SHARE * fit and rk <= 1.5 * rms_ and _distinct(Tk, T, centre, voxel):
            E = np.linalg.inv(T) @ Tk
            ang = np.rad2deg(np.linalg.norm(Rotation.from_matrix(E[:3, :3]).as_rotvec()))
            raise AmbiguousRegistration(
                f"free-hand registration of {where} is ambiguous: two poses {ang:.0f} degrees apart fit "
                f"equally well (fitness {fit:.2f} and {fk:.2f}, residual {rms_:.3f} and {rk:.3f} mm), as on a "
                f"symmetric object (a ball bar's equal spheres and square bar); {remedy}", pair, cands)
    return T


def icp_pair(src, tgt, init, voxel: float, sigma: float = 0.0):
    """Point-to-plane ICP (Tukey kernel) from ``init`` at distances 3, 1.5, 0.75 voxel:
    ``(T (4, 4), information (6, 6), fitness, inlier RMS mm)``; the information is Open3D's
    (unit weight per correspondence, target frame, order rx ry rz tx ty tz)."""
    T = np.asarray(init, float)
    for d in (3 * voxel, 1.5 * voxel, 0.75 * voxel):
        est = reg.TransformationEstimationPointToPlane(reg.TukeyLoss(k=max(d, 3 * sigma)))
        r = reg.registration_icp(src, tgt, d, T, est, reg.ICPConvergenceCriteria(max_iteration=40))
        T = np.asarray(r.transformation)
    info = reg.get_information_matrix_from_point_clouds(src, tgt, 0.75 * voxel, T)
    return T, np.asarray(info), float(r.fitness), float(r.inlier_rmse)


def skew(c) -> np.ndarray:
    """The cross-product matrix ``[c]×`` of a 3-vector (``[c]× w = c × w``)."""
    x, y, z = np.asarray(c, float)
    return np.array([[0.0, -z, y], [z, 0.0, -x], [-y, x, 0.0]])


def adjoint(T) -> np.ndarray:
    """(6, 6) adjoint of a rigid ``T`` for twists ordered (ω, v): ``ξ_a = Ad_T ξ_b`` when
    ``exp(ξ_a) = T exp(ξ_b) T⁻¹``."""
    T = np.asarray(T, float)
    R, p = T[:3, :3], T[:3, 3]
    A = np.zeros((6, 6))
    A[:3, :3] = R
    A[3:, 3:] = R
    A[3:, :3] = skew(p) @ R
    return A


def stage_covariance(sigma_rotation_mrad: float, sigma_translation_mm: float, centre) -> np.ndarray:
    """(6, 6) covariance (rad², mm²; order rx ry rz tx ty tz) of a pose error twist at a frame's
    origin for independent per-axis errors: rotation ``σ_r`` mrad and translation ``σ_t`` mm of
    the point ``centre`` (mm, that frame). The origin moves by ``v₀ = v_c − ω × c``."""
    J = np.eye(6)
    J[3:, :3] = skew(centre)  # v0 = v_c + [c]x w  (= v_c - w x c)
    D = np.diag([(1e-3 * sigma_rotation_mrad) ** 2] * 3 + [sigma_translation_mm ** 2] * 3)
    return J @ D @ J.T


def twist(T) -> np.ndarray:
    """(6,) twist (rotation vector rad, translation mm) of a small rigid ``T``."""
    T = np.asarray(T, float)
    return np.concatenate([Rotation.from_matrix(T[:3, :3]).as_rotvec(), T[:3, 3]])


def from_twist(xi) -> np.ndarray:
    """(4, 4) rigid transform of a twist (first order in translation, exact rotation)."""
    T = np.eye(4)
    T[:3, :3] = Rotation.from_rotvec(np.asarray(xi[:3], float)).as_matrix()
    T[:3, 3] = xi[3:]
    return T


def _matches(p, tree, Q, N, dmax: float):
    """Nearest target point of each placed source point ``p`` within ``dmax``: the placed points,
    their targets' points and normals, and the point-to-plane residuals (mm)."""
    dist, idx = tree.query(p, distance_upper_bound=dmax)
    ok = np.isfinite(dist)
    pp, q, n = p[ok], Q[idx[ok]], N[idx[ok]]
    return pp, n, np.einsum("ij,ij->i", pp - q, n)


def plane_information(src, tgt, T, dmax: float) -> tuple[np.ndarray, float]:
    """Point-to-plane information of ``src`` placed by ``T`` on ``tgt`` (pairs closer than
    ``dmax``): ``(Σ J Jᵀ (6, 6) with J = [p × n, n]`` per match (unit weight, target frame, order
    rx ry rz tx ty tz; a direction along which the surfaces slide gets none, unlike Open3D's
    point-to-point ``get_information_matrix_from_point_clouds``), RMS of the residuals mm (NaN
    when nothing matches))."""
    p = np.asarray(src.points) @ np.asarray(T)[:3, :3].T + np.asarray(T)[:3, 3]
    Q, N = np.asarray(tgt.points), np.asarray(tgt.normals)
    pp, n, r = _matches(p, cKDTree(Q), Q, N, dmax)
    if not len(r):
        return np.zeros((6, 6)), float("nan")
    J = np.hstack([np.cross(pp, n), n])
    return J.T @ J, float(np.sqrt(np.mean(r ** 2)))


def plane_rms(src, tgt, T, dmax: float) -> float:
    """RMS (mm) of point-to-plane distances of ``src`` placed by ``T`` onto ``tgt`` (pairs closer
    than ``dmax``); NaN when none."""
    return plane_information(src, tgt, T, dmax)[1]


def icp_prior_pair(src, tgt, init, voxel: float, sigma: float, prior_cov) -> tuple[np.ndarray, float, float]:
    """Point-to-plane ICP held by a prior: Gauss–Newton on ``Σ w r²/s² + ‖ξ‖²_Λ`` with Tukey
    weights ``w`` (scale max(d, 3σ)) at distances 3, 1.5, 0.75 ``voxel``, ``ξ`` the correction
    from ``init`` (target-frame twist) and ``Λ = prior_cov⁻¹``. ``s`` is the weighted residual
    RMS of the iteration (at least σ/2). A direction the surfaces slide along gets no data and
    stays at ``init``: ICP cannot random-walk along it. Returns ``(T, fitness, inlier RMS mm)``."""
    P = np.asarray(src.points)
    Q, N = np.asarray(tgt.points), np.asarray(tgt.normals)
    tree = cKDTree(Q)
    Lp = np.linalg.inv(prior_cov)
    init = np.asarray(init, float)
    T = init.copy()
    n_ok, r = 0, np.zeros(0)
    for d in (3 * voxel, 1.5 * voxel, 0.75 * voxel):
        k = max(d, 3 * sigma)
        for _ in range(30):
            pp, n, r = _matches(P @ T[:3, :3].T + T[:3, 3], tree, Q, N, d)
            n_ok = len(r)
            if n_ok < 6:
                break
            w = np.where(np.abs(r) < k, (1 - (r / k) ** 2) ** 2, 0.0)
            s2 = max(float(np.sum(w * r ** 2) / max(np.sum(w), 1e-12)), (0.5 * sigma) ** 2, 1e-8)
            J = np.hstack([np.cross(pp, n), n])
            A = J.T @ (w[:, None] * J) / s2 + Lp
            b = -(J.T @ (w * r)) / s2 - Lp @ twist(T @ np.linalg.inv(init))
            delta = np.linalg.solve(A, b)
            T = from_twist(delta) @ T
            if np.linalg.norm(delta[:3]) < 1e-7 and np.linalg.norm(delta[3:]) < 1e-5:
                break
    return T, n_ok / max(len(P), 1), float(np.sqrt(np.mean(r ** 2))) if len(r) else float("nan")


def coarse_poses(clouds, voxel: float, seed: int = 0) -> list[np.ndarray]:
    """Free-hand start: chained global registrations of view ``i`` onto view ``i − 1``
    (:func:`global_pair`; :class:`AmbiguousRegistration` when one is not unique)."""
    P = [np.eye(4)]
    for i in range(1, len(clouds)):
        P.append(P[-1] @ global_pair(clouds[i], clouds[i - 1], voxel, seed + i, pair=(i, i - 1)))
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
                   min_fitness: float = 0.1, seed: int = 0, stage_sigma=None) -> Registration:
    """Register ``views`` (≥ 2).

    Parameters
    ----------
    views : list of View
        The views, each in its camera frame (mm).
    poses : (V, 4, 4) array_like, optional
        View → model start values (a stage); None for free-hand (the global feature step).
    voxel : float
        Registration sampling (mm).
    reach : int
        Pairs up to ``reach`` views apart (cyclically) become graph edges; loop closures are
        uncertain and kept when their ICP fitness reaches ``min_fitness``, consecutive views
        always are.
    min_fitness : float
        Least ICP fitness (share of points matched) of a loop-closure edge.
    seed : int
        Seed of the RANSAC step (free-hand).
    stage_sigma : (float, float), optional
        The stage's stated 1σ of ``poses``: rotation (mrad per axis) and translation (mm per
        axis, at each view's object centre); adds the stage prior (module docstring).

    Returns
    -------
    Registration
        Poses, residuals, pose uncertainty and edges.
    """
    if len(views) < 2:
        raise ValueError(f"registration needs at least 2 views, got {len(views)}")
    if stage_sigma is not None:
        if poses is None:
            raise ValueError("stage_sigma weighs the stage's poses; with poses=None (free-hand) there are none")
        sr, st = (float(x) for x in stage_sigma)
        if not (np.isfinite(sr) and np.isfinite(st) and sr > 0 and st > 0):
            raise ValueError(f"stage_sigma must be two numbers > 0 (mrad, mm), got {stage_sigma}")
    clouds = [cloud(v, voxel) for v in views]
    centres = [np.asarray(c.points).mean(0) for c in clouds]
    sig = [float(np.nanmedian(v.sigma)) if np.isfinite(v.sigma).any() else 0.0 for v in views]
    P0 = [np.asarray(p, float) for p in poses] if poses is not None else coarse_poses(clouds, voxel, seed)
    prior = None if stage_sigma is None else [stage_covariance(sr, st, c) for c in centres]
    graph = reg.PoseGraph()
    for p in P0:
        graph.nodes.append(reg.PoseGraphNode(p))
    edges = []
    for i, j in _pairs(len(views), reach):
        init = np.linalg.inv(P0[j]) @ P0[i]
        if prior is None:
            T, _, fit, rmse = icp_pair(clouds[i], clouds[j], init, voxel, max(sig[i], sig[j]))
        else:  # the pair's relative pose is known to the stage's sigma of both views
            A = adjoint(init)
            T, fit, rmse = icp_prior_pair(clouds[i], clouds[j], init, voxel, max(sig[i], sig[j]),
                                          prior[j] + A @ prior[i] @ A.T)
        if fit < min_fitness and j != i + 1:  # consecutive views always keep their edge: the graph stays connected
            continue
        info, s = plane_information(clouds[i], clouds[j], T, 0.75 * voxel)
        s = max(s, 1e-3) if np.isfinite(s) else voxel
        L = info / s ** 2  # per correspondence 1/s^2: the prior's units
        A = adjoint(T)
        graph.edges.append(reg.PoseGraphEdge(i, j, T, A.T @ L @ A, uncertain=j != i + 1))
        edges.append({"source": i, "target": j, "fitness": fit, "inlier_rms_mm": rmse, "plane_rms_mm": s})
    n_data = len(graph.edges)
    if prior is not None:
        for i in range(1, len(views)):
            graph.edges.append(reg.PoseGraphEdge(i, 0, np.linalg.inv(P0[0]) @ P0[i], np.linalg.inv(prior[i]),
                                                 uncertain=False))
    # Open3D's line process scales with the mean information (5, 5) of all edges: keep it the data edges'
    w = np.array([np.asarray(e.information)[5, 5] for e in graph.edges])
    pref = float(w[:n_data].mean() / w.mean()) if n_data else 1.0
    reg.global_optimization(graph, reg.GlobalOptimizationLevenbergMarquardt(),
                            reg.GlobalOptimizationConvergenceCriteria(),
                            reg.GlobalOptimizationOption(max_correspondence_distance=0.75 * voxel,
                                                         edge_prune_threshold=0.25, preference_loop_closure=pref,
                                                         reference_node=0))
    P = np.stack([np.asarray(n.pose) for n in graph.nodes])
    res = residuals(clouds, P, 1.5 * voxel)
    rot, tra = graph_sigmas(P, [(e.source_node_id, e.target_node_id, np.asarray(e.information))
                                for e in graph.edges], centres)
    return Registration(P, res, rot, tra, edges)


def graph_sigmas(P, edges, centres) -> tuple[np.ndarray, np.ndarray]:
    """Per view 1σ of the poses ``P`` (V, 4, 4) from the pose graph's Gauss–Newton information
    at the solution, view 0 fixed: the largest rotation std (mrad) and the largest translation
    std of the view's object centre ``centres[k]`` (µm). ``edges``: ``(source, target, Λ)``
    with Λ (6, 6) in the source frame's twist (rx ry rz tx ty tz), an edge's error being
    ``ξ_s − Ad(P_t⁻¹ P_s)⁻¹ ξ_t`` for right perturbations ``P_k exp(ξ_k)``. NaN where a direction
    is left free (no data and no prior); view 0 is 0 (the reference)."""
    V = len(P)
    H = np.zeros((6 * V, 6 * V))
    for s, t, L in edges:
        Ad = adjoint(np.linalg.inv(np.linalg.inv(P[t]) @ P[s]))
        J = {s: np.eye(6), t: -Ad}
        for a, Ja in J.items():
            for b, Jb in J.items():
                H[6 * a:6 * a + 6, 6 * b:6 * b + 6] += Ja.T @ L @ Jb
    H = H[6:, 6:]
    rot, tra = np.zeros(V), np.zeros(V)
    if V == 1:
        return rot, tra
    size = max(float(np.mean([np.linalg.norm(c) for c in centres])), 1.0)
    S = np.diag(np.tile([size] * 3 + [1.0] * 3, V - 1))  # rotations in mm at the object's distance
    Hs = np.linalg.inv(S) @ H @ np.linalg.inv(S)
    lam, U = np.linalg.eigh(0.5 * (Hs + Hs.T))
    free = lam <= 1e-10 * max(lam.max(), 1e-300)
    keep = ~free
    C = np.linalg.inv(S) @ (U[:, keep] / lam[keep]) @ U[:, keep].T @ np.linalg.inv(S)
    touched = np.abs(U[:, free]).reshape(V - 1, 6, -1).max(axis=(1, 2)) > 1e-6 if free.any() else np.zeros(V - 1, bool)
    for k in range(1, V):
        if touched[k - 1]:
            rot[k] = tra[k] = np.nan
            continue
        Ck = C[6 * (k - 1):6 * k, 6 * (k - 1):6 * k]
        J = np.hstack([-skew(centres[k]), np.eye(3)])  # v_c = v0 - [c]x w
        rot[k] = 1e3 * np.sqrt(max(np.linalg.eigvalsh(Ck[:3, :3]).max(), 0.0))
        tra[k] = 1e3 * np.sqrt(max(np.linalg.eigvalsh(J @ Ck @ J.T).max(), 0.0))
    return rot, tra


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
