"""Pattern cycles from a camera: the frames of one cycle, in manifest order, and when they arrived.

A :class:`CameraCycles` wraps any :class:`fringe3d.devices.Camera` (the ``pylon``, ``genicam``
and ``opencv`` backends, the simulator's ``virtual`` camera, :class:`~fringe3d.live.replay.
ReplayCamera`) in one of two ways:

* **with a projector** (software sync, as ``fringe3d capture`` does by default): for each
  pattern frame, ``projector.show(image)``, wait ``settle`` s, trigger, grab; a cycle is the
  ``n`` frames so taken.
* **without** (the camera runs free or is triggered by a projector that loops the patterns by
  itself): the camera's frame id says which pattern a frame shows (``frame_id % n``); a cycle
  is ``n`` frames of consecutive ids starting at a multiple of ``n``. A gap in the ids (a lost
  frame) drops the partial cycle.

Each cycle is an :class:`Arrival`: its frames ``(n, H, W)``, the host time its last frame arrived
(s, ``Frame.host_time``: the start of the end-to-end latency) and the frame id of its first frame.
"""
from __future__ import annotations

import time
from typing import NamedTuple, Protocol

import numpy as np

from fringe3d.devices.base import DeviceError, Frame
from fringe3d.patterns.manifest import PatternSet


class Arrival(NamedTuple):
    """One pattern cycle as it arrived: ``frames`` (n, H, W) in manifest order, ``arrival`` the
    host time (s, monotonic) its last frame arrived, ``first_id`` the camera frame id of its
    first frame, ``choice`` the name of the pattern set it shows."""

    frames: np.ndarray
    arrival: float
    first_id: int
    choice: str = ""


class CycleSource(Protocol):
    """What the live loop takes cycles from (:class:`CameraCycles` is the one for cameras): the
    ``patterns`` its frames show (the projected manifest) and three methods."""

    patterns: PatternSet

    def start(self) -> None:
        """Start acquiring."""
        ...

    def stop(self) -> None:
        """Stop acquiring."""
        ...

    def next_cycle(self) -> Arrival:
        """The next complete cycle."""
        ...


class CameraCycles:
    """Complete pattern cycles from a camera (module docstring).

    Parameters
    ----------
    camera : Camera
        An open camera (already configured).
    patterns : PatternSet
        The pattern set the frames show (its frame count is the cycle length).
    projector : Projector, optional
        Shows ``images`` one by one with a software trigger per frame; without it the camera's
        frame ids place the frames.
    images : sequence of (H, W) uint8, optional
        What the projector shows, one per pattern frame (needed with ``projector``).
    timing : tuple of float
        ``(settle, timeout)``: seconds to wait after each show before triggering, and for each
        frame at most.
    name : str
        The pattern-set choice these cycles belong to (:attr:`Arrival.choice`).
    """

    def __init__(self, camera, patterns: PatternSet, projector=None, images=None, timing=(0.0, 1.0),
                 name: str = ""):
        self.camera = camera
        self.patterns = patterns
        self.n = len(patterns)
        if self.n < 1:
            raise ValueError("the pattern set has no frames: a cycle needs at least one")
        self.projector = projector
        self.images = list(images) if images is not None else None
        if projector is not None and (self.images is None or len(self.images) != self.n):
            raise ValueError(f"a projector shows one image per pattern frame: expected {self.n} images, got "
                             f"{0 if self.images is None else len(self.images)}")
        self.settle, self.timeout = (float(v) for v in timing)
        self.name = name
        self._partial: list[Frame] = []
        self._started = False

    def start(self) -> None:
        """Start the camera (software trigger mode when a projector shows the patterns)."""
        self.camera.trigger_mode = "software" if self.projector is not None else self.camera.trigger_mode
        self.camera.start()
        self._partial = []
        self._started = True

    def stop(self) -> None:
        """Stop the camera."""
        if self._started:
            self.camera.stop()
            self._started = False

    def next_cycle(self) -> Arrival:
        """The next complete cycle.

        Returns
        -------
        Arrival
            Its frames, arrival time and first frame id.

        Raises
        ------
        DeviceError
            A frame of another size than the first arrived.
        TimeoutError
            A frame did not arrive within the timeout.
        """
        if not self._started:
            self.start()
        return self._shown_cycle() if self.projector is not None else self._free_cycle()

    def _shown_cycle(self) -> Arrival:
        assert self.images is not None
        frames = []
        for img in self.images:
            self.projector.show(img)
            if self.settle > 0:
                time.sleep(self.settle)
            self.camera.trigger()
            frames.append(self.camera.grab(self.timeout))
        return self._arrival(frames)

    def _free_cycle(self) -> Arrival:
        while True:
            fr = self.camera.grab(self.timeout)
            part = self._partial
            if part and fr.frame_id != part[-1].frame_id + 1:
                part.clear()  # a lost frame: the partial cycle cannot be completed
            if not part and fr.frame_id % self.n != 0:
                continue  # wait for the first pattern frame
            part.append(fr)
            if len(part) == self.n:
                self._partial = []
                return self._arrival(part)

    def _arrival(self, frames: list[Frame]) -> Arrival:
        shape = np.shape(frames[0].image)
        for f in frames[1:]:
            if np.shape(f.image) != shape:
                raise DeviceError(f"camera frame {f.frame_id} is {np.shape(f.image)[::-1]} pixels but the cycle's "
                                  f"first frame was {shape[::-1]}")
        stack = np.stack([np.asarray(f.image) for f in frames])
        return Arrival(stack, float(frames[-1].host_time or time.monotonic()), int(frames[0].frame_id), self.name)
