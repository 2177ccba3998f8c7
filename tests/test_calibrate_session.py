"""End-to-end calibration on simulated sessions (sim.render -> decode -> phase mapping -> rig),
the calibrate command, the calibration file, and the bad-input errors."""
import json

import numpy as np
import pytest

from fringe3d.calibrate.calibration_file import export_opencv_yaml, load_calibration
from fringe3d.calibrate.evaluation import rotation_angle_deg
from fringe3d.calibrate.session import PoseCapture, calibrate_observations, calibrate_session, observe_session
from fringe3d.calibrate.session_settings import ObservationSettings
from fringe3d.cli import main
from fringe3d.optics import Rig
from fringe3d.sim.calibration_session import SessionImaging, SessionOptics, simulate_session
from fringe3d.utils.warning_types import CalibrationWarning


@pytest.fixture(scope="module")
def tiny_session(tmp_path_factory):
    folder = tmp_path_factory.mktemp("calib") / "session"
    ss = simulate_session("tiny", n_poses=5, seed=3, folder=folder, progress=False, imaging=SessionImaging(noise=False))
    return ss


def test_noise_free_macro_session_meets_truth_tolerances():
    # >= 10 board poses, half-resolution macro camera (640x512) to keep the test fast
    ss = simulate_session("macro", n_poses=10, seed=0, progress=False, optics=SessionOptics(camera_scale=0.5),
                          imaging=SessionImaging(noise=False))
    obs, info = observe_session(ss.poses, ss.board, progress=False)
    cal, res = calibrate_observations(obs, info, ss.board, camera_dist="k1k2")
    true, est = ss.rig, cal.rig
    for e, t in ((est.camera, true.camera), (est.projector, true.projector)):
        assert abs(e.K[0, 0] / t.K[0, 0] - 1) < 1e-3 and abs(e.K[1, 1] / t.K[1, 1] - 1) < 1e-3
        assert np.abs(e.K[:2, 2] - t.K[:2, 2]).max() < 0.1
    assert np.abs(est.projector.t - true.projector.t).max() < 0.05  # mm
    assert rotation_angle_deg(est.projector.R, true.projector.R) < 0.01
    assert cal.rms["camera_px"] < 0.01 and cal.rms["projector_px"] < 0.01
    assert cal.acceptance["passed"], [g for g in cal.acceptance["gates"] if not g["passed"]]


def test_calibrate_command_writes_json_yaml_plot_and_rig_loads(tiny_session, tmp_path, capsys):
    out = tmp_path / "calib.json"
    rc = main(["calibrate", str(tiny_session.folder), "-o", str(out), "--yaml", str(tmp_path / "c.yaml"), "--json"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert [p["name"] for p in summary["poses"]] == [f"pose_{k:02d}" for k in range(5)]
    assert (tmp_path / "calib.png").stat().st_size > 1000
    from output_checks import check_json_provenance
    check_json_provenance(out)                       # version, time, command line, units
    rig = Rig.load(out)
    # the tiny rig (160x128 camera) still lands near the true projector position
    assert np.linalg.norm(rig.projector.t - tiny_session.rig.projector.t) < 2.0
    import cv2
    fs = cv2.FileStorage(str(tmp_path / "c.yaml"), cv2.FILE_STORAGE_READ)
    assert np.allclose(fs.getNode("projector_K").mat(), rig.projector.K)
    assert np.allclose(fs.getNode("T").mat().ravel(), rig.projector.t)
    fs.release()


def test_too_few_poses_is_an_error_and_nothing_is_written(tiny_session, tmp_path, capsys):
    out = tmp_path / "calib.json"
    rc = main(["calibrate", str(tiny_session.folder / "pose_00"), str(tiny_session.folder / "pose_01"),
               "--spacing", str(tiny_session.board.spacing), "-o", str(out), "-q"])
    assert rc == 2
    assert "need at least 3" in capsys.readouterr().err
    assert not out.exists() and not list(tmp_path.glob(".*part*"))


def test_board_not_found_skips_pose_with_warning_then_errors_when_too_few(tiny_session):
    poses = [PoseCapture(p.name, p.frames.copy(), p.patterns) for p in tiny_session.poses]
    poses[1].frames[0] = poses[1].frames[0].mean()  # white frame without a board
    with pytest.warns(CalibrationWarning, match="pose pose_01"):
        obs, info = observe_session(poses, tiny_session.board, progress=False)
    assert info.skipped == ["pose_01"] and len(obs) == 4
    for p in poses[2:]:
        p.frames[0] = 0
    with pytest.warns(CalibrationWarning):
        obs, info = observe_session(poses, tiny_session.board, progress=False)
    with pytest.raises(ValueError, match=r"need at least 3.*board not found in: pose_01, pose_02"):
        calibrate_observations(obs, info, tiny_session.board)


def test_images_of_different_sizes_are_an_error(tiny_session):
    poses = [PoseCapture(p.name, p.frames, p.patterns) for p in tiny_session.poses]
    poses[2] = PoseCapture("odd", poses[2].frames[:, :100, :], poses[2].patterns)
    with pytest.raises(ValueError, match=r"pose odd has 160x100 images but pose pose_00 has 160x128"):
        observe_session(poses, tiny_session.board, progress=False)


def test_phase_invalid_at_circle_centres_is_an_error(tiny_session):
    poses = []
    for p in tiny_session.poses:
        f = p.frames.copy()
        f[1:] = f[0]  # fringe frames without fringes: no modulation anywhere
        poses.append(PoseCapture(p.name, f, p.patterns))
    obs, info = observe_session(poses, tiny_session.board, progress=False)
    with pytest.raises(ValueError, match="phase is invalid at the circle centres"):
        calibrate_observations(obs, info, tiny_session.board)


def test_calibration_file_with_missing_field_names_it(tiny_session, tmp_path):
    out = tmp_path / "calib.json"
    cal, _ = calibrate_session([tiny_session.folder], progress=False)
    cal.save(out)
    assert load_calibration(out).rig.projector.width == 256
    d = json.loads(out.read_text())
    del d["periods"]
    bad = tmp_path / "bad.json"
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match="missing field 'periods'"):
        load_calibration(bad)
    d = json.loads(out.read_text())
    del d["rig"]["projector"]["K"]
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"field rig: field projector.K: required field is missing"):
        load_calibration(bad)
    d = json.loads(out.read_text())
    d["camera_stats"]["width"] = "wide"
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match="camera_stats: field 'width' must be int"):
        load_calibration(bad)
    with pytest.raises(FileNotFoundError):
        load_calibration(tmp_path / "none.json")


