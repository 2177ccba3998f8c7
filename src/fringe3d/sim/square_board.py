"""Chessboard and ChArUco calibration boards as scene objects: a printed board texture on a plane.

The geometry (board frame, corner order) is :mod:`fringe3d.calibrate.square_boards`; the
targets here place such a board in a scene so the renderer can draw it: a matte plane with a
white margin around the squares, albedo ``white`` / ``dark``.

* :class:`ChessBoardTarget` evaluates the chessboard analytically: with ``c_x, c_y`` in
  ``[-1, 1]`` the signed distance of a point to the nearest square edge along x / y divided
  by half the edge ramp ``edge_width`` (clipped), the albedo is
  ``(white + dark) / 2 + (white - dark) / 2 * c_x c_y``: a linear ramp across each edge (it
  anti-aliases the renderer's one ray per pixel) whose saddle point stays exactly at every
  corner.
* :class:`CharucoTarget` samples ``cv2.aruco.CharucoBoard.generateImage`` (squares of an
  integer number of texels, so the corners sit on texel edges), blurred by a Gaussian of
  ``edge_width / 2.5`` (symmetric, so the corners do not move), bilinearly.

:func:`board_target` builds the target for any board kind (circle grids:
:class:`fringe3d.sim.board.BoardTarget`).
"""
from __future__ import annotations

import cv2
import numpy as np

from fringe3d.calibrate.boards import CircleBoard
from fringe3d.calibrate.square_boards import CharucoBoard, ChessBoard

from .board import BoardLook, BoardTarget, rectangle_hits
from .motion import STATIC, RigidMotion
from .projector_sampling import bilinear
from .scene_object import PosedObject, check_albedo, check_rotation, check_vec3


class _PrintedBoard(PosedObject):
    """A plane ``z_b = 0`` bounded by the board's squares plus ``margin`` (mm), posed by ``R``, ``t``."""

    def __init__(self, board, R=None, t=(0.0, 0.0, 400.0), margin=None, white=0.9, dark=0.1,
                 edge_width=0.0, motion: RigidMotion = STATIC):
        self.board = board
        self.margin = board.spacing if margin is None else float(margin)
        if self.margin < 0:
            raise ValueError(f"board margin must be >= 0 mm, got {margin}")
        self.white, self.dark = check_albedo(white, "white"), check_albedo(dark, "dark")
        self.edge_width = float(edge_width)
        if not 0 <= self.edge_width <= 0.5 * board.spacing:
            raise ValueError(f"edge_width must be in [0, spacing/2] mm, got {edge_width}")
        self.R = np.eye(3) if R is None else check_rotation(R)
        self.center = check_vec3(t, "t")
        self.motion = motion
        self.albedo = self.white
        self.texture = None
        x0, x1, y0, y1 = board.squares_extent()
        m = self.margin
        self.extent = np.array([x0 - m, x1 + m, y0 - m, y1 + m])

    def corners(self, time: float = 0.0) -> np.ndarray:
        """True inner corners in world coordinates at ``time``, ``(N, 3)`` mm (board order)."""
        return self.to_world(self.board.object_points(), time)

    def bounding_sphere_body(self):
        x0, x1, y0, y1 = self.extent
        return np.array([(x0 + x1) / 2, (y0 + y1) / 2, 0.0]), 0.5 * float(np.hypot(x1 - x0, y1 - y0))

    def intersect_body(self, o, d):
        return rectangle_hits(o, d, self.extent)

    def describe(self) -> str:
        return self.board.describe()


def _edge_ramp(x: np.ndarray, spacing: float, half: float) -> np.ndarray:
    """Signed distance of ``x`` (mm) to the nearest multiple of ``spacing``, + in even cells,
    divided by ``half`` and clipped to [-1, 1] (a step when ``half == 0``)."""
    u = x / spacing
    cell = np.floor(u)
    f = u - cell
    dist = np.minimum(f, 1.0 - f) * spacing
    sign = np.where(np.mod(cell, 2) == 0, 1.0, -1.0)
    if half <= 0:
        return sign
    return sign * np.clip(dist / half, 0.0, 1.0)


