"""Rig ray geometry: camera rays, projector rows and the closed-form ray coefficients.

One camera-ray convention (:func:`camera_rays`): every camera pixel is the ray
``X = O + s*D`` in the world frame. Pinhole cameras: ``O`` (3,) the centre and ``D`` (H, W, 3)
the undistorted direction with device-frame depth ``z = 1`` (so ``s`` is the depth along the
camera axis; Eq. 2.12-2.16 inverted). Telecentric cameras (Eq. 3.3): ``O`` (H, W, 3) per pixel
and one common unit direction ``D`` (3,).

Projector fringe coordinate along a fringe direction of angle ``alpha`` (manifest convention):
``w = v_p*cos(alpha) + u_p*sin(alpha)``; for a (3, 4) projector matrix ``P`` the row
``Q = cos(alpha)*P[1] + sin(alpha)*P[0]`` (:func:`projector_row`) gives
``w = Q.X~ / P[2].X~`` (Eq. 2.37, Eq. 4.18). Along a camera ray that is a ratio of two affine
functions of ``s``: :class:`RayGeometry` holds those per-pixel coefficients once per rig and
solves ``s = (Q.O~ - w P3.O~) / (w P3.D - Q.D)`` for a whole map of ``w``.
Units: mm and pixels; invalid pixels are NaN.
"""
from __future__ import annotations

import math
import weakref
from typing import Any, overload

import numpy as np

from fringe3d.gpu.runtime import check_backend
from fringe3d.optics._ray_kernels import (central_kernel, depth_kernel, fringe_kernel, parallel_kernel, sigma_kernel,
                                          sigma_z_kernel)
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.conventions import fringe_coordinate

ANGLE_UP = math.pi / 2  # vertical fringes: w = u_p
ANGLE_VP = 0.0          # horizontal fringes: w = v_p

_UNDISTORTED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # camera -> (H, W, 2) normalised


def projector_row(P: np.ndarray, angle: float) -> np.ndarray:
    """Row ``Q = cos(alpha)*P[1] + sin(alpha)*P[0]`` of a (3, 4) projection matrix, so that a
    world point with homogeneous ``X~`` has fringe coordinate ``w = Q.X~ / P[2].X~``."""
    return math.cos(angle) * P[1] + math.sin(angle) * P[0]


@overload
def check_map(a: None, shape: tuple[int, int], name: str) -> None: ...
@overload
def check_map(a: Any, shape: tuple[int, int], name: str) -> np.ndarray: ...
def check_map(a: Any, shape: tuple[int, int], name: str) -> np.ndarray | None:
    """Return ``a`` as an array of camera ``shape`` (H, W), or raise a clear ValueError."""
    if a is None:
        return None
    a = np.asarray(a)
    if a.shape != tuple(shape):
        raise ValueError(f"{name} has shape {a.shape} but the calibration's camera is "
                         f"{shape[1]}x{shape[0]} (expected an array of shape {tuple(shape)}): "
                         "calibration and capture sizes disagree")
    return a


def camera_shape(rig: Rig) -> tuple[int, int]:
    """(H, W) of the rig's camera."""
    cam: Any = rig.camera
    return (cam.height, cam.width)


def camera_normalized(camera) -> np.ndarray:
    """Undistorted normalised coordinates ``(H, W, 2)`` float64 of every pixel centre of a pinhole
    camera (Eq. 2.12-2.16 inverted), computed once per camera object and cached."""
    xy = _UNDISTORTED.get(camera)
    if xy is None:
        xy = camera.pixels_to_normalized(camera.pixel_grid())
        xy.setflags(write=False)
        _UNDISTORTED[camera] = xy
    return xy


def camera_rays(rig: Rig) -> tuple[np.ndarray, np.ndarray]:
    """Undistorted camera rays ``X = O + s*D`` for every pixel, world frame.

    Returns ``(O, D)``: pinhole cameras give ``O (3,)`` (the centre) and ``D (H, W, 3)`` with
    device depth ``z = 1`` (so ``s`` is the depth along the camera axis); telecentric cameras
    give ``O (H, W, 3)`` and the common unit direction ``D (3,)``.
    """
    cam: Any = rig.camera  # PinholeDevice or TelecentricCamera
    if rig.telecentric:
        return cam.rays(cam.pixel_grid())
    xy = camera_normalized(cam)
    d_dev = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
    return cam.center, d_dev @ cam.R