def test_yaml_export_failure_leaves_no_partial_file(tiny_session, tmp_path):
    cal, _ = calibrate_session([tiny_session.folder], progress=False)
    cal.periods = {"v": "x"}  # float() fails mid-write
    with pytest.raises(ValueError):
        export_opencv_yaml(cal, tmp_path / "c.yaml")
    assert list(tmp_path.iterdir()) == []


def test_pose_without_white_frame_is_rejected_by_name(tiny_session):
    from dataclasses import replace
    p = tiny_session.poses[0]
    no_white = replace(p.patterns, frames=tuple(f if f.kind != "white" else replace(f, kind="black")
                                                 for f in p.patterns.frames))
    with pytest.raises(ValueError, match="pose_00: the manifest has no white frame"):
        observe_session([PoseCapture("pose_00", p.frames, no_white)], tiny_session.board, progress=False)


def test_missing_inputs_and_empty_folders_are_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="does not exist"):
        calibrate_session([tmp_path / "nope"], progress=False)
    with pytest.raises(ValueError, match="neither a manifest.json"):
        calibrate_session([tmp_path], progress=False)


def test_calibrate_command_local_phase_window_is_recorded_and_bad_value_rejected(tiny_session, tmp_path, capsys):
    out = tmp_path / "local.json"
    rc = main(["calibrate", str(tiny_session.folder), "-o", str(out), "--phase-window", "auto", "--json", "--no-plot"])
    assert rc == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["phase_sampling"] == "local fit, radius auto"
    assert load_calibration(out).extra["phase_sampling"] == "local fit, radius auto"
    rc = main(["calibrate", str(tiny_session.folder), "-o", str(tmp_path / "x.json"), "--phase-window", "wide", "-q"])
    assert rc == 2
    assert "phase window must be 'auto', 'bilinear' or a radius in pixels" in capsys.readouterr().err
    assert not (tmp_path / "x.json").exists()


def test_pose_whose_grid_cannot_be_labelled_is_skipped_with_that_reason(tiny_session, monkeypatch):
    from fringe3d.calibrate import board_detection
    monkeypatch.setattr(board_detection, "grid_is_consistent", lambda uv, board, tolerance=0.3: False)
    with pytest.warns(CalibrationWarning, match="pose pose_00.*could not be labelled consistently"):
        obs, info = observe_session(tiny_session.poses[:1], tiny_session.board, progress=False)
    assert obs == [] and info.skipped == ["pose_00"]


def test_a_session_result_is_typed_and_its_residuals_read_alike_for_both_rig_models(tiny_session):
    from fringe3d.calibrate.session_result import SessionCalibration, SessionFacts
    obs, facts = observe_session(tiny_session.poses, tiny_session.board, progress=False)
    assert isinstance(facts, SessionFacts) and facts.camera_size == tiny_session.poses[0].frames.shape[2:0:-1]
    assert facts.names == [p.name for p in tiny_session.poses] and facts.skipped == []
    session = calibrate_session([tiny_session.folder], progress=False,
                                observe=ObservationSettings(min_modulation_share=0.1))
    assert isinstance(session, SessionCalibration)
    cal, fit = session
    assert session.pose_names == [p["name"] for p in cal.poses] and fit is session.fit
    rms = np.sqrt(np.mean(np.concatenate([np.sum(r ** 2, axis=1) for r in session.camera_residuals])))
    assert rms == pytest.approx(cal.rms["camera_px"], rel=1e-9)


def test_the_fraction_min_modulation_fraction_is_a_deprecated_spelling_of_min_modulation_share(tiny_session):
    with pytest.warns(DeprecationWarning, match="min_modulation_share"):
        old, _ = calibrate_session([tiny_session.folder], progress=False, min_modulation_fraction=0.1)
    new, _ = calibrate_session([tiny_session.folder], progress=False,
                               observe=ObservationSettings(min_modulation_share=0.1))
    assert old.rms == new.rms
