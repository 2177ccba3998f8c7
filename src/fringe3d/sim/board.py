"""The circle-grid calibration board as a scene object (ch. 2.2.4, ch. 3: dark circles on matte white).

The grid geometry (board frame, layouts, OpenCV order) is
:class:`fringe3d.calibrate.boards.CircleBoard`; :class:`BoardTarget` places such a board in
a scene (pose, margin, albedos, anti-aliased circle edges) so the renderer can draw it.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from fringe3d.calibrate.boards import CircleBoard

from .motion import STATIC, RigidMotion, rotation_vector_to_matrix
from .scene_object import PosedObject, check_albedo, check_rotation, check_vec3


#: The circle board a :class:`BoardTarget` draws when none is given: 9 x 9 circles, 10 mm apart.
DEFAULT_BOARD = CircleBoard(cols=9, rows=9, spacing=10.0, radius=2.5)


@dataclass(frozen=True)
class BoardLook:
    """How a printed circle board looks in a scene: its border and albedos.

    Attributes
    ----------
    margin : float | None
        White border around the outermost circles (mm); ``None`` = the grid spacing.
    white : float
        Albedo of the board, in [0, 1].
    dark : float
        Albedo of the circles, in [0, 1].
    edge_width : float
        Width (mm) of a linear albedo ramp centred on each circle's edge (0 = sharp). A ramp
        about one pixel footprint wide anti-aliases single-sample renders without moving the
        circle's centroid (the ramp is symmetric about the true radius).
    """

    margin: float | None = None
    white: float = 0.9
    dark: float = 0.1
    edge_width: float = 0.0


#: The board geometry fields of a scene file's ``board`` entry (the rest: pose, look, motion).
_GEOMETRY_FIELDS = ("cols", "rows", "spacing", "radius", "asymmetric")


class BoardTarget(PosedObject):
    """A matte white board with dark circles: a :class:`CircleBoard` placed in a scene.

    Parameters
    ----------
    board : CircleBoard, optional
        The grid: circles per row and rows, spacing and radius (mm), symmetric or asymmetric
        layout; default :data:`DEFAULT_BOARD` (9 x 9, 10 mm).
    R, t : board → world rotation ((3, 3) or rotation vector) and translation (mm).
    look : BoardLook
        Border (mm), albedos and anti-aliased circle edges (mm).
    motion : RigidMotion
        The board's rigid motion (default static).
    """

    def __init__(self, board: CircleBoard | None = None, R=None, t=(0.0, 0.0, 400.0),
                 look: BoardLook = BoardLook(), motion: RigidMotion = STATIC):
        b = DEFAULT_BOARD if board is None else board
        self.board = CircleBoard(cols=int(b.cols), rows=int(b.rows), spacing=float(b.spacing),
                                 radius=float(b.radius), asymmetric=bool(b.asymmetric))
        self.cols, self.rows = self.board.cols, self.board.rows
        self.spacing, self.radius, self.asymmetric = self.board.spacing, self.board.radius, self.board.asymmetric
        self.margin = self.spacing if look.margin is None else float(look.margin)
        if self.margin < self.radius:
            raise ValueError(f"board margin ({self.margin} mm) must be at least the circle radius")
        self.white, self.dark = check_albedo(look.white, "white"), check_albedo(look.dark, "dark")
        self.edge_width = float(look.edge_width)
        if self.edge_width < 0 or self.edge_width > self.radius:
            raise ValueError(f"edge_width must be in [0, radius] mm, got {look.edge_width}")
        self.R = np.eye(3) if R is None else check_rotation(R)
        self.center = check_vec3(t, "t")
        self.motion = motion
        self.albedo = self.white
        self.texture = None
        pts = self.object_points()
        self.extent = np.array([pts[:, 0].min() - self.margin, pts[:, 0].max() + self.margin,
                                pts[:, 1].min() - self.margin, pts[:, 1].max() + self.margin])

    @classmethod
    def from_fields(cls, fields: dict) -> "BoardTarget":
        """The board of a scene file's flat ``board`` entry: ``cols``, ``rows``, ``spacing`` (mm),
        ``radius`` (mm, default a quarter of the spacing), ``asymmetric``, ``R``, ``t`` (mm),
        ``margin`` (mm), ``white``, ``dark``, ``edge_width`` (mm) and ``motion``, each optional
        (defaults as :data:`DEFAULT_BOARD` and :class:`BoardLook`); the inverse of :meth:`to_dict`."""
        rest = dict(fields)
        geometry = {k: rest.pop(k) for k in _GEOMETRY_FIELDS if k in rest}
        look = {k: rest.pop(k) for k in ("margin", "white", "dark", "edge_width") if k in rest}
        spacing = float(geometry.get("spacing", DEFAULT_BOARD.spacing))
        radius = geometry.get("radius")
        board = CircleBoard(cols=int(geometry.get("cols", DEFAULT_BOARD.cols)),
                            rows=int(geometry.get("rows", DEFAULT_BOARD.rows)), spacing=spacing,
                            radius=float(radius) if radius is not None else 0.25 * spacing,
                            asymmetric=bool(geometry.get("asymmetric", False)))
        return cls(board, look=BoardLook(**look), **rest)

    # -- grid geometry -----------------------------------------------------------------------
    @property
    def t(self) -> np.ndarray:
        return self.center

    @property
    def pattern_size(self) -> tuple[int, int]:
        """``(cols, rows)`` for ``cv2.findCirclesGrid``."""
        return self.board.pattern_size

    @property
    def cv_flags(self) -> int:
        """``cv2.CALIB_CB_SYMMETRIC_GRID`` or ``cv2.CALIB_CB_ASYMMETRIC_GRID``."""
        return self.board.cv_flags

    def object_points(self) -> np.ndarray:
        """Circle centres in the board frame, ``(rows*cols, 3)`` float64 mm, row by row."""
        return self.board.object_points()

    def circle_centers(self, time: float = 0.0) -> np.ndarray:
        """True circle centres in world coordinates at ``time``, ``(rows*cols, 3)`` mm."""
        return self.to_world(self.object_points(), time)

    def to_dict(self) -> dict:
        d = {"type": "board", "cols": self.cols, "rows": self.rows, "spacing": self.spacing,
             "radius": self.radius, "R": self.R.tolist(), "t": self.center.tolist(),
             "asymmetric": self.asymmetric, "margin": self.margin, "white": self.white, "dark": self.dark,
             "edge_width": self.edge_width}
        if not self.motion.is_static:
            d["motion"] = self.motion.to_dict()
        return d

    def bounding_sphere_body(self):
        x0, x1, y0, y1 = self.extent
        return np.array([(x0 + x1) / 2, (y0 + y1) / 2, 0.0]), 0.5 * float(np.hypot(x1 - x0, y1 - y0))

    # -- albedo --------------------------------------------------------------------------------
    def distance_to_nearest_centre(self, uv: np.ndarray) -> np.ndarray:
        """Distance (mm) from board points ``uv`` (M, 2) to the nearest circle centre."""
        s = self.spacing
        best = np.full(len(uv), np.inf)
        i0 = np.round(uv[:, 1] / s)
        for di in (-1, 0, 1):
            i = np.clip(i0 + di, 0, self.rows - 1)
            if self.asymmetric:
                shift = np.mod(i, 2)
                j = np.clip(np.round((uv[:, 0] / s - shift) / 2), 0, self.cols - 1)
                cx = (2 * j + shift) * s
            else:
                j = np.clip(np.round(uv[:, 0] / s), 0, self.cols - 1)
                cx = j * s
            best = np.minimum(best, np.hypot(uv[:, 0] - cx, uv[:, 1] - i * s))
        return best

    def albedo_at(self, uv: np.ndarray) -> np.ndarray:
        """Albedo at board coordinates ``uv`` (M, 2) mm: ``dark`` inside circles, ``white`` out."""
        dist = self.distance_to_nearest_centre(uv)
        if self.edge_width > 0:
            w = np.clip((dist - self.radius) / self.edge_width + 0.5, 0.0, 1.0)
        else:
            w = (dist > self.radius).astype(float)
        return self.dark + (self.white - self.dark) * w

    # -- ray casting -----------------------------------------------------------------------------
    def intersect_body(self, o, d):
        return rectangle_hits(o, d, self.extent)

    def describe(self) -> str:
        kind = "asymmetric" if self.asymmetric else "symmetric"
        return f"CircleBoard {self.cols}x{self.rows} {kind}, spacing {self.spacing:g} mm"


def look_at_rotation(normal_towards, up=(0.0, -1.0, 0.0)) -> np.ndarray:
    """Rotation (board → world) for a board facing a viewer.

    ``normal_towards`` is the world direction
    from the board towards the viewer; the board's ``z_b`` axis points away from the viewer
    (as OpenCV's does for a board seen from the front), ``y_b`` points roughly along ``-up``.
    """
    z = -check_vec3(normal_towards, "normal_towards")
    z /= np.linalg.norm(z)
    upv = check_vec3(up, "up")
    y = -(upv - (upv @ z) * z)
    if np.linalg.norm(y) < 1e-9:
        raise ValueError("up must not be parallel to the viewing direction")
    y /= np.linalg.norm(y)
    x = np.cross(y, z)
    return np.column_stack([x, y, z])


def board_facing(camera_center, board_center, tilt=(0.0, 0.0, 0.0), **board_kwargs) -> BoardTarget:
    """A :class:`BoardTarget` whose grid centre sits at ``board_center`` (world mm), facing
    ``camera_center`` and then tilted by the rotation vector ``tilt`` (rad, board axes).

    Other keyword arguments go to :class:`BoardTarget` (``board``, ``look``, ``motion``).
    """
    bc = check_vec3(board_center, "board_center")
    R = look_at_rotation(check_vec3(camera_center, "camera_center") - bc) @ rotation_vector_to_matrix(tilt)
    probe = BoardTarget(R=R, t=bc, **board_kwargs)
    mid = probe.object_points()[:, :2]
    mid = np.array([(mid[:, 0].min() + mid[:, 0].max()) / 2, (mid[:, 1].min() + mid[:, 1].max()) / 2, 0.0])
    return BoardTarget(R=R, t=bc - R @ mid, **board_kwargs)


def rectangle_hits(o: np.ndarray, d: np.ndarray, extent) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Ray hits on the rectangle ``extent = (x0, x1, y0, y1)`` (mm) of the body plane z = 0.

    ``o``, ``d`` (N, 3) body-frame ray origins and directions -> ``t`` (N,) ray parameters
    (inf where missed), normals (N, 3) (+z) and the hits' body (x, y) (N, 2) mm.
    """
    with np.errstate(divide="ignore", invalid="ignore"):
        t = -o[:, 2] / d[:, 2]
    t = np.where(np.isfinite(t), t, np.inf)
    p = o + np.where(np.isfinite(t), t, 0.0)[:, None] * d
    x0, x1, y0, y1 = extent
    inside = (p[:, 0] >= x0) & (p[:, 0] <= x1) & (p[:, 1] >= y0) & (p[:, 1] <= y1)
    t = np.where(inside, t, np.inf)
    n = np.zeros_like(d)
    n[:, 2] = 1.0
    return t, n, p[:, :2]
