"""Turntable-axis calibration from a board seen at several table angles.

A board on the table at angles θ_k has camera-frame poses ``T_k`` (board → camera). The relative
motions ``A_k = T_k T_0⁻¹`` are rotations about the table axis: ``A_k = [R_k | (I − R_k) p]``
for a point ``p`` on the axis. The axis direction is the unit rotation vector of the ``R_k``
(sign-aligned and averaged, weighted by sin of their angle) and ``p`` the least-squares
solution of the stacked ``(I − R_k) p = t_k`` (nearest to the boards' centroid along the axis).
"""
from __future__ import annotations

import numpy as np
from scipy.spatial.transform import Rotation

from fringe3d.devices.stage import rotation_about


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
