"""Finding any calibration board in a board image: chessboard and ChArUco corners (OpenCV).

* chessboard: ``cv2.findChessboardCornersSB`` (the sector-based detector, flags
  :data:`CHESSBOARD_FLAGS` in turn) finds and orders the inner corners;
* ChArUco: ``cv2.aruco.CharucoDetector``: the ArUco markers identify each square, so a partial
  view gives the corners it sees, labelled with their ids; undetected corners are NaN rows;
* both then refine every corner (:func:`refine_corners`): ``cv2.cornerSubPix`` (the image
  gradient is orthogonal to the vector from the corner to any pixel near it), then the
  saddle point of a quadratic fitted to the lightly smoothed image in a disc around the
  corner (:func:`saddle_points`). A chessboard corner is point-symmetric, and stays so
  under a symmetric blur, so the fit's linear terms vanish exactly at the corner. On
  rendered noise-free boards the corner error goes from about 0.08 px (the detector's own
  estimate) to about 0.045 px (cornerSubPix) and 0.025 px (saddle point);
* circle grid: :func:`fringe3d.calibrate.board_detection.find_board`.

:func:`locate_board` dispatches on the board's kind and returns the points in the board's
order (``board.object_points()``).
"""
from __future__ import annotations

import cv2
import numpy as np

from fringe3d.phase.sampling import sample_bilinear

from .board_detection import find_board, to_uint8
from .boards import CircleBoard
from .square_boards import CharucoBoard, ChessBoard

#: ``findChessboardCornersSB`` flags tried in turn: histogram equalisation
#: (``CALIB_CB_NORMALIZE_IMAGE``) helps on a dim, evenly lit board but loses noisy boards on a
#: black background, so it is tried second; plain last.
CHESSBOARD_FLAGS = (cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY,
                    cv2.CALIB_CB_NORMALIZE_IMAGE | cv2.CALIB_CB_EXHAUSTIVE | cv2.CALIB_CB_ACCURACY, 0)

#: Fewest ChArUco corners a partial view must show to be used (a homography needs 4; the
#: device calibration needs 6 per view).
MIN_CHARUCO_CORNERS = 6


def saddle_points(image: np.ndarray, uv: np.ndarray, radius: float = 3.5, sigma: float = 1.0,
                  iterations: int = 20) -> np.ndarray:
    """Saddle points of ``image`` near ``uv (N, 2)`` (px): the image smoothed by a Gaussian of
    ``sigma`` px is sampled (bilinear) on the integer offsets within ``radius`` px of the
    current estimate, ``I = a + b x + c y + d x^2 + e x y + f y^2`` is fitted by least squares
    and the estimate moves to the stationary point ``[[2d, e], [e, 2f]] s = -[b, c]``, until the
    step is below 1e-5 px. A point whose step leaves the disc, or whose fit is degenerate, keeps
    its last estimate. Returns ``(N, 2)`` float64 (NaN rows stay NaN)."""
    img = cv2.GaussianBlur(np.asarray(image, np.float64), (0, 0), float(sigma))
    k = int(np.ceil(radius))
    oy, ox = np.mgrid[-k:k + 1, -k:k + 1].astype(float)
    disc = ox ** 2 + oy ** 2 <= radius ** 2
    dx, dy = ox[disc], oy[disc]
    pinv = np.linalg.pinv(np.stack([np.ones_like(dx), dx, dy, dx * dx, dx * dy, dy * dy], 1))
    out = np.array(uv, np.float64)
    for i in np.flatnonzero(np.all(np.isfinite(out), 1)):
        p = out[i].copy()
        for _ in range(iterations):
            _, b, c, d, e, f = pinv @ sample_bilinear(img, np.stack([p[0] + dx, p[1] + dy], 1))
            M = np.array([[2 * d, e], [e, 2 * f]])
            if not abs(np.linalg.det(M)) > 1e-12:
                break
            step = -np.linalg.solve(M, [b, c])
            if not np.abs(step).max() <= radius:
                break
            p = p + step
            if np.abs(step).max() < 1e-5:
                break
        out[i] = p
    return out


