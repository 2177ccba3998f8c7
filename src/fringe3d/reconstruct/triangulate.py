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
import weakref

import numba
import numpy as np

from fringe3d.utils.console import warn
from fringe3d.phase._kernels import fast_atan2

ANGLE_UP = math.pi / 2  # vertical fringes: w = u_p
ANGLE_VP = 0.0          # horizontal fringes: w = v_p


# ----------------------------------------------------------------------------- helpers
def projector_row(P: np.ndarray, angle: float) -> np.ndarray:
    """Row ``Q = cos(alpha)*P[1] + sin(alpha)*P[0]`` of a (3, 4) projection matrix, so that a
    world point with homogeneous ``X~`` has fringe coordinate ``w = Q.X~ / P[2].X~``."""
    return math.cos(angle) * P[1] + math.sin(angle) * P[0]


def check_map(a, shape, name: str) -> np.ndarray | None:
    """Return ``a`` as an array of camera ``shape`` (H, W), or raise a clear ValueError."""
    if a is None:
        return None
    a = np.asarray(a)
    if a.shape != tuple(shape):
        raise ValueError(f"{name} has shape {a.shape} but the calibration's camera is "
                         f"{shape[1]}x{shape[0]} (expected an array of shape {tuple(shape)}): "
                         "calibration and capture sizes disagree")
    return a


def camera_shape(rig) -> tuple[int, int]:
    """(H, W) of the rig's camera."""
    return (rig.camera.height, rig.camera.width)


_UNDISTORTED: weakref.WeakKeyDictionary = weakref.WeakKeyDictionary()  # camera -> (H, W, 2) normalised


def camera_normalized(camera) -> np.ndarray:
    """Undistorted normalised coordinates ``(H, W, 2)`` float64 of every pixel centre of a pinhole
    camera (Eq. 2.12-2.16 inverted), computed once per camera object and cached."""
    xy = _UNDISTORTED.get(camera)
    if xy is None:
        xy = camera.pixels_to_normalized(camera.pixel_grid())
        xy.setflags(write=False)
        _UNDISTORTED[camera] = xy
    return xy


def camera_rays(rig) -> tuple[np.ndarray, np.ndarray]:
    """Undistorted camera rays ``X = O + s*D`` for every pixel, world frame.

    Returns ``(O, D)``: pinhole cameras give ``O (3,)`` (the centre) and ``D (H, W, 3)`` with
    device depth ``z = 1`` (so ``s`` is the depth along the camera axis); telecentric cameras
    give ``O (H, W, 3)`` and the common unit direction ``D (3,)``.
    """
    cam = rig.camera
    if rig.telecentric:
        return cam.rays(cam.pixel_grid())
    xy = camera_normalized(cam)
    d_dev = np.concatenate([xy, np.ones(xy.shape[:-1] + (1,))], axis=-1)
    return cam.center, d_dev @ cam.R


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
    up_m = nan_map if up is None else np.asarray(up, np.float64)
    vp_m = nan_map if vp is None else np.asarray(vp, np.float64)
    out = np.empty(shape + (3,), np.float32)
    flags = (up is not None, vp is not None, not rig.telecentric)
    _lsq_kernel(cu, cv, valid, Pc, proj.P, up_m, vp_m, *flags, out)
    if proj.dist.any() and valid.any():
        for _ in range(iterations):
            prev = out.copy()
            uu, vv = _undistorted_proj(proj, up_m, vp_m, out.astype(np.float64))
            _lsq_kernel(cu, cv, valid, Pc, proj.P, uu, vv, *flags, out)
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


