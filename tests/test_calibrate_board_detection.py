"""Circle-grid detection on boards rendered by the simulator, against the true centres."""
import cv2
import numpy as np
import pytest

from fringe3d.calibrate.board_detection import detect_board
from fringe3d.calibrate.boards import CircleBoard
from fringe3d.sim.calibration_session import render_board_poses
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


def _grid(board, k1=0.0):
    """Pixel centres of a correctly labelled board seen frontally, optionally barrel-distorted."""
    xy = board.object_points()[:, :2] * 6.0 + 40.0
    c = xy.mean(0)
    r2 = np.sum(((xy - c) / 400.0) ** 2, 1, keepdims=True)  # corners at r^2 = 0.72
    return c + (xy - c) * (1 + k1 * r2)


def test_grid_check_accepts_distorted_grid_and_rejects_block_labelled_one_place_off():
    from fringe3d.calibrate.board_detection import grid_is_consistent
    board = CircleBoard(cols=9, rows=9, spacing=10.0, radius=2.5)
    good = _grid(board, k1=-0.3)  # 22 % barrel at the corners
    assert grid_is_consistent(good, board)
    bad = good.reshape(9, 9, 2).copy()
    bad[4:, 5:] = good.reshape(9, 9, 2)[4:, 4:8]  # a block shifted by one column (a missed blob)
    assert not grid_is_consistent(bad.reshape(-1, 2), board)


def test_noisy_microscope_board_that_opencv_mislabels_is_found_with_true_labels():
    """Microscope preset, sensor noise: for this seeded pose OpenCV's default search returns a
    grid with a block labelled one place off (a noise blob); detect_board must reject that
    and return the true labels (from the clustering search or the smoothed image)."""
    from fringe3d.calibrate.board_detection import blob_detector, grid_is_consistent, to_uint8
    from fringe3d.sim.calibration_session import default_board, sample_board_poses
    from fringe3d.sim import presets
    p = presets.get("microscope")
    board = default_board(p.rig, p.volume)
    poses = sample_board_poses(p.rig, p.volume, board, 12, np.random.default_rng(0))[:7]
    white = PatternSet(p.rig.projector.width, p.rig.projector.height, (white_frame(),))
    img = render_board_poses(p.rig, p.settings, board, poses, white, seed=24, progress=False)[6].frames[0]
    img8 = to_uint8(img)
    det = blob_detector(board, (1.5, max(3.0, 1.3 * board.radius / board.spacing * min(img8.shape) / 8)))
    found, raw = cv2.findCirclesGrid(img8, board.pattern_size, flags=cv2.CALIB_CB_SYMMETRIC_GRID, blobDetector=det)
    assert found and not grid_is_consistent(np.asarray(raw).reshape(-1, 2), board)  # the case exists
    uv = detect_board(img, board)
    assert uv is not None
    R, t = poses[6]
    truth = p.rig.camera.project(board.object_points() @ R.T + t)
    err = min(np.max(np.linalg.norm(uv - truth, axis=1)), np.max(np.linalg.norm(uv[::-1] - truth, axis=1)))
    assert err < 0.5  # px; one label off is a whole spacing


def test_noisy_board_with_spurious_blobs_is_found_with_true_labels():
    board = CircleBoard(cols=9, rows=9, spacing=10.0, radius=2.5)
    R, _ = cv2.Rodrigues(np.array([0.2, -0.15, 0.05]))
    t = np.array([0, 0, 520.0]) - R @ board.object_points().mean(0)
    s = RenderSettings(bit_depth=16, shadows=False)
    img = render_board_poses(Rig(CAM, PRJ), s, board, [(R, t)], WHITE, progress=False)[0].frames[0].astype(float)
    img = img / img.max() * 220.0
    rng = np.random.default_rng(3)
    for _ in range(12):  # dark specks the size of a few pixels on the white board (noise blobs)
        u, v = rng.integers(20, 620), rng.integers(20, 460)
        img[v:v + 2, u:u + 2] = 60.0
    img = np.clip(img + rng.normal(0, 6.0, img.shape), 0, 255).astype(np.uint8)
    uv = detect_board(img, board)
    assert uv is not None
    truth = CAM.project(board.object_points() @ R.T + t)
    d = np.linalg.norm(uv[:, None] - truth[None], axis=-1)
    # every label lands on its own true circle, up to OpenCV's choice of starting corner
    flip = uv if np.linalg.norm(uv[0] - truth[0]) < np.linalg.norm(uv[0] - truth[-1]) else uv[::-1]
    assert np.max(np.linalg.norm(flip - truth, axis=1)) < 1.0  # px; one label off is ~17 px
    assert len(set(d.argmin(1))) == board.count