def refine_corners(image: np.ndarray, uv: np.ndarray) -> np.ndarray:
    """``cv2.cornerSubPix`` then :func:`saddle_points` of the finite rows of ``uv (N, 2)`` (see
    the module doc; disc radius 3.5 px, at most a fifth of the corner spacing); NaN rows stay."""
    out = np.array(uv, np.float64)
    ok = np.all(np.isfinite(out), 1)
    if ok.sum() < 2:
        return out
    pts = out[ok]
    d = np.linalg.norm(pts[:, None] - pts[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    half = int(np.clip(0.25 * np.median(d.min(1)), 2, 5))
    crit = (cv2.TERM_CRITERIA_EPS + cv2.TERM_CRITERIA_COUNT, 100, 1e-4)
    ref = cv2.cornerSubPix(np.asarray(image, np.float32), pts.astype(np.float32).reshape(-1, 1, 2).copy(),
                           (half, half), (-1, -1), crit)
    out[ok] = np.asarray(ref, np.float64).reshape(-1, 2)
    radius = float(np.clip(0.2 * np.median(d.min(1)), 1.5, 3.5))
    return saddle_points(image, out, radius)


def find_chessboard(image: np.ndarray, board: ChessBoard) -> tuple[np.ndarray | None, str]:
    """Inner corners of ``board`` in a grey image: ``((cols-1)*(rows-1), 2)`` float64 pixels
    ``(u, v)`` in OpenCV order and ``""``, or None and why."""
    img8 = to_uint8(image)
    found, corners = False, None
    for flags in CHESSBOARD_FLAGS:
        found, corners = cv2.findChessboardCornersSB(img8, board.pattern_size, flags=flags)
        if found and corners is not None:
            break
    check_not_larger(img8, board)
    if not found or corners is None:
        return None, "not found"
    uv = np.asarray(corners, np.float64).reshape(-1, 2)
    if uv.shape[0] != board.count:
        return None, f"found {uv.shape[0]} of its {board.count} corners"
    return refine_corners(image, uv), ""


def check_not_larger(img8: np.ndarray, board: ChessBoard) -> None:
    """Refuse a board stated smaller than the one in the image: ``findChessboardCornersSB``
    matches any sub-grid of a larger chessboard (a 5x3 grid of a 9x7-corner board, silently
    wrong object points), so the image is searched once more with ``CALIB_CB_LARGER``; more
    corners than ``board`` has raise ``ValueError`` saying how OpenCV counts them."""
    found, _, meta = cv2.findChessboardCornersSBWithMeta(img8, board.pattern_size,
                                                         flags=CHESSBOARD_FLAGS[0] | cv2.CALIB_CB_LARGER)
    if not found or meta is None or meta.size <= board.count:
        return
    a, b = sorted(meta.shape, reverse=True)
    c, r = board.pattern_size
    raise ValueError(f"the image shows a chessboard of {a}x{b} inner corners ({a + 1}x{b + 1} squares), larger "
                     f"than the stated {board.describe()}: only a {c}x{r} part of it would be matched. State the "
                     f"board as OpenCV counts it, `inner_corners` {a}x{b} (or `cols` {a + 1} `rows` {b + 1} squares)")


def find_charuco(image: np.ndarray, board: CharucoBoard,
                 min_corners: int = MIN_CHARUCO_CORNERS) -> tuple[np.ndarray | None, str]:
    """ChArUco corners of ``board``: ``((cols-1)*(rows-1), 2)`` float64 pixels in id order with
    NaN rows for the corners not seen (partial views), and ``""``; or None and why (fewer than
    ``min_corners`` corners)."""
    img8 = to_uint8(image)
    det = cv2.aruco.CharucoDetector(board.cv_board())
    corners, ids, _, marker_ids = det.detectBoard(img8)
    markers = len(board.cv_board().getIds())
    if marker_ids is not None and len(marker_ids) and int(np.max(marker_ids)) >= markers:
        raise ValueError(f"the image shows {board.dictionary} marker id {int(np.max(marker_ids))}, but the stated "
                         f"{board.describe()} has markers 0..{markers - 1}: the board is larger than stated "
                         "(`cols`/`rows` count squares; `inner_corners` COLSxROWS counts corners as OpenCV does)")
    n = 0 if ids is None else len(np.asarray(ids).ravel())
    if n < min_corners:
        return None, "not found" if n == 0 else f"only {n} corner(s) seen; need {min_corners}"
    uv = np.full((board.count, 2), np.nan)
    uv[np.asarray(ids).ravel().astype(int)] = np.asarray(corners, np.float64).reshape(-1, 2)
    return refine_corners(image, uv), ""


def locate_board(image: np.ndarray, board) -> tuple[np.ndarray | None, str]:
    """The board's points in ``image`` (any kind; see the module doc): ``(N, 2)`` float64 in
    ``board.object_points()`` order (NaN rows: not seen) and ``""``, or None and why.

    Parameters
    ----------
    image : (H, W) array, any dtype
        Grey board image.
    board : CircleBoard or ChessBoard or CharucoBoard
        The board to find.

    Returns
    -------
    uv : (N, 2) ndarray (float64) or None
        Board points ``(u, v)``, pixels, or None when not found.
    reason : str
        ``""`` when found, else why not (e.g. "the image is flat").
    """
    if np.ndim(image) != 2:
        raise ValueError(f"board image must be a 2-D grey image, got shape {np.shape(image)}")
    if not np.ptp(np.asarray(image)) > 0:
        return None, "the image is flat"
    if isinstance(board, CircleBoard):
        return find_board(image, board)
    if isinstance(board, ChessBoard):
        return find_chessboard(image, board)
    if isinstance(board, CharucoBoard):
        return find_charuco(image, board)
    raise TypeError(f"not a calibration board: {board!r}")
