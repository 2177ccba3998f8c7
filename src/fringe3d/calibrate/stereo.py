"""Pinhole camera + pinhole projector rig calibration (ch. 2.2.5 steps 2-5).

World frame = camera frame: the camera gets ``[I|0]``, the projector ``[R|t]`` with
``X_proj = R X_cam + t``. Steps: camera intrinsics from the board images; projector
intrinsics from the phase-mapped centres (linear model by default); ``[R|t]`` from
``cv2.stereoCalibrate`` with both intrinsics fixed.

Optionally (``correct_circle_bias=True``) the perspective bias of circle centres is removed:
the image of a circle is an ellipse whose centroid is not the image of the circle's centre.
With the current estimate of each board pose, the bias is computed exactly (the centroid of
the projected, distorted circle outline minus the projected centre) and subtracted; the
projector sees, through phase, the board point under the camera's *observed* centroid, so its
observation is moved by the projector image of the same offset. Two or three passes converge.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from fringe3d.calibrate.serial_opencv import serial_opencv
from fringe3d.optics import PinholeDevice, Rig

from .boards import CircleBoard
from .camera import DeviceCalibration, calibrate_device
from .model_choice import AUTO, FALLBACK, choose_model


@dataclass
class PoseObservation:
    """Board points seen by the camera and (through phase or code) by the projector in one pose.

    ``camera_uv`` and ``projector_uv`` are ``(N, 2)`` float64 in the board's point order;
    rows of ``camera_uv`` are NaN for points the camera did not see (a ChArUco board's
    partial view), rows of ``projector_uv`` where the phase was invalid or the modulation too low.
    """

    name: str
    camera_uv: np.ndarray
    projector_uv: np.ndarray


@dataclass
class RigCalibration:
    """A calibrated pinhole rig plus its residuals."""

    rig: Rig
    camera: DeviceCalibration
    projector: DeviceCalibration
    stereo_rms: float
    pose_names: list[str]
    projector_poses: list[int] = field(default_factory=list)  # indices into pose_names of prj poses
    used_points: list[np.ndarray] = field(default_factory=list)  # per pose: bool (N,) valid projector points
    model_choice: dict = field(default_factory=dict)  # device -> report, for "auto" distortion models
    camera_points: list = field(default_factory=list)  # per pose: (N_i, 2) px detected, rows of camera.residuals


def circle_bias(board: CircleBoard, K, dist, rvec, tvec, samples: int = 96) -> np.ndarray:
    """Ellipse-centroid minus projected-centre offsets ``(N, 2)`` (pixels) for one pose.

    Each circle outline (radius ``board.radius``) is projected with ``cv2.projectPoints``;
    the area centroid of the projected polygon is what an intensity-weighted (or moment)
    centroid detector returns.
    """
    centres = board.object_points()
    a = np.linspace(0, 2 * np.pi, samples, endpoint=False)
    ring = np.stack([np.cos(a), np.sin(a), np.zeros_like(a)], -1) * board.radius
    pts = (centres[:, None, :] + ring[None]).reshape(-1, 3)
    K = np.asarray(K, np.float64)
    dist = np.asarray(dist, np.float64)
    poly, _ = cv2.projectPoints(pts, np.asarray(rvec, np.float64), np.asarray(tvec, np.float64), K, dist)
    poly = poly.reshape(len(centres), samples, 2)
    x, y = poly[..., 0], poly[..., 1]
    x1, y1 = np.roll(x, -1, axis=1), np.roll(y, -1, axis=1)
    cross = x * y1 - x1 * y
    area = cross.sum(1) / 2
    cx = ((x + x1) * cross).sum(1) / (6 * area)
    cy = ((y + y1) * cross).sum(1) / (6 * area)
    cen, _ = cv2.projectPoints(centres, np.asarray(rvec, np.float64), np.asarray(tvec, np.float64), K, dist)
    return np.stack([cx, cy], -1) - cen.reshape(-1, 2)


def _board_point_under_pixel(uv, K, dist, rvec, tvec) -> np.ndarray:
    """Board-plane (z=0) points ``(N, 3)`` seen at camera pixels ``uv (N, 2)``."""
    xy = cv2.undistortPoints(np.asarray(uv, np.float64).reshape(-1, 1, 2), K, dist).reshape(-1, 2)
    R, _ = cv2.Rodrigues(np.asarray(rvec, np.float64))
    t = np.asarray(tvec, np.float64).ravel()
    d = np.concatenate([xy, np.ones((len(xy), 1))], 1)  # camera-frame ray directions
    # board frame: X_b = R^T (s d - t); z_b = 0 -> s = (R^T t)_z / (R^T d)_z
    Rt = R.T
    s = (Rt @ t)[2] / (d @ Rt.T)[:, 2]
    Xc = d * s[:, None]
    return (Xc - t) @ R  # R^T (Xc - t) for row vectors


def calibrate_pinhole_rig(board: CircleBoard, poses: list[PoseObservation], camera_size, projector_size,
                          camera_dist: str = "k1k2p", projector_dist: str = "none",
                          correct_circle_bias: bool = True, min_poses: int = 3,
                          min_points: int = 6) -> RigCalibration:
    """Calibrate camera, projector and their ``[R|t]`` from board poses.

    Parameters
    ----------
    board : CircleBoard
    poses : list of PoseObservation (one per usable board pose)
    camera_size, projector_size : (width, height) pixels
    camera_dist, projector_dist : distortion models (see ``camera.DIST_MODELS``), or ``"auto"``:
        chosen by held-out reprojection error (:func:`.model_choice.choose_model`) from the
        points after the circle-bias correction (the correction passes use
        :data:`.model_choice.FALLBACK`)
    correct_circle_bias : remove the perspective bias of circle centres (see module doc)
    min_poses : fewer usable poses is a ``ValueError``
    min_points : a pose with fewer valid projector points is left out of the projector and
        stereo steps

    Returns
    -------
    RigCalibration
        The :class:`~fringe3d.optics.rig.Rig` (camera = world frame, projector ``[R|t]`` in mm),
        both devices' calibrations, the stereo RMS (px), the poses used and the model choice.
    """
    if len(poses) < min_poses:
        raise ValueError(f"only {len(poses)} usable board pose(s); need at least {min_poses} "
                         "(check that the board is fully visible in each pose)")
    obj = board.object_points()
    seen = [np.all(np.isfinite(p.camera_uv), axis=1) for p in poses]  # partial views: NaN rows
    keep = [np.all(np.isfinite(p.projector_uv), axis=1) & c for p, c in zip(poses, seen)]
    proj_poses = [i for i, k in enumerate(keep) if k.sum() >= min_points]
    if len(proj_poses) < min_poses:
        bad = [poses[i].name for i in range(len(poses)) if i not in proj_poses]
        where = "the circle centres" if isinstance(board, CircleBoard) else "the board corners"
        raise ValueError(f"phase is invalid at {where} in pose(s) {bad}: only {len(proj_poses)} pose(s) "
                         f"have >= {min_points} valid projector points; need {min_poses}")
    cam_uv = [p.camera_uv.astype(np.float64).copy() for p in poses]
    prj_uv = [p.projector_uv.astype(np.float64).copy() for p in poses]
    cam_obs0 = [c.copy() for c in cam_uv]
    passes = 3 if correct_circle_bias else 1
    models = {"camera": camera_dist, "projector": projector_dist}
    choice: dict = {}
    for it in range(passes):
        pobj = [obj[keep[i]] for i in proj_poses]
        puv = [prj_uv[i][keep[i]] for i in proj_poses]
        cuv = [cam_uv[i][keep[i]] for i in proj_poses]
        views = {"camera": ([obj[c] for c in seen], [u[c] for u, c in zip(cam_uv, seen)], camera_size),
                 "projector": (pobj, puv, projector_size)}
        use = {d: FALLBACK[d] if m == AUTO else m for d, m in models.items()}
        if it == passes - 1:  # the final pass: choose the "auto" models on the corrected points
            for d in (d for d, m in models.items() if m == AUTO):
                use[d], choice[d] = choose_model(*views[d], d)
        cam = calibrate_device(*views["camera"], use["camera"], min_poses, "camera")
        prj = calibrate_device(*views["projector"], use["projector"], min_poses, "projector")
        crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
        with serial_opencv():  # bit-reproducible sums
            out = cv2.stereoCalibrate([o.astype(np.float32).reshape(-1, 1, 3) for o in pobj],
                                      [c.astype(np.float32).reshape(-1, 1, 2) for c in cuv],
                                      [p.astype(np.float32).reshape(-1, 1, 2) for p in puv],
                                      cam.K, cam.dist, prj.K, prj.dist, tuple(int(x) for x in camera_size),
                                      flags=cv2.CALIB_FIX_INTRINSIC, criteria=crit)
        stereo_rms, R, T = float(out[0]), np.asarray(out[5], np.float64), np.asarray(out[6], np.float64).ravel()
        if it == passes - 1:
            break
        # circle-centre bias correction from the current pose estimates
        for i in range(len(poses)):
            rv, tv = cam.rvecs[i], cam.tvecs[i]
            cam_uv[i] = cam_obs0[i] - circle_bias(board, cam.K, cam.dist, rv, tv)
            Xb = _board_point_under_pixel(cam_obs0[i], cam.K, cam.dist, rv, tv)
            Rc, _ = cv2.Rodrigues(rv)
            Rp = R @ Rc
            tp = R @ tv + T
            rvp, _ = cv2.Rodrigues(Rp)
            p_true, _ = cv2.projectPoints(obj, rvp, tp, prj.K, prj.dist)
            p_seen, _ = cv2.projectPoints(Xb, rvp, tp, prj.K, prj.dist)
            prj_uv[i] = poses[i].projector_uv + (p_true - p_seen).reshape(-1, 2)
    camera = PinholeDevice(K=cam.K, dist=cam.dist, width=int(camera_size[0]), height=int(camera_size[1]))
    projector = PinholeDevice(K=prj.K, dist=prj.dist, width=int(projector_size[0]), height=int(projector_size[1]),
                              R=R, t=T)
    return RigCalibration(rig=Rig(camera=camera, projector=projector), camera=cam, projector=prj,
                          stereo_rms=stereo_rms, pose_names=[p.name for p in poses],
                          projector_poses=proj_poses, used_points=keep, model_choice=choice,
                          camera_points=[u[c] for u, c in zip(cam_obs0, seen)])
