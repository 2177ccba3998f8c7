"""Turntable-axis calibration from a board seen at several table angles.

A board on the table at angles θ_k has camera-frame poses ``T_k`` (board → camera). The relative
motions ``A_k = T_k T_0⁻¹`` are rotations about the table axis: ``A_k = [R_k | (I − R_k) p]``
for a point ``p`` on the axis. The axis direction is the unit rotation vector of the ``R_k``
(sign-aligned and averaged, weighted by sin of their angle) and ``p`` the least-squares
solution of the stacked ``(I − R_k) p = t_k`` (nearest to the boards' centroid along the axis).
"""
from __future__ import annotations

import json
from pathlib import Path

import numpy as np
from scipy.spatial.transform import Rotation

from fringe3d.devices.stage import rotation_about
from fringe3d.utils.atomic import atomic_write_text
from fringe3d.utils.jsonfile import read_format_json


def fit_axis(board_poses) -> tuple[np.ndarray, np.ndarray]:
    """``(unit axis (3,), point on the axis (3,) mm)`` from ≥ 2 board poses (K, 4, 4) board → camera;
    the axis is signed so that the table turns right-handed from pose 0 to pose 1."""
    T = np.asarray(board_poses, float)
    if T.ndim != 3 or T.shape[1:] != (4, 4) or len(T) < 2:
        raise ValueError(f"board_poses must be (K >= 2, 4, 4), got {T.shape}")
    A = T[1:] @ np.linalg.inv(T[0])
    rv = Rotation.from_matrix(A[:, :3, :3]).as_rotvec()
    ang = np.linalg.norm(rv, axis=1)
    if ang.max() < 1e-3:
        raise ValueError("board poses do not rotate (all within 1 mrad): no axis to fit")
    ref = rv[np.argmax(ang)] / ang.max()
    signs = np.sign(rv @ ref)
    w = np.sin(np.minimum(ang, np.pi / 2))
    axis = (signs[:, None] * rv / np.maximum(ang, 1e-12)[:, None] * w[:, None]).sum(0)
    axis /= np.linalg.norm(axis)
    if rv[0] @ axis < 0:
        axis = -axis
    M = np.concatenate([np.eye(3) - a[:3, :3] for a in A])
    b = np.concatenate([a[:3, 3] for a in A])
    p, *_ = np.linalg.lstsq(M, b, rcond=None)
    c = T[:, :3, 3].mean(0)
    p = p + axis * ((c - p) @ axis)
    return axis, p


def turntable_poses(axis, point, angles_deg) -> np.ndarray:
    """(V, 4, 4) view → model transforms (model frame = view 0's camera frame) for views taken at
    table angles ``angles_deg``: the object turned by θ_k − θ_0, so view k's points go back by it."""
    a = np.asarray(angles_deg, float)
    return np.stack([rotation_about(axis, -np.deg2rad(t - a[0]), point) for t in a])


AXIS_FORMAT = "fringe3d-turntable-axis"


def axis_residuals(board_poses, angles_deg, axis, point, object_points) -> dict:
    """How well a turntable model explains the board poses.

    Each board pose ``k`` is predicted from pose 0 turned by the stage's ``θ_k − θ_0`` about the
    fitted axis; the residual is the distance (mm) between the predicted and the observed board
    points, and the rotation residual the angle (mrad) of ``R_pred⁻¹ R_obs``.

    Parameters
    ----------
    board_poses : (K, 4, 4) array_like
        Board → camera, mm.
    angles_deg : (K,) array_like
        The stage angles the poses were taken at.
    axis, point : (3,) array_like
        The fitted axis (unit) and a point on it, camera frame, mm.
    object_points : (N, 3) array_like
        The board points (board frame, mm).

    Returns
    -------
    dict
        ``rms_residual_mm`` (over all poses' points), ``rms_rotation_residual_mrad`` and per
        pose ``residual_mm`` (RMS), ``rotation_residual_mrad`` and ``measured_angle_deg`` (the
        turn from pose 0 about ``axis`` the board poses show).
    """
    T = np.asarray(board_poses, float)
    a = np.asarray(angles_deg, float)
    X = np.c_[np.asarray(object_points, float), np.ones(len(object_points))]
    per, rot, meas, sq = [], [], [], []
    for Tk, ak in zip(T, a):
        pred = rotation_about(axis, np.deg2rad(ak - a[0]), point) @ T[0]
        d = (X @ pred.T)[:, :3] - (X @ Tk.T)[:, :3]
        sq.append(np.sum(d * d, axis=1))
        per.append(float(np.sqrt(np.mean(sq[-1]))))
        rot.append(1e3 * float(np.linalg.norm(Rotation.from_matrix(pred[:3, :3].T @ Tk[:3, :3]).as_rotvec())))
        rel = Rotation.from_matrix(Tk[:3, :3] @ T[0][:3, :3].T).as_rotvec()
        meas.append(float(np.rad2deg(rel @ np.asarray(axis, float))))
    return {"rms_residual_mm": float(np.sqrt(np.mean(np.concatenate(sq)))),
            "rms_rotation_residual_mrad": float(np.sqrt(np.mean(np.square(rot)))),
            "residual_mm": per, "rotation_residual_mrad": rot, "measured_angle_deg": meas}


