"""Typed results of a calibration session: what the poses share, and the calibration with its fit.

:class:`SessionFacts` is what :func:`fringe3d.calibrate.session.observe_session` learns from the
poses besides their observations (sizes, periods, angles, skipped poses, how the projector saw
the board); :class:`SessionCalibration` is what
:func:`fringe3d.calibrate.session.calibrate_observations` returns: the :class:`Calibration` and
the raw fit of either rig model, with the residuals both models have under one name.
"""
from __future__ import annotations

from dataclasses import dataclass, field
from typing import NamedTuple

import numpy as np

from .calibration_file import Calibration
from .stereo import RigCalibration
from .telecentric import TelecentricCalibration


@dataclass
class SessionFacts:
    """What every pose of a session shares, gathered while the poses are observed.

    Attributes
    ----------
    camera_size, projector_size : (int, int)
        ``(width, height)`` in px, the same for every pose.
    names : list of str
        Every pose, in order; ``skipped`` those whose board was not found.
    correspondences : str
        How the projector saw the board (phase, or Gray-code local homographies).
    phase_sampling : str
        How the phase was sampled at the board points.
    periods, angles : dict
        Per direction, the narrowest fringe period (px) and the fringe angle (rad) of the
        first usable pose.
    alpha_opt : float or None
        The optimal fringe angle (rad) of an optimal-angle set.
    """

    camera_size: tuple[int, int]
    projector_size: tuple[int, int]
    names: list[str] = field(default_factory=list)
    skipped: list[str] = field(default_factory=list)
    correspondences: str = "phase (Eq. 2.30-2.34)"
    phase_sampling: str = "bilinear"
    periods: dict[str, float] = field(default_factory=dict)
    angles: dict[str, float] = field(default_factory=dict)
    alpha_opt: float | None = None


class SessionCalibration(NamedTuple):
    """A session's calibration and the fit it came from (unpacks as ``cal, fit``).

    Attributes
    ----------
    calibration : Calibration
        The calibrated rig, its figures and acceptance gates.
    fit : RigCalibration or TelecentricCalibration
        The raw fit of the rig model (``calibration.model``).
    """

    calibration: Calibration
    fit: RigCalibration | TelecentricCalibration

    @property
    def camera_residuals(self) -> list[np.ndarray]:
        """Per pose, the camera's reprojection residuals ``(n, 2)`` in px."""
        f = self.fit
        return f.camera.residuals if isinstance(f, RigCalibration) else f.camera_residuals

    @property
    def projector_residuals(self) -> list[np.ndarray]:
        """Per pose, the projector's reprojection residuals ``(n, 2)`` in px."""
        return self.fit.projector.residuals

    @property
    def pose_names(self) -> list[str]:
        """The poses the fit used, in order."""
        return list(self.fit.pose_names)