@numba.njit(parallel=True, cache=True)
def _lsq_kernel(cu, cv, valid, Pc, Pp, up, vp, use_up, use_vp, check_front, out):  # pragma: no cover
    H, W = cu.shape
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        A = np.empty((4, 3))
        b = np.empty(4)
        for j in range(W):
            out[i, j, 0] = nan
            out[i, j, 1] = nan
            out[i, j, 2] = nan
            if not valid[i, j]:
                continue
            n = 0
            for r, (x, P, k) in enumerate(((cu[i, j], Pc, 0), (cv[i, j], Pc, 1), (up[i, j], Pp, 0),
                                           (vp[i, j], Pp, 1))):
                if (r == 2 and not use_up) or (r == 3 and not use_vp):
                    continue
                for c in range(3):
                    A[n, c] = x * P[2, c] - P[k, c]
                b[n] = P[k, 3] - x * P[2, 3]
                n += 1
            if n == 3:
                X0, X1, X2, ok = _solve3(A[0, 0], A[0, 1], A[0, 2], A[1, 0], A[1, 1], A[1, 2],
                                         A[2, 0], A[2, 1], A[2, 2], b[0], b[1], b[2])
            else:  # normal equations, Eq. (2.37)
                M = np.zeros((3, 3))
                v = np.zeros(3)
                for r in range(n):
                    for c in range(3):
                        v[c] += A[r, c] * b[r]
                        for d in range(3):
                            M[c, d] += A[r, c] * A[r, d]
                X0, X1, X2, ok = _solve3(M[0, 0], M[0, 1], M[0, 2], M[1, 0], M[1, 1], M[1, 2],
                                         M[2, 0], M[2, 1], M[2, 2], v[0], v[1], v[2])
            if not ok:
                continue
            if check_front and not (Pc[2, 0] * X0 + Pc[2, 1] * X1 + Pc[2, 2] * X2 + Pc[2, 3] > 0.0):
                continue  # behind the pinhole camera
            out[i, j, 0] = X0
            out[i, j, 1] = X1
            out[i, j, 2] = X2


@numba.njit(cache=True, inline="always")
def _solve3(a, b, c, d, e, f, g, h, k, r0, r1, r2):  # pragma: no cover - compiled
    """Solve the 3x3 system [[a b c] [d e f] [g h k]] x = r by Cramer's rule."""
    c0 = e * k - f * h
    c1 = f * g - d * k
    c2 = d * h - e * g
    det = a * c0 + b * c1 + c * c2
    if det == 0.0 or not math.isfinite(det):
        return 0.0, 0.0, 0.0, False
    x0 = (r0 * c0 + b * (f * r2 - r1 * k) + c * (r1 * h - e * r2)) / det
    x1 = (a * (r1 * k - f * r2) + r0 * c1 + c * (d * r2 - r1 * g)) / det
    x2 = (a * (e * r2 - r1 * h) + b * (r1 * g - d * r2) + r0 * c2) / det
    return x0, x1, x2, True


def _undistorted_proj(proj, up, vp, X):
    """Undistorted projector pixel coordinates ``(up', vp')`` (H, W) from the measured ones and
    the current estimate ``X`` (H, W, 3): the unknown coordinate is predicted by projecting
    ``X`` (with distortion), then the pair is undistorted."""
    pred = proj.project(X)
    u = np.where(np.isfinite(up), up, pred[..., 0])
    v = np.where(np.isfinite(vp), vp, pred[..., 1])
    uvu = proj.normalized_to_pixels(proj.pixels_to_normalized(np.stack([u, v], axis=-1)))
    return np.ascontiguousarray(uvu[..., 0]), np.ascontiguousarray(uvu[..., 1])


