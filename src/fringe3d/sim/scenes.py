"""Ray-traceable scene objects and the :class:`Scene` container (the simulator's geometry).

Every object implements ``intersect(origins, dirs, time=0.0) -> Hit``:

* ``origins``: ``(3,)`` one shared origin (pinhole camera/projector) or ``(N, 3)`` one per ray
  (telecentric camera), mm, world frame;
* ``dirs``: ``(N, 3)`` ray directions (need not be unit length);
* ``time``: seconds, for moving or deforming objects.

The hit point is ``X = origin + t * dir`` for the smallest ``t > T_MIN``. ``Hit.normal`` is the
unit surface normal turned to face the ray (``normal · dir <= 0``). Misses have ``t = inf``,
``object_id = -1``, ``normal = NaN``, ``albedo = 0`` and ``material_uv = NaN``.

Objects whose pose changes over time carry a :class:`~fringe3d.sim.motion.RigidMotion`.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from .motion import STATIC, RigidMotion, rotation_vector_to_matrix

T_MIN = 1e-9  # smallest accepted ray parameter (avoids self-hits at the origin)


# --------------------------------------------------------------------------------------------
# Hit record
# --------------------------------------------------------------------------------------------
@dataclass(eq=False)
class Hit:
    """Result of casting ``N`` rays.

    Attributes
    ----------
    t : (N,) float64 ray parameter (``inf`` where missed).
    normal : (N, 3) float64 unit normal facing the ray (NaN where missed).
    object_id : (N,) int32, index of the object in its :class:`Scene` (-1 where missed).
    albedo : (N,) float64 in [0, 1], base albedo × texture (0 where missed).
    material_uv : (N, 2) float64 material coordinates (mm, or rad on spheres); NaN if none.
    """

    t: np.ndarray
    normal: np.ndarray
    object_id: np.ndarray
    albedo: np.ndarray
    material_uv: np.ndarray

    @classmethod
    def miss(cls, n: int) -> "Hit":
        return cls(t=np.full(n, np.inf), normal=np.full((n, 3), np.nan),
                   object_id=np.full(n, -1, np.int32), albedo=np.zeros(n),
                   material_uv=np.full((n, 2), np.nan))

    def __len__(self) -> int:
        return len(self.t)

    @property
    def mask(self) -> np.ndarray:
        """(N,) bool, True where a ray hit something."""
        return self.object_id >= 0

    def points(self, origins, dirs) -> np.ndarray:
        """World hit points ``origin + t * dir`` (N, 3); NaN where missed."""
        o, d = as_rays(origins, dirs)
        t = np.where(self.mask, self.t, np.nan)
        return o + t[:, None] * d

    def take(self, other: "Hit", where: np.ndarray) -> None:
        """Overwrite rows ``where`` (bool (N,)) with those of ``other`` (in place)."""
        _take_kernel(where, self.t, self.normal, self.object_id, self.albedo, self.material_uv,
                     other.t, other.normal, other.object_id, other.albedo, other.material_uv)

    def merge_nearer(self, other: "Hit", object_id: int) -> None:
        """Keep, per ray, the nearer of ``self`` and ``other`` (in place); rows taken from
        ``other`` get ``object_id``."""
        _merge_kernel(self.t, self.normal, self.object_id, self.albedo, self.material_uv,
                      other.t, other.normal, other.object_id, other.albedo, other.material_uv,
                      np.int32(object_id))


@numba.njit(cache=True, inline="always")
def copy_hit_row(i, j, t, n, alb, uv, t2, n2, alb2, uv2):
    """Row ``i`` of a hit record (t, normal, albedo, material uv) takes row ``j`` of another;
    the caller sets the object id."""
    t[i] = t2[j]
    alb[i] = alb2[j]
    for k in range(3):
        n[i, k] = n2[j, k]
    uv[i, 0] = uv2[j, 0]
    uv[i, 1] = uv2[j, 1]


@numba.njit(cache=True)
def _take_kernel(where, t, n, oid, alb, uv, t2, n2, oid2, alb2, uv2):
    for i in range(t.shape[0]):
        if where[i]:
            copy_hit_row(i, i, t, n, alb, uv, t2, n2, alb2, uv2)
            oid[i] = oid2[i]


@numba.njit(cache=True)
def _merge_kernel(t, n, oid, alb, uv, t2, n2, oid2, alb2, uv2, new_id):
    for i in range(t.shape[0]):
        if oid2[i] >= 0 and t2[i] < t[i]:
            copy_hit_row(i, i, t, n, alb, uv, t2, n2, alb2, uv2)
            oid[i] = new_id


@numba.njit(cache=True)
def _rigid_to_body(x, R, c, out):
    """out = (x - c) @ R for rows of x (N, 3); c may be zeros (directions)."""
    for i in range(x.shape[0]):
        a = x[i, 0] - c[0]
        b = x[i, 1] - c[1]
        e = x[i, 2] - c[2]
        for k in range(3):
            out[i, k] = a * R[0, k] + b * R[1, k] + e * R[2, k]


def rigid_to_body(x, R, c=None):
    """Rows ``(x - c) @ R`` (N, 3): world points (or directions with ``c=None``) into a body
    frame whose pose is ``X = R @ x_body + c``."""
    out = np.empty_like(x)
    _rigid_to_body(x, np.ascontiguousarray(R), np.zeros(3) if c is None else np.asarray(c, float), out)
    return out


@numba.njit(cache=True)
def _finish_kernel(t, n, d, uv, t_out, n_out, id_out, uv_out, hit):
    """Mark hits, copy t and uv, normalise normals and turn them to face the ray; misses get
    t = inf, normal = uv = NaN, id = -1. Outputs may be the inputs (row i is read first)."""
    count = 0
    nan = np.nan
    for i in range(t.shape[0]):
        ti = t[i]
        nx, ny, nz = n[i, 0], n[i, 1], n[i, 2]
        nn = np.sqrt(nx * nx + ny * ny + nz * nz)
        if not (ti > 1e-9 and ti < np.inf) or not nn > 0:
            hit[i] = False
            t_out[i] = np.inf
            n_out[i, 0] = nan
            n_out[i, 1] = nan
            n_out[i, 2] = nan
            id_out[i] = -1
            uv_out[i, 0] = nan
            uv_out[i, 1] = nan
            continue
        if nx * d[i, 0] + ny * d[i, 1] + nz * d[i, 2] > 0:
            nn = -nn
        n_out[i, 0] = nx / nn
        n_out[i, 1] = ny / nn
        n_out[i, 2] = nz / nn
        t_out[i] = ti
        id_out[i] = 0
        uv_out[i, 0] = uv[i, 0]
        uv_out[i, 1] = uv[i, 1]
        hit[i] = True
        count += 1
    return count


def as_rays(origins, dirs) -> tuple[np.ndarray, np.ndarray]:
    """Validate rays: returns ``origins`` as (1, 3) or (N, 3) and ``dirs`` as (N, 3), float64."""
    d = np.ascontiguousarray(dirs, dtype=np.float64)
    if d.ndim != 2 or d.shape[1] != 3:
        raise ValueError(f"ray directions must have shape (N, 3), got {d.shape}")
    o = np.ascontiguousarray(origins, dtype=np.float64)
    if o.shape == (3,):
        o = o[None, :]
    if o.ndim != 2 or o.shape[1] != 3 or o.shape[0] not in (1, d.shape[0]):
        raise ValueError(f"ray origins must have shape (3,) or ({d.shape[0]}, 3), got {o.shape}")
    return o, d


def _vec3(v, name) -> np.ndarray:
    v = np.asarray(v, float).ravel()
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be a finite 3-vector, got {np.asarray(v).tolist()}")
    return v


def _albedo(a, name="albedo") -> float:
    a = float(a)
    if not 0.0 <= a <= 1.0:
        raise ValueError(f"{name} must be in [0, 1], got {a}")
    return a


def _rotation(R, name="R") -> np.ndarray:
    R = np.asarray(R, float)
    if R.shape == (3,):  # rotation vector
        return rotation_vector_to_matrix(R)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
        raise ValueError(f"{name} must be a (3, 3) rotation matrix or a rotation vector (3,)")
    return R


# --------------------------------------------------------------------------------------------
# Base class
# --------------------------------------------------------------------------------------------
class SceneObject:
    """Base class: an object with a body frame posed by ``R`` (body → world), ``center`` and a
    :class:`RigidMotion`. Subclasses implement :meth:`intersect_body` in body coordinates
    (or override :meth:`intersect`) and :meth:`bounding_sphere_body`.
    """

    albedo: float = 1.0
    texture = None
    motion: RigidMotion = STATIC
    R: np.ndarray = np.eye(3)
    center: np.ndarray = np.zeros(3)

    # -- pose ------------------------------------------------------------------------------
    def pose(self, time: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Body → world pose at ``time``: ``X_world = R(t) @ x_body + c(t)``; returns (R, c)."""
        return self.motion.rotation(time) @ self.R, self.center + self.motion.offset(time)

    def to_world(self, x_body, time: float = 0.0) -> np.ndarray:
        R, c = self.pose(time)
        return np.asarray(x_body, float) @ R.T + c

    def to_body(self, X, time: float = 0.0) -> np.ndarray:
        R, c = self.pose(time)
        return (np.asarray(X, float) - c) @ R

    @property
    def moving(self) -> bool:
        return not self.motion.is_static

    def bounding_sphere(self, time: float = 0.0) -> tuple[np.ndarray, float]:
        """World (centre (3,), radius) enclosing the object (radius ``inf`` if unbounded)."""
        cb, r = self.bounding_sphere_body()
        return self.to_world(cb, time), r

    def bounding_sphere_body(self) -> tuple[np.ndarray, float]:
        raise NotImplementedError

    # -- ray casting -----------------------------------------------------------------------
    def intersect(self, origins, dirs, time: float = 0.0) -> Hit:
        """Cast rays at ``time``; see the module docstring for shapes and conventions."""
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        t, nb, uv = self.intersect_body(rigid_to_body(o, R, c), rigid_to_body(d, R))
        return self._finish(t, rigid_to_body(nb, R.T), uv, d)

    def intersect_body(self, o, d):
        """Body-frame cast: returns (t (N,), body normal (N, 3), material uv (N, 2))."""
        raise NotImplementedError

    def hit_distance(self, origins, dirs, time: float = 0.0) -> np.ndarray:
        """Ray parameter (N,) of each ray's first hit, ``inf`` where it misses (shadow rays);
        equal to ``intersect(...).t``. Subclasses may override it with a cheaper cast."""
        h = self.intersect(origins, dirs, time)
        return np.where(h.object_id >= 0, h.t, np.inf)

    def albedo_at(self, uv: np.ndarray) -> np.ndarray:
        """Albedo (M,) at material coordinates (M, 2): base albedo × texture factor."""
        a = np.full(len(uv), self.albedo)
        if self.texture is not None and len(uv):
            a *= np.clip(self.texture(uv), 0.0, 1.0)
        return a

    def _finish(self, t, normal, uv, d, reuse: bool = False) -> Hit:
        """Assemble a Hit: misses get the miss values, normals are unit and face the ray.

        ``reuse=True`` lets the Hit take over ``t``, ``normal`` and ``uv`` (fresh float64
        arrays the caller will not use again) instead of copying them."""
        n = len(d)
        t = np.ascontiguousarray(t, dtype=np.float64)
        normal = np.ascontiguousarray(normal, dtype=np.float64)
        uv = np.full((n, 2), np.nan) if uv is None else np.ascontiguousarray(uv, dtype=np.float64)
        if reuse:
            t_out, n_out, uv_out = t, normal, uv
        else:
            t_out, n_out, uv_out = np.empty(n), np.empty((n, 3)), np.empty((n, 2))
        oid = np.empty(n, np.int32)
        hit = np.empty(n, np.bool_)
        count = _finish_kernel(t, normal, d, uv, t_out, n_out, oid, uv_out, hit)
        h = Hit(t=t_out, normal=n_out, object_id=oid, albedo=np.zeros(n), material_uv=uv_out)
        if count and self.texture is None and type(self).albedo_at is SceneObject.albedo_at:
            np.copyto(h.albedo, self.albedo, where=hit)  # untextured: the base albedo everywhere
        elif count:
            idx = np.flatnonzero(hit)
            h.albedo[idx] = self.albedo_at(h.material_uv[idx])
        return h

    def describe(self) -> str:
        return type(self).__name__

    def _style_dict(self, motion: bool = True) -> dict:
        """Scene-file fields shared by most objects: albedo, texture and (non-static) motion."""
        d = {"albedo": self.albedo}
        if self.texture is not None:
            if not hasattr(self.texture, "to_dict"):
                raise ValueError(f"{self.describe()}: its texture {self.texture!r} cannot be saved to a scene file")
            d["texture"] = self.texture.to_dict()
        if motion and not self.motion.is_static:
            d["motion"] = self.motion.to_dict()
        return d

    def to_dict(self) -> dict:
        """Scene-file entry (see :mod:`fringe3d.sim.scene_file`)."""
        raise ValueError(f"{self.describe()} cannot be saved to a scene file")


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
    n = _vec3(normal, "normal")
    if np.linalg.norm(n) == 0:
        raise ValueError("plane normal must be non-zero")
    n = n / np.linalg.norm(n)
    if u_axis is None:
        u_axis = np.eye(3)[np.argmin(np.abs(n))]
    e1 = _vec3(u_axis, "u_axis")
    e1 = e1 - (e1 @ n) * n
    if np.linalg.norm(e1) < 1e-9:
        raise ValueError("u_axis must not be parallel to the plane normal")
    e1 /= np.linalg.norm(e1)
    return n, e1, np.cross(n, e1)


