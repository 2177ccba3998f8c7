"""A turntable on a GRBL (or grblHAL) controller's rotary axis, over a serial line.

The controller speaks GRBL 1.1's line protocol: each G-code line is answered ``ok`` or
``error:N``; ``?`` (a real-time command, no newline) is answered by a status report
``<Idle|MPos:x,y,z[,a]|...>``; ``Ctrl-X`` resets it (it then prints its ``Grbl ...`` banner).
:class:`GrblStage` moves with ``G90 G0`` (or ``G1 F`` with a feed rate), waits for the motion
to end with ``G4 P0`` (its ``ok`` comes once the planner has run dry), then checks the machine
position in a status report against the target. An alarm (``ALARM:N`` or an ``Alarm`` state) or
an ``error:N`` reply raises :class:`~fringe3d.devices.base.DeviceError` naming the line sent.

Positions are degrees; ``scale`` converts them into controller units (GRBL moves in mm, so a
rotary axis is usually set up with ``$10x`` steps per degree: ``scale`` 1). The stage's own
frame has the table axis along z through the origin: a real table's axis in the camera frame
comes from the axis calibration (:mod:`fringe3d.multiview.axis`).

The serial line is a POSIX terminal (``termios``: Linux, macOS); Windows is not supported.
Tested against an emulated controller on a pseudo-terminal, never against a physical one.
"""
from __future__ import annotations

import os
import re
import select
import time

import numpy as np

from .base import DeviceError, DeviceNotFoundError
from .stage import rotation_about

AXES = ("X", "Y", "Z", "A", "B", "C")
_STATUS = re.compile(r"<(?P<state>[A-Za-z]+)(?::\d+)?\|(?:MPos|WPos):(?P<pos>[-0-9.,]+)")


class SerialLine:
    """A raw serial line (POSIX ``termios``) with line reads and a timeout."""

    def __init__(self, path: str, baud: int = 115200):
        import termios
        import tty

        speed = getattr(termios, f"B{int(baud)}", None)
        if speed is None:
            raise ValueError(f"grbl stage: baud rate {baud} is not a standard rate (e.g. 115200)")
        try:
            self.fd = os.open(path, os.O_RDWR | os.O_NOCTTY | os.O_NONBLOCK)
        except OSError as e:
            raise DeviceNotFoundError(f"grbl stage: cannot open serial port {path}: {e.strerror}") from None
        try:
            tty.setraw(self.fd)
            attrs = termios.tcgetattr(self.fd)
            attrs[4] = attrs[5] = speed
            termios.tcsetattr(self.fd, termios.TCSANOW, attrs)
        except termios.error as e:
            os.close(self.fd)
            raise DeviceNotFoundError(f"grbl stage: {path} is not a serial port ({e})") from None
        self._buf = b""

    def write(self, data: bytes) -> None:
        os.write(self.fd, data)

    def readline(self, timeout: float) -> str | None:
        """The next non-empty line (stripped), or None after ``timeout`` s without one."""
        end = time.monotonic() + timeout
        while True:
            while b"\n" in self._buf:
                line, self._buf = self._buf.split(b"\n", 1)
                text = line.decode("ascii", "replace").strip()
                if text:
                    return text
            left = end - time.monotonic()
            if left <= 0:
                return None
            ready, _, _ = select.select([self.fd], [], [], left)
            if ready:
                try:
                    chunk = os.read(self.fd, 4096)
                except BlockingIOError:
                    continue
                if not chunk:
                    raise DeviceError("grbl stage: the serial line closed")
                self._buf += chunk

    def close(self) -> None:
        os.close(self.fd)


