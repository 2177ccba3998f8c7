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


#: ``--stage`` backends: the simulator's turntable and a GRBL controller's rotary axis.
STAGE_BACKENDS = ("virtual", "grbl")


def open_stage(spec) -> Stage:
    """Open a real stage from a spec.

    Parameters
    ----------
    spec : str or DeviceSpec
        ``grbl:PORT[?axis=A&baud=115200&feed=F&scale=1&timeout=S&step=DEG]``
        (:class:`fringe3d.devices.grbl.GrblStage`; ``step`` is the capture's, not the stage's).

    Returns
    -------
    Stage
        The open stage (close it when done).

    The ``virtual`` stage is opened by :func:`fringe3d.sim.turntable.open_virtual_stage` (the
    command layer routes it there; devices do not import the simulator).
    """
    from .base import DeviceSpec, check_unknown_options, option

    spec = spec if isinstance(spec, DeviceSpec) else DeviceSpec.parse(spec)
    if spec.backend == "grbl":
        from .grbl import GrblStage

        check_unknown_options(spec, {"axis", "baud", "feed", "scale", "timeout", "step"})
        if not spec.ident:
            raise ValueError("grbl stage: give the serial port, e.g. grbl:/dev/ttyUSB0")
        return GrblStage(spec.ident, axis=option(spec.options, "axis", "X"),
                         baud=option(spec.options, "baud", 115200, int),
                         feed=option(spec.options, "feed", None, float),
                         scale=option(spec.options, "scale", 1.0, float),
                         timeout=option(spec.options, "timeout", 60.0, float))
    raise ValueError(f"unknown stage backend {spec.backend!r}; expected one of {', '.join(STAGE_BACKENDS)}")
