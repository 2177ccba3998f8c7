"""Chessboard and ChArUco boards, Gray-code correspondences through local homographies, other
tools' session folders: simulated sessions checked against the simulator's true rig."""
import json

import numpy as np
import pytest

from fringe3d.calibrate.code_mapping import corner_homography_points
from fringe3d.calibrate.evaluation import compare_to_truth
from fringe3d.calibrate.session import calibrate_observations, observe_session
from fringe3d.calibrate.square_boards import CharucoBoard, ChessBoard, board_from_dict
from fringe3d.cli import main
from fringe3d.io.images import write_image
from fringe3d.sim.calibration_session import PoseRanges, SessionImaging, SessionOptics, simulate_session


def test_charuco_corners_are_opencvs_board_corners_in_id_order():
    board = CharucoBoard(cols=6, rows=5, spacing=12.0, marker=8.5, dictionary="DICT_5X5_100")
    assert np.array_equal(board.object_points(), np.asarray(board.cv_board().getChessboardCorners(), float))
    assert board.image(20).shape == (5 * 20, 6 * 20)


def test_board_descriptions_round_trip_and_bad_fields_are_named():
    for b in (ChessBoard(cols=7, rows=5, spacing=20.0), CharucoBoard(cols=5, rows=4, spacing=30.0, marker=21.0)):
        assert board_from_dict(json.loads(json.dumps(b.to_dict()))) == b
    assert board_from_dict({"cols": 4, "rows": 3, "spacing": 5.0, "radius": 1.0}).count == 12  # circles
    with pytest.raises(ValueError, match="unknown kind 'dots'"):
        board_from_dict({"kind": "dots", "cols": 4, "rows": 4, "spacing": 5.0})
    with pytest.raises(ValueError, match=r"unknown field\(s\) \['radius'\]"):
        board_from_dict({"kind": "chessboard", "cols": 4, "rows": 4, "spacing": 5.0, "radius": 1.0})
    with pytest.raises(ValueError, match="unknown ArUco dictionary 'DICT_9X9'"):
        CharucoBoard(dictionary="DICT_9X9")


def test_local_homography_recovers_points_from_one_pixel_stripe_codes():
    # a plane seen by two pinhole devices: camera -> projector is a homography; the Gray code
    # gives the projector pixel (rounded) of every camera pixel, a few pixels decode wrongly
    H = np.array([[1.1, 0.08, 40.0], [-0.05, 1.2, 25.0], [2e-4, -1e-4, 1.0]])
    v, u = np.mgrid[0:160, 0:200].astype(float)
    q = np.stack([u, v, np.ones_like(u)], -1) @ H.T
    up, vp = np.rint(q[..., 0] / q[..., 2]), np.rint(q[..., 1] / q[..., 2])
    rng = np.random.default_rng(1)
    bad = rng.random(up.shape) < 0.03
    up[bad] += rng.integers(-40, 40, bad.sum())
    up[rng.random(up.shape) < 0.1] = np.nan
    pts = rng.uniform([30, 30], [170, 130], (25, 2))
    got = corner_homography_points(up, vp, pts, window=47)
    ph = np.c_[pts, np.ones(len(pts))] @ H.T
    assert np.abs(got - ph[:, :2] / ph[:, 2:]).max() < 0.05  # px, from 1-px quantised codes
    assert np.isnan(corner_homography_points(np.full_like(up, np.nan), vp, pts[:2])).all()


@pytest.fixture(scope="module")
def chess_gray_session():
    # macro rig at half camera resolution; a sharp projector (the Gray-code route needs one:
    # 1-px stripes = OpenCV's GrayCodePattern layout), no sensor noise
    return simulate_session("macro", n_poses=10, seed=0, progress=False,
                            board=ChessBoard(cols=11, rows=9, spacing=13.0), patterns="gray-code",
                            optics=SessionOptics(camera_scale=0.5, defocus=0.3), imaging=SessionImaging(noise=False))


