"""Calibration that knows when it failed: acceptance gates on degenerate simulated sessions (few
poses, near-parallel poses), outlier poses dropped, distortion models chosen by held-out error."""
import json

import cv2
import numpy as np
import pytest

from fringe3d.calibrate import gates
from fringe3d.calibrate.calibration_file import load_calibration
from fringe3d.calibrate.session import calibrate_observations, observe_session
from fringe3d.cli import main
from fringe3d.optics import intrinsics
from fringe3d.sim.calibration_session import PoseRanges, SessionOptics, simulate_session


def _calibrate_cli(folder, out, *extra, capsys=None):
    rc = main(["calibrate", str(folder), "-o", str(out), "--no-plot", "--json", *extra])
    captured = capsys.readouterr()
    return rc, json.loads(captured.out), captured.err


def _failed_names(summary):
    return {g["name"] for g in summary["acceptance"]["gates"] if not g["passed"]}


@pytest.fixture(scope="module")
def few_poses(tmp_path_factory):
    folder = tmp_path_factory.mktemp("gates") / "few"
    simulate_session("tiny", n_poses=4, seed=1, folder=folder, progress=False)
    return folder


def test_session_of_four_poses_exits_2_naming_the_pose_gate_and_writes_nothing(few_poses, tmp_path, capsys):
    out = tmp_path / "calib.json"
    rc, summary, err = _calibrate_cli(few_poses, out, capsys=capsys)
    assert rc == 2
    assert _failed_names(summary) == {"poses"} and "poses: 4 poses, needs >= 5" in err
    assert summary["written"] == {} and not out.exists()


def test_accept_poor_writes_the_file_and_records_the_failed_gates(few_poses, tmp_path, capsys):
    out = tmp_path / "calib.json"
    rc, summary, err = _calibrate_cli(few_poses, out, "--accept-poor", capsys=capsys)
    assert rc == 0 and out.exists() and "written anyway" in err
    q = load_calibration(out).acceptance
    assert q["passed"] is False and q["accepted_poor"] is True
    assert [g["name"] for g in q["gates"] if not g["passed"]] == ["poses"]


def test_near_parallel_poses_exit_2_naming_the_orientation_gate(tmp_path, capsys):
    # every board tilted by at most 1 deg: the focal length is undetermined (Zhang's method)
    ss = simulate_session("tiny", n_poses=8, seed=1, folder=tmp_path / "flat", progress=False,
                          pose_ranges=PoseRanges(max_tilt_deg=1.0))
    out = tmp_path / "calib.json"
    rc, summary, err = _calibrate_cli(ss.folder, out, capsys=capsys)
    assert rc == 2 and not out.exists() and "orientations:" in err
    assert "orientations" in _failed_names(summary)
    # what the gate guards against: the focal length is far from the true one
    assert abs(summary["camera"]["K"][0][0] / ss.rig.camera.K[0, 0] - 1) > 0.2


def test_good_simulated_session_passes_every_gate(tmp_path, capsys):
    # the session of the determinism test and of `fringe3d calibrate --simulate tiny --poses 6`
    ss = simulate_session("tiny", n_poses=6, seed=0, folder=tmp_path / "good", progress=False)
    rc, summary, _ = _calibrate_cli(ss.folder, tmp_path / "calib.json", capsys=capsys)
    assert rc == 0 and summary["acceptance"]["passed"]
    assert not _failed_names(summary) and summary["acceptance"]["dropped_poses"] == []