# ----------------------------------------------------------------------------- fast path
@numba.njit(parallel=True, cache=True)
def _central_kernel(w, mask, O, D, Q, P3, out):  # pragma: no cover - compiled
    """Pinhole rays: O (3,) centre, D (3, H, W) ray planes; out (H, W, 3)."""
    H, W = w.shape
    qo = Q[0] * O[0] + Q[1] * O[1] + Q[2] * O[2] + Q[3]
    po = P3[0] * O[0] + P3[1] * O[1] + P3[2] * O[2] + P3[3]
    for i in numba.prange(H):
        srow = np.empty(W, np.float64)
        for j in range(W):  # contiguous planes: this loop vectorises
            wij = np.float64(w[i, j])
            dx = np.float64(D[0, i, j])
            dy = np.float64(D[1, i, j])
            dz = np.float64(D[2, i, j])
            s = (qo - wij * po) / (wij * (P3[0] * dx + P3[1] * dy + P3[2] * dz) - (Q[0] * dx + Q[1] * dy + Q[2] * dz))
            srow[j] = s if (mask[i, j] and s > 0.0 and s < np.inf) else np.nan
        _write_row(out, i, srow, O[0], O[1], O[2], D[0, i], D[1, i], D[2, i])


@numba.njit(cache=True, inline="always")
def _write_row(out, i, srow, ox, oy, oz, dx, dy, dz):  # pragma: no cover - compiled
    for j in range(srow.shape[0]):
        s = srow[j]
        out[i, j, 0] = ox + s * dx[j]
        out[i, j, 1] = oy + s * dy[j]
        out[i, j, 2] = oz + s * dz[j]


@numba.njit(parallel=True, cache=True)
def _parallel_kernel(w, mask, O, D, Q, P3, out):  # pragma: no cover - compiled
    """Telecentric rays: O (3, H, W) origin planes, D (3,) common direction; out (H, W, 3)."""
    H, W = w.shape
    qd = Q[0] * D[0] + Q[1] * D[1] + Q[2] * D[2]
    pd = P3[0] * D[0] + P3[1] * D[1] + P3[2] * D[2]
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            wij = np.float64(w[i, j])
            ox = np.float64(O[0, i, j])
            oy = np.float64(O[1, i, j])
            oz = np.float64(O[2, i, j])
            num = (Q[0] * ox + Q[1] * oy + Q[2] * oz + Q[3]) - wij * (P3[0] * ox + P3[1] * oy + P3[2] * oz + P3[3])
            s = num / (wij * pd - qd)
            if mask[i, j] and math.isfinite(s):
                out[i, j, 0] = ox + s * D[0]
                out[i, j, 1] = oy + s * D[1]
                out[i, j, 2] = oz + s * D[2]
            else:
                out[i, j, 0] = nan
                out[i, j, 1] = nan
                out[i, j, 2] = nan


