"""Calibration of camera-projector rigs (dissertation ch. 2.2.4-2.2.5 and ch. 3).

* :mod:`.boards` - the circle-grid board geometry (:class:`CircleBoard`).
* :mod:`.square_boards` - chessboard and ChArUco geometry (:class:`ChessBoard`,
  :class:`CharucoBoard`, :func:`board_from_dict`).
* :mod:`.board_detection` - sub-pixel circle-centre detection (OpenCV).
* :mod:`.grid_extent` - a circle grid stated smaller than the one in the image (refused).
* :mod:`.corner_detection` - chessboard / ChArUco corners, any board (:func:`locate_board`).
* :mod:`.camera` - camera intrinsics and distortion from board views.
* :mod:`.phase_mapping` - the projector "sees" the circle centres through absolute phase
  (Eq. 2.30-2.31, 2.32-2.34), which works however defocused the projector is.
* :mod:`.code_mapping` - ... or through Gray code and local homographies (Moreno & Taubin).
* :mod:`.stereo` - the pinhole camera + pinhole projector rig.
* :mod:`.optimal_angle` - the optimal fringe angle (Eq. 2.5-2.7).
* :mod:`.telecentric` - telecentric camera + pinhole projector (ch. 3).
* :mod:`.calibration_file` - the versioned calibration JSON (embeds a ``Rig``).
* :mod:`.session` - from capture folders (or poses in memory) to a calibration.
* :mod:`.gates` - acceptance gates: whether a calibration is plausible enough to be used.
* :mod:`.outliers` - the rule that drops outlier board poses.
* :mod:`.model_choice` - distortion models chosen by held-out reprojection error (``auto``).
* :mod:`.evaluation` - judging a calibration by what it measures.

Simulated sessions live in :mod:`fringe3d.sim.calibration_session`.
"""
from .board_detection import detect_board, find_board, refine_centres
from .boards import CircleBoard
from .calibration_file import Calibration, export_opencv_yaml, load_calibration
from .camera import DeviceCalibration, calibrate_device
from .code_mapping import code_projector_points, corner_homography_points
from .corner_detection import locate_board
from .evaluation import compare_to_truth, measure_points
from .optimal_angle import epipolar_angle, optimal_angle
from .phase_mapping import FringeDirection, projector_maps, projector_points
from .session import (
    PoseCapture,
    calibrate_observations,
    calibrate_session,
    find_pose_folders,
    observe_pose,
    observe_session,
)
from .session_settings import CalibrationOutput, FitSettings, ObservationSettings
from .square_boards import CharucoBoard, ChessBoard, board_from_dict
from .stereo import PoseObservation, RigCalibration, calibrate_pinhole_rig
from .telecentric import (
    TelecentricCalibration,
    calibrate_telecentric_rig,
    triangulate_telecentric,
)

__all__ = [
    "CircleBoard", "detect_board", "find_board", "refine_centres",
    "ChessBoard", "CharucoBoard", "board_from_dict", "locate_board",
    "code_projector_points", "corner_homography_points",
    "Calibration", "load_calibration", "export_opencv_yaml",
    "DeviceCalibration", "calibrate_device",
    "FringeDirection", "projector_points", "projector_maps",
    "PoseCapture", "PoseObservation", "observe_pose", "observe_session", "find_pose_folders",
    "calibrate_observations", "calibrate_session", "ObservationSettings", "FitSettings", "CalibrationOutput",
    "RigCalibration", "calibrate_pinhole_rig",
    "TelecentricCalibration", "calibrate_telecentric_rig", "triangulate_telecentric",
    "optimal_angle", "epipolar_angle",
    "measure_points", "compare_to_truth",
]
