"""Calibration capture: a live preview of the board, and one calibration set per board pose.

:func:`capture_session` shows white on the projector and grabs preview frames (software
trigger). In each frame it looks for the circle board (:func:`fringe3d.calibrate.board_detection.find_board`).
A pose is taken when the user presses space in the preview window, or with ``auto`` when the
board has been found in every frame of the last ``still_seconds`` (camera timestamps) with
every centre within ``still_px`` pixels of where it is now ("found and still for a second").
After a pose the board must move (a centre more than ``moved_px`` away, or out of view) before
the next one can be taken, so one pose is never captured twice. Each pose's calibration set
goes through :func:`fringe3d.devices.acquire.capture_sequence` into ``DIR/pose_XX/`` (a
complete capture folder each), and ``DIR/session.json`` records the board, so that
``fringe3d calibrate DIR`` reads the session unchanged.

The preview window (pyglet, needs a display) shows the camera image with the detected centres
drawn on it, the poses taken so far and how long the board has been still; space captures,
Esc / q stops early.
"""
from __future__ import annotations

import time
from dataclasses import dataclass
from pathlib import Path

import cv2
import numpy as np

from fringe3d.calibrate.board_detection import find_board
from fringe3d.calibrate.boards import CircleBoard
from fringe3d.utils.jsonfile import write_json

from .acquire import CaptureTiming, capture_sequence
from .base import DeviceError, require_module


class PreviewWindow:
    """A plain pyglet window showing camera frames with an overlay; ``keys`` collects presses."""

    def __init__(self, width: int, height: int):
        pyglet = require_module("window")
        self._pyglet = pyglet
        self.window = pyglet.window.Window(width, height, caption="fringe3d calibration preview")
        self.keys: list[str] = []

        @self.window.event
        def on_key_press(symbol, modifiers):
            key = pyglet.window.key
            if symbol == key.SPACE:
                self.keys.append("capture")
            elif symbol in (key.ESCAPE, key.Q):
                self.keys.append("quit")
            return True

        self.label = pyglet.text.Label("", x=4, y=4, color=(255, 255, 0, 255), font_size=10)

    def update(self, image: np.ndarray, uv, text: str) -> None:
        pyglet = self._pyglet
        img = np.asarray(image)
        if img.dtype != np.uint8:
            img = np.clip(img.astype(float) * 255.0 / max(1.0, float(img.max())), 0, 255).astype(np.uint8)
        rgb = cv2.cvtColor(img, cv2.COLOR_GRAY2RGB)
        if uv is not None:
            for u, v in uv:
                cv2.circle(rgb, (int(round(u)), int(round(v))), 3, (0, 255, 0), 1)
        h, w = rgb.shape[:2]
        win = self.window
        win.switch_to()
        win.dispatch_events()
        data = pyglet.image.ImageData(w, h, "RGB", np.ascontiguousarray(rgb[::-1]).tobytes())
        win.clear()
        data.blit(0, 0, width=win.width, height=win.height)
        self.label.text = text
        self.label.draw()
        win.flip()

    def close(self) -> None:
        self.window.close()


@dataclass(frozen=True)
class SessionBoard:
    """The circle board of a captured session; only its layout is needed to find it.

    Attributes
    ----------
    cols : int
        Circles per row.
    rows : int
        Rows of circles.
    spacing : float | None
        Grid spacing (mm), written to ``session.json`` for calibration; ``None``: not written
        (the board is found with a 10 mm spacing).
    radius : float | None
        Circle radius (mm); ``None`` = a quarter of the spacing.
    """

    cols: int = 9
    rows: int = 9
    spacing: float | None = None
    radius: float | None = None

    def circle_board(self) -> CircleBoard:
        """The :class:`~fringe3d.calibrate.boards.CircleBoard` to look for."""
        s = float(self.spacing) if self.spacing else 10.0
        return CircleBoard(cols=self.cols, rows=self.rows, spacing=s,
                           radius=float(self.radius) if self.radius else 0.25 * s)


@dataclass(frozen=True)
class PoseTrigger:
    """When a board pose is taken (see the module docstring).

    Attributes
    ----------
    auto : bool
        Capture when the board is found and still for ``still_seconds`` (camera time).
    preview : bool
        Show the preview window (needs a display); without it ``auto`` is required.
    still_seconds : float
        How long (s, camera time) the board must be still before an automatic capture.
    still_px : float
        Largest movement (camera px) of a circle centre that still counts as still.
    moved_px : float
        Movement (camera px) of a centre that re-arms the trigger after a pose.
    pose_timeout : float
        Give up when no pose is taken within this many seconds of camera time.
    """

    auto: bool = True
    preview: bool = False
    still_seconds: float = 1.0
    still_px: float = 0.5
    moved_px: float = 5.0
    pose_timeout: float = 120.0


@dataclass(frozen=True)
class GrabTiming:
    """The timing of every grab of a session (preview frames and calibration sets).

    Attributes
    ----------
    settle : float
        Wait (s) after showing a pattern before triggering the camera.
    timeout : float
        Longest wait (s) for a camera frame.
    """

    settle: float = 0.0
    timeout: float = 1.0


