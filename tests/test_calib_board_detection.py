"""Circle-grid detection on boards rendered by the simulator, against the true centres."""
import cv2
import numpy as np
import pytest

from fringe3d.calibrate.board_detection import CircleBoard, detect_board
from fringe3d.calibrate.simulated_session import render_board_poses
from fringe3d.calibrate.stereo import circle_bias
from fringe3d.optics import PinholeDevice, Rig, intrinsics
from fringe3d.patterns.manifest import PatternSet
from fringe3d.patterns.sets import white_frame
from fringe3d.sim.settings import RenderSettings

CAM = PinholeDevice(K=intrinsics(900, 900, 319.5, 239.5), width=640, height=480)
PRJ = PinholeDevice(K=intrinsics(700, 700, 399.5, 299.5), width=800, height=600, t=[-60.0, 0, 0])
WHITE = PatternSet(800, 600, (white_frame(),))


@pytest.mark.parametrize("asymmetric", [False, True])
def test_detected_centres_match_true_ellipse_centroids(asymmetric):
    board = CircleBoard(cols=7 if not asymmetric else 4, rows=6 if not asymmetric else 9, spacing=15.0,
                        radius=4.0, asymmetric=asymmetric)
    R, _ = cv2.Rodrigues(np.array([0.35, -0.25, 0.1]))
    mid = board.object_points().mean(0)
    t = np.array([0, 0, 500.0]) - R @ mid
    s = RenderSettings(bit_depth=16, shadows=False)
    pose = render_board_poses(Rig(CAM, PRJ), s, board, [(R, t)], WHITE, progress=False)[0]
    uv = detect_board(pose.frames[0], board)
    assert uv is not None and uv.shape == (board.count, 2)
    rv, _ = cv2.Rodrigues(R)
    truth = CAM.project(board.object_points() @ R.T + t) + circle_bias(board, CAM.K, CAM.dist, rv, t)
    # OpenCV may start the grid at another corner: match each detection to its nearest truth
    d = np.linalg.norm(uv[:, None] - truth[None], axis=-1)
    assert len(set(d.argmin(1))) == board.count
    err = d.min(1)
    assert np.sqrt(np.mean(err ** 2)) < 0.03  # px


def test_flat_or_boardless_image_is_not_found():
    board = CircleBoard(cols=9, rows=9, spacing=10.0, radius=2.5)
    assert detect_board(np.full((120, 160), 128, np.uint8), board) is None
    rng = np.random.default_rng(0)
    assert detect_board(rng.integers(0, 255, (120, 160)).astype(np.uint8), board) is None
    with pytest.raises(ValueError, match="2-D grey image"):
        detect_board(np.zeros((4, 5, 3)), board)


def test_board_object_points_follow_opencv_layouts():
    sym = CircleBoard(cols=3, rows=2, spacing=5.0, radius=1.0)
    assert np.allclose(sym.object_points()[:, :2], [[0, 0], [5, 0], [10, 0], [0, 5], [5, 5], [10, 5]])
    asym = CircleBoard(cols=2, rows=3, spacing=5.0, radius=1.0, asymmetric=True)
    assert np.allclose(asym.object_points()[:, :2], [[0, 0], [10, 0], [5, 5], [15, 5], [0, 10], [10, 10]])
    with pytest.raises(ValueError, match="does not fit"):
        CircleBoard(cols=3, rows=3, spacing=5.0, radius=3.0)
