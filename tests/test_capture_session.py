"""``fringe3d capture --session DIR --poses N --auto`` on the virtual rig (a hand-held board held
still at each pose): one complete pose folder per pose, and ``fringe3d calibrate DIR`` reads it."""
import json

import numpy as np


from fringe3d.cli import main

CAMERA = "virtual:tiny?scene=handheld-board&poses=3&hold=2.3&move=0.1&frame_rate=20"


def test_auto_session_captures_each_still_pose_once_and_calibrates(tmp_path, capsys):
    pats, sess = tmp_path / "pats", tmp_path / "session"
    assert main(["patterns", "--set", "calibration", "--width", "256", "--height", "200", "-o", str(pats), "-q"]) == 0
    code = main(["capture", str(pats), "--session", str(sess), "--poses", "3", "--auto", "--still", "0.5",
                 "--no-preview", "--spacing", "12", "--projector", "virtual:tiny", "--camera", CAMERA, "--json"])
    assert code == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["pose_folders"] == ["pose_00", "pose_01", "pose_02"]
    centres = []
    for name in summary["pose_folders"]:
        meta = json.loads((sess / name / "capture.json").read_text())
        assert meta["complete"] is True and meta["frames_received"] == 31
        centres.append(np.array(meta["board_centres_px"]))
    # three different poses (the board moved between them), not one pose three times
    assert min(np.abs(a - b).max() for i, a in enumerate(centres) for b in centres[i + 1:]) > 5
    assert json.loads((sess / "session.json").read_text())["board"]["spacing"] == 12
    # three poses are below the calibration's pose-count gate: --accept-poor writes it anyway
    assert main(["calibrate", str(sess), "-o", str(tmp_path / "cal.json"), "--json", "--accept-poor"]) == 0
    cal = json.loads(capsys.readouterr().out)
    assert cal["skipped_poses"] == [] and cal["rms"]["camera_px"] < 0.2


def test_session_without_preview_needs_auto(tmp_path, capsys):
    pats = tmp_path / "pats"
    assert main(["patterns", "--set", "calibration", "--width", "256", "--height", "200", "-o", str(pats), "-q"]) == 0
    code = main(["capture", str(pats), "--session", str(tmp_path / "s"), "--no-preview", "--projector", "virtual:tiny",
                 "--camera", CAMERA])
    assert code == 2 and "use --auto or --preview" in " ".join(capsys.readouterr().err.split())


def test_preview_window_under_xvfb_takes_a_pose(tmp_path, xvfb, capsys):
    pats, sess = tmp_path / "pats", tmp_path / "session"
    assert main(["patterns", "--set", "calibration", "--width", "256", "--height", "200", "-o", str(pats), "-q"]) == 0
    code = main(["capture", str(pats), "--session", str(sess), "--poses", "1", "--auto", "--still", "0.5", "--preview",
                 "--projector", "virtual:tiny", "--camera", CAMERA, "--json"])
    assert code == 0
    assert json.loads(capsys.readouterr().out)["pose_folders"] == ["pose_00"]
    assert json.loads((sess / "pose_00" / "capture.json").read_text())["complete"] is True
