"""A circle grid stated smaller than the one in the image is refused, not matched as a sub-grid
(issue 23: a wrong board size exits non-zero naming it); board flags are not silently ignored."""
import cv2
import numpy as np
import pytest

from fringe3d.calibrate.board_detection import blob_detector, find_board, to_uint8
from fringe3d.calibrate.boards import CircleBoard
from fringe3d.calibrate.grid_extent import check_not_larger, grid_extent
from fringe3d.calibrate.session import observe_session
from fringe3d.cli import main
from fringe3d.optics import PinholeDevice, Rig, intrinsics
from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.sets import white_frame
from fringe3d.sim.calibration_session import render_board_poses, simulate_session
from fringe3d.sim.settings import RenderSettings


@pytest.fixture(scope="module")
def nine_by_seven(tmp_path_factory):
    """A simulated session of a 9x7 circle grid (tiny rig, six poses)."""
    folder = tmp_path_factory.mktemp("grid") / "session"
    return simulate_session("tiny", n_poses=6, seed=0, board=("circles", 9, 7), folder=folder, progress=False)


@pytest.mark.parametrize("cols, rows", [(8, 7), (9, 6), (7, 5)])
def test_calibrate_refuses_a_circle_grid_stated_smaller_than_the_image_and_writes_nothing(nine_by_seven, cols, rows,
                                                                                         tmp_path, capsys):
    out = tmp_path / "out" / "calib.json"
    rc = main(["calibrate", str(nine_by_seven.folder), "--cols", str(cols), "--rows", str(rows),
               "--spacing", str(nine_by_seven.board.spacing), "-o", str(out), "--no-plot", "-q"])
    err = " ".join(capsys.readouterr().err.split())
    assert rc == 2 and "Traceback" not in err
    assert "pose pose_00, white frame" in err
    assert f"at least 9x7 circles where {cols}x{rows} were given" in err and "Pass --cols 9 --rows 7" in err
    assert not out.parent.exists()


def test_the_true_size_is_found_at_the_true_centres_and_a_smaller_one_refused_in_every_pose(nine_by_seven):
    board = nine_by_seven.board
    assert board.pattern_size == (9, 7)
    smaller = CircleBoard(cols=8, rows=7, spacing=board.spacing, radius=board.radius)
    cam = nine_by_seven.rig.camera
    for pose, (R, t) in zip(nine_by_seven.poses, nine_by_seven.board_poses):
        uv, why = find_board(pose.frames[0], board)
        truth = cam.project(board.object_points() @ R.T + t)
        d = np.linalg.norm(uv[:, None] - truth[None], axis=-1)  # OpenCV may start at another corner
        assert why == "" and len(set(d.argmin(1))) == board.count and d.min(1).max() < 0.5
        with pytest.raises(ValueError, match="at least 9x7 circles where 8x7 were given"):
            find_board(pose.frames[0], smaller)


def test_a_gray_code_session_of_a_larger_grid_is_refused_naming_the_pose_and_the_white_frame():
    ss = simulate_session("tiny", n_poses=2, seed=0, board=("circles", 9, 7), patterns="gray-code", progress=False)
    stated = CircleBoard(cols=9, rows=6, spacing=ss.board.spacing, radius=ss.board.radius)
    white = ss.poses[0].patterns.indices(kind="white")[0]
    with pytest.raises(ValueError, match=rf"pose pose_00, white frame \(frame {white}\): .*at least 9x7 circles "
                                         r"where 9x6 were given.*Pass `cols` 9 `rows` 7"):
        observe_session(ss.poses, stated, progress=False)


def test_an_asymmetric_grid_is_found_whole_and_a_part_of_it_grows_back_to_the_whole():
    """OpenCV's asymmetric finder matched no sub-grid of this render (every smaller size: not
    found), so the part is taken from the whole detection: rows 2-8, columns 1-3 of a 4x9 grid,
    grown over the blobs the detector sees in the image."""
    board = CircleBoard(cols=4, rows=9, spacing=15.0, radius=4.0, asymmetric=True)
    cam = PinholeDevice(K=intrinsics(900, 900, 319.5, 239.5), width=640, height=480)
    prj = PinholeDevice(K=intrinsics(700, 700, 399.5, 299.5), width=800, height=600, t=[-60.0, 0, 0])
    R, _ = cv2.Rodrigues(np.array([0.3, -0.2, 0.1]))
    t = np.array([0, 0, 500.0]) - R @ board.object_points().mean(0)
    img = render_board_poses(Rig(cam, prj), RenderSettings(bit_depth=16, shadows=False), board, [(R, t)],
                             PatternSet(800, 600, (white_frame(),)), progress=False)[0].frames[0]
    uv, why = find_board(img, board)  # the true size is not refused
    truth = cam.project(board.object_points() @ R.T + t)
    assert why == "" and np.linalg.norm(uv[:, None] - truth[None], axis=-1).min(1).max() < 0.5
    keypoints = blob_detector(board, (3.0, 30.0)).detect(to_uint8(img))
    blobs = np.array([k.pt for k in keypoints]).reshape(-1, 2)
    sizes = np.array([k.size for k in keypoints])
    part = CircleBoard(cols=3, rows=7, spacing=15.0, radius=4.0, asymmetric=True)
    i, j = np.divmod(np.arange(part.count), part.cols)
    assert grid_extent(blobs, sizes, uv, board) == (4, 9)
    assert grid_extent(blobs, sizes, uv[(i + 2) * board.cols + j + 1], part) == (4, 9)
    with pytest.raises(ValueError, match=r"larger asymmetric circle grid: at least 4x9 circles where 3x7.*`cols` 4"):
        check_not_larger(blobs, sizes, uv[(i + 2) * board.cols + j + 1], part)


def test_board_flags_without_spacing_are_refused_not_silently_replaced_by_session_json(nine_by_seven, tmp_path,
                                                                                       capsys):
    out = tmp_path / "calib.json"
    rc = main(["calibrate", str(nine_by_seven.folder), "--cols", "8", "-o", str(out), "--no-plot", "-q"])
    err = " ".join(capsys.readouterr().err.split())
    assert rc == 2 and "--cols describe(s) the board only together with --spacing" in err
    assert not out.exists()