@pytest.mark.parametrize("k1", [0.0, 0.08])
def test_auto_models_projector_distortion_only_when_the_lens_has_it(k1):
    ss = simulate_session("tiny", n_poses=8, seed=1, progress=False,
                          optics=SessionOptics(projector_dist=(k1, 0, 0, 0, 0)))
    with pytest.warns(Warning, match="pose_07"):  # the tiny camera's noise spoils one pose's grid
        obs, info = observe_session(ss.poses, ss.board, progress=False)
    cal, _ = calibrate_observations(obs, info, ss.board, camera_dist="auto", projector_dist="auto")
    chosen = cal.projector["dist_model"]
    report = cal.acceptance["model_choice"]["projector"]
    assert report["chosen"] == chosen
    if k1 == 0:
        assert chosen == "none"
    else:
        assert chosen != "none"
        assert report["held_out_rms_px"]["none"] > 2 * report["held_out_rms_px"][chosen]
        assert abs(cal.rig.projector.dist[0] - k1) < 0.01
    assert cal.acceptance["passed"]


def test_outlier_pose_is_dropped_named_and_the_rest_recalibrated():
    ss = simulate_session("tiny", n_poses=6, seed=0, progress=False)
    obs, info = observe_session(ss.poses, ss.board, progress=False)
    rng = np.random.default_rng(5)
    obs[2].projector_uv = obs[2].projector_uv + rng.normal(0, 3.0, obs[2].projector_uv.shape)
    cal, _ = calibrate_observations(obs, info, ss.board)
    assert [d["name"] for d in cal.acceptance["dropped_poses"]] == [obs[2].name]
    assert obs[2].name not in [p["name"] for p in cal.poses]
    assert cal.rms["projector_px"] < 0.05 and cal.acceptance["passed"]


def test_distortion_share_is_k1_r_squared_and_a_folding_model_fails():
    K = intrinsics(1000.0, 1000.0, 639.5, 511.5)
    r2 = (639.5 ** 2 + 511.5 ** 2) / 1000.0 ** 2  # the corner's normalised radius, squared
    share = gates.distortion_share(K, [-0.1, 0, 0, 0, 0], 1280, 1024)
    assert share == pytest.approx(0.1 * r2, rel=1e-9)
    assert gates.distortion_gate("camera", K, [-0.1, 0, 0, 0, 0], 1280, 1024).passed
    # d/dr r(1 + k1 r^2) = 1 + 3 k1 r^2 < 0 before the corner: the mapping folds
    assert not gates.radial_is_monotonic(K, [-0.5, 0, 0, 0, 0], 1280, 1024)
    # k3 = 45 (a 'full' model fitted to 5 poses): 45 r^6 of the radius at the corner
    assert not gates.distortion_gate("camera", K, [0, 0, 0, 0, 45.0], 1280, 1024).passed


def test_implausible_focal_length_and_principal_point_fail():
    ok = gates.intrinsics_gates("projector", intrinsics(1500.0, 1500.0, 455.0, 1100.0), 912, 1140)
    assert all(g.passed for g in ok)  # an offset projector lens: principal point near the bottom edge
    bad = {g.name: g.passed for g in gates.intrinsics_gates("projector", intrinsics(7.0, 7.0, 455.0, 570.0),
                                                              912, 1140)}
    assert bad == {"projector_focal": False, "projector_principal_point": True}
    cam = {g.name: g.passed for g in gates.intrinsics_gates("camera", intrinsics(1600.0, 1600.0, -20.0, 240.0),
                                                             640, 480)}
    assert cam == {"camera_focal": True, "camera_principal_point": False}


def test_orientations_counts_normals_more_than_the_step_apart():
    def normal(tilt_deg, az_deg):
        t, a = np.deg2rad(tilt_deg), np.deg2rad(az_deg)
        return np.array([np.sin(t) * np.cos(a), np.sin(t) * np.sin(a), np.cos(t)])
    near = np.array([normal(2, a) for a in (0, 90, 180, 270)])  # every pair <= 4 deg apart
    assert gates.distinct_orientations(near) == 1
    spread = np.array([normal(0, 0), normal(20, 0), normal(20, 180), normal(25, 90), normal(3, 45)])
    assert gates.distinct_orientations(spread) == 4
    assert gates.distinct_orientations(-spread) == 4  # a normal and its opposite are one orientation
    rv = np.array([cv2.Rodrigues(np.eye(3))[0].ravel()] * 3)
    assert not gates.orientation_gate(rv).passed
