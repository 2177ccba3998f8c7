"""The scene-object protocol, the posed base class every simulator object derives from, and the
checks of their parameters.

:class:`SceneObject` names what the renderer, the scene container, the pre-flight checks and the
scene files need of an object: a ray cast ``intersect(origins, dirs, time) -> Hit`` (shapes and
conventions in :mod:`fringe3d.sim.hits`), a cheaper distance-only cast for shadow rays, a
conservative culling volume, a bounding sphere, whether it moves, a description and a scene-file
entry. :class:`PosedObject` supplies all of them for an object with a body frame posed by ``R``
(body → world), ``center`` and a :class:`~fringe3d.sim.motion.RigidMotion`; a subclass only
casts rays in its body frame (:meth:`PosedObject.intersect_body`) and gives its bounding sphere.

Two optional capabilities are separate protocols, checked with ``isinstance``:
:class:`SupportsTruthFields` (extra per-pixel ground truth, the flapping wing) and
:class:`SupportsCircleCentres` (true circle centres of a calibration board).
"""
from __future__ import annotations

from typing import NamedTuple, Protocol, runtime_checkable

import numba
import numpy as np

from .hits import Hit, as_rays
from .motion import STATIC, RigidMotion, rotation_vector_to_matrix
from .specular import check_gloss


class CullingVolume(NamedTuple):
    """A conservative volume around an object: rays that miss it miss the object.

    ``radius > 0``: the sphere of that radius about ``center`` (``R``, ``lo``, ``hi`` unused);
    ``radius < 0``: the body-frame box ``lo..hi`` (mm) posed by ``R`` (body → world) about
    ``center``.
    """

    center: np.ndarray
    radius: float
    R: np.ndarray
    lo: np.ndarray
    hi: np.ndarray


