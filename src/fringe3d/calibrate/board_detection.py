"""Sub-pixel detection of circle-grid boards (ch. 2.2.5 step 2, ch. 3.3).

The board geometry is :class:`fringe3d.calibrate.boards.CircleBoard`.
OpenCV's ``findCirclesGrid`` finds and orders the circles; a ``SimpleBlobDetector`` sized to
the expected circle area keeps it from locking onto noise or fringe remnants, and each centre
is then refined to sub-pixel accuracy by an intensity-weighted centroid over the blob.
"""
from __future__ import annotations

import cv2
import numpy as np

from .boards import CircleBoard
from .grid_extent import check_not_larger


def to_uint8(image: np.ndarray) -> np.ndarray:
    """Scale an image (any dtype) to uint8 with its 0.5-99.5 percentile range."""
    img = np.asarray(image)
    if img.ndim != 2:
        raise ValueError(f"expected a 2-D grey image, got shape {img.shape}")
    if img.dtype == np.uint8:
        return img
    f = img.astype(np.float64)
    lo, hi = np.nanpercentile(f, [0.5, 99.5])
    if not hi > lo:
        raise ValueError("board image has no contrast (all pixels equal)")
    return np.clip((f - lo) * (255.0 / (hi - lo)), 0, 255).astype(np.uint8)


def blob_detector(board: CircleBoard, expected_radius_px: tuple[float, float]) -> cv2.SimpleBlobDetector:
    """A ``SimpleBlobDetector`` accepting blobs whose radius lies in ``expected_radius_px``
    (min, max in pixels), of the board's circle polarity."""
    p = cv2.SimpleBlobDetector_Params()
    rmin, rmax = expected_radius_px
    p.filterByArea = True
    p.minArea = float(max(np.pi * rmin ** 2, 4.0))
    p.maxArea = float(np.pi * rmax ** 2)
    p.filterByColor = True
    p.blobColor = 0 if board.dark_circles else 255
    p.filterByCircularity = True
    p.minCircularity = 0.5
    p.filterByConvexity = True
    p.minConvexity = 0.8
    p.filterByInertia = True
    p.minInertiaRatio = 0.15
    p.minThreshold = 20
    p.maxThreshold = 235
    p.thresholdStep = 10
    p.minDistBetweenBlobs = max(1.0, rmin)
    return cv2.SimpleBlobDetector_create(p)


def detect_board(image: np.ndarray, board: CircleBoard, radius_px: tuple[float, float] | None = None,
                 refine: bool = True) -> np.ndarray | None:
    """The board's circle centres, or None; see :func:`find_board` (which also says why not).

    Parameters
    ----------
    image : (H, W) array, any dtype
        Board image (the "white" frame of a calibration pose).
    board : CircleBoard
        The circle grid to find.
    radius_px : (min, max) or None
        Expected circle radius range in pixels; None derives it from the image size.
    refine : bool
        Refine each centre by an intensity-weighted centroid (sub-pixel).

    Returns
    -------
    (rows*cols, 2) ndarray (float64) or None
        Pixel centres ``(u, v)`` in OpenCV order, or None when the board was not found.
    """
    return find_board(image, board, radius_px, refine)[0]


def find_board(image: np.ndarray, board: CircleBoard, radius_px: tuple[float, float] | None = None,
               refine: bool = True) -> tuple[np.ndarray | None, str]:
    """Find the board's circle centres in a white-illuminated image.

    Parameters
    ----------
    image : (H, W) array, any dtype
        Board image (the "white" frame of a calibration pose).
    board : CircleBoard
    radius_px : (min, max) or None
        Expected circle radius range in pixels; None derives it from the image size and the
        board's circle count (radius between 1/6 and 1.2 of the largest spacing that fits).
    refine : bool
        Refine each centre by an intensity-weighted centroid (sub-pixel).

    Returns
    -------
    ``(uv, reason)``: (rows*cols, 2) float64 pixel centres ``(u, v)`` in OpenCV order and "",
    or None and why ("not found", or found but its circles could not be labelled consistently).

    Raises
    ------
    ValueError
        When the grid found continues past the stated board: the image holds a larger circle
        grid (:func:`fringe3d.calibrate.grid_extent.check_not_larger`).
    """
    if np.ndim(image) != 2:
        raise ValueError(f"board image must be a 2-D grey image, got shape {np.shape(image)}")
    if not np.ptp(np.asarray(image)) > 0:
        return None, "the image is flat"
    img8 = to_uint8(image)
    h, w = img8.shape
    if radius_px is None:
        span = max(board.cols * (2 if board.asymmetric else 1), board.rows)
        s_max = min(h, w) / max(span - 1, 1)
        ratio = board.radius / board.spacing
        radius_px = (1.5, max(3.0, 1.3 * ratio * s_max * (2 if board.asymmetric else 1)))
    flags = board.cv_flags
    det = blob_detector(board, radius_px)
    uv, mislabelled = None, False
    # when the default search fails or mislabels the grid: OpenCV's clustering search, then both
    # again on a lightly smoothed image (sensor noise makes small spurious blobs)
    for smooth, extra in ((False, 0), (False, cv2.CALIB_CB_CLUSTERING), (True, 0), (True, cv2.CALIB_CB_CLUSTERING)):
        im = cv2.GaussianBlur(img8, (0, 0), 1.0) if smooth else img8
        found, centres = cv2.findCirclesGrid(im, board.pattern_size, flags=flags | extra, blobDetector=det)
        if found and centres is not None:
            cand = np.asarray(centres, dtype=np.float64).reshape(-1, 2)  # OpenCV 4: (N,1,2); 5: may be (N,2)
            if cand.shape[0] == board.count and grid_is_consistent(cand, board):
                uv = cand
                keypoints = det.detect(im)
                check_not_larger(np.array([k.pt for k in keypoints], float).reshape(-1, 2),
                                 np.array([k.size for k in keypoints], float), uv, board)
                break
            mislabelled = True
    if uv is None:
        return None, ("a grid was found but its circles could not be labelled consistently (noise blobs?)"
                      if mislabelled else "not found")
    if refine:
        uv = refine_centres(np.asarray(image, dtype=np.float64), uv, board)
    return uv, ""


