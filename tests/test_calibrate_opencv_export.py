"""``fringe3d calibrate --export-opencv``: an existing calibration (or rig) JSON as an OpenCV
FileStorage YAML, read back by cv2.FileStorage (independent reader) and by the importer."""
from __future__ import annotations

import cv2
import numpy as np

from fringe3d.calibrate.calibration_file import Calibration
from fringe3d.calibrate.opencv_file import load_opencv_calibration
from fringe3d.cli import main
from fringe3d.sim import presets


def _calibration(tmp_path):
    rig = presets.get("tiny").rig

    def stats(dev, rms):
        return {"width": dev.width, "height": dev.height, "dist_model": "k1k2", "rms_px": rms,
                "per_pose_rms_px": [rms]}

    cal = Calibration("pinhole", rig, stats(rig.camera, 0.05), stats(rig.projector, 0.07),
                      {"cols": 9, "rows": 7, "spacing": 10.0}, {"v": 12.5}, {"v": 0.0},
                      [{"name": "p0", "camera_rms_px": 0.05, "projector_rms_px": 0.07, "points": 63}],
                      {"camera_px": 0.05, "projector_px": 0.07})
    return cal.save(tmp_path / "calib.json"), rig


def test_export_opencv_writes_an_existing_calibration_opencv_reads_back(tmp_path, capsys):
    src, rig = _calibration(tmp_path)
    out = tmp_path / "calib.yaml"
    assert main(["calibrate", "--export-opencv", str(src), "-o", str(out), "-q"]) == 0
    fs = cv2.FileStorage(str(out), cv2.FILE_STORAGE_READ)
    try:
        np.testing.assert_array_equal(fs.getNode("camera_K").mat(), rig.camera.K)
        np.testing.assert_array_equal(fs.getNode("projector_K").mat(), rig.projector.K)
        np.testing.assert_array_equal(fs.getNode("R").mat(), rig.projector.R)
        np.testing.assert_array_equal(fs.getNode("T").mat().ravel(), rig.projector.t)
        assert fs.getNode("projector_rms").real() == 0.07 and fs.getNode("period_v").real() == 12.5
    finally:
        fs.release()
    back = load_opencv_calibration(out)
    for a, b in ((back.camera, rig.camera), (back.projector, rig.projector)):
        assert a.size == b.size
        for k in ("K", "dist", "R", "t"):
            assert np.array_equal(getattr(a, k), getattr(b, k)), k


def test_export_opencv_takes_a_plain_rig_json_and_refuses_bad_inputs_before_writing(tmp_path, capsys):
    rig = presets.get("tiny").rig
    rig.save(tmp_path / "rig.json")
    out = tmp_path / "rig.yaml"
    assert main(["calibrate", "--export-opencv", str(tmp_path / "rig.json"), "-o", str(out), "-q"]) == 0
    np.testing.assert_array_equal(load_opencv_calibration(out).projector.t, rig.projector.t)
    capsys.readouterr()
    assert main(["calibrate", "--export-opencv", str(tmp_path / "missing.json"), "-o", str(tmp_path / "m.yaml")]) == 2
    assert not (tmp_path / "m.yaml").exists() and "missing.json" in capsys.readouterr().err
    assert main(["calibrate", "--export-opencv", str(tmp_path / "rig.json"), "-o", str(tmp_path / "x.json")]) == 2
    assert not (tmp_path / "x.json").exists() and ".yaml" in capsys.readouterr().err
