"""``fringe3d capture --views N --stage ...``: the virtual stage turns the simulated object, each
view is a capture folder, poses.json carries the stage's poses and the truth, and
capture -> reconstruct -> merge recovers the true poses."""
from __future__ import annotations

import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.io.capture import read_capture
from fringe3d.multiview.accuracy import pose_errors
from fringe3d.multiview.poses import read_poses, read_true_poses
from fringe3d.sim import presets
from fringe3d.sim.turntable import default_turntable

RIG = ["--projector", "virtual:tiny"]


@pytest.fixture(scope="module")
def scan(pats, tmp_path_factory):
    """Three views of the sculpture, 20 degrees apart, on the virtual stage (default noise)."""
    out = tmp_path_factory.mktemp("views") / "scan"
    assert main(["capture", str(pats), "-o", str(out), "--views", "3", "--stage", "virtual:20", *RIG,
                 "--camera", "virtual:tiny?scene=sculpture", "-q"]) == 0
    return out


def test_virtual_stage_views_are_bit_identical_to_simulated_turntable_views(pats, tmp_path):
    cap, sim = tmp_path / "cap", tmp_path / "sim"
    assert main(["capture", str(pats), "-o", str(cap), "--views", "2", "--stage", "virtual:25", *RIG,
                 "--camera", "virtual:tiny?scene=sculpture&ideal=1", "-q"]) == 0
    assert main(["simulate", "--scene", "sculpture", "--set", str(pats / "manifest.json"), "--views", "2",
                 "--turntable-step", "25", "--ideal", "-o", str(sim), "-q"]) == 0
    a0, a1 = read_capture(cap / "view-00").frames, read_capture(cap / "view-01").frames
    assert np.array_equal(a0, read_capture(sim / "view-00").frames)
    assert np.array_equal(a1, read_capture(sim / "view-01").frames)
    assert np.abs(a0.astype(float) - a1).mean() > 1.0  # the object did turn between the views
    assert read_poses(cap / "poses.json").keys() == read_true_poses(sim / "poses.json").keys()


def test_poses_file_holds_the_stage_angles_and_the_true_turn_of_the_virtual_table(scan):
    doc = json.loads((scan / "poses.json").read_text())
    assert [v["angle_deg"] for v in doc["views"]] == [0.0, 20.0, 40.0]
    assert doc["stage"]["kind"] == "virtual turntable" and doc["stage"]["step_deg"] == 20.0
    table = default_turntable(presets.get("tiny"))
    true = read_true_poses(scan / "poses.json")
    for k, name in enumerate(["view-00", "view-01", "view-02"]):
        table.move_to(20.0 * k)
        assert np.allclose(true[name] @ table.transform(), np.eye(4), atol=1e-9)  # view -> model undoes the turn
        assert np.allclose(read_poses(scan / "poses.json")[name], true[name])  # no axis file: the stage's own axis
        meta = json.loads((scan / name / "capture.json").read_text())
        assert meta["complete"] is True and meta["stage"]["position"] == 20.0 * k
        assert (scan / name / "rig.json").is_file()
    assert json.loads((scan / "fringe3d.json").read_text())["complete"] is True


def test_capture_reconstruct_merge_recovers_the_true_poses(scan, tmp_path):
    names = ["view-00", "view-01", "view-02"]
    for n in names:
        assert main(["reconstruct", str(scan / n), "-c", str(scan / n / "rig.json"), "-o", str(tmp_path / n),
                     "-q"]) == 0
    assert main(["merge", *[str(tmp_path / n) for n in names], "--poses", str(scan / "poses.json"),
                 "--mesh", "none", "-o", str(tmp_path / "merged"), "-q"]) == 0
    reg, true = read_poses(tmp_path / "merged" / "poses.json"), read_true_poses(scan / "poses.json")
    rot, tra = pose_errors(np.stack([reg[n] for n in names]), np.stack([true[n] for n in names]),
                           default_turntable(presets.get("tiny")).point)
    assert rot.max() < 2.0 and tra.max() < 50.0  # mrad, um (measured: 0.22 mrad, 12 um)


def test_a_second_capture_into_the_same_folder_needs_overwrite(pats, scan, capsys):
    args = ["capture", str(pats), "-o", str(scan), "--views", "3", "--stage", "virtual:20", *RIG,
            "--camera", "virtual:tiny?scene=sculpture", "-q"]
    assert main(args) == 2
    assert "not empty" in " ".join(capsys.readouterr().err.split())
    assert json.loads((scan / "fringe3d.json").read_text())["complete"] is True


