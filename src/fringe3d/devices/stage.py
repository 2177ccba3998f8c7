"""Stages that move the object between views: the protocol every stage driver implements.

A multi-view scan turns or moves the object between captures. A :class:`Stage` reports where it
is as a 4×4 rigid transform (mm) that maps the object's coordinates at the home position to its
coordinates now, in the stage's own frame; the turntable-axis calibration
(:mod:`fringe3d.multiview.axis`) turns that into camera-frame poses. The simulator's virtual
turntable (:class:`fringe3d.sim.turntable.VirtualTurntable`) implements it.
"""
from __future__ import annotations

from typing import Protocol, runtime_checkable

import numpy as np


@runtime_checkable
class Stage(Protocol):
    """A positioning stage (turntable, linear or robot stage)."""

    def move_to(self, position: float) -> None:
        """Move to ``position`` (degrees for a turntable, mm for a linear stage) and wait."""
        ...

    @property
    def position(self) -> float:
        """The current position (degrees or mm)."""
        ...

    def transform(self) -> np.ndarray:
        """(4, 4) float: object home → object now, in the stage frame (mm)."""
        ...

    def describe(self) -> dict:
        """What the stage is (kind, axis, limits), for the capture's record."""
        ...

    def close(self) -> None:
        ...


def rotation_about(axis, angle_rad: float, point=(0.0, 0.0, 0.0)) -> np.ndarray:
    """(4, 4) rigid transform rotating by ``angle_rad`` (right hand) about the line through
    ``point`` (mm) along ``axis`` (Rodrigues' formula ``R = I + sinθ K + (1 − cosθ) K²``)."""
    a = np.asarray(axis, float)
    n = np.linalg.norm(a)
    if not np.isfinite(n) or n == 0:
        raise ValueError(f"rotation axis must be a non-zero 3-vector, got {axis}")
    a = a / n
    K = np.array([[0, -a[2], a[1]], [a[2], 0, -a[0]], [-a[1], a[0], 0]])
    R = np.eye(3) + np.sin(angle_rad) * K + (1 - np.cos(angle_rad)) * K @ K
    p = np.asarray(point, float)
    T = np.eye(4)
    T[:3, :3] = R
    T[:3, 3] = p - R @ p
    return T
