"""Triangulation: camera pixel + projector coordinate -> 3D point, Eq. (2.37)-(2.38).

Two paths, same geometry:

* :func:`triangulate` - the least-squares solution of Eq. (2.37): two camera rows plus one
  projector row per known projector coordinate (``u_p`` from vertical fringes, ``v_p`` from
  horizontal fringes, or both), ``X = (H^T H)^{-1} H^T b``. Camera distortion is removed by
  undistorting the pixel; projector distortion is handled by iterating (predict the unknown
  projector coordinate, undistort the pair, solve again). Pinhole and telecentric (Eq. 3.3)
  cameras.
* :class:`Triangulator` - the fast closed form for one projector coordinate. Every camera
  pixel defines a ray ``X = O + s*D`` (undistorted, precomputed once per rig); the projector
  row ``w * (P3 . X~) = Q . X~`` then gives ``s = (Q.O~ - w P3.O~) / (w P3.D - Q.D)``, a ratio
  of two affine functions of ``w``, evaluated by a numba kernel straight into an organized
  ``(H, W, 3)`` float32 point map. It ignores projector lens distortion (it says so).

Projector coordinate along a fringe direction of angle ``alpha`` (manifest convention):
``w = v_p*cos(alpha) + u_p*sin(alpha)``; vertical fringes (alpha = pi/2) give ``w = u_p``.
Units: mm and pixels. Invalid pixels are NaN.
"""
from __future__ import annotations

import math
import warnings
from typing import NamedTuple

import numpy as np

from fringe3d.gpu.runtime import check_backend
from fringe3d.optics.rays import ANGLE_UP, ANGLE_VP, RayGeometry, camera_normalized, camera_shape, check_map, ray_points
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.conventions import phase_to_w
from fringe3d.phase.psp import lsq_coefficients
from fringe3d.reconstruct._kernels import lsq_kernel, three_step_fields_kernel, three_step_kernel
from fringe3d.unwrap.geometric import MinimumPhase
from fringe3d.utils.camera_size import check_camera_size
from fringe3d.utils.warning_types import ReconstructionWarning

__all__ = ["ANGLE_UP", "ANGLE_VP", "FastThreeStep", "Triangulator", "triangulate"]


# ----------------------------------------------------------------------------- least squares
def triangulate(rig, up=None, vp=None, mask=None, *, iterations: int = 8) -> np.ndarray:
    """Least-squares triangulation of Eq. (2.37)-(2.38) for every camera pixel.

    Parameters
    ----------
    rig : fringe3d.optics.Rig
        Pinhole or telecentric camera plus a pinhole projector.
    up, vp : (H, W) float arrays, optional
        Projector column ``u_p`` (from vertical fringes) and/or row ``v_p`` (horizontal fringes),
        projector pixels; NaN where unknown. At least one is required; with both the system is
        over-determined (4 rows) and solved in least squares.
    mask : (H, W) bool, optional
        Pixels to reconstruct (default: where the given coordinates are finite).
    iterations : int
        Fixed-point iterations for projector lens distortion (unused without it).

    Returns
    -------
    (H, W, 3) float32
        World coordinates in mm (camera frame for pinhole rigs, projector frame for telecentric
        rigs); NaN where invalid (masked, unknown coordinate, or behind a pinhole camera).

    Notes
    -----
    Camera rows use undistorted pixel coordinates (cached per camera); each pixel's 3x3 (one
    projector coordinate) or 4x3 (both) system is solved by a numba kernel - exactly for 3 rows,
    by the normal equations ``(H^T H)^{-1} H^T b`` of Eq. (2.37) for 4.

    Examples
    --------
    >>> from fringe3d.optics import PinholeDevice, Rig, intrinsics
    >>> cam = PinholeDevice(intrinsics(200.0, 200.0, 79.5, 63.5), 160, 128)
    >>> proj = PinholeDevice(intrinsics(290.0, 290.0, 127.5, 99.5), 256, 200, t=[-100.0, 0.0, 0.0])
    >>> O, D = cam.rays(cam.pixel_grid())
    >>> uv_p = proj.project(O + 400.0 * D)                # projector pixels seen on z = 400 mm
    >>> xyz = triangulate(Rig(cam, proj), up=uv_p[..., 0], vp=uv_p[..., 1])
    >>> bool(np.allclose(xyz[..., 2], 400.0, atol=1e-3))
    True
    """
    if up is None and vp is None:
        raise ValueError("triangulate needs at least one projector coordinate: up (from vertical "
                         "fringes) and/or vp (from horizontal fringes)")
    shape = camera_shape(rig)
    up = check_map(up, shape, "up")
    vp = check_map(vp, shape, "vp")
    mask = check_map(mask, shape, "mask")
    valid = np.ones(shape, bool) if mask is None else mask.astype(bool)
    for a in (up, vp):
        if a is not None:
            valid &= np.isfinite(a)
    cu, cv, Pc = _camera_coordinates(rig)
    proj = rig.projector
    nan_map = np.full(shape, np.nan)
    # C-contiguous, so that a column of an (H, W, 2) map or any other strided view compiles no
    # second specialisation of the kernel (numba specialises on layout; the arithmetic is the same)
    up_m = nan_map if up is None else np.ascontiguousarray(up, np.float64)
    vp_m = nan_map if vp is None else np.ascontiguousarray(vp, np.float64)
    out = np.empty(shape + (3,), np.float32)
    flags = (up is not None, vp is not None, not rig.telecentric)
    lsq_kernel(cu, cv, valid, Pc, proj.P, up_m, vp_m, *flags, out)
    if proj.dist.any() and valid.any():
        for _ in range(iterations):
            prev = out.copy()
            uu, vv = _undistorted_proj(proj, up_m, vp_m, out.astype(np.float64))
            lsq_kernel(cu, cv, valid, Pc, proj.P, uu, vv, *flags, out)
            with np.errstate(invalid="ignore"):
                step = np.nanmax(np.abs(out - prev), initial=0.0)
            if step < 1e-6:
                break
    return out


