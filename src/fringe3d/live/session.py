"""The live loop: camera cycles -> the engine -> a viewer, continuously, with the page's controls.

Two threads. The **capture** thread takes complete pattern cycles from the active source
(:class:`~fringe3d.live.cycles.CameraCycles`), applies the page's exposure and pattern-set
changes between cycles, feeds a recording, and leaves each cycle in a one-place mailbox,
replacing one not yet taken (a viewer shows the newest cycle; the replaced ones are counted as
skipped). The **pipeline** (the calling thread) waits while the viewer is busy (the page has
not drawn the frames sent: :meth:`Viewer.busy`; the cycles that arrive meanwhile are skipped),
then takes the newest cycle, reconstructs it with the choice's
:class:`~fringe3d.reconstruct.frame.FrameReconstructor` (the engine every other command uses),
draws its points (:func:`~fringe3d.live.display.display_points`), or its depth map as an image
when the page shows the depth view (:func:`~fringe3d.live.display.depth_image`), and, twice a
second (:attr:`LiveSettings.refresh`; each update re-renders GUI elements in the page), the mask
overlay and the figures (:class:`~fringe3d.live.stats.LiveStats`), until the
frame or time limit, :meth:`LiveSession.stop` or Ctrl-C.

A viewer is anything with the methods of :class:`Viewer` (:class:`fringe3d.live.viewer.
ViserViewer` is the browser one); the page's controls write into :class:`Controls`.
"""
from __future__ import annotations

import threading
import time
import warnings
from dataclasses import dataclass, field
from pathlib import Path
from typing import Callable, Protocol

import numpy as np

from fringe3d.decode.edges import INVALID
from fringe3d.optics.rig import Rig
from fringe3d.reconstruct.depth import EmptyMaskError
from fringe3d.reconstruct.frame import Cycle, FrameReconstructor
from fringe3d.utils.warning_types import DeviceWarning

from .cycles import Arrival, CycleSource
from .display import depth_image, display_points, mask_overlay
from .record import Recording, write_recording
from .stats import LiveStats


@dataclass
class Choice:
    """One pattern set the page can switch to: its ``name``, the ``source`` of its cycles (a
    :class:`~fringe3d.live.cycles.CycleSource`: a :class:`~fringe3d.live.cycles.CameraCycles`)
    and the ``engine`` that reconstructs them."""

    name: str
    source: CycleSource
    engine: FrameReconstructor


@dataclass
class Controls:
    """What the page's controls ask for; read by the loop between cycles.

    ``paused`` (show nothing new), ``choice`` (the pattern set), ``colouring`` (``"z"`` or
    ``"texture"``), ``view`` (``"cloud"``: the points; ``"depth"``: the depth map as an image),
    ``exposure`` (a new exposure value not yet applied, or None), ``record`` (a ``(folder,
    cycles)`` request not yet started, or None) and ``stop``.
    """

    choice: str
    paused: bool = False
    colouring: str = "z"
    view: str = "cloud"
    exposure: float | None = None
    record: tuple | None = None
    stop: bool = False


class Viewer(Protocol):
    """What the loop draws on (:class:`fringe3d.live.viewer.ViserViewer` in a browser)."""

    def show_points(self, points: np.ndarray, colours: np.ndarray, arrival: float) -> None:
        """Draw ``(N, 3)`` float32 points (mm) with ``(N, 3)`` uint8 colours, replacing the last;
        ``arrival`` is the host time (``time.monotonic()``, s) their cycle arrived."""
        ...

    def show_depth(self, image: np.ndarray, arrival: float) -> None:
        """Show the ``(h, w, 3)`` uint8 depth image (:func:`~fringe3d.live.display.depth_image`)
        instead of the points; ``arrival`` as for :meth:`show_points`."""
        ...

    def busy(self) -> bool:
        """Whether the page is still drawing the last frame (the loop then waits before the next)."""
        ...

    def show_overlay(self, image: np.ndarray) -> None:
        """Show the ``(h, w, 3)`` uint8 mask overlay."""
        ...

    def show_stats(self, summary: dict) -> None:
        """Show the figures of :meth:`LiveStats.summary`."""
        ...

    def show_status(self, text: str) -> None:
        """Show a line of status (recordings)."""
        ...

    def clients(self) -> int:
        """Pages connected now."""
        ...


@dataclass(frozen=True)
class LiveSettings:
    """How a live run behaves.

    Attributes
    ----------
    frames : int or None
        Stop after showing this many 3D frames.
    seconds : float or None
        Stop after this many seconds of showing.
    step : int
        Draw every ``step``-th pixel in both directions.
    z_range : (float, float)
        Depths (mm) at the ends of the colour ramp.
    overlay_width : int
        Columns of the mask overlay at most.
    refresh : float
        Seconds between updates of the overlay and the figures.
    wait_viewer : float
        Seconds to wait for a page to connect before the first cycle (0: start at once).
    """

    frames: int | None = None
    seconds: float | None = None
    step: int = 1
    z_range: tuple[float, float] = (0.0, 1000.0)
    overlay_width: int = 320
    refresh: float = 0.5
    wait_viewer: float = 0.0


