"""Chessboard and ChArUco calibration boards: geometry shared by detection, calibration and the simulator.

Both boards are ``cols`` x ``rows`` squares of side ``spacing`` (mm); the calibration points
are the ``(cols - 1) * (rows - 1)`` inner corners, row by row (OpenCV order). Board frame (mm):
the board is the plane ``z_b = 0``, ``x_b`` along a row of squares, ``y_b`` down the rows.

* :class:`ChessBoard` (``cv2.findChessboardCornersSB``, ``patternSize = (cols - 1, rows - 1)``):
  the first inner corner is the origin, inner corner ``(i, j)`` (row, column) lies at
  ``(j s, i s, 0)``; the squares span ``[-s, (cols - 1) s] x [-s, (rows - 1) s]``.
* :class:`CharucoBoard` (``cv2.aruco.CharucoBoard``): OpenCV's board frame, the origin at the
  outer top-left corner of the squares (a black square), inner corner ``k`` (OpenCV's
  ChArUco corner id) at ``((k mod (cols - 1) + 1) s, (k div (cols - 1) + 1) s, 0)``; ArUco
  markers of side ``marker`` (mm) from ``dictionary`` sit centred in the white squares, so a
  partial view still identifies every corner it sees.

:func:`board_from_dict` reads any board description (circle grid, chessboard, ChArUco) from
its ``to_dict()`` form; a description without ``"kind"`` is a circle grid (the original format).

>>> ChessBoard(cols=3, rows=3, spacing=10.0).object_points()[:, :2].tolist()
[[0.0, 0.0], [10.0, 0.0], [0.0, 10.0], [10.0, 10.0]]
>>> CharucoBoard(cols=3, rows=3, spacing=10.0, marker=7.0).object_points()[:, :2].tolist()
[[10.0, 10.0], [20.0, 10.0], [10.0, 20.0], [20.0, 20.0]]
"""
from __future__ import annotations

import math

from dataclasses import asdict, dataclass

import cv2
import numpy as np

from .boards import CircleBoard

#: Board kinds :func:`board_from_dict` and the command line know.
BOARD_KINDS = ("circles", "chessboard", "charuco")


def _inner_corners(cols: int, rows: int, spacing: float, offset: float) -> np.ndarray:
    """``((cols-1)*(rows-1), 3)`` inner corners ``((j + offset) s, (i + offset) s, 0)``, row by row."""
    j, i = np.meshgrid(np.arange(cols - 1), np.arange(rows - 1))
    xy = np.stack([(j.ravel() + offset) * spacing, (i.ravel() + offset) * spacing], -1)
    return np.concatenate([xy, np.zeros((len(xy), 1))], 1).astype(float)


def _check_squares(kind: str, cols: int, rows: int, spacing: float) -> None:
    if cols < 3 or rows < 3:
        raise ValueError(f"a {kind} needs at least 3x3 squares (2x2 inner corners), got {cols}x{rows}")
    if not spacing > 0:
        raise ValueError(f"{kind} square size must be > 0 mm, got {spacing}")


class _SquareGrid:
    """What a board of ``cols`` x ``rows`` squares knows about its inner corners."""

    cols: int
    rows: int

    @property
    def pattern_size(self) -> tuple[int, int]:
        """Inner corners per row and per column, ``cv2.findChessboardCornersSB``'s ``patternSize``."""
        return (self.cols - 1, self.rows - 1)

    @property
    def count(self) -> int:
        """Number of inner corners."""
        return (self.cols - 1) * (self.rows - 1)