def camera_planes(rig: Rig, geometry: RigGeometry | None = None) -> tuple[np.ndarray, np.ndarray]:
    """:func:`camera_rays` as the (3, H, W) float32 planes :class:`RayGeometry` keeps: pinhole
    cameras ``(O (3,) float64, D_planes (3, H, W) float32)``, telecentric ones ``(O_planes
    (3, H, W) float32, D (3,) float64)``.

    With ``geometry`` (the rig's :class:`~fringe3d.optics.rig_geometry.RigGeometry`) they are
    built once and shared by every :class:`RayGeometry` of it, whatever its fringe angle (the
    minimum phase maps and the triangulators of one engine: about 30 ms of a 1280 x 1024 camera
    each time otherwise); the shared arrays must not be written to.
    """
    if geometry is not None:
        return RigGeometry.of(rig, geometry).memo(("camera_planes",), lambda: camera_planes(rig))
    O, D = camera_rays(rig)
    if rig.telecentric:
        return np.ascontiguousarray(np.moveaxis(O, -1, 0), dtype=np.float32), np.asarray(D, np.float64)
    return np.asarray(O, np.float64), np.ascontiguousarray(np.moveaxis(D, -1, 0), dtype=np.float32)


def pixel_rays(rig: Rig, uv: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """World rays of camera pixels ``uv (..., 2)`` (column, row), in the convention of
    :func:`camera_rays` (pinhole: ``O (3,)``, ``D (..., 3)`` with device depth 1; telecentric:
    ``O (..., 3)``, ``D (3,)`` unit)."""
    cam: Any = rig.camera  # PinholeDevice or TelecentricCamera
    return cam.rays(uv)


def projector_fringe_coordinate(rig: Rig, X: np.ndarray, angle: float, distortion: bool = True) -> np.ndarray:
    """Projector fringe coordinate ``w`` (pixels) of world points ``X (..., 3)`` (Eq. 4.18).

    With ``distortion`` the projector's lens distortion is applied (``Projector.project``);
    otherwise the linear model ``w = Q.X~ / P3.X~``.
    """
    proj = rig.projector
    if distortion and proj.dist.any():
        uv = proj.project(X)
        return fringe_coordinate(uv[..., 0], uv[..., 1], angle)
    Xh = np.concatenate([X, np.ones(X.shape[:-1] + (1,))], axis=-1)
    return (Xh @ projector_row(proj.P, angle)) / (Xh @ proj.P[2])


def ray_points(O: np.ndarray, D_planes: np.ndarray, s: np.ndarray, out: np.ndarray | None = None) -> np.ndarray:
    """Points ``X = O + s*D`` (H, W, 3) float32 mm of pinhole rays from their parameters ``s``.

    ``O`` (3,) float64 is the camera centre, ``D_planes`` (3, H, W) float32 the rays' directions
    with device depth 1 (:attr:`RayGeometry.D_planes`, so ``s`` is the camera-frame depth in mm)
    and ``s`` (H, W) float32 (NaN: no point). Evaluated in float64 and rounded once; the fused
    3-step path and the point store's ``ray_depth`` layout both go through this function, so the
    points a store gives back are the ones the reconstruction made, bit for bit.
    """
    s = np.ascontiguousarray(s, np.float32)
    D_planes = np.ascontiguousarray(D_planes, np.float32)
    if s.ndim != 2 or D_planes.shape != (3,) + s.shape:
        raise ValueError(f"ray parameters {s.shape} and ray directions {D_planes.shape} must be (H, W) and (3, H, W)")
    if out is None:
        out = np.empty(s.shape + (3,), np.float32)
    depth_kernel(s, np.asarray(O, np.float64), D_planes, out)
    return out


class RayGeometry:
    """Per-pixel closed-form ray coefficients of one rig and fringe direction.

    Parameters
    ----------
    rig : fringe3d.optics.Rig
    angle : float
        Fringe angle alpha (rad) of the direction that supplies ``w``: pi/2 (default) for
        vertical fringes (``w = u_p``), 0 for horizontal fringes (``w = v_p``).
    geometry : fringe3d.optics.rig_geometry.RigGeometry, optional
        The rig's precomputed geometry: the camera rays are then built once for all of its
        ray geometries (:func:`camera_planes`) instead of once per object.

    Attributes
    ----------
    central : bool
        Pinhole camera (rays through one centre) or telecentric (parallel rays).
    O, D_planes : (3,) float64, (3, H, W) float32
        Pinhole: the camera centre and each pixel's ray direction as contiguous planes.
    O_planes, D : (3, H, W) float32, (3,) float64
        Telecentric: each pixel's ray origin as planes and the common direction.
    Q, P3 : (4,) float64
        Projector row of the fringe direction (:func:`projector_row`) and third row of ``P``.

    Notes
    -----
    Pinhole camera: ``s = (a + b*w) / (c + e*w)`` with ``a = Q.O~``, ``b = -P3.O~``,
    ``c = -Q.D``, ``e = P3.D`` (Eq. 2.37 solved along the ray). Projector lens distortion is
    ignored (linear projector model).
    """

    def __init__(self, rig: Rig, angle: float = ANGLE_UP, geometry: RigGeometry | None = None):
        self.rig = rig
        self.angle = float(angle)
        self.shape: tuple[int, int] = camera_shape(rig)
        self.central: bool = not rig.telecentric
        # per-pixel vectors are stored as (3, H, W) float32 planes so the kernels vectorise
        if self.central:
            self.O, self.D_planes = camera_planes(rig, geometry)
        else:
            self.O_planes, self.D = camera_planes(rig, geometry)
        P = rig.projector.P
        self.Q = np.ascontiguousarray(projector_row(P, self.angle), dtype=np.float64)
        self.P3 = np.ascontiguousarray(P[2], dtype=np.float64)
        self._qd: np.ndarray | None = None  # Q.D and P3.D per pixel, built on first use
        self._dsdw_num: np.ndarray | None = None  # ds/dw numerator per pixel (sigma_z_from_phase_noise)
        self._pd: np.ndarray | None = None

    @property
    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(O, D)`` as in :func:`camera_rays` (views of the stored planes)."""
        if self.central:
            return self.O, np.moveaxis(self.D_planes, 0, -1)
        return np.moveaxis(self.O_planes, 0, -1), self.D

    def points(self, w: np.ndarray, mask: np.ndarray | None = None, out: np.ndarray | None = None,
               backend: str = "cpu", device_output: bool = False) -> np.ndarray:
        """3D points from the projector coordinate ``w`` (H, W) (``u_p`` for vertical fringes).

        Returns ``(H, W, 3)`` float32 in mm, NaN where ``w`` is NaN, ``mask`` is False, or the
        point falls behind a pinhole camera. ``out`` may be a preallocated float32 array.
        ``backend="cuda"`` (pinhole cameras): :func:`fringe3d.gpu.ops.central_points` on a CUDA
        device, which also takes (C, H, W) stacks and returns (C, H, W, 3), kept on the device
        with ``device_output``.
        """
        if check_backend(backend) == "cuda":
            if not self.central:
                raise ValueError("the CUDA triangulation supports pinhole cameras; use backend='cpu' for "
                                 "telecentric rigs")
            from fringe3d.gpu import ops

            pts = ops.central_points(w, mask, self.O, self.D_planes, self.Q, self.P3, device_output=device_output)
            if out is not None and not device_output:
                out[...] = pts
                return out
            return pts
        w = check_map(w, self.shape, "projector coordinate map")
        if w.dtype not in (np.float32, np.float64):
            w = w.astype(np.float32)
        mask = np.ones(self.shape, bool) if mask is None else check_map(mask, self.shape, "mask").astype(bool)
        if out is None:
            out = np.empty(self.shape + (3,), np.float32)
        if self.central:
            central_kernel(np.ascontiguousarray(w), np.ascontiguousarray(mask), self.O, self.D_planes, self.Q,
                           self.P3, out)
        else:
            parallel_kernel(np.ascontiguousarray(w), np.ascontiguousarray(mask), self.O_planes, self.D, self.Q,
                            self.P3, out)
        return out

    def _ray_rows(self) -> tuple[float, float, np.ndarray, np.ndarray]:
        """``(Q.O~, P3.O~, Q.D (H, W), P3.D (H, W))`` of the pinhole rays (float64, built once)."""
        if not self.central:
            raise ValueError("ray parameters along pinhole rays need a pinhole camera")
        if self._qd is None or self._pd is None:
            D = self.D_planes.astype(np.float64)
            self._qd = np.ascontiguousarray(np.einsum("k,khw->hw", self.Q[:3], D))
            self._pd = np.ascontiguousarray(np.einsum("k,khw->hw", self.P3[:3], D))
        return (float(self.Q[:3] @ self.O + self.Q[3]), float(self.P3[:3] @ self.O + self.P3[3]), self._qd,
                self._pd)

    def fringe_coordinate_at(self, s: np.ndarray) -> np.ndarray:
        """(H, W) float32 projector fringe coordinate ``w = Q.X~ / P3.X~`` (px) of the pinhole
        rays' points ``X = O + s*D`` at parameters ``s`` (H, W) (the linear projector model, the
        inverse of the closed form; NaN where ``s`` is)."""
        qo, po, qd, pd = self._ray_rows()
        out = np.empty(self.shape, np.float32)
        fringe_kernel(np.ascontiguousarray(check_map(s, self.shape, "ray parameter map")), qo, po, qd, pd, out)
        return out

    def point_sigma_from_w(self, w: np.ndarray, sigma_w: np.ndarray, mask: np.ndarray) -> np.ndarray:
        """(H, W, 3) float32 per-axis standard deviations (mm) of the closed-form points of the
        fringe coordinate ``w`` (px) with standard deviation ``sigma_w`` (px): ``|D ds/dw| sigma_w``
        with the exact derivative of ``s = (Q.O~ - w P3.O~) / (w P3.D - Q.D)``,
        ``ds/dw = (P3.O~ Q.D - Q.O~ P3.D) / (w P3.D - Q.D)^2``; NaN where ``mask`` is False."""
        qo, po, qd, pd = self._ray_rows()
        out = np.empty(self.shape + (3,), np.float32)
        sigma_kernel(np.ascontiguousarray(check_map(w, self.shape, "fringe coordinate map")),
                     np.ascontiguousarray(check_map(sigma_w, self.shape, "fringe coordinate sigma map")),
                     np.ascontiguousarray(check_map(mask, self.shape, "mask"), bool), qo, po, qd, pd,
                     self.D_planes, out)
        return out

    def sigma_z_from_phase_noise(self, w: np.ndarray, modulation: np.ndarray, noise: float, steps: int,
                                 period: float, mask: np.ndarray) -> np.ndarray:
        """(H, W) float32 standard deviation of world z (mm) of the closed-form points of the
        fringe coordinate ``w`` (px) of an ``N``-step phase (``steps``) with camera noise
        ``noise`` (frames' units) and modulation ``B`` (H, W): ``sigma_w = sqrt(2/N) noise / B
        * T / 2pi`` (:func:`fringe3d.phase.noise.phase_sigma`, ``T`` = ``period`` px), then
        :meth:`point_sigma_from_w`'s z, in one pass and bit for bit; inf where ``B <= 0``, NaN
        where ``mask`` is False."""
        qo, po, qd, pd = self._ray_rows()
        if self._dsdw_num is None:  # ds/dw's numerator, once (the same float64 operations as sigma_kernel's)
            self._dsdw_num = po * qd - qo * pd
        out = np.empty(self.shape, np.float32)
        c_sigma = np.float32(math.sqrt(2.0 / steps)) * np.float32(noise)
        sigma_z_kernel(np.ascontiguousarray(check_map(w, self.shape, "fringe coordinate map"), np.float32),
                       np.ascontiguousarray(check_map(modulation, self.shape, "modulation map"), np.float32),
                       np.ascontiguousarray(check_map(mask, self.shape, "mask"), bool), c_sigma,
                       np.float32(period / (2 * math.pi)), self._dsdw_num, qd, pd, self.D_planes[2], out)
        return out

    def ray_points_at_z(self, z: float | np.ndarray) -> np.ndarray:
        """World points ``(H, W, 3)`` float64 where each pixel's ray meets the plane world-z = ``z``
        (Eq. 4.15-4.17). NaN where the ray is parallel to the plane or, for a pinhole camera,
        where the plane lies behind it."""
        O, D = (np.asarray(a, np.float64) for a in self.rays)
        with np.errstate(divide="ignore", invalid="ignore"):
            s = (np.asarray(z, float) - O[..., 2]) / D[..., 2]
            X = O + s[..., None] * D
        bad = ~np.isfinite(s)
        if self.central:
            bad |= ~(s > 0)
        X[bad] = np.nan
        return X
