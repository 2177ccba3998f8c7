"""Calibration of camera-projector rigs (dissertation ch. 2.2.4-2.2.5 and ch. 3).

* :mod:`.board_detection` - circle-grid boards and sub-pixel centre detection (OpenCV).
* :mod:`.camera` - camera intrinsics and distortion from board views.
* :mod:`.phase_mapping` - the projector "sees" the circle centres through absolute phase
  (Eq. 2.30-2.31, 2.32-2.34), which works however defocused the projector is.
* :mod:`.stereo` - the pinhole camera + pinhole projector rig.
* :mod:`.optimal_angle` - the optimal fringe angle (Eq. 2.5-2.7).
* :mod:`.telecentric` - telecentric camera + pinhole projector (ch. 3).
* :mod:`.calibration_file` - the versioned calibration JSON (embeds a ``Rig``).
* :mod:`.session` - from capture folders to a calibration; simulated sessions.
"""