# --------------------------------------------------------------------------------------------
# Primitives
# --------------------------------------------------------------------------------------------
class Plane(SceneObject):
    """A plane through ``point`` with ``normal``, optionally a finite rectangle.

    Material coordinates ``uv`` (mm) are measured from ``point`` along ``e1`` (``u_axis``
    projected into the plane) and ``e2 = n × e1``. ``size=(width, height)`` (mm) bounds the
    plane to ``|u| <= width/2, |v| <= height/2``; ``None`` means infinite.
    """

    def __init__(self, point, normal, albedo=1.0, texture=None, u_axis=None, size=None,
                 motion: RigidMotion = STATIC):
        self.point = _vec3(point, "point")
        self.normal, self.e1, self.e2 = plane_axes(normal, u_axis)
        self.albedo = _albedo(albedo)
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


class Sphere(SceneObject):
    """Sphere of ``radius`` (mm) about ``center``; may move (``velocity``, ``acceleration``) and
    spin (``spin`` rad/s) — the texture turns with it.

    Material coordinates are body-frame (longitude, latitude) in radians: longitude
    ``atan2(y_b, x_b)`` in (-π, π], latitude ``asin(z_b / r)``.
    """

    def __init__(self, center, radius, albedo=1.0, texture=None, velocity=(0.0, 0.0, 0.0),
                 acceleration=(0.0, 0.0, 0.0), spin=(0.0, 0.0, 0.0), t0: float = 0.0, R=None,
                 motion: RigidMotion | None = None):
        self.center = _vec3(center, "center")
        self.radius = float(radius)
        if not self.radius > 0:
            raise ValueError(f"sphere radius must be > 0 mm, got {radius}")
        self.albedo = _albedo(albedo)
        self.texture = texture
        self.R = np.eye(3) if R is None else _rotation(R)
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


