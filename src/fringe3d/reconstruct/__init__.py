"""Reconstruction: absolute phase -> organized 3D point maps (Eq. 2.37-2.38, 3.3, 4.13).

* :func:`triangulate` - least squares over every known projector coordinate; :class:`Triangulator`
  - the fast per-pixel closed form (pinhole and telecentric rigs).
* :func:`depth_map`, :func:`projector_coordinates`, :func:`points_from_decoded` - from a decode
  to points.
* :class:`FastThreeStep` - the superfast fused kernel: three frames -> wrapped phase ->
  geometric-constraint order -> point map, one pass.
* :func:`single_shot` (ch. 4) and :func:`measure` (ch. 5, motion) - one-call measurements.
* :mod:`.frame` - the engine: one cycle -> decoded fields -> points (:class:`~.frame.FrameReconstructor`).
* :mod:`.sequence` - many-frame captures -> one 3D frame per cycle / window, with settings
  (:mod:`.settings`) and an injected executor (:mod:`.executors`) (imported on use: it pulls in
  the point stores).
"""
from fringe3d.reconstruct.depth import depth_map, points_from_decoded, projector_coordinates
from fringe3d.reconstruct.motion import Measurement, dissertation_sequence, hybrid_view, measure
from fringe3d.reconstruct.single_shot import SingleShotResult, SingleShotSettings, single_shot
from fringe3d.reconstruct.triangulate import FastThreeStep, Triangulator, triangulate

__all__ = ["FastThreeStep", "Measurement", "SingleShotResult", "SingleShotSettings",
           "Triangulator", "depth_map", "dissertation_sequence",
           "hybrid_view", "measure", "points_from_decoded", "projector_coordinates", "single_shot", "triangulate"]
