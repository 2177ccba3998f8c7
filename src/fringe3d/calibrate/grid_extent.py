"""A circle grid stated smaller than the one in the image (issue 23: a wrong board size).

``cv2.findCirclesGrid`` matches any sub-grid of a larger circle board: a 9x7 grid stated as
8x7 is found, its circles get the wrong object points, and the calibration quietly goes
wrong. After a detection, :func:`grid_extent` looks one spacing past each end of every row
and column for a blob of the grid's size; a side where most lines continue is added to the
grid and searched again. :func:`check_not_larger` turns a grid that grew into a ``ValueError``.

Grid index ``(i, j)`` (row ``i``, column ``j``, the board's OpenCV order) has board
coordinates ``(j s, i s)`` (symmetric) or ``((2 j + i mod 2) s, i s)`` (asymmetric),
:class:`fringe3d.calibrate.boards.CircleBoard`; indices outside ``0..rows-1, 0..cols-1`` are
circles beyond the stated board. A point's expected pixel position comes from the
homography of the board plane fitted to every circle found so far, corrected by the
homography's residual at the nearest found circle (lens distortion varies slowly).
"""
from __future__ import annotations

import cv2
import numpy as np

from .boards import CircleBoard

#: a blob counts as the next circle when it lies within this fraction of the local spacing
#: of the expected position and its size is within this factor of the grid circles' median
MATCH_FRACTION = 0.3
SIZE_FACTOR = 2.0
#: a side continues when at least this fraction of its lines (and at least 2) continue
CONTINUE_FRACTION = 0.5


def board_xy(board: CircleBoard, i: np.ndarray, j: np.ndarray) -> np.ndarray:
    """``(N, 2)`` board coordinates (mm) of grid indices ``i, j (N,)`` (may lie outside the board)."""
    i, j = np.asarray(i, float), np.asarray(j, float)
    x = (2 * j + np.mod(i, 2)) * board.spacing if board.asymmetric else j * board.spacing
    return np.stack([x, i * board.spacing], axis=-1)


def _predict(board: CircleBoard, known: dict, idx: list[tuple[int, int]]) -> tuple[np.ndarray, np.ndarray]:
    """Expected pixels ``(N, 2)`` of grid indices ``idx`` and the pixel distance to the nearest
    known circle ``(N,)`` (the local spacing)."""
    ki = np.array(list(known), float)
    kxy = board_xy(board, ki[:, 0], ki[:, 1])
    kuv = np.array(list(known.values()), float)
    H, _ = cv2.findHomography(kxy, kuv, 0)
    qi = np.array(idx, float)
    qxy = board_xy(board, qi[:, 0], qi[:, 1])
    nearest = np.linalg.norm(qxy[:, None] - kxy[None], axis=-1).argmin(axis=1)
    residual = kuv - cv2.perspectiveTransform(kxy[:, None], H)[:, 0]
    quv = cv2.perspectiveTransform(qxy[:, None], H)[:, 0] + residual[nearest]
    return quv, np.linalg.norm(quv - kuv[nearest], axis=1)


def _side(extent: list[int], side: int) -> list[tuple[int, int]]:
    """Grid indices one line past ``side`` (0: top, 1: bottom, 2: left, 3: right) of ``extent``
    ``[i0, i1, j0, j1]`` (inclusive)."""
    i0, i1, j0, j1 = extent
    if side < 2:
        i = i0 - 1 if side == 0 else i1 + 1
        return [(i, j) for j in range(j0, j1 + 1)]
    j = j0 - 1 if side == 2 else j1 + 1
    return [(i, j) for i in range(i0, i1 + 1)]


def grid_extent(blobs: np.ndarray, sizes: np.ndarray, uv: np.ndarray, board: CircleBoard,
                max_lines: int = 64) -> tuple[int, int]:
    """``(cols, rows)`` of the grid the detected circles belong to: at least the board's.

    Parameters
    ----------
    blobs : (M, 2) float
        Blob centres (px) of the blob detector that found the grid.
    sizes : (M,) float
        Their diameters (px).
    uv : (rows*cols, 2) float
        The detected circle centres (px), OpenCV order.
    board : CircleBoard
        The stated board.
    max_lines : int
        At most this many lines are added (a guard; a real board stops far earlier).
    """
    if len(blobs) == 0:
        return board.pattern_size
    near = np.linalg.norm(uv[:, None] - blobs[None], axis=-1).argmin(axis=1)
    size = float(np.median(sizes[near]))
    similar = (sizes >= size / SIZE_FACTOR) & (sizes <= size * SIZE_FACTOR)
    blobs = blobs[similar]
    ii, jj = np.divmod(np.arange(board.count), board.cols)
    known = {(int(i), int(j)): p for i, j, p in zip(ii, jj, uv)}
    extent = [0, board.rows - 1, 0, board.cols - 1]
    grew, added = True, 0
    while grew and len(blobs) and added < max_lines:
        grew = False
        for side in range(4):
            idx = _side(extent, side)
            quv, local = _predict(board, known, idx)
            d = np.linalg.norm(quv[:, None] - blobs[None], axis=-1)
            hit = d.min(axis=1) <= MATCH_FRACTION * local
            if hit.sum() >= max(2, CONTINUE_FRACTION * len(idx)):
                known.update({q: blobs[k] for q, k, h in zip(idx, d.argmin(axis=1), hit) if h})
                extent[side] += -1 if side in (0, 2) else 1
                grew, added = True, added + 1
    return extent[3] - extent[2] + 1, extent[1] - extent[0] + 1


def check_not_larger(blobs: np.ndarray, sizes: np.ndarray, uv: np.ndarray, board: CircleBoard) -> None:
    """``ValueError`` when the detected grid continues past the stated board (:func:`grid_extent`),
    naming the stated size, the size seen and the flags that state it."""
    cols, rows = grid_extent(blobs, sizes, uv, board)
    if (cols, rows) == board.pattern_size:
        return
    kind = "asymmetric circle grid" if board.asymmetric else "circle grid"
    raise ValueError(f"the image holds a larger {kind}: at least {cols}x{rows} circles where "
                     f"{board.cols}x{board.rows} were given (`cols` {board.cols} `rows` {board.rows}); only part of "
                     "it would be matched, with wrong board coordinates. "
                     f"Pass `cols` {cols} `rows` {rows}")