@dataclass(frozen=True)
class RecordSettings:
    """How recordings are written: ``meta`` for ``capture.json``, the ``rig`` (``rig.json``, or
    None), ``overwrite`` (replace a non-empty folder) and ``describe_error`` (an error as the
    page's status line says it)."""

    meta: dict = field(default_factory=dict)
    rig: Rig | None = None
    overwrite: bool = False
    describe_error: Callable[[BaseException], str] = str


class _Mailbox:
    """The newest cycle, replacing one not yet taken."""

    def __init__(self) -> None:
        self._cond = threading.Condition()
        self._item: Arrival | None = None
        self.replaced = 0

    def put(self, item: Arrival) -> None:
        with self._cond:
            if self._item is not None:
                self.replaced += 1
            self._item = item
            self._cond.notify()

    def take(self, timeout: float) -> Arrival | None:
        with self._cond:
            if self._item is None:
                self._cond.wait(timeout)
            item, self._item = self._item, None
            return item


class LiveSession:
    """Run the live loop (module docstring).

    Parameters
    ----------
    choices : list of Choice
        The pattern sets the page can switch between (the first is shown first).
    viewer : Viewer
        Where the points, overlay and figures go.
    settings : LiveSettings
        Limits and drawing settings.
    controls : Controls, optional
        The page's requests (the viewer writes into it); a fresh one by default.
    apply_exposure : callable, optional
        Sets the camera's exposure control to a value (called in the capture thread).
    record : RecordSettings, optional
        How recordings are written.
    """

    def __init__(self, choices: list[Choice], viewer: Viewer, settings: LiveSettings,
                 controls: Controls | None = None, apply_exposure: Callable[[float], None] | None = None,
                 record: RecordSettings | None = None):
        if not choices:
            raise ValueError("a live session needs at least one pattern set to show")
        self.choices = {c.name: c for c in choices}
        self.viewer = viewer
        self.settings = settings
        self.controls = controls or Controls(choice=choices[0].name)
        self.apply_exposure = apply_exposure
        self.record_settings = record or RecordSettings()
        self.stats = LiveStats()
        self.recordings: list[dict] = []
        self._mailbox = _Mailbox()
        self._capture_error: BaseException | None = None
        self._writers: list[threading.Thread] = []
        self._stopping = threading.Event()
        self._paused = 0

    # -- the capture thread -----------------------------------------------------------------
    def _capture(self) -> None:
        active = None
        recording: Recording | None = None
        try:
            while not self._stopping.is_set():
                c = self.controls
                choice = self.choices.get(c.choice) or next(iter(self.choices.values()))
                if choice is not active:
                    if active is not None:
                        active.source.stop()
                    choice.source.start()
                    active = choice
                if c.exposure is not None and self.apply_exposure is not None:
                    value, c.exposure = c.exposure, None
                    self.apply_exposure(value)
                if c.record is not None and recording is None:
                    folder, cycles = c.record
                    c.record = None
                    recording = Recording(Path(folder), int(cycles), choice.source.patterns)
                    self.viewer.show_status(f"recording {int(cycles)} cycle(s) into {folder}")
                arrival = choice.source.next_cycle()
                self.stats.arrived += 1
                if recording is not None and recording.patterns is choice.source.patterns:
                    if recording.add(arrival.frames, arrival.first_id):
                        self._write(recording)
                        recording = None
                self._mailbox.put(arrival)
        except BaseException as e:  # handed to the pipeline, which raises it
            self._capture_error = e
        finally:
            if recording is not None and recording.frames:  # stopped part way: keep the cycles taken
                self._write(recording)
            if active is not None:
                try:
                    active.source.stop()
                except Exception as e:  # the camera's own error is the one worth reporting
                    warnings.warn(f"stopping the camera failed: {e}", DeviceWarning, stacklevel=2)

    def _write(self, recording: Recording) -> None:
        rs = self.record_settings
        engine = next(c.engine for c in self.choices.values() if c.source.patterns is recording.patterns)
        meta = {**rs.meta, "reconstruct": {"method": engine.patterns.plans[0].method if engine.patterns.plans else None,
                                           "z_min": engine.z_min}}

        def write() -> None:
            try:
                done = write_recording(recording, meta, rs.rig, rs.overwrite)
                self.recordings.append(done)
                self.viewer.show_status(f"recorded {done['cycles']} cycle(s) ({done['frames']} frames) into "
                                        f"{done['folder']}")
            except (ValueError, OSError) as e:
                self.recordings.append({"folder": str(recording.folder), "error": rs.describe_error(e)})
                self.viewer.show_status(f"not recorded: {rs.describe_error(e)}")

        t = threading.Thread(target=write, name="fringe3d-live-record", daemon=False)
        self._writers.append(t)
        t.start()

    # -- the pipeline -----------------------------------------------------------------------
    def stop(self) -> None:
        """Ask the loop to finish after the current cycle."""
        self.controls.stop = True

    def _wait_for_viewer(self) -> None:
        deadline = time.monotonic() + self.settings.wait_viewer
        while self.viewer.clients() == 0 and time.monotonic() < deadline and not self.controls.stop:
            time.sleep(0.02)

    def _finished(self, t_first: float | None) -> bool:
        s = self.settings
        if self.controls.stop:
            return True
        if s.frames is not None and self.stats.frames_shown >= s.frames:
            return True
        return s.seconds is not None and t_first is not None and time.monotonic() - t_first >= s.seconds

    def reconstruct(self, arrival: Arrival, texture: bool) -> Cycle | None:
        """One cycle through its choice's engine (points, quality, the texture if asked).

        Parameters
        ----------
        arrival : Arrival
            The cycle.
        texture : bool
            Compute the texture too.

        Returns
        -------
        Cycle or None
            The engine's result; None when no pixel has a phase (nothing to show).
        """
        engine = self.choices[arrival.choice].engine
        try:
            return engine.reconstruct(arrival.frames, uncertainty=False, texture=texture)
        except EmptyMaskError:
            return None

    def run(self) -> dict:
        """Show cycles until a limit, :meth:`stop` or Ctrl-C; the run's figures.

        Returns
        -------
        dict
            :meth:`LiveStats.summary` plus ``recordings`` (one dict per recording: ``folder``,
            ``frames``, ``cycles`` or ``error``).
        """
        if self.settings.wait_viewer > 0:
            self._wait_for_viewer()
        capture = threading.Thread(target=self._capture, name="fringe3d-live-capture", daemon=True)
        capture.start()
        try:
            self._pipeline()
        finally:
            self._stopping.set()
            capture.join(timeout=5.0)
            for t in self._writers:
                t.join()
            summary = self.summary()
            self.viewer.show_stats(summary)
        return summary

    def summary(self) -> dict:
        """The run's figures so far (:meth:`LiveStats.summary` plus ``recordings``).

        Returns
        -------
        dict
            The figures.
        """
        self.stats.skipped = self._mailbox.replaced + self._paused
        return {**self.stats.summary(), "recordings": list(self.recordings)}

    def _next(self) -> Arrival | None:
        """The newest cycle (None after 0.2 s without one); raises what the capture thread raised."""
        arrival = self._mailbox.take(timeout=0.2)
        if self._capture_error is not None:
            raise self._capture_error
        return arrival

    def _warm_up(self) -> float:
        """Reconstruct the first cycle unshown (the kernels load or compile) and return the time it
        ended: cycles that arrived before it waited in buffers, they are not shown."""
        while not self.controls.stop:
            arrival = self._next()
            if arrival is not None:
                self.reconstruct(arrival, texture=True)
                self.stats.warm_up += 1
                break
        return time.monotonic()

    def _pipeline(self) -> None:
        s = self.settings
        t_first: float | None = None
        t_refresh = 0.0
        warm = self._warm_up()
        while not self._finished(t_first):
            if self.viewer.busy():  # the page has not drawn the last frame: the newest cycle waits in the mailbox
                time.sleep(0.002)
                continue
            arrival = self._next()
            if arrival is None:
                continue
            if arrival.arrival < warm:
                self.stats.warm_up += 1
                continue
            if self.controls.paused:
                self._paused += 1
                continue
            refresh = time.monotonic() - t_refresh >= s.refresh
            depth = self.controls.view == "depth"
            cyc = self.reconstruct(arrival, texture=refresh or (self.controls.colouring == "texture" and not depth))
            if cyc is None or cyc.points is None:
                self.stats.empty += 1
            if depth:
                points = (cyc.points if cyc is not None and cyc.points is not None
                          else np.full((*arrival.frames.shape[1:], 3), np.nan, np.float32))
                image = depth_image(points, cyc.quality if cyc is not None else None, s.z_range, s.step)
                self.viewer.show_depth(image, arrival.arrival)
                count = int(np.count_nonzero(np.isfinite(points[::s.step, ::s.step, 2])))
            else:
                if cyc is None or cyc.points is None:
                    pts, cols = np.zeros((0, 3), np.float32), np.zeros((0, 3), np.uint8)
                else:
                    colouring = self.controls.colouring if cyc.texture is not None else "z"
                    pts, cols = display_points(cyc.points, cyc.texture, colouring, s.z_range, s.step)
                self.viewer.show_points(pts, cols, arrival.arrival)
                count = len(pts)
            sent = time.monotonic()
            self.stats.shown(arrival.arrival, sent, count)
            t_first = sent if t_first is None else t_first
            if refresh:
                t_refresh = sent
                quality = cyc.quality if cyc is not None else np.full(arrival.frames.shape[1:], INVALID, np.uint8)
                self.viewer.show_overlay(mask_overlay(cyc.texture if cyc is not None else None, quality,
                                                      s.overlay_width))
                self.viewer.show_stats(self.summary())
