"""Camera (or projector-as-camera) intrinsics and distortion from board views (OpenCV).

Eq. (2.8)-(2.16): ``s [u v 1]^T = A [R|t] X`` with Brown distortion. ``calibrate_device``
wraps ``cv2.calibrateCamera`` and reports the reprojection error per pose; the projector is
calibrated by the same routine from its phase-mapped centres (ch. 2.2.5 step 4), normally
with the linear model (no distortion), as the dissertation found sufficient.
"""
from __future__ import annotations

from dataclasses import dataclass, field

import cv2
import numpy as np

from fringe3d.calibrate.serial_opencv import serial_opencv

#: Distortion models: which Brown coefficients are estimated.
DIST_MODELS = ("none", "k1", "k1k2", "k1k2p", "full")


@dataclass
class DeviceCalibration:
    """Result of calibrating one pinhole device from ``P`` board poses.

    Attributes
    ----------
    K : (3, 3) intrinsics (pixels); dist : (5,) ``k1 k2 p1 p2 k3``
    width, height : device size in pixels
    rvecs, tvecs : (P, 3) board-to-device Rodrigues vectors and translations (mm)
    per_pose_rms : (P,) reprojection RMS per pose (pixels)
    rms : overall reprojection RMS (pixels)
    residuals : list of (N_i, 2) observed minus reprojected (pixels)
    """

    K: np.ndarray
    dist: np.ndarray
    width: int
    height: int
    rvecs: np.ndarray
    tvecs: np.ndarray
    per_pose_rms: np.ndarray
    rms: float
    residuals: list = field(default_factory=list)
    dist_model: str = "none"


def dist_flags(model: str) -> int:
    """OpenCV calibration flags for a distortion model in :data:`DIST_MODELS`."""
    if model not in DIST_MODELS:
        raise ValueError(f"unknown distortion model {model!r}; expected one of {DIST_MODELS}")
    f = 0
    if model in ("none", "k1", "k1k2"):
        f |= cv2.CALIB_ZERO_TANGENT_DIST
    if model == "none":
        f |= cv2.CALIB_FIX_K1 | cv2.CALIB_FIX_K2
    if model == "k1":
        f |= cv2.CALIB_FIX_K2
    if model != "full":
        f |= cv2.CALIB_FIX_K3
    return f


def _as_cv_lists(object_points, image_points):
    obj = [np.ascontiguousarray(o, dtype=np.float32).reshape(-1, 1, 3) for o in object_points]
    img = [np.ascontiguousarray(p, dtype=np.float32).reshape(-1, 1, 2) for p in image_points]
    return obj, img


def reprojection_residuals(object_points, image_points, K, dist, rvecs, tvecs) -> list[np.ndarray]:
    """Observed minus reprojected pixels per pose: list of ``(N_i, 2)`` float64."""
    out = []
    for o, p, r, t in zip(object_points, image_points, rvecs, tvecs):
        proj, _ = cv2.projectPoints(np.asarray(o, np.float64).reshape(-1, 3), np.asarray(r, np.float64),
                                    np.asarray(t, np.float64), K, dist)
        out.append(np.asarray(p, np.float64).reshape(-1, 2) - proj.reshape(-1, 2))
    return out


def rms_of(residuals: list[np.ndarray]) -> tuple[np.ndarray, float]:
    """Per-pose and overall RMS of 2-D residual vectors (pixels)."""
    per = np.array([np.sqrt(np.mean(np.sum(r ** 2, axis=1))) for r in residuals])
    allr = np.concatenate(residuals)
    return per, float(np.sqrt(np.mean(np.sum(allr ** 2, axis=1))))


def check_views(object_points, image_points, min_poses: int, what: str) -> None:
    """Raise ``ValueError`` unless there are enough poses with matching point counts."""
    if len(object_points) != len(image_points):
        raise ValueError(f"{what}: {len(object_points)} board point sets but {len(image_points)} image point sets")
    if len(object_points) < min_poses:
        raise ValueError(f"{what}: {len(object_points)} usable board pose(s); need at least {min_poses}")
    for i, (o, p) in enumerate(zip(object_points, image_points)):
        if len(o) != len(p):
            raise ValueError(f"{what}: pose {i} has {len(o)} board points but {len(p)} image points")
        if len(o) < 6:
            raise ValueError(f"{what}: pose {i} has only {len(o)} usable points; need at least 6")


def calibrate_device(object_points: list[np.ndarray], image_points: list[np.ndarray], size: tuple[int, int],
                     dist_model: str = "k1k2p", min_poses: int = 3, what: str = "camera",
                     K_guess: np.ndarray | None = None) -> DeviceCalibration:
    """Intrinsics, distortion and board poses of one device (``cv2.calibrateCamera``).

    Parameters
    ----------
    object_points : list of (N_i, 3) board points (mm) per pose
    image_points : list of (N_i, 2) observed pixels per pose
    size : (width, height) of the device in pixels
    dist_model : one of :data:`DIST_MODELS` ("none" = linear model)
    min_poses : int
        Fewest poses accepted (each needs at least 6 points); fewer raise ValueError.
    what : str
        The device's name in error messages ("camera", "projector").
    K_guess : (3, 3) array, optional
        Initial intrinsics (pixels) for ``cv2.CALIB_USE_INTRINSIC_GUESS``; default OpenCV's own.

    Returns
    -------
    DeviceCalibration
        ``K`` (px), ``dist`` (5,), size, board poses (Rodrigues vectors, translations in mm),
        reprojection residuals and RMS (px).
    """
    check_views(object_points, image_points, min_poses, what)
    w, h = int(size[0]), int(size[1])
    obj, img = _as_cv_lists(object_points, image_points)
    flags = dist_flags(dist_model)
    K0 = None
    if K_guess is not None:
        K0 = np.asarray(K_guess, np.float64).copy()
        flags |= cv2.CALIB_USE_INTRINSIC_GUESS
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)
    with serial_opencv():  # bit-reproducible sums
        rms, K, dist, rvecs, tvecs = cv2.calibrateCamera(obj, img, (w, h), K0, None, flags=flags, criteria=crit)
    K = np.asarray(K, np.float64).reshape(3, 3)
    dist5 = np.zeros(5)
    d = np.asarray(dist, np.float64).ravel()
    dist5[: min(5, d.size)] = d[:5]
    rv = np.array([np.asarray(r, np.float64).ravel() for r in rvecs])
    tv = np.array([np.asarray(t, np.float64).ravel() for t in tvecs])
    res = reprojection_residuals(object_points, image_points, K, dist5, rv, tv)
    per, overall = rms_of(res)
    return DeviceCalibration(K=K, dist=dist5, width=w, height=h, rvecs=rv, tvecs=tv, per_pose_rms=per,
                             rms=overall, residuals=res, dist_model=dist_model)