def _camera_coordinates(rig):
    """Undistorted camera pixel coordinates ``(cu, cv)`` (H, W) float64 and the (3, 4) matrix
    whose rows give the camera equations ``u*P3 - P1``, ``v*P3 - P2`` (Eq. 2.38). A telecentric
    camera uses its affine ``M`` with ``P3 = [0, 0, 0, 1]`` (Eq. 3.3)."""
    cam = rig.camera
    if rig.telecentric:
        v, u = np.mgrid[0:cam.height, 0:cam.width].astype(np.float64)
        return u, v, np.vstack([cam.M, [0.0, 0.0, 0.0, 1.0]])
    uvu = cam.normalized_to_pixels(camera_normalized(cam))
    return np.ascontiguousarray(uvu[..., 0]), np.ascontiguousarray(uvu[..., 1]), cam.P


def _undistorted_proj(proj, up, vp, X):
    """Undistorted projector pixel coordinates ``(up', vp')`` (H, W) from the measured ones and
    the current estimate ``X`` (H, W, 3): the unknown coordinate is predicted by projecting
    ``X`` (with distortion), then the pair is undistorted."""
    pred = proj.project(X)
    u = np.where(np.isfinite(up), up, pred[..., 0])
    v = np.where(np.isfinite(vp), vp, pred[..., 1])
    uvu = proj.normalized_to_pixels(proj.pixels_to_normalized(np.stack([u, v], axis=-1)))
    return np.ascontiguousarray(uvu[..., 0]), np.ascontiguousarray(uvu[..., 1])


class Triangulator(RayGeometry):
    """Per-pixel closed-form triangulation with coefficients precomputed once per rig.

    The ray coefficients and the solve along each ray are :class:`fringe3d.optics.rays.RayGeometry`
    (``points``, ``rays``, ``ray_points_at_z``); this class adds the distortion notice and
    :meth:`points_from_phase`.

    Parameters
    ----------
    rig, angle, geometry
        As for :class:`~fringe3d.optics.rays.RayGeometry` (``angle``: the fringe angle of the
        direction that supplies ``w``, pi/2 by default; ``geometry``: the rig's
        :class:`~fringe3d.optics.rig_geometry.RigGeometry`, whose camera rays are shared).
    warn_distortion : bool
        Warn (once, here; :class:`~fringe3d.utils.warning_types.ReconstructionWarning`) when the
        projector has lens distortion, which this path ignores.

    Notes
    -----
    Pinhole camera: ``X = O + s*D`` with ``O`` the camera centre and ``D (H, W, 3)`` the
    undistorted ray of each pixel (device depth 1), ``s = (a + b*w) / (c + e*w)`` with
    ``a = Q.O~``, ``b = -P3.O~``, ``c = -Q.D``, ``e = P3.D`` (Eq. 2.37 solved along the ray).
    Telecentric camera (Eq. 3.3): ``O (H, W, 3)`` per pixel, ``D`` the viewing direction.
    Projector lens distortion is ignored here: use :func:`triangulate` (least squares,
    iterated) when the projector has distortion.

    Examples
    --------
    >>> from fringe3d.optics import PinholeDevice, Rig, intrinsics
    >>> cam = PinholeDevice(intrinsics(200.0, 200.0, 79.5, 63.5), 160, 128)
    >>> proj = PinholeDevice(intrinsics(290.0, 290.0, 127.5, 99.5), 256, 200, t=[-100.0, 0.0, 0.0])
    >>> rig = Rig(cam, proj)
    >>> O, D = cam.rays(cam.pixel_grid())                 # depth-1 ray directions
    >>> up = proj.project(O + 400.0 * D)[..., 0]          # u_p seen on the plane z = 400 mm
    >>> xyz = Triangulator(rig).points(up)                # (H, W, 3) float32, NaN where invalid
    >>> bool(np.allclose(xyz[..., 2], 400.0, atol=1e-3))
    True
    """

    def __init__(self, rig: Rig, angle: float = ANGLE_UP, warn_distortion: bool = True,
                 geometry: RigGeometry | None = None):
        super().__init__(rig, angle, geometry)
        self.ignores_distortion: bool = bool(rig.projector.dist.any())
        if self.ignores_distortion and warn_distortion:
            warnings.warn("the projector has lens distortion, which the fast triangulation path ignores; "
                          "use fringe3d.reconstruct.triangulate (least squares, iterated) for full accuracy",
                          ReconstructionWarning, stacklevel=2)

    def points_from_phase(self, phase, period: float, mask=None, out=None) -> np.ndarray:
        """3D points from the absolute phase ``Phi`` (rad) of fringes of ``period`` (projector
        pixels): ``w = Phi*T/(2*pi)`` (Eq. 4.13), then :meth:`points`."""
        if not period > 0:
            raise ValueError(f"fringe period must be positive (projector pixels), got {period}")
        phase = check_map(phase, self.shape, "absolute phase map")
        return self.points(phase_to_w(np.asarray(phase, np.float64), period), mask, out)


