"""Circle-grid board: albedo lookup, true centres, and OpenCV detection of a ray-cast image."""
import cv2
import numpy as np
import pytest

from fringe3d.calibrate.boards import CircleBoard
from fringe3d.optics import PinholeDevice, intrinsics
from fringe3d.sim.board import BoardLook, BoardTarget, board_facing

CAM = PinholeDevice(intrinsics(400, 400, 159.5, 127.5), 320, 256)


def _image(board):
    o, d = CAM.rays(CAM.pixel_grid().reshape(-1, 2))
    h = board.intersect(o, d)
    return (h.albedo.reshape(CAM.height, CAM.width) * 255).round().astype(np.uint8)


@pytest.mark.parametrize("asym", [False, True])
def test_opencv_finds_board_circles_at_projected_true_centres(asym):
    grid = (CircleBoard(cols=4, rows=9, spacing=12.0, radius=3.0, asymmetric=True) if asym
            else CircleBoard(cols=7, rows=6, spacing=15.0, radius=3.75))
    board = board_facing((0, 0, 0), (5, -3, 300), tilt=(0.3, -0.2, 0.1), board=grid, look=BoardLook(edge_width=0.6))
    ok, found = cv2.findCirclesGrid(_image(board), board.pattern_size, flags=board.cv_flags)
    assert ok
    truth = CAM.project(board.circle_centers())
    # the projected circle centroid differs from the projected centre by perspective only
    assert np.abs(found.reshape(-1, 2) - truth).max() < 0.15


def test_board_albedo_dark_in_circles_white_between():
    for asym in (False, True):
        b = BoardTarget(CircleBoard(cols=5, rows=4, spacing=10, radius=3, asymmetric=asym),
                        look=BoardLook(white=0.9, dark=0.1))
        c = b.object_points()[:, :2]
        np.testing.assert_allclose(b.albedo_at(c), 0.1)
        np.testing.assert_allclose(b.albedo_at(c + [2.9, 0]), 0.1)
        np.testing.assert_allclose(b.albedo_at(c + [3.1, 0]), 0.9)
        np.testing.assert_allclose(b.albedo_at(c + [0, -3.1]), 0.9)


def test_board_pose_maps_object_points_and_hits_lie_on_board_plane():
    R = cv2.Rodrigues(np.array([0.2, -0.4, 0.1]))[0]
    t = np.array([-40.0, -30.0, 350.0])
    b = BoardTarget(CircleBoard(cols=6, rows=5, spacing=10, radius=2.5), R=R, t=t)
    np.testing.assert_allclose(b.circle_centers(), b.object_points() @ R.T + t)
    # a ray aimed at each true centre hits the board there and sees a dark circle
    X = b.circle_centers()
    h = b.intersect(np.zeros(3), X / np.linalg.norm(X, axis=1, keepdims=True))
    np.testing.assert_allclose(h.points(np.zeros(3), X / np.linalg.norm(X, axis=1, keepdims=True)), X, atol=1e-9)
    np.testing.assert_allclose(h.material_uv, b.object_points()[:, :2], atol=1e-9)
    np.testing.assert_allclose(h.albedo, b.dark)
    np.testing.assert_allclose(np.abs(h.normal @ R[:, 2]), 1.0)


def test_board_is_finite_with_its_margin():
    b = BoardTarget(CircleBoard(cols=3, rows=3, spacing=10, radius=2.5), t=(0, 0, 100), look=BoardLook(margin=5))
    d = np.array([[-4.9, 0, 100], [-5.1, 0, 100], [24.9, 24.9, 100], [25.1, 10, 100]])
    np.testing.assert_array_equal(b.intersect(np.zeros(3), d).mask, [True, False, True, False])


def test_board_rejects_overlapping_circles_and_tiny_grids():
    with pytest.raises(ValueError, match="radius"):
        BoardTarget(CircleBoard(spacing=10, radius=5))
    with pytest.raises(ValueError, match="radius"):
        BoardTarget(CircleBoard(spacing=10, radius=7.1, asymmetric=True))
    with pytest.raises(ValueError, match="2x2"):
        BoardTarget(CircleBoard(cols=1, rows=5))
