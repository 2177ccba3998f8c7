"""The GRBL turntable driver against an emulated GRBL 1.1 controller on a pseudo-terminal: moves,
waits, checks the reported position, names errors and alarms; ``capture --views`` with it
records the stage angles (no poses without an axis calibration). No physical controller."""
from __future__ import annotations

import json
import os
import re
import threading
import tty

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.devices.base import DeviceError
from fringe3d.devices.stage_backends import open_stage

BANNER = b"\r\nGrbl 1.1h ['$' for help]\r\n"


class EmulatedGrbl:
    """GRBL 1.1's replies on the master side of a pty: banner after Ctrl-X, status after ``?``,
    ``ok`` (or ``error:N`` / ``ALARM:N`` when told) after each line; G0/G1 set the axis."""

    def __init__(self, mode: str = "ok"):
        self.master, self.slave = os.openpty()
        tty.setraw(self.slave)
        self.port = os.ttyname(self.slave)
        self.mode = mode
        self.pos = {"X": 0.0, "Y": 0.0, "Z": 0.0}
        self.lines: list[str] = []
        self._stop = False
        self._thread = threading.Thread(target=self._serve, daemon=True)
        self._thread.start()

    def _send(self, data: bytes) -> None:
        os.write(self.master, data)

    def _status(self) -> bytes:
        state = "Alarm" if self.mode == "alarm" else "Idle"
        p = self.pos
        return f"<{state}|MPos:{p['X']:.3f},{p['Y']:.3f},{p['Z']:.3f}|FS:0,0>\r\n".encode()

    def _line(self, text: str) -> bytes:
        self.lines.append(text)
        if self.mode == "error" and text.startswith("G90"):
            return b"error:15\r\n"  # travel exceeded
        m = re.match(r"G90 G[01] ([XYZ])(-?[0-9.]+)", text)
        if m:
            self.pos[m.group(1)] = float(m.group(2))
        return b"[MSG:echo]\r\nok\r\n"

    def _serve(self) -> None:
        buf = b""
        while not self._stop:
            try:
                chunk = os.read(self.master, 1024)
            except OSError:
                return
            for byte in chunk:
                c = bytes([byte])
                if c == b"\x18":
                    self._send(BANNER)
                elif c == b"?":
                    self._send(self._status())
                elif c == b"\n":
                    line, buf = buf.decode().strip(), b""
                    if line:
                        self._send(self._line(line))
                else:
                    buf += c

    def close(self) -> None:
        self._stop = True
        for fd in (self.slave, self.master):
            try:
                os.close(fd)
            except OSError:
                pass


@pytest.fixture
def grbl(request):
    ctl = EmulatedGrbl(getattr(request, "param", "ok"))
    yield ctl
    ctl.close()


def test_grbl_stage_moves_waits_and_reports_the_controller_position(grbl):
    stage = open_stage(f"grbl:{grbl.port}?axis=Y&scale=2")
    try:
        assert stage.describe()["firmware"].startswith("Grbl 1.1h")
        stage.move_to(30.0)
        assert stage.position == pytest.approx(30.0)
        assert grbl.pos["Y"] == pytest.approx(60.0)  # 2 controller units per degree
        assert grbl.lines == ["G90 G0 Y60.0000", "G4 P0"]  # the move, then the wait for its end
        c, s = np.cos(np.deg2rad(30.0)), np.sin(np.deg2rad(30.0))
        assert np.allclose(stage.transform()[:3, :3], [[c, -s, 0], [s, c, 0], [0, 0, 1]])
    finally:
        stage.close()


@pytest.mark.parametrize("grbl, expected", [
    ("error", "the controller refused 'G90 G0 X10.0000' (error:15)"),
], indirect=["grbl"])
def test_a_refused_move_is_a_device_error_naming_the_line_and_the_code(grbl, expected):
    stage = open_stage(f"grbl:{grbl.port}")
    try:
        with pytest.raises(DeviceError, match=re.escape(expected)):
            stage.move_to(10.0)
    finally:
        stage.close()


@pytest.mark.parametrize("grbl", ["alarm"], indirect=True)
def test_a_controller_in_alarm_is_refused_when_opened(grbl):
    with pytest.raises(DeviceError, match=r"in alarm \(<Alarm\|MPos"):
        open_stage(f"grbl:{grbl.port}")


@pytest.mark.parametrize("spec, expected", [
    ("grbl:", "give the serial port"),
    ("grbl:/dev/nonexistent-fringe3d-port", "cannot open serial port /dev/nonexistent-fringe3d-port"),
    ("grbl:/dev/null", "is not a serial port"),
    ("grbl:/dev/null?axis=Q", "axis must be one of X, Y, Z, A, B, C"),
    ("grbl:/dev/null?speed=3", "unknown option(s) ['speed']"),
])
def test_bad_grbl_specs_get_clear_messages(spec, expected):
    with pytest.raises(ValueError, match=re.escape(expected)):
        open_stage(spec)


def test_capture_views_on_a_grbl_stage_records_angles_and_refuses_to_merge_without_an_axis(grbl, tmp_path, capsys):
    pats, out = tmp_path / "pats", tmp_path / "scan"
    assert main(["patterns", "--set", "phase-shift", "--width", "256", "--height", "200", "-o", str(pats), "-q"]) == 0
    assert main(["capture", str(pats), "-o", str(out), "--views", "3", "--stage", f"grbl:{grbl.port}?step=45",
                 "--projector", "virtual:tiny", "--camera", "virtual:tiny", "-q"]) == 0
    doc = json.loads((out / "poses.json").read_text())
    assert [v["angle_deg"] for v in doc["views"]] == [0.0, 45.0, 90.0]
    assert all("matrix" not in v for v in doc["views"]) and doc["stage"]["kind"] == "GRBL rotary axis"
    assert grbl.pos["X"] == pytest.approx(90.0)
    assert json.loads((out / "view-02" / "capture.json").read_text())["stage"]["position"] == 90.0
    from fringe3d.multiview.poses import read_poses
    with pytest.raises(ValueError, match="recorded without a turntable axis"):
        read_poses(out / "poses.json")