class GrblStage:
    """A turntable on axis ``axis`` of a GRBL controller at ``port`` (see the module docstring).

    Parameters
    ----------
    port : str
        The serial device (``/dev/ttyUSB0``, ``/dev/ttyACM0``).
    axis : str
        The controller axis the table is on (X, Y, Z or A, B, C on grblHAL).
    baud : int
        Baud rate.
    feed : float, optional
        Feed rate (controller units per minute) for ``G1``; None moves with ``G0`` (rapid).
    scale : float
        Controller units per degree.
    timeout : float
        Seconds a move may take.
    """

    def __init__(self, port: str, axis: str = "X", baud: int = 115200, feed: float | None = None,
                 scale: float = 1.0, timeout: float = 60.0):
        self.axis = str(axis).upper()
        if self.axis not in AXES:
            raise ValueError(f"grbl stage: axis must be one of {', '.join(AXES)}, got {axis!r}")
        if not (np.isfinite(scale) and scale != 0):
            raise ValueError(f"grbl stage: scale (controller units per degree) must be non-zero, got {scale}")
        if feed is not None and not feed > 0:
            raise ValueError(f"grbl stage: feed must be > 0 (units per minute), got {feed}")
        self.port, self.feed, self.scale, self.timeout = port, feed, float(scale), float(timeout)
        self.line = SerialLine(port, baud)
        self._position = 0.0
        try:
            self.banner = self._reset()
            self._position = self._status()[1] / self.scale
        except BaseException:
            self.line.close()
            raise

    # -- protocol ------------------------------------------------------------------------------
    def _reset(self) -> str:
        self.line.write(b"\x18")
        end = time.monotonic() + 5.0
        while time.monotonic() < end:
            text = self.line.readline(max(0.0, end - time.monotonic()))
            if text is None:
                break
            if text.lower().startswith("grbl"):
                return text
        raise DeviceError(f"grbl stage: no GRBL banner from {self.port} within 5 s after a reset "
                          "(wrong port or baud rate?)")

    def _command(self, line: str, timeout: float) -> None:
        self.line.write(line.encode("ascii") + b"\n")
        end = time.monotonic() + timeout
        while True:
            text = self.line.readline(max(0.0, end - time.monotonic()))
            if text is None:
                raise DeviceError(f"grbl stage: no reply to {line!r} within {timeout:g} s")
            if text == "ok":
                return
            if text.startswith("error:"):
                raise DeviceError(f"grbl stage: the controller refused {line!r} ({text})")
            if text.startswith("ALARM:"):
                raise DeviceError(f"grbl stage: alarm {text} after {line!r}; clear it at the controller "
                                  "(check limits, then $X or $H)")
            # other messages ([MSG:...], echoes) are informational

    def _status(self) -> tuple[str, float]:
        self.line.write(b"?")
        end = time.monotonic() + 2.0
        while True:
            text = self.line.readline(max(0.0, end - time.monotonic()))
            if text is None:
                raise DeviceError(f"grbl stage: no status report from {self.port} within 2 s")
            m = _STATUS.match(text)
            if m is None:
                continue
            state = m.group("state")
            if state == "Alarm":
                raise DeviceError(f"grbl stage: the controller is in alarm ({text}); clear it (check limits, "
                                  "then $X or $H)")
            values = [float(v) for v in m.group("pos").split(",") if v]
            i = "XYZABC".index(self.axis)
            if i >= len(values):
                raise DeviceError(f"grbl stage: the status report {text!r} has no {self.axis} axis")
            return state, values[i]

    # -- Stage protocol --------------------------------------------------------------------------
    def move_to(self, position: float) -> None:
        """Move to ``position`` degrees and wait until the controller reports it there."""
        if not np.isfinite(position):
            raise ValueError(f"grbl stage: position must be a finite angle in degrees, got {position}")
        target = float(position) * self.scale
        move = f"G90 G0 {self.axis}{target:.4f}" if self.feed is None else \
            f"G90 G1 {self.axis}{target:.4f} F{self.feed:g}"
        self._command(move, 5.0)
        self._command("G4 P0", self.timeout)  # ok once the motion has finished
        state, at = self._status()
        if state != "Idle" or abs(at - target) > 1e-3 + 1e-6 * abs(target):
            raise DeviceError(f"grbl stage: after {move!r} the controller reports {state} at {at:g}, "
                              f"expected Idle at {target:g}")
        self._position = at / self.scale

    @property
    def position(self) -> float:
        return self._position

    def transform(self) -> np.ndarray:
        """Rotation by the position about the stage's own z axis (stage frame, mm)."""
        return rotation_about((0.0, 0.0, 1.0), np.deg2rad(self._position))

    def describe(self) -> dict:
        return {"kind": "GRBL rotary axis", "port": self.port, "axis_letter": self.axis, "unit": "deg",
                "scale": self.scale, "feed": self.feed, "firmware": self.banner}

    def close(self) -> None:
        self.line.close()
