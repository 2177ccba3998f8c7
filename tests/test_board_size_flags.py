"""Board sizes as OpenCV tools count them (--inner-corners), and a board stated smaller than the
one in the image refused instead of matched as a sub-grid (issue 23, item 5)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from fringe3d.calibrate.corner_detection import locate_board
from fringe3d.calibrate.square_boards import CharucoBoard, ChessBoard
from fringe3d.cli import main
from fringe3d.commands.calibrate import board_counts

SQUARE, MARGIN = 24, 40


def chessboard_image(cols: int, rows: int) -> tuple[np.ndarray, np.ndarray]:
    """A lightly blurred chessboard of ``cols`` x ``rows`` squares (black top-left) and its
    inner corners (px, row by row): square edges lie between pixels, at ``MARGIN + k SQUARE - 0.5``."""
    img = np.full((rows * SQUARE + 2 * MARGIN, cols * SQUARE + 2 * MARGIN), 230.0)
    for i in range(rows):
        for j in range(cols):
            if (i + j) % 2 == 0:
                img[MARGIN + i * SQUARE:MARGIN + (i + 1) * SQUARE, MARGIN + j * SQUARE:MARGIN + (j + 1) * SQUARE] = 25
    v, u = np.mgrid[1:rows, 1:cols]
    corners = np.stack([MARGIN + u.ravel() * SQUARE - 0.5, MARGIN + v.ravel() * SQUARE - 0.5], 1)
    return cv2.GaussianBlur(img, (0, 0), 1.0).astype(np.uint8), corners


def test_a_chessboard_stated_smaller_than_the_image_is_refused_not_matched_as_a_sub_grid():
    img, corners = chessboard_image(10, 8)  # 9x7 inner corners
    for stated in (ChessBoard(cols=7, rows=5, spacing=10.0), ChessBoard(cols=9, rows=7, spacing=10.0)):
        with pytest.raises(ValueError, match=r"9x7 inner corners.*`inner_corners` 9x7"):
            locate_board(img, stated)
    uv, why = locate_board(img, ChessBoard(cols=10, rows=8, spacing=10.0))
    assert why == "" and uv.shape == (63, 2)
    # OpenCV may start at either end of the symmetric board: compare as point sets
    d = np.linalg.norm(uv[:, None] - corners[None], axis=-1).min(axis=1)
    assert d.max() < 0.1


def test_a_charuco_board_stated_smaller_than_its_markers_is_refused():
    big = CharucoBoard(cols=8, rows=6, spacing=20.0, marker=14.0)
    img = np.pad(big.image(40), 40, constant_values=255)
    uv, why = locate_board(img, big)
    assert why == "" and np.isfinite(uv).all()
    with pytest.raises(ValueError, match=r"marker id \d+.*larger than stated"):
        locate_board(img, CharucoBoard(cols=5, rows=4, spacing=20.0, marker=14.0))


def test_inner_corners_count_as_opencv_does_and_must_agree_with_cols_rows(tmp_path, capsys):
    assert board_counts("chessboard", None, None, "9x6") == (10, 7)
    assert board_counts("charuco", 10, None, "9x6") == (10, 7)
    assert board_counts("chessboard", None, None, None) == (9, 9)
    for bad, message in ((("chessboard", 9, None, "9x6"), "--cols says 9"), (("circles", None, None, "9x6"), "circle"),
                         (("chessboard", None, None, "9by6"), "COLSxROWS")):
        with pytest.raises(ValueError, match=message):
            board_counts(*bad)
    assert main(["calibrate", str(tmp_path), "--board", "chessboard", "--inner-corners", "9x6", "--rows", "6",
                 "--spacing", "20", "-o", str(tmp_path / "c.json")]) == 2
    assert "--rows says 6" in " ".join(capsys.readouterr().err.split())