class ChessBoardTarget(_PrintedBoard):
    """A :class:`~fringe3d.calibrate.square_boards.ChessBoard` in a scene (see the module doc).

    Parameters
    ----------
    board : ChessBoard
    R, t : board -> world rotation ((3, 3) or rotation vector) and translation (mm)
    margin : white border around the squares (mm); default one square
    white, dark : albedos of the white and the black squares, in [0, 1]
    edge_width : width (mm) of the linear albedo ramp across each square edge (0 = sharp)
    """

    def __init__(self, board: ChessBoard, **kw):
        super().__init__(board, **kw)

    def albedo_at(self, uv: np.ndarray) -> np.ndarray:
        """Albedo at board coordinates ``uv`` (M, 2) mm."""
        b = self.board
        s, half = b.spacing, 0.5 * self.edge_width
        # the square (i, j) containing the origin's lower right is white: shift by one square so
        # the top-left square (x in [-s, 0)) is black, as OpenCV draws it
        c = _edge_ramp(uv[:, 0] + s, s, half) * _edge_ramp(uv[:, 1] + s, s, half)
        value = 0.5 * (self.white + self.dark) - 0.5 * (self.white - self.dark) * c
        x0, x1, y0, y1 = b.squares_extent()
        # outside the squares: white, with the same ramp across the outer edge
        out = np.maximum.reduce([x0 - uv[:, 0], uv[:, 0] - x1, y0 - uv[:, 1], uv[:, 1] - y1])
        w = np.clip(out / (2 * half) + 0.5, 0.0, 1.0) if half > 0 else (out > 0).astype(float)
        return value * (1 - w) + self.white * w


class CharucoTarget(_PrintedBoard):
    """A :class:`~fringe3d.calibrate.square_boards.CharucoBoard` in a scene (see the module doc).

    Parameters as :class:`ChessBoardTarget`; ``pixels_per_square`` sets the texture resolution
    (default: four texels per edge ramp, 16 to 400 per square).
    """

    def __init__(self, board: CharucoBoard, pixels_per_square: int | None = None, **kw):
        super().__init__(board, **kw)
        s = board.spacing
        if pixels_per_square is None:
            pixels_per_square = int(np.clip(np.ceil(4 * s / self.edge_width), 16, 400)) if self.edge_width > 0 else 200
        p = int(pixels_per_square)
        img = board.image(p).astype(np.float64) / 255.0
        texel = s / p
        pad = int(np.ceil(self.margin / texel)) + 2
        tex = np.pad(img, pad, constant_values=1.0)
        if self.edge_width > 0:
            tex = np.asarray(cv2.GaussianBlur(tex, (0, 0), self.edge_width / 2.5 / texel), np.float64)
        self._tex = np.ascontiguousarray(tex)
        self._texel, self._pad = texel, pad

    def albedo_at(self, uv: np.ndarray) -> np.ndarray:
        """Albedo at board coordinates ``uv`` (M, 2) mm (bilinear texture sample)."""
        u = np.ascontiguousarray(uv[:, 0] / self._texel - 0.5 + self._pad)
        v = np.ascontiguousarray(uv[:, 1] / self._texel - 0.5 + self._pad)
        f = np.empty(len(uv))
        bilinear(self._tex, u, v, f)
        return self.dark + (self.white - self.dark) * np.clip(f, 0.0, 1.0)


def board_target(board, R, t, white: float = 0.9, dark: float = 0.1, edge_width: float = 0.0):
    """The scene object that renders ``board`` (any kind) posed by ``(R, t)`` (board -> world)."""
    if isinstance(board, CircleBoard):
        return BoardTarget(board, R=R, t=t, look=BoardLook(white=white, dark=dark,
                                                           edge_width=min(edge_width, 0.9 * board.radius)))
    cls = ChessBoardTarget if isinstance(board, ChessBoard) else CharucoTarget
    return cls(board, R=R, t=t, white=white, dark=dark, edge_width=min(edge_width, 0.5 * board.spacing))
