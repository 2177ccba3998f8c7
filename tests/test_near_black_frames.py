"""Near-black frames (every pixel at most 3 counts of noise): ``decode`` and ``reconstruct``
warn, exit 2 with the reason and write nothing."""
from __future__ import annotations

import shutil

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.io.capture import read_capture, write_capture


@pytest.fixture(scope="module")
def dark_capture(tmp_path_factory):
    root = tmp_path_factory.mktemp("dark")
    assert main(["simulate", "-o", str(root / "cap"), "--preset", "tiny", "--scene", "plane", "-q"]) == 0
    cap = read_capture(root / "cap")
    noise = np.random.default_rng(5).integers(0, 4, cap.frames.shape).astype(cap.frames.dtype)
    write_capture(root / "dark", noise, cap.patterns, cap.meta)
    shutil.copy(root / "cap" / "rig.json", root / "dark" / "rig.json")
    return root / "dark"


@pytest.mark.parametrize("command", ["decode", "reconstruct"])
def test_near_black_frames_warn_exit_2_saying_why_and_write_nothing(dark_capture, tmp_path, capsys, command):
    out = tmp_path / "out"
    extra = ["-c", str(dark_capture / "rig.json")] if command == "reconstruct" else []
    assert main([command, str(dark_capture), "-o", str(out), *extra]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "frames are dark" in err                                    # the DataQualityWarning
    assert f"{dark_capture}: no valid" in err and "nearly black" in err  # the reason, naming the capture
    assert "below 2% of full scale 255" in err
    assert "Traceback" not in err
    assert not out.exists()