class Triangulator:
    """Per-pixel closed-form triangulation with coefficients precomputed once per rig.

    Parameters
    ----------
    rig : fringe3d.optics.Rig
    angle : float
        Fringe angle alpha (rad) of the direction that supplies ``w``: pi/2 (default) for
        vertical fringes (``w = u_p``), 0 for horizontal fringes (``w = v_p``).
    warn_distortion : bool
        Warn (once, here) when the projector has lens distortion, which this path ignores.

    Notes
    -----
    Pinhole camera: ``X = O + s*D`` with ``O`` the camera centre and ``D (H, W, 3)`` the
    undistorted ray of each pixel (device depth 1), ``s = (a + b*w) / (c + e*w)`` with
    ``a = Q.O~``, ``b = -P3.O~``, ``c = -Q.D``, ``e = P3.D`` (Eq. 2.37 solved along the ray).
    Telecentric camera (Eq. 3.3): ``O (H, W, 3)`` per pixel, ``D`` the viewing direction.
    Projector lens distortion is ignored here: use :func:`triangulate` (least squares,
    iterated) when the projector has distortion.

    Example
    -------
    >>> tri = Triangulator(rig)                       # doctest: +SKIP
    >>> xyz = tri.points(up)                           # (H, W, 3) float32, NaN where invalid
    """

    def __init__(self, rig, angle: float = ANGLE_UP, warn_distortion: bool = True):
        self.rig = rig
        self.angle = float(angle)
        self.shape = camera_shape(rig)
        O, D = camera_rays(rig)
        self.central = not rig.telecentric
        # per-pixel vectors are stored as (3, H, W) float32 planes so the kernels vectorise
        if self.central:
            self.O = np.asarray(O, np.float64)
            self.D_planes = np.ascontiguousarray(np.moveaxis(D, -1, 0), dtype=np.float32)
        else:
            self.O_planes = np.ascontiguousarray(np.moveaxis(O, -1, 0), dtype=np.float32)
            self.D = np.asarray(D, np.float64)
        P = rig.projector.P
        self.Q = np.ascontiguousarray(projector_row(P, self.angle), dtype=np.float64)
        self.P3 = np.ascontiguousarray(P[2], dtype=np.float64)
        self.ignores_distortion = bool(rig.projector.dist.any())
        if self.ignores_distortion and warn_distortion:
            warn("the projector has lens distortion, which the fast triangulation path ignores; "
                 "use fringe3d.reconstruct.triangulate (least squares, iterated) for full accuracy")

    @property
    def rays(self) -> tuple[np.ndarray, np.ndarray]:
        """``(O, D)`` as in :func:`camera_rays` (views of the stored planes)."""
        if self.central:
            return self.O, np.moveaxis(self.D_planes, 0, -1)
        return np.moveaxis(self.O_planes, 0, -1), self.D

    def points(self, w, mask=None, out=None) -> np.ndarray:
        """3D points from the projector coordinate ``w`` (H, W) (``u_p`` for vertical fringes).

        Returns ``(H, W, 3)`` float32 in mm, NaN where ``w`` is NaN, ``mask`` is False, or the
        point falls behind a pinhole camera. ``out`` may be a preallocated float32 array.
        """
        w = check_map(w, self.shape, "projector coordinate map")
        if w.dtype not in (np.float32, np.float64):
            w = w.astype(np.float32)
        mask = np.ones(self.shape, bool) if mask is None else check_map(mask, self.shape, "mask").astype(bool)
        if out is None:
            out = np.empty(self.shape + (3,), np.float32)
        if self.central:
            _central_kernel(np.ascontiguousarray(w), np.ascontiguousarray(mask), self.O, self.D_planes, self.Q, self.P3, out)
        else:
            _parallel_kernel(np.ascontiguousarray(w), np.ascontiguousarray(mask), self.O_planes, self.D, self.Q, self.P3, out)
        return out

    def points_from_phase(self, phase, period: float, mask=None, out=None) -> np.ndarray:
        """3D points from the absolute phase ``Phi`` (rad) of fringes of ``period`` (projector
        pixels): ``w = Phi*T/(2*pi)`` (Eq. 4.13), then :meth:`points`."""
        if not period > 0:
            raise ValueError(f"fringe period must be positive (projector pixels), got {period}")
        phase = check_map(phase, self.shape, "absolute phase map")
        return self.points(np.asarray(phase, np.float64) * (period / (2 * np.pi)), mask, out)

    def ray_points_at_z(self, z) -> np.ndarray:
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


# ----------------------------------------------------------------------------- fused 3-step pipeline
_FAST = {"nsz", "arcp", "contract", "afn", "reassoc"}  # fastmath without the no-NaN/no-inf assumptions