@dataclass(frozen=True)
class ChessBoard(_SquareGrid):
    """A planar chessboard of ``cols`` x ``rows`` squares of side ``spacing`` mm (see module doc).

    Attributes
    ----------
    cols, rows : int
        Squares per row and rows of squares (the inner corners are ``(cols-1) x (rows-1)``).
    spacing : float
        Square side (mm).
    """

    cols: int = 9
    rows: int = 7
    spacing: float = 10.0
    kind = "chessboard"

    def __post_init__(self):
        _check_squares("chessboard", self.cols, self.rows, self.spacing)


    def object_points(self) -> np.ndarray:
        """``((cols-1)*(rows-1), 3)`` float64 inner corners in board coordinates (mm), OpenCV order."""
        return _inner_corners(self.cols, self.rows, self.spacing, 0.0)

    def squares_extent(self) -> tuple[float, float, float, float]:
        """``(x0, x1, y0, y1)`` (mm) of the squares (the printed pattern without its white margin)."""
        s = self.spacing
        return (-s, (self.cols - 1) * s, -s, (self.rows - 1) * s)

    def describe(self) -> str:
        c, r = self.pattern_size
        return f"{self.cols}x{self.rows}-square chessboard ({c}x{r} inner corners, {self.spacing:g} mm squares)"

    def to_dict(self) -> dict:
        return {"kind": self.kind, "cols": self.cols, "rows": self.rows, "spacing": self.spacing}


@dataclass(frozen=True)
class CharucoBoard(_SquareGrid):
    """A ChArUco board (OpenCV's ``cv2.aruco.CharucoBoard``; see module doc).

    Attributes
    ----------
    cols, rows : int
        Squares per row and rows of squares.
    spacing : float
        Square side (mm).
    marker : float
        ArUco marker side (mm), smaller than ``spacing``.
    dictionary : str
        Name of a predefined ArUco dictionary (``cv2.aruco.DICT_...``), e.g. ``"DICT_4X4_50"``;
        it must hold at least one marker per white square.
    """

    cols: int = 9
    rows: int = 7
    spacing: float = 10.0
    marker: float = 7.0
    dictionary: str = "DICT_4X4_50"
    kind = "charuco"

    def __post_init__(self):
        _check_squares("ChArUco board", self.cols, self.rows, self.spacing)
        if not 0 < self.marker < self.spacing:
            raise ValueError(f"ChArUco marker size must be > 0 and below the square size {self.spacing:g} mm, "
                             f"got {self.marker}")
        d = self.cv_dictionary()
        need = (self.cols * self.rows) // 2
        if d.bytesList.shape[0] < need:
            raise ValueError(f"ArUco dictionary {self.dictionary} has {d.bytesList.shape[0]} markers but a "
                             f"{self.cols}x{self.rows} ChArUco board needs {need}; choose a larger dictionary")


    def cv_dictionary(self):
        """The ``cv2.aruco.Dictionary`` named by :attr:`dictionary`; ``ValueError`` for unknown names."""
        name = str(self.dictionary)
        code = getattr(cv2.aruco, name, None) if name.startswith("DICT_") else None
        if not isinstance(code, int):
            known = sorted(k for k in dir(cv2.aruco) if k.startswith("DICT_"))
            raise ValueError(f"unknown ArUco dictionary {name!r}; expected one of {', '.join(known)}")
        return cv2.aruco.getPredefinedDictionary(code)

    def cv_board(self):
        """The ``cv2.aruco.CharucoBoard`` (lengths in mm)."""
        return cv2.aruco.CharucoBoard((self.cols, self.rows), float(self.spacing), float(self.marker),
                                      self.cv_dictionary())

    def object_points(self) -> np.ndarray:
        """``((cols-1)*(rows-1), 3)`` float64 inner corners (mm) in ChArUco id order."""
        return _inner_corners(self.cols, self.rows, self.spacing, 1.0)

    def squares_extent(self) -> tuple[float, float, float, float]:
        """``(x0, x1, y0, y1)`` (mm) of the squares (the printed pattern without its white margin)."""
        return (0.0, self.cols * self.spacing, 0.0, self.rows * self.spacing)

    def image(self, pixels_per_square: int) -> np.ndarray:
        """The board's squares and markers, ``(rows * p, cols * p)`` uint8 (0 black, 255 white),
        ``p = pixels_per_square`` (``CharucoBoard.generateImage`` without margin)."""
        p = int(pixels_per_square)
        img = self.cv_board().generateImage((self.cols * p, self.rows * p), marginSize=0, borderBits=1)
        return np.asarray(img, np.uint8)

    def describe(self) -> str:
        return (f"{self.cols}x{self.rows}-square ChArUco board ({self.spacing:g} mm squares, {self.marker:g} mm "
                f"{self.dictionary} markers)")

    def to_dict(self) -> dict:
        return {"kind": self.kind, **asdict(self)}