@runtime_checkable
class SceneObject(Protocol):
    """What the simulator needs of an object in a :class:`~fringe3d.sim.scene.Scene`."""

    @property
    def moving(self) -> bool:
        """True if the object moves or deforms over time."""

    def intersect(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> Hit:
        """Cast rays ``origins`` (3,) or (N, 3), ``dirs`` (N, 3) at ``time`` (s)."""

    def hit_distance(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> np.ndarray:
        """Ray parameter (N,) of each first hit, ``inf`` where a ray misses (``intersect(...).t``)."""

    def culling_volume(self, time: float = 0.0) -> CullingVolume | None:
        """A conservative volume at ``time``, or None (unbounded: cast every ray)."""

    def bounding_sphere(self, time: float = 0.0) -> tuple[np.ndarray, float]:
        """World (centre (3,), radius) enclosing the object (radius ``inf`` if unbounded)."""

    def describe(self) -> str:
        """A short human-readable label."""

    def to_dict(self) -> dict:
        """The object's scene-file entry (:mod:`fringe3d.sim.scene_file`)."""


@runtime_checkable
class SupportsTruthFields(Protocol):
    """An object that knows scene-specific per-point truth (the wing: curvature, strain)."""

    def truth_fields(self, uv: np.ndarray, time: float = 0.0) -> dict:
        """``{name: (M, ...)}`` at material coordinates ``uv`` (M, 2) and ``time``."""


@runtime_checkable
class SupportsCircleCentres(Protocol):
    """An object carrying circles whose true centres are ground truth (a calibration board)."""

    def circle_centers(self, time: float = 0.0) -> np.ndarray:
        """World circle centres (M, 3) mm at ``time``."""


@runtime_checkable
class Texture(Protocol):
    """Albedo factor in [0, 1] at material coordinates, storable in scene files
    (:mod:`fringe3d.sim.textures`)."""

    def __call__(self, uv: np.ndarray) -> np.ndarray: ...

    def to_dict(self) -> dict: ...


# -------------------------------------------------------------------------- parameter checks
def check_vec3(v, name: str) -> np.ndarray:
    """``v`` as a finite float (3,) vector; raises ``ValueError`` naming ``name``."""
    v = np.asarray(v, float).ravel()
    if v.shape != (3,) or not np.all(np.isfinite(v)):
        raise ValueError(f"{name} must be a finite 3-vector, got {np.asarray(v).tolist()}")
    return v


def check_albedo(a, name: str = "albedo") -> float:
    """``a`` as a float in [0, 1]; raises ``ValueError`` naming ``name``."""
    a = float(a)
    if not 0.0 <= a <= 1.0:
        raise ValueError(f"{name} must be in [0, 1], got {a}")
    return a


def check_rotation(R, name: str = "R") -> np.ndarray:
    """A (3, 3) rotation matrix from a matrix or a rotation vector (3,) rad."""
    R = np.asarray(R, float)
    if R.shape == (3,):  # rotation vector
        return rotation_vector_to_matrix(R)
    if R.shape != (3, 3) or not np.allclose(R @ R.T, np.eye(3), atol=1e-9) or np.linalg.det(R) < 0:
        raise ValueError(f"{name} must be a (3, 3) rotation matrix or a rotation vector (3,)")
    return R


# -------------------------------------------------------------------------- body frames
@numba.njit(cache=True)
def _rigid_to_body(x, R, c, out):  # pragma: no cover - compiled
    """out = (x - c) @ R for rows of x (N, 3); c may be zeros (directions)."""
    for i in range(x.shape[0]):
        a = x[i, 0] - c[0]
        b = x[i, 1] - c[1]
        e = x[i, 2] - c[2]
        for k in range(3):
            out[i, k] = a * R[0, k] + b * R[1, k] + e * R[2, k]


def rigid_to_body(x: np.ndarray, R: np.ndarray, c: np.ndarray | None = None) -> np.ndarray:
    """Rows ``(x - c) @ R`` (N, 3): world points (or directions with ``c=None``) into a body
    frame whose pose is ``X = R @ x_body + c``."""
    out = np.empty_like(x)
    _rigid_to_body(x, np.ascontiguousarray(R), np.zeros(3) if c is None else np.asarray(c, float), out)
    return out


@numba.njit(cache=True)
def _finish_kernel(t, n, d, uv, t_out, n_out, id_out, uv_out, hit):  # pragma: no cover - compiled
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


class PosedObject:
    """Base class of the simulator's objects: a body frame posed by ``R`` (body → world),
    ``center`` and a :class:`RigidMotion`, with an albedo and an optional texture.

    Implements the :class:`SceneObject` protocol. Subclasses implement :meth:`intersect_body`
    in body coordinates (or override :meth:`intersect`) and :meth:`bounding_sphere_body`.
    """

    albedo: float = 1.0
    texture: Texture | None = None
    specular: float = 0.0    # glossy lobe weight k_s (:mod:`fringe3d.sim.specular`); 0 = matte
    roughness: float = 1.0   # lobe roughness alpha in [0.02, 1]
    motion: RigidMotion = STATIC
    R: np.ndarray = np.eye(3)
    center: np.ndarray = np.zeros(3)

    def set_gloss(self, specular: float, roughness: float):
        """Make the object glossy: specular weight ``k_s`` >= 0 and roughness ``alpha`` in
        [0.02, 1] of the Blinn-Phong lobe (:mod:`fringe3d.sim.specular`); returns the object."""
        self.specular, self.roughness = check_gloss(specular, roughness)
        return self

    # -- pose ------------------------------------------------------------------------------
    def pose(self, time: float = 0.0) -> tuple[np.ndarray, np.ndarray]:
        """Body → world pose at ``time``: ``X_world = R(t) @ x_body + c(t)``; returns (R, c)."""
        return self.motion.rotation(time) @ self.R, self.center + self.motion.offset(time)

    def to_world(self, x_body, time: float = 0.0) -> np.ndarray:
        """World points (M, 3) of body points ``x_body`` (M, 3) at ``time``."""
        R, c = self.pose(time)
        return np.asarray(x_body, float) @ R.T + c

    def to_body(self, X, time: float = 0.0) -> np.ndarray:
        """Body points (M, 3) of world points ``X`` (M, 3) at ``time``."""
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
        """Body-frame (centre (3,), radius) enclosing the object."""
        raise NotImplementedError

    def culling_volume(self, time: float = 0.0) -> CullingVolume | None:
        """The bounding sphere, padded by a relative 1e-9 (None when unbounded)."""
        c, r = self.bounding_sphere(time)
        if not np.isfinite(r):
            return None
        return CullingVolume(np.asarray(c, float), float(r) * (1 + 1e-9) + 1e-9, np.eye(3), np.zeros(3),
                             np.zeros(3))

    # -- ray casting -----------------------------------------------------------------------
    def intersect(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> Hit:
        """Cast rays at ``time``; see :mod:`fringe3d.sim.hits` for shapes and conventions."""
        o, d = as_rays(origins, dirs)
        R, c = self.pose(time)
        t, nb, uv = self.intersect_body(rigid_to_body(o, R, c), rigid_to_body(d, R))
        return self._finish(t, rigid_to_body(nb, R.T), uv, d)

    def intersect_body(self, o: np.ndarray, d: np.ndarray) -> tuple[np.ndarray, np.ndarray, np.ndarray]:
        """Body-frame cast: returns (t (N,), body normal (N, 3), material uv (N, 2))."""
        raise NotImplementedError

    def hit_distance(self, origins: np.ndarray, dirs: np.ndarray, time: float = 0.0) -> np.ndarray:
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
        if count and self.texture is None and type(self).albedo_at is PosedObject.albedo_at:
            np.copyto(h.albedo, self.albedo, where=hit)  # untextured: the base albedo everywhere
        elif count:
            idx = np.flatnonzero(hit)
            h.albedo[idx] = self.albedo_at(h.material_uv[idx])
        return h

    # -- description and scene files -------------------------------------------------------
    def describe(self) -> str:
        return type(self).__name__

    def _style_dict(self, motion: bool = True) -> dict:
        """Scene-file fields shared by most objects: albedo, texture and (non-static) motion."""
        d: dict = {"albedo": self.albedo}
        if self.texture is not None:
            if not isinstance(self.texture, Texture):
                raise ValueError(f"{self.describe()}: its texture {self.texture!r} cannot be saved to a scene file")
            d["texture"] = self.texture.to_dict()
        if self.specular > 0:
            d["specular"], d["roughness"] = self.specular, self.roughness
        if motion and not self.motion.is_static:
            d["motion"] = self.motion.to_dict()
        return d

    def to_dict(self) -> dict:
        """Scene-file entry (see :mod:`fringe3d.sim.scene_file`)."""
        raise ValueError(f"{self.describe()} cannot be saved to a scene file")
