"""Turntable-axis calibration from a multi-view capture of a circle board on the table.

A board lies on the turntable; ``fringe3d capture --views N --stage ...`` captures it at N table
angles (``view-NN`` capture folders and ``poses.json`` with each view's ``angle_deg``). Each
view's board image (the pattern set's white frame, else the mean of the first pattern cycle)
gives the circle centres (:func:`fringe3d.calibrate.board_detection.find_board`); with the
calibrated camera (intrinsics and distortion, the camera frame as world frame) ``cv2.solvePnP``
gives the board pose (board → camera, mm) and :func:`fringe3d.multiview.axis.fit_turntable` the
axis, its point and the residuals. A symmetric circle grid has a 180° labelling ambiguity: each
view takes the labelling whose turn from view 0 is nearest to the stage's.
"""
from __future__ import annotations

import json
from pathlib import Path

import cv2
import numpy as np
from scipy.spatial.transform import Rotation

from fringe3d.calibrate.board_detection import find_board
from fringe3d.calibrate.boards import CircleBoard
from fringe3d.io.capture import read_capture

from .axis import fit_turntable


def board_image(folder) -> np.ndarray:
    """The board image of a capture folder: its white frame, else the mean of its first cycle."""
    cap = read_capture(folder, max_cycles=1)
    frames = np.asarray(cap.frames[: len(cap.patterns)], float)
    white = cap.patterns.indices(kind="white")
    return frames[white[0]] if len(white) else frames.mean(axis=0)


def board_pose(uv, board: CircleBoard, camera) -> np.ndarray:
    """(4, 4) board → camera (mm) from circle centres ``uv`` (N, 2) px by ``cv2.solvePnP``
    (iterative, refined by Levenberg-Marquardt) with ``camera``'s ``K`` and ``dist``."""
    obj = np.ascontiguousarray(board.object_points(), np.float64)
    img = np.ascontiguousarray(uv, np.float64).reshape(-1, 1, 2)
    K, dist = np.asarray(camera.K, float), np.asarray(camera.dist, float)
    ok, rv, tv = cv2.solvePnP(obj, img, K, dist, flags=cv2.SOLVEPNP_ITERATIVE)
    if not ok:
        raise ValueError("solvePnP found no board pose")
    rv, tv = cv2.solvePnPRefineLM(obj, img, K, dist, rv, tv)
    T = np.eye(4)
    T[:3, :3] = cv2.Rodrigues(rv)[0]
    T[:3, 3] = np.ravel(tv)
    return T


def _turn_deg(T0, T) -> float:
    return float(np.rad2deg(np.linalg.norm(Rotation.from_matrix(T[:3, :3] @ T0[:3, :3].T).as_rotvec())))


def stage_angles(folder) -> dict[str, float]:
    """``{view name: stage angle (deg)}`` from ``folder/poses.json``'s ``angle_deg`` fields."""
    path = Path(folder) / "poses.json"
    if not path.is_file():
        raise ValueError(f"{folder} holds no poses.json: expected the folder of a multi-view capture "
                         "(view-NN capture folders and poses.json with each view's stage angle)")
    try:
        views = json.loads(path.read_text()).get("views")
    except (json.JSONDecodeError, UnicodeDecodeError, AttributeError) as e:
        raise ValueError(f"poses file {path} is not a JSON object: {e}") from None
    out = {}
    for i, v in enumerate(views or []):
        a = v.get("angle_deg") if isinstance(v, dict) else None
        if isinstance(a, bool) or not isinstance(a, (int, float)) or not np.isfinite(a):
            raise ValueError(f"poses file {path}: field 'views[{i}].angle_deg' must be a number (the stage angle)")
        out[str(v.get("name"))] = float(a)
    if len(out) < 2:
        raise ValueError(f"poses file {path}: field 'views' must list at least 2 views with their angle_deg")
    return out


def calibrate_axis(folder, camera, board: CircleBoard) -> dict:
    """Fit the turntable axis to the board seen in every view of a multi-view capture.

    Parameters
    ----------
    folder : path
        The multi-view capture (``view-NN`` folders and ``poses.json``).
    camera : PinholeDevice
        The calibrated camera (its frame is the camera frame the axis is given in).
    board : CircleBoard
        The board on the table.

    Returns
    -------
    dict
        :func:`fringe3d.multiview.axis.fit_turntable`'s fields plus ``views``: per view its
        ``name``, ``angle_deg`` (stage), ``measured_angle_deg`` (the board's turn about the axis
        from view 0), ``residual_mm`` and ``rotation_residual_mrad``; ``board_poses`` (K, 4, 4).

    Raises
    ------
    ValueError
        Fewer than 2 views with the board found (naming the views and why), or views without
        a stage angle.
    """
    folder = Path(folder)
    angles = stage_angles(folder)
    names, poses, used, missed = sorted(angles), [], [], []
    for name in names:
        uv, why = find_board(board_image(folder / name), board)
        if uv is None:
            missed.append(f"{name} ({why})")
            continue
        T = board_pose(uv, board, camera)
        if poses and not board.asymmetric:  # 180 degree labelling ambiguity: the one nearest the stage's turn
            T2 = board_pose(uv[::-1], board, camera)
            want = abs(angles[name] - angles[used[0]])
            if abs(_turn_deg(poses[0], T2) - want) < abs(_turn_deg(poses[0], T) - want):
                T = T2
        poses.append(T)
        used.append(name)
    if len(poses) < 2:
        raise ValueError(f"the board was found in {len(poses)} view(s) of {folder}; the axis needs at least 2 "
                         f"at different angles (not found: {', '.join(missed)})")
    fit = fit_turntable(np.stack(poses), [angles[n] for n in used], board.object_points())
    fit["views"] = [{"name": n, "angle_deg": angles[n], "measured_angle_deg": m, "residual_mm": r,
                     "rotation_residual_mrad": q}
                    for n, m, r, q in zip(used, fit.pop("measured_angle_deg"), fit.pop("residual_mm"),
                                          fit.pop("rotation_residual_mrad"))]
    fit["views_without_board"] = missed
    fit["board_poses"] = np.stack(poses)
    return fit