def test_noise_free_chessboard_gray_code_calibration_meets_truth_tolerances(chess_gray_session):
    ss = chess_gray_session
    assert len(ss.poses[0].patterns) == 2 * (10 + 10) + 2  # OpenCV's layout for 800x600
    obs, info = observe_session(ss.poses, ss.board, progress=False)
    assert len(obs) == 10 and info.correspondences.startswith("gray code, local homographies")
    cal, _ = calibrate_observations(obs, info, ss.board, camera_dist="k1k2")
    err = compare_to_truth(cal.rig, ss.rig)
    assert err["camera_focal_rel_error"] < 1e-3 and err["projector_focal_rel_error"] < 1e-3
    assert err["camera_principal_point_error_px"] < 0.1 and err["projector_principal_point_error_px"] < 0.1
    assert err["translation_error_mm"] < 0.05 and err["rotation_error_deg"] < 0.01
    assert not cal.extra["circle_bias_corrected"]


def test_charuco_partial_views_are_used_and_calibrate_near_truth():
    ss = simulate_session("macro", n_poses=7, seed=2, progress=False,
                          board=CharucoBoard(cols=8, rows=6, spacing=16.0, marker=11.2),
                          optics=SessionOptics(camera_scale=0.5), imaging=SessionImaging(noise=False),
                          pose_ranges=PoseRanges(partial=2))
    obs, info = observe_session(ss.poses, ss.board, progress=False)
    assert len(obs) == 7
    seen = [int(np.isfinite(o.camera_uv[:, 0]).sum()) for o in obs]
    assert all(s >= 0.8 * ss.board.count for s in seen[:5])
    assert all(6 <= s < 0.8 * ss.board.count for s in seen[5:])  # the partial views, used
    # the corners seen are where the true board corners project
    for o, (R, t) in zip(obs[5:], ss.board_poses[5:]):
        true = ss.rig.camera.project(ss.board.object_points() @ R.T + t)
        ok = np.isfinite(o.camera_uv[:, 0])
        assert np.abs(o.camera_uv[ok] - true[ok]).max() < 0.3
    cal, res = calibrate_observations(obs, info, ss.board, camera_dist="k1k2")
    assert [len(r) for r in res.camera.residuals][5:] == seen[5:]
    err = compare_to_truth(cal.rig, ss.rig)
    # 7 poses, phase route, noise-free: measured 0.024 % / 0.0035 %, 0.13 / 0.10 px, 0.10 mm, 0.0096 deg
    assert err["camera_focal_rel_error"] < 1e-3 and err["projector_focal_rel_error"] < 1e-3
    assert err["camera_principal_point_error_px"] < 0.25 and err["projector_principal_point_error_px"] < 0.25
    assert err["translation_error_norm_mm"] < 0.25 and err["rotation_error_deg"] < 0.02


@pytest.fixture(scope="module")
def tiny_circles(tmp_path_factory):
    folder = tmp_path_factory.mktemp("calib") / "session"
    return simulate_session("tiny", n_poses=3, seed=3, folder=folder, progress=False,
                            imaging=SessionImaging(noise=False))


def test_board_not_found_in_any_pose_names_the_board_and_poses_and_writes_nothing(tiny_circles, tmp_path, capsys):
    out = tmp_path / "calib.json"
    rc = main(["calibrate", str(tiny_circles.folder), "--board", "chessboard", "--cols", "7", "--rows", "6",
               "--spacing", "20", "-o", str(out), "-q"])
    assert rc == 2
    err = capsys.readouterr().err
    assert "7x6-square chessboard" in err and "not found in any of the 3 pose(s)" in err
    assert "pose_00, pose_01, pose_02" in err.replace("\n", " ").replace("  ", " ")
    assert "Traceback" not in err
    assert list(tmp_path.iterdir()) == []


