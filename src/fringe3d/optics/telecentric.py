"""Telecentric (affine) camera, Eq. (3.1)-(3.3).

``[u v]^T = M [x y z 1]^T`` with ``M`` a (2, 4) matrix: orthographic projection scaled by
the lens magnification (pixels per mm) and offset by the principal point. The image does
not change with distance along the viewing direction, which is why depth must come from
the projector.
"""
from __future__ import annotations

from dataclasses import dataclass
from typing import Any

import numpy as np


@dataclass(frozen=True, eq=False)
class TelecentricCamera:
    """Affine camera: ``uv = M @ [X, 1]``.

    Attributes
    ----------
    M : (2, 4) float
        Affine projection in pixels per mm (world frame -> pixels).
    width, height : int
        Sensor size in pixels.
    """

    M: np.ndarray
    width: int
    height: int
    kind: str = "telecentric"

    def __post_init__(self) -> None:
        M = np.asarray(self.M, float)
        if M.shape != (2, 4):
            raise ValueError(f"telecentric M must have shape (2, 4), got {M.shape}")
        object.__setattr__(self, "M", M)

    @classmethod
    def from_pose(cls, magnification: float, R: np.ndarray, t: np.ndarray, cx: float, cy: float, width: int,
                  height: int, pixel_size: float = 1.0) -> "TelecentricCamera":
        """Build ``M`` from a magnification (image mm per object mm), sensor pixel size (mm),
        world-to-camera rotation ``R`` and translation ``t`` and a principal point."""
        s = magnification / pixel_size
        R = np.asarray(R, float)
        t = np.asarray(t, float)
        M = np.zeros((2, 4))
        M[:, :3] = s * R[:2]
        M[:, 3] = s * t[:2] + [cx, cy]
        return cls(M=M, width=width, height=height)

    @property
    def size(self) -> tuple[int, int]:
        return (self.width, self.height)

    @property
    def view_direction(self) -> np.ndarray:
        """Unit world vector along which the image does not change (null space of M[:, :3])."""
        d = np.cross(self.M[0, :3], self.M[1, :3])
        return d / np.linalg.norm(d)

    def project(self, X: np.ndarray) -> np.ndarray:
        """World points ``(..., 3)`` to pixels ``(..., 2)``, Eq. (3.3)."""
        X = np.asarray(X, float)
        return X @ self.M[:, :3].T + self.M[:, 3]

    def rays(self, uv: np.ndarray, normalize: bool = True) -> tuple[np.ndarray, np.ndarray]:
        """Back-project pixels to parallel rays: ``(origins (..., 3), direction (3,))``.

        Origins are the minimum-norm solutions of ``M[:, :3] X = uv - M[:, 3]``.
        """
        uv = np.asarray(uv, float)
        A = self.M[:, :3]
        pinv = np.linalg.pinv(A)
        origins = (uv - self.M[:, 3]) @ pinv.T
        return origins, self.view_direction

    def pixel_grid(self) -> np.ndarray:
        """``(height, width, 2)`` pixel centres ``(u, v)`` = (column, row)."""
        v, u = np.mgrid[0 : self.height, 0 : self.width].astype(float)
        return np.stack([u, v], axis=-1)

    def to_dict(self) -> dict[str, Any]:
        return {"kind": "telecentric", "M": self.M.tolist(), "width": self.width, "height": self.height}
