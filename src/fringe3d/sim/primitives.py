"""Analytic scene primitives: planes, spheres and boxes, each a :class:`PosedObject` with its
own numba ray cast (one pass over the rays, no temporaries).

Material coordinates: planes (mm along two in-plane axes), spheres (body-frame longitude and
latitude, rad), boxes (body ``(x, y)``, mm). Shapes and conventions of the casts:
:mod:`fringe3d.sim.hits`.

>>> import numpy as np
>>> h = Sphere((0.0, 0.0, 100.0), 10.0).intersect(np.zeros(3), np.array([[0.0, 0.0, 1.0]]))
>>> float(h.t[0]), h.normal[0].tolist()
(90.0, [0.0, 0.0, -1.0])
"""
from __future__ import annotations

import numba
import numpy as np

from .hits import Hit, as_rays
from .motion import STATIC, RigidMotion
from .scene_object import (
    PosedObject,
    check_albedo,
    check_rotation,
    check_vec3,
    rigid_to_body,
)


# --------------------------------------------------------------------------------------------
# Numba kernels for the analytic primitives (one pass over the rays, no temporaries)
# --------------------------------------------------------------------------------------------
@numba.njit(cache=True)
def _sphere_kernel(o, d, c, r, t_out, n_out):
    n_rays = d.shape[0]
    shared = o.shape[0] == 1
    for i in range(n_rays):
        j = 0 if shared else i
        ox = o[j, 0] - c[0]
        oy = o[j, 1] - c[1]
        oz = o[j, 2] - c[2]
        dx, dy, dz = d[i, 0], d[i, 1], d[i, 2]
        a = dx * dx + dy * dy + dz * dz
        b = ox * dx + oy * dy + oz * dz
        cc = ox * ox + oy * oy + oz * oz - r * r
        disc = b * b - a * cc
        t_out[i] = np.inf
        if disc < 0 or a == 0:
            continue
        sq = np.sqrt(disc)
        q = -(b + sq) if b >= 0 else -(b - sq)  # numerically stable roots
        t1 = q / a
        t2 = cc / q if q != 0 else t1
        lo, hi = (t1, t2) if t1 < t2 else (t2, t1)
        t = lo if lo > 1e-9 else hi
        if t <= 1e-9:
            continue
        t_out[i] = t
        n_out[i, 0] = (ox + t * dx) / r
        n_out[i, 1] = (oy + t * dy) / r
        n_out[i, 2] = (oz + t * dz) / r


@numba.njit(cache=True)
def _plane_kernel(o, d, p, nrm, e1, e2, half_u, half_v, t_out, uv_out):
    n_rays = d.shape[0]
    shared = o.shape[0] == 1
    for i in range(n_rays):
        j = 0 if shared else i
        den = d[i, 0] * nrm[0] + d[i, 1] * nrm[1] + d[i, 2] * nrm[2]
        t_out[i] = np.inf
        if den == 0:
            continue
        wx, wy, wz = p[0] - o[j, 0], p[1] - o[j, 1], p[2] - o[j, 2]
        t = (wx * nrm[0] + wy * nrm[1] + wz * nrm[2]) / den
        if t <= 1e-9:
            continue
        rx = o[j, 0] + t * d[i, 0] - p[0]
        ry = o[j, 1] + t * d[i, 1] - p[1]
        rz = o[j, 2] + t * d[i, 2] - p[2]
        u = rx * e1[0] + ry * e1[1] + rz * e1[2]
        v = rx * e2[0] + ry * e2[1] + rz * e2[2]
        if abs(u) > half_u or abs(v) > half_v:
            continue
        t_out[i] = t
        uv_out[i, 0] = u
        uv_out[i, 1] = v


def plane_axes(normal, u_axis=None) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
    """Unit normal and two in-plane unit axes ``(e1, e2)`` with ``e1 × e2 = n``.

    ``e1`` is ``u_axis`` projected into the plane, or the world axis least aligned with ``n``.
    """
    n = check_vec3(normal, "normal")
    if np.linalg.norm(n) == 0:
        raise ValueError("plane normal must be non-zero")
    n = n / np.linalg.norm(n)
    if u_axis is None:
        u_axis = np.eye(3)[np.argmin(np.abs(n))]
    e1 = check_vec3(u_axis, "u_axis")
    e1 = e1 - (e1 @ n) * n
    if np.linalg.norm(e1) < 1e-9:
        raise ValueError("u_axis must not be parallel to the plane normal")
    e1 /= np.linalg.norm(e1)
    return n, e1, np.cross(n, e1)