@pytest.mark.parametrize("args, expected", [
    (["--stage", "virtual:20"], "--stage belong to a multi-view capture: add --views N"),
    (["--views", "3"], "--views needs --stage"),
    (["--views", "1", "--stage", "virtual"], "--views must be between 2 and 360"),
    (["--views", "3", "--stage", "robot:1"], "unknown stage backend 'robot'"),
    (["--views", "3", "--stage", "virtual:0"], "the step is a non-zero angle in degrees, got '0'"),
    (["--views", "3", "--stage", "virtual?axis=1,2"], "axis='1,2': expected three comma-separated numbers"),
    (["--views", "3", "--stage", "virtual", "--session", "s"], "separate modes"),
])
def test_bad_multiview_flags_are_refused_before_anything_is_written(pats, tmp_path, capsys, args, expected):
    out = tmp_path / "x"
    assert main(["capture", str(pats), "-o", str(out), *RIG, "--camera", "virtual:tiny", *args]) == 2
    assert expected in " ".join(capsys.readouterr().err.split())
    assert not out.exists()


# --------------------------------------------------------------------------- turntable axis calibration
#: a virtual table whose axis is tilted off image-up and passes beside the volume centre (camera frame, mm)
TRUE_AXIS, TRUE_POINT = np.array([0.1, -1.0, 0.05]) / np.linalg.norm([0.1, -1.0, 0.05]), np.array([10.0, 0.0, 420.0])
TILTED = "?axis=0.1,-1,0.05&point=10,0,420"
BOARD = ["--cols", "7", "--rows", "6", "--spacing", "16", "--radius", "4.5"]


@pytest.fixture(scope="module")
def axis_file(pats, tmp_path_factory):
    """A 7x6 circle board off the axis, captured at 0, -12, ..., -48 deg; its axis.json."""
    root = tmp_path_factory.mktemp("axis")
    scene = root / "board.json"
    scene.write_text(json.dumps({"objects": [{"type": "board", "cols": 7, "rows": 6, "spacing": 16, "radius": 4.5,
                                              "t": [-68, -40, 380]}]}))
    assert main(["capture", str(pats), "-o", str(root / "cap"), "--views", "5", "--stage", "virtual:-12" + TILTED,
                 *RIG, "--camera", f"virtual:tiny?scene={scene}", "-q"]) == 0
    out = root / "axis.json"
    assert main(["calibrate-axis", str(root / "cap"), "-c", str(root / "cap" / "view-00" / "rig.json"), *BOARD,
                 "-o", str(out), "-q"]) == 0
    return out


def test_axis_calibrated_from_a_board_on_the_virtual_stage_matches_the_true_axis(axis_file):
    from fringe3d.multiview.axis import read_axis
    axis, point = read_axis(axis_file)
    off = point - TRUE_POINT
    assert 1e3 * np.arccos(min(1.0, axis @ TRUE_AXIS)) < 4.0  # mrad (measured 1.0 on the 160x128 tiny camera)
    assert np.linalg.norm(off - (off @ TRUE_AXIS) * TRUE_AXIS) < 2.0  # mm from the true axis line (measured 0.6)
    doc = json.loads(axis_file.read_text())
    assert doc["frame"] == "camera" and doc["unit"] == "mm" and 0 < doc["rms_residual_mm"] < 1.0
    turns = [v["measured_angle_deg"] - v["angle_deg"] for v in doc["views"]]
    assert len(turns) == 5 and np.abs(turns).max() < 0.5  # the board turned as the stage said (deg)


def test_capture_with_the_calibrated_axis_poses_the_views_near_the_truth(pats, axis_file, tmp_path):
    out = tmp_path / "scan"
    assert main(["capture", str(pats), "-o", str(out), "--views", "3", "--stage", "virtual:20" + TILTED,
                 "--stage-axis", str(axis_file), *RIG, "--camera", "virtual:tiny?scene=sculpture", "-q"]) == 0
    stage, true = read_poses(out / "poses.json"), read_true_poses(out / "poses.json")
    names = sorted(true)
    rot, tra = pose_errors(np.stack([stage[n] for n in names]), np.stack([true[n] for n in names]),
                           np.array([0.0, 0.0, 400.0]))
    assert rot.max() < 3.0 and tra.max() < 1500.0  # mrad, um: the axis error turned by 40 deg (measured 0.7, 410)
    assert json.loads((out / "poses.json").read_text())["stage"]["axis_file"] == str(axis_file)


def test_a_stage_axis_file_that_is_not_one_is_refused_naming_the_field(pats, tmp_path, capsys):
    bad = tmp_path / "axis.json"
    bad.write_text(json.dumps({"format": "fringe3d-turntable-axis", "axis": [0, 0], "point_mm": [0, 0, 1]}))
    assert main(["capture", str(pats), "-o", str(tmp_path / "x"), "--views", "2", "--stage", "virtual",
                 "--stage-axis", str(bad), *RIG, "--camera", "virtual:tiny"]) == 2
    assert "field 'axis' must be three finite numbers" in " ".join(capsys.readouterr().err.split())
    assert not (tmp_path / "x").exists()


def test_calibrate_axis_without_the_board_in_view_names_the_views_and_writes_nothing(scan, tmp_path, capsys):
    out = tmp_path / "axis.json"
    assert main(["calibrate-axis", str(scan), "-c", str(scan / "view-00" / "rig.json"), *BOARD, "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "the board was found in 0 view(s)" in err and "view-00 (" in err
    assert not out.exists()