@numba.njit(parallel=True, fastmath=_FAST, cache=True)
def _three_step_kernel(frames, idx, coef, min_mod2, phi_min, sign, scale, O, D, Q, P3, out):  # pragma: no cover
    """3 frames -> wrapped phase (Eq. 2.4) -> k (Eq. 4.21) -> w (Eq. 4.13) -> X (Eq. 2.37).

    Branch-free per pixel so the row loop vectorises: ``k = sg*ceil(sg*x)`` is ceil for a
    rising and floor for a falling phase; invalid pixels carry ``s = NaN`` into the output.
    """
    H = frames.shape[1]
    W = frames.shape[2]
    two_pi = 2.0 * math.pi
    qo = Q[0] * O[0] + Q[1] * O[1] + Q[2] * O[2] + Q[3]
    po = P3[0] * O[0] + P3[1] * O[1] + P3[2] * O[2] + P3[3]
    i0, i1, i2 = idx[0], idx[1], idx[2]
    for i in numba.prange(H):
        srow = np.empty(W, np.float64)
        for j in range(W):
            a0 = np.float64(frames[i0, i, j])
            a1 = np.float64(frames[i1, i, j])
            a2 = np.float64(frames[i2, i, j])
            b = coef[1, 0] * a0 + coef[1, 1] * a1 + coef[1, 2] * a2
            c = coef[2, 0] * a0 + coef[2, 1] * a1 + coef[2, 2] * a2
            phi = fast_atan2(-c, b)
            sg = np.float64(sign[i, j])
            x = (np.float64(phi_min[i, j]) - phi) * (1.0 / two_pi)
            w = (phi + two_pi * (sg * math.ceil(sg * x))) * scale
            dx = np.float64(D[0, i, j])
            dy = np.float64(D[1, i, j])
            dz = np.float64(D[2, i, j])
            s = (qo - w * po) / (w * (P3[0] * dx + P3[1] * dy + P3[2] * dz) - (Q[0] * dx + Q[1] * dy + Q[2] * dz))
            ok = ((b * b + c * c) >= min_mod2) & (sg != 0.0) & (s > 0.0)
            srow[j] = s if ok else np.nan
        _write_row(out, i, srow, O[0], O[1], O[2], D[0, i], D[1, i], D[2, i])


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
    """

    def __init__(self, triangulator: Triangulator, minimum_phase, shifts=(-2 * math.pi / 3, 0.0, 2 * math.pi / 3),
                 min_modulation: float = 0.0):
        if not triangulator.central:
            raise ValueError("FastThreeStep supports pinhole cameras; use Triangulator for telecentric rigs")
        if abs(triangulator.angle - minimum_phase.angle) > 1e-12 or minimum_phase.shape != triangulator.shape:
            raise ValueError("the triangulator and the minimum phase map must share the fringe angle and camera size")
        from fringe3d.phase.psp import lsq_coefficients
        self.tri = triangulator
        self.mp = minimum_phase
        self.coef = np.ascontiguousarray(lsq_coefficients(shifts))
        if self.coef.shape[1] != 3:
            raise ValueError(f"FastThreeStep needs exactly 3 phase shifts, got {self.coef.shape[1]}")
        self.min_mod2 = float(min_modulation) ** 2
        self.phi_min = np.ascontiguousarray(minimum_phase.phi_min, np.float32)
        self.sign = np.ascontiguousarray(minimum_phase.sign, np.int8)
        self.scale = minimum_phase.period / (2 * math.pi)

    def points(self, frames, index=(0, 1, 2), out=None) -> np.ndarray:
        """``(H, W, 3)`` float32 points (mm, NaN invalid) from ``frames[index]`` of an
        ``(F, H, W)`` stack; ``out`` may be a preallocated float32 array."""
        frames = np.asarray(frames)
        H, W = self.tri.shape
        if frames.ndim != 3 or frames.shape[1:] != (H, W):
            raise ValueError(f"frames must be an (F, {H}, {W}) stack for this rig's camera, got {frames.shape}: "
                             "calibration and capture sizes disagree" if frames.ndim == 3 else
                             f"frames must be an (F, H, W) stack, got shape {frames.shape}")
        idx = np.asarray(index, np.int64)
        if idx.shape != (3,) or idx.min() < 0 or idx.max() >= frames.shape[0]:
            raise ValueError(f"index must name 3 frames of the {frames.shape[0]}-frame stack, got {list(index)}")
        if out is None:
            out = np.empty((H, W, 3), np.float32)
        _three_step_kernel(frames, idx, self.coef, self.min_mod2, self.phi_min, self.sign, self.scale,
                           self.tri.O, self.tri.D_planes, self.tri.Q, self.tri.P3, out)
        return out