def grid_is_consistent(uv: np.ndarray, board: CircleBoard, tolerance: float = 0.3) -> bool:
    """Whether detected centres ``uv (N, 2)`` (OpenCV order) form a smooth grid.

    Along every grid row and column the second difference ``uv[k+1] - 2 uv[k] + uv[k-1]``
    of a correctly labelled grid is small (perspective and lens distortion bend the grid
    slowly); a block of circles labelled one place off (a spurious or missed blob) makes it
    about one spacing. The grid is rejected when any second difference exceeds ``tolerance``
    times the median neighbour distance. For an asymmetric grid the check runs along the
    rows of the OpenCV order only.
    """
    g = np.asarray(uv, float).reshape(board.rows, board.cols, 2)
    steps = [np.diff(g, axis=1)]
    if not board.asymmetric:
        steps.append(np.diff(g, axis=0))
    spacing = np.median(np.concatenate([np.linalg.norm(s, axis=-1).ravel() for s in steps]))
    second = [np.linalg.norm(np.diff(s, axis=ax), axis=-1) for s, ax in zip(steps, (1, 0))]
    worst = max((float(x.max()) for x in second if x.size), default=0.0)
    return worst <= tolerance * spacing


def refine_centres(image: np.ndarray, uv: np.ndarray, board: CircleBoard) -> np.ndarray:
    """Flat-field-normalised intensity-weighted centroids around the initial centres ``uv (N, 2)``.

    In a window of 0.45 times the distance to the nearest neighbouring centre, a plane
    ``a + b u + c v`` fitted to the background pixels (the brighter 50 % for dark circles)
    models the local illumination; the weight of a pixel is its relative darkness
    ``1 - I / plane`` (or brightness ``I / plane - 1`` for bright circles) minus 3 % of the
    circle's contrast, clipped at zero. Normalising by the fitted background keeps shading
    gradients across the board from pulling the centroid.

    Parameters
    ----------
    image : (H, W) float array
        Board image.
    uv : (N, 2) float64 array
        Initial centres ``(u, v)``, pixels (N >= 2: the window size comes from neighbours).
    board : CircleBoard
        Only ``board.dark_circles`` is read (dark circles on a bright background, or the reverse).

    Returns
    -------
    (N, 2) ndarray (float64)
        Refined centres, pixels; a centre keeps its initial value where its window has too few
        pixels, a non-positive background plane or no contrast.
    """
    h, w = image.shape
    d = np.linalg.norm(uv[:, None] - uv[None], axis=-1)
    np.fill_diagonal(d, np.inf)
    out = uv.copy()
    for k, (u, v) in enumerate(uv):
        r = 0.45 * d[k].min()
        u0, u1 = int(max(np.floor(u - r), 0)), int(min(np.ceil(u + r), w - 1))
        v0, v1 = int(max(np.floor(v - r), 0)), int(min(np.ceil(v + r), h - 1))
        patch = image[v0:v1 + 1, u0:u1 + 1]
        vv, uu = np.mgrid[v0:v1 + 1, u0:u1 + 1]
        inside = (uu - u) ** 2 + (vv - v) ** 2 <= r * r
        vals = patch[inside]
        if vals.size < 16:
            continue
        pu, pv = uu[inside].astype(float), vv[inside].astype(float)
        med = np.median(vals)
        bg = vals >= med if board.dark_circles else vals <= med
        A = np.stack([np.ones(bg.sum()), pu[bg] - u, pv[bg] - v], 1)
        coef, *_ = np.linalg.lstsq(A, vals[bg], rcond=None)
        plane = coef[0] + coef[1] * (pu - u) + coef[2] * (pv - v)
        if not np.all(plane > 0):
            continue
        rel = (1 - vals / plane) if board.dark_circles else (vals / plane - 1)
        contrast = np.percentile(rel, 95)
        if not contrast > 0:
            continue
        wgt = np.clip(rel - 0.03 * contrast, 0, None)
        s = wgt.sum()
        if s <= 0:
            continue
        out[k] = [(wgt * pu).sum() / s, (wgt * pv).sum() / s]
    return out
