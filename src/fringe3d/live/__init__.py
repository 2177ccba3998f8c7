"""Live view: camera cycles -> decode -> 3D, shown continuously in a browser (``fringe3d live``).

* :mod:`.replay`: :class:`ReplayCamera`, recorded frames delivered as a free-running camera
  delivers them (the virtual rig's camera for live views).
* :mod:`.cycles`: :class:`CameraCycles`, complete pattern cycles from any camera (with a
  projector in software sync, or free running by frame id), each an :class:`Arrival`.
* :mod:`.session`: :class:`LiveSession`, the loop (capture thread, newest-cycle mailbox, the
  engine :class:`fringe3d.reconstruct.frame.FrameReconstructor`, the viewer), with
  :class:`Controls` from the page and :class:`LiveSettings`.
* :mod:`.display`: the points and colours drawn, the mask overlay.
* :mod:`.stats`: frame rate and end-to-end latency (:class:`LiveStats`).
* :mod:`.record`: record cycles into a capture folder from the page.
* :mod:`.viewer`: :class:`ViserViewer`, the page on viser (the ``live`` extra, imported when a
  viewer is made).
"""
from __future__ import annotations

from .cycles import Arrival, CameraCycles, CycleSource
from .display import display_points, mask_overlay
from .record import Recording, write_recording
from .replay import ReplayCamera
from .session import Choice, Controls, LiveSession, LiveSettings, RecordSettings
from .stats import LiveStats
from .viewer import ExposureControl, ViewerSetup, ViserViewer, require_viser

__all__ = [
    "Arrival",
    "CameraCycles",
    "CycleSource",
    "Choice",
    "Controls",
    "ExposureControl",
    "LiveSession",
    "LiveSettings",
    "LiveStats",
    "RecordSettings",
    "Recording",
    "ReplayCamera",
    "ViewerSetup",
    "ViserViewer",
    "display_points",
    "mask_overlay",
    "require_viser",
    "write_recording",
]