def capture_session(projector, camera, patterns, images, folder, poses: int, *,
                    board: SessionBoard = SessionBoard(), trigger: PoseTrigger = PoseTrigger(),
                    timing: GrabTiming = GrabTiming(), extra_meta: dict | None = None) -> dict:
    """Capture ``poses`` board poses into ``folder/pose_XX`` (see the module docstring).

    Parameters
    ----------
    projector, camera : the devices
    patterns, images : the calibration set (PatternSet) and its 8-bit frames
    folder : the session folder (created)
    poses : number of board poses to take
    board : SessionBoard
        The circle board (cols, rows; spacing and radius in mm).
    trigger : PoseTrigger
        When a pose is taken: automatically (still for seconds, px) or by key in the preview
        window, and the pose timeout (s).
    timing : GrabTiming
        Settle time and frame timeout (s) of every grab.
    extra_meta : dict, optional
        Extra fields for every pose's ``capture.json``.

    Returns
    -------
    dict: folder, poses, pose folders, preview frames per pose.
    """
    auto, preview, still_seconds = trigger.auto, trigger.preview, trigger.still_seconds
    still_px, moved_px, pose_timeout = trigger.still_px, trigger.moved_px, trigger.pose_timeout
    settle, timeout, spacing = timing.settle, timing.timeout, board.spacing
    if poses < 1:
        raise ValueError(f"`poses` must be >= 1, got {poses}")
    if not preview and not auto:
        raise ValueError("without the preview window nothing can press the capture key: use "
                         "`auto=True` or `preview=True`")
    if not any(f.kind == "white" for f in patterns.frames):
        raise ValueError("the calibration pattern set has no white frame to find the board in; pass "
                         "the 'calibration' pattern set as `patterns`")
    grid = board.circle_board()

    folder = Path(folder)
    folder.mkdir(parents=True, exist_ok=True)
    white = np.full((projector.height, projector.width), 255, np.uint8)
    win = PreviewWindow(*_preview_size(camera)) if preview else None
    taken: list[str] = []
    frames_per_pose: list[int] = []
    last_uv = None
    armed = True
    stamps: list[float] = []
    use_host = False
    try:
        while len(taken) < poses:
            history: list[tuple[float, np.ndarray]] = []
            camera.trigger_mode = "software"
            camera.start()
            t_start = None
            n_preview = 0
            go = False
            try:
                projector.show(white)
                while not go:
                    if settle > 0:
                        time.sleep(settle)
                    camera.trigger()
                    fr = camera.grab(timeout)
                    n_preview += 1
                    stamps.append(fr.timestamp)
                    if len(stamps) == 2 and not any(stamps):  # the camera has no timestamps: host clock
                        use_host = True
                        history.clear()
                        t_start = None
                    t = fr.host_time if use_host else fr.timestamp
                    t_start = t if t_start is None else t_start
                    if t - t_start > pose_timeout:
                        raise DeviceError(f"no board pose was taken within {pose_timeout:g} s "
                                          f"({len(taken)} of {poses} poses done)")
                    uv, _ = find_board(fr.image, grid)
                    if uv is None:
                        history.clear()
                        armed = True
                    else:
                        if last_uv is not None and np.max(np.linalg.norm(uv - last_uv, axis=1)) > moved_px:
                            armed = True
                        history.append((t, uv))
                        history = [(tt, u) for tt, u in history
                                   if np.max(np.linalg.norm(u - uv, axis=1)) <= still_px]
                        # keep only the unbroken run of still frames ending now
                    still_for = (t - history[0][0]) if history and len(history) > 1 else 0.0
                    keys = win.keys if win is not None else []
                    if win is not None:
                        win.update(fr.image, uv, f"poses {len(taken)}/{poses}  board "
                                   f"{'found' if uv is not None else 'not found'}  still {still_for:.1f} s"
                                   f"{'' if armed else '  (move the board)'}")
                    if "quit" in keys:
                        raise KeyboardInterrupt("stopped from the preview window")
                    if uv is not None and armed and (
                            (auto and still_for >= still_seconds) or "capture" in keys):
                        go = True
                    keys.clear()
            finally:
                camera.stop()
            name = f"pose_{len(taken):02d}"
            capture_sequence(projector, camera, patterns, images, folder / name,
                             timing=CaptureTiming(settle=settle, timeout=timeout),
                             extra_meta={**(extra_meta or {}), "session_pose": len(taken),
                                         "board_centres_px": history[-1][1].tolist()})
            taken.append(name)
            frames_per_pose.append(n_preview)
            last_uv = history[-1][1]
            armed = False
    finally:
        if win is not None:
            win.close()
    meta = {"format": "fringe3d-session", "poses": taken, "captured_with": "fringe3d capture --session"}
    if spacing:
        meta["board"] = grid.to_dict()
    write_json(folder / "session.json", meta, units={"spacing": "mm"})
    return {"folder": str(folder), "poses": len(taken), "pose_folders": taken, "preview_frames": frames_per_pose}


def _preview_size(camera) -> tuple[int, int]:
    x, y, w, h = camera.roi
    return int(w), int(h)
