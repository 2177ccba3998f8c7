"""The same calibration session gives the same calibration file, byte for byte apart from its
provenance (OpenCV's threaded solvers run serially inside calibration)."""
from __future__ import annotations

import json

from fringe3d.cli import main


def test_calibrating_one_session_three_times_gives_identical_json(tmp_path):
    session = tmp_path / "session"
    outputs = []
    for i in range(3):
        out = tmp_path / f"cal{i}.json"
        args = ["calibrate", str(session), "-o", str(out), "-q"]
        if i == 0:  # render the session once, then calibrate the same frames again
            args += ["--simulate", "tiny", "--poses", "6", "--seed", "0"]
        assert main(args) == 0
        d = json.loads(out.read_text())
        assert d.pop("provenance")["units"]  # its time and command line differ between the runs
        outputs.append(json.dumps(d))
    assert outputs[1] == outputs[0] and outputs[2] == outputs[0]