def fit_turntable(board_poses, angles_deg, object_points) -> dict:
    """The turntable axis from board poses taken at known stage angles.

    :func:`fit_axis`, with the axis signed so that a positive stage turn is right-handed about
    it (the sign the stage's angles show), and its :func:`axis_residuals`.

    Parameters
    ----------
    board_poses : (K, 4, 4) array_like
        Board → camera, mm (K ≥ 2, not all at one angle).
    angles_deg : (K,) array_like
        Stage angles of the poses.
    object_points : (N, 3) array_like
        The board points (board frame, mm), for the residuals.

    Returns
    -------
    dict
        ``axis`` (unit, camera frame), ``point_mm`` (on the axis, nearest the boards' centroid)
        and the residual fields of :func:`axis_residuals`.
    """
    a = np.asarray(angles_deg, float)
    T = np.asarray(board_poses, float)
    if a.shape != (len(T),):
        raise ValueError(f"angles_deg must give one angle per board pose ({len(T)}), got shape {a.shape}")
    axis, point = fit_axis(T)
    k = int(np.argmax(np.abs(a - a[0])))
    rel = Rotation.from_matrix(T[k][:3, :3] @ T[0][:3, :3].T).as_rotvec()
    if (rel @ axis) * (a[k] - a[0]) < 0:
        axis = -axis
    res = axis_residuals(T, a, axis, point, object_points)
    return {"axis": axis.tolist(), "point_mm": point.tolist(), **res}


def write_axis(path, fit: dict, views: list[dict] | None = None) -> Path:
    """Write ``axis.json``: ``axis`` (unit, camera frame), ``point_mm``, the residuals of
    :func:`fit_turntable` and ``views`` (per view: name, stage angle and its residuals)."""
    doc = {"format": AXIS_FORMAT, "version": 1, "unit": "mm", "frame": "camera",
           **{k: fit[k] for k in ("axis", "point_mm", "rms_residual_mm", "rms_rotation_residual_mrad")}}
    if views is not None:
        doc["views"] = views
    atomic_write_text(path, json.dumps(doc, indent=1))
    return Path(path)


def read_axis(path) -> tuple[np.ndarray, np.ndarray]:
    """``(unit axis, point mm)`` from an ``axis.json``; ValueError naming the file and field."""
    path = Path(path)
    doc = read_format_json(path, "turntable axis file", AXIS_FORMAT)
    if doc.get("unit", "mm") != "mm":
        raise ValueError(f"turntable axis file {path}: field 'unit' must be 'mm', got {doc.get('unit')!r}")
    out = []
    for key in ("axis", "point_mm"):
        try:
            v = np.asarray(doc.get(key), float)
        except (TypeError, ValueError):
            v = np.array([])
        if v.shape != (3,) or not np.all(np.isfinite(v)):
            raise ValueError(f"turntable axis file {path}: field '{key}' must be three finite numbers")
        out.append(v)
    n = np.linalg.norm(out[0])
    if not n > 0:
        raise ValueError(f"turntable axis file {path}: field 'axis' must be a non-zero direction")
    return out[0] / n, out[1]