# ----------------------------------------------------------------------------- fused 3-step pipeline
class ThreeStepFields(NamedTuple):
    """One pass of the fused kernel (:meth:`FastThreeStep.depth_fields`): ``depth`` the ray
    parameters (mm, NaN invalid), ``w`` the fringe coordinate (px), ``average`` ``A`` and
    ``modulation`` ``B`` (Eq. 2.4, frames' units); each (H, W) float32 (None where only the
    depth was computed, e.g. on the CUDA backend)."""

    depth: np.ndarray
    w: np.ndarray | None = None
    average: np.ndarray | None = None
    modulation: np.ndarray | None = None


class FastThreeStep:
    """Superfast absolute 3D from three phase-shifted frames, one fused numba pass.

    ``frames (3, H, W)`` (uint8/uint16/float) -> least-squares wrapped phase (Eq. 2.4 with the
    given shifts) -> fringe order from the precomputed minimum phase map, ``k = ceil((Phi_min -
    phi)/2pi)`` (Eq. 4.21; floor where the phase falls with depth) -> ``w = Phi*T/2pi``
    (Eq. 4.13) -> point along the undistorted camera ray (closed form of Eq. 2.37). Nothing but
    the ``(H, W, 3)`` float32 output is written. Pinhole cameras only; projector distortion is
    ignored (as in :class:`Triangulator`).

    Parameters
    ----------
    triangulator : Triangulator
        For the fringe direction's angle.
    minimum_phase : fringe3d.unwrap.geometric.MinimumPhase
        Same rig, period and angle.
    shifts : 3 floats, rad
        Phase shift of each frame (default ``-2pi/3, 0, 2pi/3``, Eq. 1.1-1.3).
    min_modulation : float
        Pixels whose modulation ``I''`` (frames' units) is below this are NaN.
    backend : {"cpu", "cuda"}
        ``"cuda"`` runs the same fused kernel on a CUDA device
        (:func:`fringe3d.gpu.ops.three_step_points`); :meth:`points` then also takes many cycles
        ``(C, F, H, W)`` at once (host frames stream up in double-buffered chunks; device frames
        are used in place) and returns ``(C, H, W, 3)``.
    """

    def __init__(self, triangulator: Triangulator, minimum_phase: MinimumPhase,
                 shifts=(-2 * math.pi / 3, 0.0, 2 * math.pi / 3),
                 min_modulation: float = 0.0, backend: str = "cpu"):
        self.backend = check_backend(backend)
        if not triangulator.central:
            raise ValueError("FastThreeStep supports pinhole cameras; use Triangulator for telecentric rigs")
        if abs(triangulator.angle - minimum_phase.angle) > 1e-12 or minimum_phase.shape != triangulator.shape:
            raise ValueError("the triangulator and the minimum phase map must share the fringe angle and camera size")
        self.tri = triangulator
        self.mp = minimum_phase
        self.coef = np.ascontiguousarray(lsq_coefficients(shifts))
        if self.coef.shape[1] != 3:
            raise ValueError(f"FastThreeStep needs exactly 3 phase shifts, got {self.coef.shape[1]}")
        self.min_mod2 = float(min_modulation) ** 2
        self.phi_min = np.ascontiguousarray(minimum_phase.phi_min, np.float32)
        self.sign = np.ascontiguousarray(minimum_phase.sign, np.int8)
        self.scale = minimum_phase.period / (2 * math.pi)

    def set_min_modulation(self, min_modulation: float) -> None:
        """The modulation threshold (frames' units) below which a pixel is invalid, from now on."""
        self.min_mod2 = float(min_modulation) ** 2

    def depth(self, frames, index=(0, 1, 2), out=None, device_output: bool = False) -> np.ndarray:
        """``(H, W)`` float32 ray parameters ``s`` of ``X = O + s*D`` (the camera-frame depth, mm;
        NaN invalid) from ``frames[index]`` of an ``(F, H, W)`` stack; ``out`` may be a
        preallocated float32 array. :meth:`points` of the same frames is ``ray_points(s)``.
        With the CUDA backend also ``(C, F, H, W)`` -> ``(C, H, W)``; ``device_output`` keeps
        them on the device."""
        if self.backend == "cuda":
            return self._cuda(frames, index, out, device_output, depth=True)
        frames, idx = self._checked(frames, index)
        H, W = self.tri.shape
        if out is None:
            out = np.empty((H, W), np.float32)
        three_step_kernel(frames, idx, self.coef, self.min_mod2, self.phi_min, self.sign, self.scale,
                          self.tri.O, self.tri.D_planes, self.tri.Q, self.tri.P3, out)
        return out

    def depth_fields(self, frames, index=(0, 1, 2)) -> ThreeStepFields:
        """:meth:`depth` (CPU) and, from the same pass, what the quality tests of the fused path
        read: the fringe coordinate ``w`` (px), the average ``A`` and the modulation ``B`` (frames'
        units), each (H, W) float32 (:class:`ThreeStepFields`)."""
        frames, idx = self._checked(frames, index)
        H, W = self.tri.shape
        out, w, avg, mod = (np.empty((H, W), np.float32) for _ in range(4))
        three_step_fields_kernel(frames, idx, self.coef, self.min_mod2, self.phi_min, self.sign, self.scale,
                                 self.tri.O, self.tri.D_planes, self.tri.Q, self.tri.P3, out, w, avg, mod)
        return ThreeStepFields(out, w, avg, mod)

    def _checked(self, frames, index) -> tuple[np.ndarray, np.ndarray]:
        """``(frames, index)`` as arrays, checked against the rig's camera (clear errors)."""
        frames = np.asarray(frames)
        H, W = self.tri.shape
        if frames.ndim != 3:
            raise ValueError(f"frames must be an (F, H, W) stack, got shape {frames.shape}")
        check_camera_size(frames.shape[1:], (H, W), what="the frames")
        idx = np.asarray(index, np.int64)
        if idx.shape != (3,) or idx.min() < 0 or idx.max() >= frames.shape[0]:
            raise ValueError(f"index must name 3 frames of the {frames.shape[0]}-frame stack, got {list(index)}")
        return frames, idx

    def ray_points(self, s: np.ndarray, out=None) -> np.ndarray:
        """``(H, W, 3)`` float32 points (mm) of the ray parameters ``s`` (:func:`ray_points`)."""
        return ray_points(self.tri.O, self.tri.D_planes, s, out)

    def points(self, frames, index=(0, 1, 2), out=None, device_output: bool = False) -> np.ndarray:
        """``(H, W, 3)`` float32 points (mm, NaN invalid) from ``frames[index]`` of an
        ``(F, H, W)`` stack; ``out`` may be a preallocated float32 array. With the CUDA backend
        also ``(C, F, H, W)`` -> ``(C, H, W, 3)``, made on the device (``device_output`` keeps
        them there)."""
        if self.backend == "cuda":
            return self._cuda(frames, index, out, device_output, depth=False)
        return self.ray_points(self.depth(frames, index), out)

    def device_geometry(self) -> tuple:
        """``(geometry, constants)`` of the CUDA kernels: the per-rig host arrays
        (:class:`fringe3d.gpu.ops.ThreeStepGeometry`) and their device copies, uploaded on the first call
        (:func:`fringe3d.gpu.ops.three_step_constants`: the ray planes and ``phi_min`` go up once)."""
        from fringe3d.gpu import ops

        geometry = ops.ThreeStepGeometry(self.coef, self.phi_min, self.sign, self.scale, self.tri.O,
                                         self.tri.D_planes, self.tri.Q, self.tri.P3)
        if getattr(self, "_cuda_constants", None) is None:
            self._cuda_constants = ops.three_step_constants(geometry)
        return geometry, self._cuda_constants

    def _cuda(self, frames, index, out, device_output: bool, depth: bool):
        from fringe3d.gpu import ops

        geometry, constants = self.device_geometry()
        res = ops.three_step_points(frames if hasattr(frames, "copy_to_host") else np.asarray(frames),
                                    np.asarray(index, np.int64), geometry, self.min_mod2,
                                    device_output=device_output, constants=constants, depth=depth)
        if out is not None and not device_output:
            out[...] = res
            return out
        return res