# --------------------------------------------------------------------------------------------
# Primitives
# --------------------------------------------------------------------------------------------
class Plane(PosedObject):
    """A plane through ``point`` with ``normal``, optionally a finite rectangle.

    Material coordinates ``uv`` (mm) are measured from ``point`` along ``e1`` (``u_axis``
    projected into the plane) and ``e2 = n × e1``. ``size=(width, height)`` (mm) bounds the
    plane to ``|u| <= width/2, |v| <= height/2``; ``None`` means infinite.
    """

    def __init__(self, point, normal, albedo=1.0, texture=None, u_axis=None, size=None,
                 motion: RigidMotion = STATIC):
        self.point = check_vec3(point, "point")
        self.normal, self.e1, self.e2 = plane_axes(normal, u_axis)
        self.albedo = check_albedo(albedo)
        self.texture = texture
        self.motion = motion
        if size is None:
            self.size = None
        else:
            self.size = np.asarray(size, float).ravel()
            if self.size.shape != (2,) or np.any(self.size <= 0):
                raise ValueError(f"plane size must be (width, height) > 0 in mm, got {size}")
        self.R = np.column_stack([self.e1, self.e2, self.normal])
        self.center = self.point

    def bounding_sphere_body(self):
        r = np.inf if self.size is None else 0.5 * float(np.hypot(*self.size))
        return np.zeros(3), r

    def to_dict(self) -> dict:
        d = {"type": "plane", "point": self.point.tolist(), "normal": self.normal.tolist(),
             "u_axis": self.e1.tolist()}
        if self.size is not None:
            d["size"] = self.size.tolist()
        return {**d, **self._style_dict()}

    def intersect(self, origins, dirs, time: float = 0.0) -> Hit:
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        half = (np.inf, np.inf) if self.size is None else 0.5 * self.size
        t = np.empty(len(d))
        uv = np.full((len(d), 2), np.nan)
        _plane_kernel(o, d, c, R[:, 2].copy(), R[:, 0].copy(), R[:, 1].copy(),
                      float(half[0]), float(half[1]), t, uv)
        normal = np.empty_like(d)
        normal[:] = R[:, 2]
        return self._finish(t, normal, uv, d, reuse=True)

    def hit_distance(self, origins, dirs, time: float = 0.0) -> np.ndarray:
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        half = (np.inf, np.inf) if self.size is None else 0.5 * self.size
        t = np.empty(len(d))
        _plane_kernel(o, d, c, R[:, 2].copy(), R[:, 0].copy(), R[:, 1].copy(),
                      float(half[0]), float(half[1]), t, np.empty((len(d), 2)))
        return t


