"""The settings of a calibration session, grouped by concern and passed whole
(:func:`fringe3d.calibrate.session.calibrate_session`,
:func:`fringe3d.calibrate.session.calibrate_to_files`):

* :class:`ObservationSettings` - how the board points are seen by the projector;
* :class:`FitSettings` - the distortion models and the telecentric refinement;
* :class:`CalibrationOutput` - the extra files written beside the calibration, and whether a
  calibration that fails its acceptance gates is written anyway.
"""
from __future__ import annotations

from dataclasses import dataclass
from pathlib import Path

from .code_mapping import DEFAULT_WINDOW


@dataclass(frozen=True)
class ObservationSettings:
    """How a pose's board points are observed (:func:`fringe3d.calibrate.session.observe_pose`).

    Attributes
    ----------
    min_modulation_share : float
        Board points whose modulation is below this share (0..1) of the pose's 95th percentile
        are left out of the projector's points.
    phase_window : float or str
        How the phase is sampled at a board point: a window in camera px, or a named sampling
        (:func:`fringe3d.calibrate.session.phase_window_px`).
    homography_window : int
        Gray-code sets: the local homographies' window (camera px).
    """

    min_modulation_share: float = 0.1
    phase_window: float | str = 0.0
    homography_window: int = DEFAULT_WINDOW


@dataclass(frozen=True)
class FitSettings:
    """The calibration fit (:func:`fringe3d.calibrate.session.calibrate_observations`).

    Attributes
    ----------
    camera_dist : str
        The camera's distortion model (e.g. ``"k1k2p"``), or ``"auto"`` (chosen by held-out
        reprojection error).
    projector_dist : str
        The projector's distortion model (e.g. ``"none"``), or ``"auto"``.
    telecentric_refine : bool
        Telecentric rigs: the joint refinement after ch. 3's steps.
    """

    camera_dist: str = "k1k2p"
    projector_dist: str = "none"
    telecentric_refine: bool = True


@dataclass(frozen=True)
class CalibrationOutput:
    """What :func:`fringe3d.calibrate.session.calibrate_to_files` writes beside the calibration JSON.

    Attributes
    ----------
    plot : Path | None
        The reprojection-residual PNG plot, if any.
    yaml : Path | None
        The OpenCV YAML export, if any.
    accept_poor : bool
        Write a calibration that fails its acceptance gates anyway (recorded in the file, with a
        warning).
    """

    plot: Path | None = None
    yaml: Path | None = None
    accept_poor: bool = False