def test_other_tools_session_of_numbered_frames_calibrates_through_layout(tmp_path, capsys):
    board = ChessBoard(cols=6, rows=5, spacing=20.0)
    ss = simulate_session("tiny", n_poses=5, seed=1, progress=False, board=board, patterns="gray-code",
                          imaging=SessionImaging(noise=True))
    assert ss.poses[0].patterns.name.startswith("opencv-graycode")
    for pose in ss.poses:  # another tool's layout: one folder per pose, frames img_1.png ...
        for k, f in enumerate(pose.frames):
            write_image(tmp_path / "captures" / f"view{pose.name[-1]}" / f"img_{k + 1}.png", f)
    out = tmp_path / "out" / "calib.json"
    rc = main(["calibrate", str(tmp_path / "captures"), "--set", "opencv-graycode", "--projector-size", "256x200",
               "--board", "chessboard", "--cols", "6", "--rows", "5", "--spacing", "20", "-o", str(out), "--json"])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    assert [p["name"] for p in s["poses"]] == [f"view{k}" for k in range(5)]
    assert s["board"]["kind"] == "chessboard" and s["correspondences"].startswith("gray code")
    from fringe3d.optics import Rig
    rig = Rig.load(out)
    # the frames read from the numbered files calibrate exactly as the session in memory
    obs, info = observe_session(ss.poses, board, progress=False)
    cal, _ = calibrate_observations(obs, info, board, camera_dist="auto", projector_dist="auto")  # the CLI's
    assert np.allclose(rig.camera.K, cal.rig.camera.K, rtol=1e-9) and np.allclose(rig.projector.t, cal.rig.projector.t)
    # and the tiny rig (160x128 camera) lands near the true projector position
    assert np.linalg.norm(rig.projector.t - ss.rig.projector.t) < 3.0
    # a pose folder with a frame missing is named, with the count the layout expects
    (tmp_path / "captures" / "view3" / "img_34.png").unlink()
    rc = main(["calibrate", str(tmp_path / "captures"), "--set", "opencv-graycode", "--projector-size", "256x200",
               "--board", "chessboard", "--cols", "6", "--rows", "5", "--spacing", "20", "-o",
               str(tmp_path / "out2" / "calib.json"), "-q"])
    err = capsys.readouterr().err.replace("\n", " ")
    assert rc == 2 and "view3 has 33 frames" in err and "expected exactly 34" in err
    assert not (tmp_path / "out2" / "calib.json").exists()


def test_calibrate_simulate_renders_a_gray_code_chessboard_session_and_compares_with_truth(tmp_path, capsys):
    sim = tmp_path / "sim"
    rc = main(["calibrate", str(sim), "--simulate", "tiny", "--board", "chessboard", "--cols", "6", "--rows", "5",
               "--spacing", "20", "--set", "gray-code", "--poses", "4", "--noise-free",
               "-o", str(tmp_path / "calib.json"), "--json", "--accept-poor"])
    assert rc == 0
    s = json.loads(capsys.readouterr().out)
    # 4 poses fail the pose-count gate: written with --accept-poor, the failure recorded
    assert [g["name"] for g in s["acceptance"]["gates"] if not g["passed"]] == ["poses"]
    session = json.loads((sim / "session.json").read_text())
    assert session["board"] == {"kind": "chessboard", "cols": 6, "rows": 5, "spacing": 20.0}
    assert json.loads((sim / "pose_00" / "manifest.json").read_text())["name"].startswith("opencv-graycode")
    assert len(s["poses"]) == 4 and all(p["points"] == 20 for p in s["poses"])
    # the comparison is with the simulated session's own true rig (a 4-pose 160x128 rig is weak)
    truth = json.loads((sim / "session.json").read_text())["truth"]["rig"]
    assert truth["projector"]["width"] == 256
    assert {"translation_error_norm_mm", "rotation_error_deg"} <= set(s["truth_comparison"])