class Sphere(PosedObject):
    """Sphere of ``radius`` (mm) about ``center``; may move (``velocity``, ``acceleration``) and
    spin (``spin`` rad/s) — the texture turns with it.

    Material coordinates are body-frame (longitude, latitude) in radians: longitude
    ``atan2(y_b, x_b)`` in (-π, π], latitude ``asin(z_b / r)``.
    """

    def __init__(self, center, radius, albedo=1.0, texture=None, velocity=(0.0, 0.0, 0.0),
                 acceleration=(0.0, 0.0, 0.0), spin=(0.0, 0.0, 0.0), t0: float = 0.0, R=None,
                 motion: RigidMotion | None = None):
        self.center = check_vec3(center, "center")
        self.radius = float(radius)
        if not self.radius > 0:
            raise ValueError(f"sphere radius must be > 0 mm, got {radius}")
        self.albedo = check_albedo(albedo)
        self.texture = texture
        self.R = np.eye(3) if R is None else check_rotation(R)
        self.motion = motion if motion is not None else RigidMotion(velocity, acceleration, spin, t0)

    def center_at(self, time: float = 0.0) -> np.ndarray:
        """Closed-form centre ``c0 + v0 dt + a dt²/2`` (mm)."""
        return self.center + self.motion.offset(time)

    def bounding_sphere_body(self):
        return np.zeros(3), self.radius

    def to_dict(self) -> dict:
        m = self.motion
        d = {"type": "sphere", "center": self.center.tolist(), "radius": self.radius, "R": self.R.tolist(),
             **self._style_dict(motion=False)}
        if not m.is_static:
            d.update(velocity=m.velocity.tolist(), acceleration=m.acceleration.tolist(),
                     spin=m.angular_velocity.tolist(), t0=m.t0)
        return d

    def intersect(self, origins, dirs, time: float = 0.0) -> Hit:
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        t = np.empty(len(d))
        n = np.full(d.shape, np.nan)
        _sphere_kernel(o, d, c, self.radius, t, n)
        uv = np.full((len(d), 2), np.nan)
        idx = np.flatnonzero(np.isfinite(t))
        if idx.size:
            nb = rigid_to_body(n[idx], R)  # body-frame unit vector (numba: no BLAS threads)
            uv[idx, 0] = np.arctan2(nb[:, 1], nb[:, 0])
            uv[idx, 1] = np.arcsin(np.clip(nb[:, 2], -1, 1))
        return self._finish(t, n, uv, d, reuse=True)

    def hit_distance(self, origins, dirs, time: float = 0.0) -> np.ndarray:
        o, d = as_rays(origins, dirs)
        t = np.empty(len(d))
        _sphere_kernel(o, d, self.pose(time)[1], self.radius, t, np.empty(d.shape))
        return t


class Box(PosedObject):
    """Rectangular block of ``size = (sx, sy, sz)`` mm centred at ``center``, rotated by ``R``
    (body → world, matrix or rotation vector). Material ``uv`` are body ``(x, y)`` (mm)."""

    def __init__(self, center, size, R=None, albedo=1.0, texture=None,
                 motion: RigidMotion = STATIC):
        self.center = check_vec3(center, "center")
        self.size = np.asarray(size, float).ravel()
        if self.size.shape != (3,) or np.any(self.size <= 0):
            raise ValueError(f"box size must be three positive lengths (mm), got {size}")
        self.R = np.eye(3) if R is None else check_rotation(R)
        self.albedo = check_albedo(albedo)
        self.texture = texture
        self.motion = motion

    def bounding_sphere_body(self):
        return np.zeros(3), 0.5 * float(np.linalg.norm(self.size))

    def to_dict(self) -> dict:
        return {"type": "box", "center": self.center.tolist(), "size": self.size.tolist(), "R": self.R.tolist(),
                **self._style_dict()}

    def intersect_body(self, o, d):
        """Slab method in the body frame (numba)."""
        t = np.empty(len(d))
        n = np.zeros_like(d)
        uv = np.full((len(d), 2), np.nan)
        _box_kernel(o, d, 0.5 * self.size, t, n, uv)
        return t, n, uv


@numba.njit(cache=True)
def _box_kernel(o, d, half, t_out, n_out, uv_out):
    shared = o.shape[0] == 1
    for i in range(d.shape[0]):
        j = 0 if shared else i
        t_near, t_far = -np.inf, np.inf
        ax_near, ax_far = -1, -1
        ok = True
        for k in range(3):
            if d[i, k] == 0.0:
                if abs(o[j, k]) > half[k]:
                    ok = False
                    break
                continue
            t1 = (-half[k] - o[j, k]) / d[i, k]
            t2 = (half[k] - o[j, k]) / d[i, k]
            if t1 > t2:
                t1, t2 = t2, t1
            if t1 > t_near:
                t_near, ax_near = t1, k
            if t2 < t_far:
                t_far, ax_far = t2, k
        t_out[i] = np.inf
        if not ok or t_far < t_near:
            continue
        if t_near > 1e-9:
            t, ax = t_near, ax_near
        elif t_far > 1e-9:
            t, ax = t_far, ax_far  # origin inside the box
        else:
            continue
        t_out[i] = t
        n_out[i, ax] = 1.0
        uv_out[i, 0] = o[j, 0] + t * d[i, 0]
        uv_out[i, 1] = o[j, 1] + t * d[i, 1]