class Box(SceneObject):
    """Rectangular block of ``size = (sx, sy, sz)`` mm centred at ``center``, rotated by ``R``
    (body → world, matrix or rotation vector). Material ``uv`` are body ``(x, y)`` (mm)."""

    def __init__(self, center, size, R=None, albedo=1.0, texture=None,
                 motion: RigidMotion = STATIC):
        self.center = _vec3(center, "center")
        self.size = np.asarray(size, float).ravel()
        if self.size.shape != (3,) or np.any(self.size <= 0):
            raise ValueError(f"box size must be three positive lengths (mm), got {size}")
        self.R = np.eye(3) if R is None else _rotation(R)
        self.albedo = _albedo(albedo)
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


# --------------------------------------------------------------------------------------------
# Scene container
# --------------------------------------------------------------------------------------------
class Scene:
    """A list of objects; :meth:`intersect` keeps the nearest hit and sets ``object_id`` to the
    object's index in ``objects``. ``ambient`` (in [0, 1]) is the scene's ambient light level
    relative to the projector's full white, for the renderer."""

    def __init__(self, objects, ambient: float = 0.0, name: str = "scene"):
        self.objects = list(objects)
        if not self.objects:
            raise ValueError("a scene needs at least one object")
        for i, ob in enumerate(self.objects):
            if not hasattr(ob, "intersect"):
                raise ValueError(f"scene object {i} ({type(ob).__name__}) has no intersect method")
        self.ambient = _albedo(ambient, "ambient")
        self.name = name

    def __len__(self):
        return len(self.objects)

    def __getitem__(self, i):
        return self.objects[i]

    @property
    def moving(self) -> bool:
        """True if any object moves or deforms over time (render each frame at its time)."""
        return any(getattr(ob, "moving", False) for ob in self.objects)

    def to_dict(self) -> dict:
        """The scene as a scene-file dictionary (:func:`fringe3d.sim.scene_file.save_scene`)."""
        return {"format": "fringe3d-scene", "version": 1, "name": self.name, "ambient": self.ambient,
                "objects": [ob.to_dict() for ob in self.objects]}

    def intersect(self, origins, dirs, time: float = 0.0) -> Hit:
        o, d = as_rays(origins, dirs)
        best = None
        for i, ob in enumerate(self.objects):
            h = ob.intersect(o, d, time)
            if best is None and _is_fresh_hit(h, len(d)):
                best = h  # the first object's own record, relabelled (object 0): no copy
                best.object_id[best.object_id >= 0] = 0
                continue
            if best is None:
                best = Hit.miss(len(d))
            best.merge_nearer(h, i)
        return best

    def truth_fields(self, points, hit: Hit, time: float = 0.0) -> dict:
        """Extra per-ray ground truth from objects that provide ``truth_fields(uv, time)`` (the
        wing: curvature, principal curvature/direction, bending strain). Returns
        ``{name: (N, ...) float32}`` with NaN on rays that hit other objects or nothing; ``{}``
        when no object provides extra truth."""
        n = len(hit)
        out: dict = {}
        for i, ob in enumerate(self.objects):
            fn = getattr(ob, "truth_fields", None)
            if not callable(fn):
                continue
            rows = np.flatnonzero(hit.object_id == i)
            fields = fn(hit.material_uv[rows], time) if rows.size else fn(np.zeros((1, 2)), time)
            for name, val in fields.items():
                if name not in out:
                    out[name] = np.full((n,) + np.shape(val)[1:], np.nan, np.float32)
                if rows.size:
                    out[name][rows] = val
        return out


def _is_fresh_hit(h, n: int) -> bool:
    """Whether ``h`` is a :class:`Hit` of ``n`` rays with writable arrays of the merge kernel's
    dtypes (so :meth:`Scene.intersect` can keep it as its running nearest hit)."""
    if not isinstance(h, Hit):
        return False
    want = ((h.t, np.float64, (n,)), (h.normal, np.float64, (n, 3)), (h.object_id, np.int32, (n,)),
            (h.albedo, np.float64, (n,)), (h.material_uv, np.float64, (n, 2)))
    return all(isinstance(a, np.ndarray) and a.dtype == dt and a.shape == sh and a.flags.writeable
               and a.flags.c_contiguous and a.base is None for a, dt, sh in want)


def named_scene(name: str, preset) -> "Scene":
    """Scenes built inside a preset's working volume: see :mod:`fringe3d.sim.catalog`."""
    from .catalog import named_scene as build
    return build(name, preset)
