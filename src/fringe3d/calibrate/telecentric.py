"""Telecentric camera + pinhole projector calibration (dissertation ch. 3, Eq. 3.1-3.9).

World frame = projector frame (projector ``[I|0]``). Steps (ch. 3.3):

1. the projector sees the circle centres through absolute phase (periods 18 and 36 in the
   dissertation, Eq. 3.7-3.8) and is calibrated like a camera (linear model);
2. each board pose ``[R_t|t_t]`` (board -> world) comes from Levenberg-Marquardt on the
   projector observations (Eq. 3.9, ``cv2.solvePnP`` iterative + ``solvePnPRefineLM``);
3. the board points transformed to world give, with the camera's circle centres, the
   camera's 2x4 affine matrix ``M_c`` in least squares (Eq. 3.3).

Reconstruction (Eq. 3.3 + 3.4): the two affine camera rows and the projector's ``u_p`` row
(or both projector rows) form a linear system per pixel for ``(x, y, z)``. An affine camera
maps a circle's centroid to its image's centroid, so the camera centres carry no perspective
bias; the projector observations are read at those centres, so they are unbiased too.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np
from scipy.optimize import least_squares

from fringe3d.calibrate.serial_opencv import serial_opencv
from fringe3d.optics import PinholeDevice, Rig, TelecentricCamera

from .boards import CircleBoard
from .camera import DeviceCalibration, calibrate_device
from .stereo import PoseObservation


@dataclass
class TelecentricCalibration:
    """A calibrated telecentric camera + pinhole projector rig plus its residuals (ch. 3.3).

    Attributes
    ----------
    rig : Rig
        Affine camera ``M`` (2, 4) and projector; world = projector frame, mm.
    projector : DeviceCalibration
        The projector's intrinsics, distortion, poses and reprojection residuals (px).
    camera_residuals : list of (N_i, 2) ndarray
        Camera reprojection residuals per pose, pixels.
    camera_per_pose_rms : (P,) ndarray
        Camera reprojection RMS per pose, pixels.
    camera_rms : float
        Camera reprojection RMS over all poses, pixels.
    board_to_world : list of (R (3, 3), t (3,))
        Board pose per pose in the world (projector) frame, t in mm.
    pose_names : list of str
        The poses used.
    used_points : list of (N,) bool ndarray
        Per pose, the board points with valid projector coordinates.
    """

    rig: Rig
    projector: DeviceCalibration
    camera_residuals: list[np.ndarray]          # per pose (N_i, 2) pixels
    camera_per_pose_rms: np.ndarray             # pixels
    camera_rms: float                           # pixels
    board_to_world: list[tuple[np.ndarray, np.ndarray]]  # per pose (R (3,3), t (3,))
    pose_names: list[str] = field(default_factory=list)
    used_points: list[np.ndarray] = field(default_factory=list)  # per pose: bool (N,) valid projector points

    @property
    def camera_scale(self) -> float:
        """Camera pixels per mm in object space (mean norm of the rows of ``M[:, :3]``)."""
        M = self.rig.camera.M
        return float(np.mean(np.linalg.norm(M[:, :3], axis=1)))


def fit_affine_camera(X: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """Least-squares 2x4 affine camera ``uv = M [X; 1]`` (Eq. 3.3) from world points
    ``X (N, 3)`` mm and pixels ``uv (N, 2)``; needs N >= 4 non-coplanar points."""
    X = np.asarray(X, float).reshape(-1, 3)
    uv = np.asarray(uv, float).reshape(-1, 2)
    if len(X) < 4:
        raise ValueError(f"affine camera fit needs at least 4 points, got {len(X)}")
    A = np.hstack([X, np.ones((len(X), 1))])
    if np.linalg.matrix_rank(A) < 4:
        raise ValueError("affine camera fit needs board points spanning 3-D (poses at different tilts)")
    M, *_ = np.linalg.lstsq(A, uv, rcond=None)
    return np.ascontiguousarray(M.T)


def board_pose_lm(obj: np.ndarray, uv: np.ndarray, K: np.ndarray, dist: np.ndarray, rvec0=None, tvec0=None):
    """Board -> device pose by Levenberg-Marquardt reprojection minimisation, Eq. (3.9)."""
    obj = np.asarray(obj, np.float64).reshape(-1, 3)
    uv = np.asarray(uv, np.float64).reshape(-1, 2)
    if rvec0 is None:
        ok, rvec, tvec = cv2.solvePnP(obj, uv, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
        if not ok:
            raise ValueError("solvePnP failed for a board pose")
    else:
        rvec, tvec = np.asarray(rvec0, np.float64).reshape(3, 1), np.asarray(tvec0, np.float64).reshape(3, 1)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 100, 1e-14)
    with serial_opencv():  # bit-reproducible sums
        rvec, tvec = cv2.solvePnPRefineLM(obj, uv, K, dist, rvec, tvec, criteria=crit)
    R, _ = cv2.Rodrigues(rvec)
    return R, np.asarray(tvec, np.float64).ravel()


def refine_jointly(obj, cam_uv, prj_uv, keep, K, M, b2w):
    """Joint Levenberg-Marquardt refinement (beyond the dissertation's sequential steps):
    board poses, the camera's affine ``M`` and the projector's ``fx, fy, cx, cy`` minimise the
    camera and projector reprojection errors together. The sequential method fixes each
    board pose from the projector alone; with a long-focal-length projector its depth is
    weakly determined, and the tilted telecentric camera sees that error. Returns
    ``(K, M, b2w)``."""
    n = len(b2w)
    x0 = [K[0, 0], K[1, 1], K[0, 2], K[1, 2], *M.ravel()]
    for R, t in b2w:
        x0 += [*cv2.Rodrigues(R)[0].ravel(), *t]
    x0 = np.array(x0, float)
    scale = np.abs(x0) * 1e-3 + 1e-6

    def unpack(x):
        Kx = np.array([[x[0], 0, x[2]], [0, x[1], x[3]], [0, 0, 1.0]])
        Mx = x[4:12].reshape(2, 4)
        poses = []
        for i in range(n):
            p = x[12 + 6 * i: 18 + 6 * i]
            poses.append((cv2.Rodrigues(p[:3])[0], p[3:]))
        return Kx, Mx, poses

    def residuals(x):
        Kx, Mx, poses = unpack(x)
        out = []
        for i, (R, t) in enumerate(poses):
            Xw = obj @ R.T + t
            out.append((Xw @ Mx[:, :3].T + Mx[:, 3] - cam_uv[i]).ravel())
            xy = Xw[keep[i], :2] / Xw[keep[i], 2:3]
            pp = xy @ Kx[:2, :2].T + Kx[:2, 2]
            out.append((pp - prj_uv[i][keep[i]]).ravel())
        return np.concatenate(out)

    sol = least_squares(residuals, x0, method="lm", x_scale=scale, xtol=1e-12, ftol=1e-12, max_nfev=2000)
    return unpack(sol.x)


def calibrate_telecentric_rig(board: CircleBoard, poses: list[PoseObservation], camera_size, projector_size,
                              projector_dist: str = "none", min_poses: int = 3,
                              min_points: int = 6, refine: bool = False) -> TelecentricCalibration:
    """Calibrate a telecentric camera + pinhole projector rig (ch. 3.3 steps 4-7).

    ``poses`` carry the camera circle centres and the phase-mapped projector centres
    (NaN rows = invalid phase). Returns the rig (world = projector frame) and residuals.

    Parameters
    ----------
    board : CircleBoard
        The calibration board (spacing in mm).
    poses : list of PoseObservation
        Camera and projector board points per pose, pixels (the whole board in every pose).
    camera_size, projector_size : (width, height)
        Device sizes, pixels.
    projector_dist : str
        Projector distortion model (:data:`.camera.DIST_MODELS`).
    min_poses : int
        Fewest poses with at least ``min_points`` valid projector points.
    min_points : int
        A pose with fewer valid projector points is left out.
    refine : bool
        Joint Levenberg-Marquardt refinement of the projector ``K``, the affine camera and the
        board poses after the sequential steps (linear projector model only).

    Returns
    -------
    TelecentricCalibration
        The rig and its camera and projector residuals.
    """
    if len(poses) < min_poses:
        raise ValueError(f"only {len(poses)} usable board pose(s); need at least {min_poses}")
    obj = board.object_points()
    keep = [np.all(np.isfinite(p.projector_uv), axis=1) for p in poses]
    bad = [p.name for p, k in zip(poses, keep) if k.sum() < min_points]
    if len(poses) - len(bad) < min_poses:
        raise ValueError(f"phase is invalid at the circle centres in pose(s) {bad}; need {min_poses} good poses")
    good = [i for i, k in enumerate(keep) if k.sum() >= min_points]
    prj = calibrate_device([obj[keep[i]] for i in good], [poses[i].projector_uv[keep[i]] for i in good],
                           projector_size, projector_dist, min_poses, "projector")
    Xw, uvc, b2w = [], [], []
    for k, i in enumerate(good):
        R, t = board_pose_lm(obj[keep[i]], poses[i].projector_uv[keep[i]], prj.K, prj.dist,
                             prj.rvecs[k], prj.tvecs[k])
        b2w.append((R, t))
        Xw.append(obj @ R.T + t)
        uvc.append(np.asarray(poses[i].camera_uv, float))
    M = fit_affine_camera(np.concatenate(Xw), np.concatenate(uvc))
    if refine:
        if np.any(prj.dist):
            raise ValueError("joint telecentric refinement supports the linear projector model only")
        Kr, M, b2w = refine_jointly(obj, uvc, [poses[i].projector_uv for i in good], [keep[i] for i in good],
                                    prj.K, M, b2w)
        Xw = [obj @ R.T + t for R, t in b2w]
        prj.K = Kr
        pres = [poses[i].projector_uv[keep[i]] - prj_project(Kr, X[keep[i]]) for i, X in zip(good, Xw)]
        prj.residuals = pres
        prj.per_pose_rms = np.array([np.sqrt(np.mean(np.sum(r ** 2, 1))) for r in pres])
        prj.rms = float(np.sqrt(np.mean(np.sum(np.concatenate(pres) ** 2, 1))))
    cam = TelecentricCamera(M=np.ascontiguousarray(M), width=int(camera_size[0]), height=int(camera_size[1]))
    res = [u - cam.project(X) for X, u in zip(Xw, uvc)]
    per = np.array([np.sqrt(np.mean(np.sum(r ** 2, 1))) for r in res])
    allr = np.concatenate(res)
    projector = PinholeDevice(K=prj.K, dist=prj.dist, width=int(projector_size[0]), height=int(projector_size[1]))
    return TelecentricCalibration(rig=Rig(camera=cam, projector=projector), projector=prj, camera_residuals=res,
                                  camera_per_pose_rms=per, camera_rms=float(np.sqrt(np.mean(np.sum(allr ** 2, 1)))),
                                  board_to_world=b2w, pose_names=[poses[i].name for i in good],
                                  used_points=[keep[i] for i in good])


def prj_project(K, X):
    """Distortion-free pinhole projection with the projector at the world origin."""
    xy = X[:, :2] / X[:, 2:3]
    return xy @ K[:2, :2].T + K[:2, 2]


def triangulate_telecentric(camera: TelecentricCamera, projector: PinholeDevice, uv: np.ndarray,
                            up: np.ndarray, vp: np.ndarray | None = None) -> np.ndarray:
    """3-D points from a telecentric camera and a pinhole projector (Eq. 3.3-3.4).

    Per point: the two affine rows ``M[r, :3] X = uv_r - M[r, 3]`` and the projector row(s)
    ``(P[0] - u_p P[2]) [X; 1] = 0`` (and ``v_p`` likewise) - 3 equations solved exactly, or 4 in
    least squares. Projector distortion is removed from ``(u_p, v_p)`` first when ``vp`` is
    given (it needs both coordinates); with ``u_p`` alone the projector must be distortion-free.

    Parameters
    ----------
    camera : TelecentricCamera
        The affine camera ``M`` (2, 4), px per mm.
    projector : PinholeDevice
        The projector (world frame, mm).
    uv : (..., 2)
        Camera pixels.
    up, vp : (...)
        Projector coordinates (column, row), pixels; ``vp`` optional.

    Returns
    -------
    (..., 3) ndarray (float)
        Points, mm, NaN where the inputs are NaN.
    """
    uv = np.asarray(uv, float)
    up = np.asarray(up, float)
    shape = up.shape
    uv = uv.reshape(-1, 2)
    up = up.ravel()
    P = projector.P
    if vp is not None:
        vp = np.asarray(vp, float).ravel()
        if np.any(projector.dist):
            xy = projector.pixels_to_normalized(np.stack([up, vp], -1))
            K = projector.K
            up = K[0, 0] * xy[:, 0] + K[0, 1] * xy[:, 1] + K[0, 2]
            vp = K[1, 1] * xy[:, 1] + K[1, 2]
    elif np.any(projector.dist):
        raise ValueError("a distorted projector needs both u_p and v_p for triangulation")
    M = camera.M
    rows = [np.broadcast_to(M[0], (len(up), 4)), np.broadcast_to(M[1], (len(up), 4))]
    rhs = [uv[:, 0], uv[:, 1]]
    rows.append(P[0][None] - up[:, None] * P[2][None])
    rhs.append(np.zeros(len(up)))
    if vp is not None:
        rows.append(P[1][None] - vp[:, None] * P[2][None])
        rhs.append(np.zeros(len(up)))
    A = np.stack(rows, 1)  # (N, k, 4)
    b = np.stack(rhs, 1)   # (N, k)
    A3, b3 = A[..., :3], b - A[..., 3]
    AtA = np.einsum("nki,nkj->nij", A3, A3)
    Atb = np.einsum("nki,nk->ni", A3, b3)
    ok = np.all(np.isfinite(Atb), 1) & np.all(np.isfinite(AtA), (1, 2))
    X = np.full((len(up), 3), np.nan)
    if ok.any():
        X[ok] = np.linalg.solve(AtA[ok], Atb[ok][..., None])[..., 0]
    return X.reshape(shape + (3,))
