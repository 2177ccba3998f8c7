"""The circle-grid calibration board: one geometry for detection, calibration and the simulator.

Board frame (mm): the board is the plane ``z_b = 0``; the first circle centre (top-left,
OpenCV order: row by row, left to right) is the origin; ``x_b`` runs along a grid row
(columns), ``y_b`` down the rows. This is OpenCV's object-point frame, so a board pose
``(R, t)`` (board -> world, ``X = R @ x_b + t``) is what ``cv2.solvePnP`` /
``cv2.calibrateCamera`` estimate when the world is the camera frame (ch. 2.2.5, ch. 3.3).

Grid layouts, ``pattern_size = (cols, rows)`` as in ``cv2.findCirclesGrid``:

* symmetric: centre ``(j s, i s, 0)`` for row ``i`` and column ``j``;
* asymmetric (``cv2.CALIB_CB_ASYMMETRIC_GRID``): centre ``((2 j + i mod 2) s, i s, 0)``.

>>> CircleBoard(cols=3, rows=2, spacing=5.0, radius=1.0).object_points()[:, :2].tolist()
[[0.0, 0.0], [5.0, 0.0], [10.0, 0.0], [0.0, 5.0], [5.0, 5.0], [10.0, 5.0]]
"""
from __future__ import annotations

from dataclasses import dataclass

import cv2
import numpy as np


@dataclass(frozen=True)
class CircleBoard:
    """A planar circle-grid target.

    Attributes
    ----------
    cols, rows : int
        Circles per row and number of rows (OpenCV ``patternSize = (cols, rows)``).
    spacing : float
        Centre-to-centre distance in mm (for asymmetric grids: the distance between
        neighbouring circles of one row is ``2*spacing``, rows are offset by ``spacing``).
    radius : float
        Circle radius in mm.
    asymmetric : bool
        OpenCV asymmetric grid layout.
    dark_circles : bool
        True for dark circles on a bright board, False for bright circles on a dark board.
    """

    cols: int = 9
    rows: int = 9
    spacing: float = 10.0
    radius: float = 2.5
    asymmetric: bool = False
    dark_circles: bool = True

    def __post_init__(self):
        if self.cols < 2 or self.rows < 2:
            raise ValueError(f"a circle board needs at least 2x2 circles, got {self.cols}x{self.rows}")
        if not self.spacing > 0:
            raise ValueError(f"board spacing must be > 0 mm, got {self.spacing}")
        if not (0 < 2 * self.radius < self.spacing * (np.sqrt(2) if self.asymmetric else 1)):
            raise ValueError(f"circle radius {self.radius} mm does not fit the spacing {self.spacing} mm")

    @property
    def pattern_size(self) -> tuple[int, int]:
        return (self.cols, self.rows)

    @property
    def cv_flags(self) -> int:
        """``cv2.CALIB_CB_SYMMETRIC_GRID`` or ``cv2.CALIB_CB_ASYMMETRIC_GRID``."""
        return cv2.CALIB_CB_ASYMMETRIC_GRID if self.asymmetric else cv2.CALIB_CB_SYMMETRIC_GRID

    @property
    def count(self) -> int:
        return self.cols * self.rows

    def object_points(self) -> np.ndarray:
        """``(rows*cols, 3)`` float64 circle centres in board coordinates (mm), OpenCV order."""
        j, i = np.meshgrid(np.arange(self.cols), np.arange(self.rows))
        if self.asymmetric:
            x = (2 * j + (i % 2)) * self.spacing
        else:
            x = j * self.spacing
        y = i * self.spacing
        return np.stack([x.ravel(), y.ravel(), np.zeros(self.count)], axis=-1).astype(float)

    def corner_indices(self) -> dict[str, int]:
        """Indices of the four corner circles A (top-left), B (top-right), C (bottom-right),
        D (bottom-left) used for the diagonal-length check of ch. 3.4."""
        c, r = self.cols, self.rows
        return {"A": 0, "B": c - 1, "C": r * c - 1, "D": (r - 1) * c}

    def to_dict(self) -> dict:
        return {"cols": self.cols, "rows": self.rows, "spacing": self.spacing, "radius": self.radius,
                "asymmetric": self.asymmetric, "dark_circles": self.dark_circles}

    @classmethod
    def from_dict(cls, d: dict) -> "CircleBoard":
        known = {"cols", "rows", "spacing", "radius", "asymmetric", "dark_circles"}
        unknown = sorted(set(d) - known)
        if unknown:
            raise ValueError(f"board: unknown field(s) {unknown}; allowed {sorted(known)}")
        return cls(**d)