def squares_from_inner_corners(text: str, option: str = "`inner_corners`") -> tuple[int, int]:
    """(cols, rows) squares of a chessboard/ChArUco board given as OpenCV counts it, ``"COLSxROWS"``
    inner corners (``patternSize``): one square more each way. ``ValueError`` naming ``option``.

    >>> squares_from_inner_corners("9x6")
    (10, 7)
    """
    c, sep, r = str(text).lower().partition("x")
    if not (sep and c.strip().isdigit() and r.strip().isdigit() and int(c) >= 2 and int(r) >= 2):
        raise ValueError(f"{option} {text!r}: expected COLSxROWS inner corners (at least 2x2), e.g. 9x6 as "
                         "cv2.findChessboardCorners' patternSize")
    return int(c) + 1, int(r) + 1


def board_from_dict(d: dict):
    """A :class:`~fringe3d.calibrate.boards.CircleBoard`, :class:`ChessBoard` or
    :class:`CharucoBoard` from its ``to_dict()`` form (no ``"kind"``: a circle grid).
    ``ValueError`` naming unknown kinds and fields.

    Parameters
    ----------
    d : dict
        The board's fields (``kind``, ``cols``, ``rows``, ``spacing`` in mm, and the kind's own
        fields), e.g. from a calibration file.

    Returns
    -------
    CircleBoard or ChessBoard or CharucoBoard
        The board.
    """
    if not isinstance(d, dict):
        raise ValueError(f"board: expected an object with the board's fields, got {d!r}")
    check_board_fields(d)
    fields = dict(d)
    kind = fields.pop("kind", "circles")
    if kind == "circles":
        return CircleBoard.from_dict(fields)
    classes = {"chessboard": ChessBoard, "charuco": CharucoBoard}
    if kind not in classes:
        raise ValueError(f"board: unknown kind {kind!r}; expected one of {', '.join(BOARD_KINDS)}")
    cls = classes[kind]
    known = {"cols", "rows", "spacing"} | ({"marker", "dictionary"} if kind == "charuco" else set())
    unknown = sorted(set(fields) - known)
    if unknown:
        raise ValueError(f"board ({kind}): unknown field(s) {unknown}; allowed {sorted(known | {'kind'})}")
    return cls(**fields)


#: Most circles / squares along one side of a board read from a file (bounds OpenCV's grid search).
MAX_FILE_BOARD_SIDE = 100
_BOARD_NUMBERS = ("spacing", "radius", "marker")
_BOARD_FLAGS = ("asymmetric", "dark_circles")


def check_board_fields(d: dict) -> None:
    """Refuse, before any board is built or searched for, a board description whose ``cols``/``rows``
    are not whole numbers in [2, :data:`MAX_FILE_BOARD_SIDE`], whose sizes are not finite numbers
    > 0 mm or whose flags are not true/false (a hostile ``cols: 1e9`` would make OpenCV search forever)."""
    for k in ("cols", "rows"):
        v = d.get(k, 2)
        if isinstance(v, bool) or not isinstance(v, int) or not 2 <= v <= MAX_FILE_BOARD_SIDE:
            raise ValueError(f"board: field {k}: expected a whole number in [2, {MAX_FILE_BOARD_SIDE}], got {v!r}")
    for k in _BOARD_NUMBERS:
        v = d.get(k, 1.0)
        if isinstance(v, bool) or not isinstance(v, (int, float)) or not (math.isfinite(v) and v > 0):
            raise ValueError(f"board: field {k}: expected a finite number > 0 (mm), got {v!r}")
    for k in _BOARD_FLAGS:
        if not isinstance(d.get(k, False), bool):
            raise ValueError(f"board: field {k}: expected true or false, got {d[k]!r}")


def describe_board(board) -> str:
    """A short description of any board for messages, e.g. ``"9x9 circle grid (10 mm spacing)"``."""
    if isinstance(board, CircleBoard):
        kind = "asymmetric circle grid" if board.asymmetric else "circle grid"
        return f"{board.cols}x{board.rows} {kind} ({board.spacing:g} mm spacing)"
    return board.describe()
