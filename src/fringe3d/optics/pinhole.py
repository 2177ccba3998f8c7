"""Pinhole camera / projector model, Eq. (2.8)-(2.18).

``s [u v 1]^T = A [R | t] [x y z 1]^T`` with intrinsics
``A = [[fx, skew, cx], [0, fy, cy], [0, 0, 1]]`` and Brown distortion applied in
normalised coordinates. The projector is modelled as an inverse camera with the same
class (Eq. 2.35-2.38). ``R, t`` map world points into this device's frame:
``X_dev = R @ X_world + t``. With the camera frame as world frame the camera has
``R = I, t = 0``.
"""
from __future__ import annotations

from dataclasses import dataclass, field, replace
from typing import Any

import numpy as np

from .distortion import as_coeffs, distort, undistort


def _arr(a: Any, shape: tuple[int, ...], name: str) -> np.ndarray:
    a = np.asarray(a, dtype=float)
    if a.shape != shape:
        raise ValueError(f"{name} must have shape {shape}, got {a.shape}")
    return a


@dataclass(frozen=True, eq=False)
class PinholeDevice:
    """A pinhole camera or projector.

    Attributes
    ----------
    K : (3, 3) float
        Intrinsic matrix in pixels.
    dist : (5,) or (14,) float
        Distortion ``k1 k2 p1 p2 k3`` (OpenCV order); OpenCV's full 14 (``... k4 k5 k6 s1 s2 s3 s4
        tau_x tau_y``) when an 8/12/14-vector with a non-zero extra term is given
        (:func:`fringe3d.optics.distortion.as_coeffs`).
    width, height : int
        Sensor (or DMD) size in pixels.
    R : (3, 3) float, t : (3,) float
        World-to-device rotation and translation (mm).
    """

    K: np.ndarray
    width: int
    height: int
    dist: np.ndarray = field(default_factory=lambda: np.zeros(5))
    R: np.ndarray = field(default_factory=lambda: np.eye(3))
    t: np.ndarray = field(default_factory=lambda: np.zeros(3))
    kind: str = "pinhole"

    def __post_init__(self) -> None:
        object.__setattr__(self, "K", _arr(self.K, (3, 3), "K"))
        object.__setattr__(self, "dist", as_coeffs(self.dist))
        object.__setattr__(self, "R", _arr(self.R, (3, 3), "R"))
        object.__setattr__(self, "t", _arr(np.ravel(self.t), (3,), "t"))
        if self.width <= 0 or self.height <= 0:
            raise ValueError(f"image size must be positive, got {self.width}x{self.height}")
        if abs(np.linalg.det(self.R) - 1) > 1e-6:
            raise ValueError("R must be a rotation matrix (det = +1)")

    # -- convenience --------------------------------------------------------------
    @property
    def size(self) -> tuple[int, int]:
        """(width, height) in pixels."""
        return (self.width, self.height)

    @property
    def center(self) -> np.ndarray:
        """Optical centre in world coordinates, ``-R^T t`` (mm)."""
        return -self.R.T @ self.t

    @property
    def P(self) -> np.ndarray:
        """(3, 4) projection matrix ``K [R | t]`` (ignores distortion)."""
        return self.K @ np.hstack([self.R, self.t[:, None]])

    def with_pose(self, R: np.ndarray, t: np.ndarray) -> "PinholeDevice":
        """A copy with world-to-device rotation ``R`` (3, 3) and translation ``t`` (3,)."""
        return replace(self, R=np.asarray(R, float), t=np.asarray(t, float))

    # -- geometry -----------------------------------------------------------------
    def to_device(self, X: np.ndarray) -> np.ndarray:
        """World points ``(..., 3)`` into the device frame."""
        return np.asarray(X, float) @ self.R.T + self.t

    def project(self, X: np.ndarray) -> np.ndarray:
        """World points ``(..., 3)`` (mm) to pixel coordinates ``(..., 2)``, with distortion.

        Examples
        --------
        >>> import numpy as np
        >>> cam = PinholeDevice(K=intrinsics(1000, 1000, 320, 240), width=640, height=480)
        >>> cam.project(np.array([[0.0, 0.0, 500.0], [10.0, 0.0, 500.0]])).tolist()
        [[320.0, 240.0], [340.0, 240.0]]
        """
        Xd = self.to_device(X)
        with np.errstate(divide="ignore", invalid="ignore"):
            xy = Xd[..., :2] / Xd[..., 2:3]
        return self.normalized_to_pixels(distort(xy, self.dist))

    def normalized_to_pixels(self, xy: np.ndarray) -> np.ndarray:
        """Distorted normalised coordinates ``(..., 2)`` to pixels."""
        K = self.K
        u = K[0, 0] * xy[..., 0] + K[0, 1] * xy[..., 1] + K[0, 2]
        v = K[1, 1] * xy[..., 1] + K[1, 2]
        return np.stack([u, v], axis=-1)

    def pixels_to_normalized(self, uv: np.ndarray) -> np.ndarray:
        """Pixels ``(..., 2)`` to undistorted normalised coordinates ``(..., 2)``."""
        uv = np.asarray(uv, float)
        K = self.K
        y = (uv[..., 1] - K[1, 2]) / K[1, 1]
        x = (uv[..., 0] - K[0, 2] - K[0, 1] * y) / K[0, 0]
        return undistort(np.stack([x, y], axis=-1), self.dist)

    def rays(self, uv: np.ndarray, normalize: bool = False) -> tuple[np.ndarray, np.ndarray]:
        """Back-project pixels to world rays.

        Returns ``(origin (3,), directions (..., 3))``; directions have device-frame ``z = 1``
        before rotation to world (so ``X = origin + s*d`` has depth ``s`` in the device frame),
        or unit length with ``normalize=True``.
        """
        xy = self.pixels_to_normalized(uv)
        d_dev = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
        d = d_dev @ self.R  # R^T applied to row vectors
        if normalize:
            d = d / np.linalg.norm(d, axis=-1, keepdims=True)
        return self.center, d

    def pixel_grid(self) -> np.ndarray:
        """``(height, width, 2)`` pixel centres ``(u, v)`` = (column, row)."""
        v, u = np.mgrid[0 : self.height, 0 : self.width].astype(float)
        return np.stack([u, v], axis=-1)

    # -- serialisation ------------------------------------------------------------
    def to_dict(self) -> dict[str, Any]:
        return {"kind": "pinhole", "K": self.K.tolist(), "dist": self.dist.tolist(),
                "width": self.width, "height": self.height,
                "R": self.R.tolist(), "t": self.t.tolist()}


def intrinsics(fx: float, fy: float, cx: float, cy: float, skew: float = 0.0) -> np.ndarray:
    """The (3, 3) intrinsic matrix A of Eq. (2.9).

    Parameters
    ----------
    fx, fy : float
        Focal lengths along x and y, pixels.
    cx, cy : float
        Principal point, pixels.
    skew : float
        Skew term ``A[0, 1]``, pixels (0 for square pixel axes).

    Returns
    -------
    (3, 3) ndarray (float)
        ``[[fx, skew, cx], [0, fy, cy], [0, 0, 1]]``.
    """
    return np.array([[fx, skew, cx], [0.0, fy, cy], [0.0, 0.0, 1.0]])
