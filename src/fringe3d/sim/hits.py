"""The hit record of a ray cast and the nearest-hit merge (the bottom of the simulator's geometry).

Rays are ``origins``: ``(3,)`` one shared origin (pinhole camera/projector) or ``(N, 3)`` one per
ray (telecentric camera), mm, world frame; ``dirs``: ``(N, 3)`` directions (need not be unit
length). The hit point is ``X = origin + t * dir`` for the smallest ``t > T_MIN``.

A :class:`Hit` holds, per ray, ``t``, the unit normal turned to face the ray
(``normal · dir <= 0``), the index of the object hit, its albedo and material coordinates.
Misses have ``t = inf``, ``object_id = -1``, ``normal = NaN``, ``albedo = 0`` and
``material_uv = NaN``. Merging keeps, per ray, the nearer of two records.

>>> h = Hit.miss(2)
>>> h.mask.tolist(), h.t.tolist()
([False, False], [inf, inf])
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

T_MIN = 1e-9  # smallest accepted ray parameter (avoids self-hits at the origin)


@dataclass(eq=False)
class Hit:
    """Result of casting ``N`` rays.

    Attributes
    ----------
    t : (N,) float64 ray parameter (``inf`` where missed).
    normal : (N, 3) float64 unit normal facing the ray (NaN where missed).
    object_id : (N,) int32, index of the object in its :class:`~fringe3d.sim.scene.Scene`
        (-1 where missed).
    albedo : (N,) float64 in [0, 1], base albedo × texture (0 where missed).
    material_uv : (N, 2) float64 material coordinates (mm, or rad on spheres); NaN if none.
    """

    t: np.ndarray
    normal: np.ndarray
    object_id: np.ndarray
    albedo: np.ndarray
    material_uv: np.ndarray

    @classmethod
    def miss(cls, n: int) -> Hit:
        """A record of ``n`` rays that hit nothing."""
        return cls(t=np.full(n, np.inf), normal=np.full((n, 3), np.nan),
                   object_id=np.full(n, -1, np.int32), albedo=np.zeros(n),
                   material_uv=np.full((n, 2), np.nan))

    def __len__(self) -> int:
        return len(self.t)

    @property
    def mask(self) -> np.ndarray:
        """(N,) bool, True where a ray hit something."""
        return self.object_id >= 0

    def points(self, origins: np.ndarray, dirs: np.ndarray) -> np.ndarray:
        """World hit points ``origin + t * dir`` (N, 3); NaN where missed."""
        o, d = as_rays(origins, dirs)
        t = np.where(self.mask, self.t, np.nan)
        return o + t[:, None] * d

    def take(self, other: Hit, where: np.ndarray) -> None:
        """Overwrite rows ``where`` (bool (N,)) with those of ``other`` (in place)."""
        _take_kernel(where, self.t, self.normal, self.object_id, self.albedo, self.material_uv,
                     other.t, other.normal, other.object_id, other.albedo, other.material_uv)

    def merge_nearer(self, other: Hit, object_id: int) -> None:
        """Keep, per ray, the nearer of ``self`` and ``other`` (in place); rows taken from
        ``other`` get ``object_id``."""
        _merge_kernel(self.t, self.normal, self.object_id, self.albedo, self.material_uv,
                      other.t, other.normal, other.object_id, other.albedo, other.material_uv,
                      np.int32(object_id))

    def merge_nearer_rows(self, rows: np.ndarray, other: Hit, object_id: int) -> None:
        """Like :meth:`merge_nearer` for a subset: ray ``rows[r]`` takes row ``r`` of ``other``
        (a record of ``len(rows)`` rays) when that is a hit nearer than its current one."""
        uv = other.material_uv if other.material_uv is not None else np.full((rows.size, 2), np.nan)
        _merge_rows_kernel(rows, self.t, self.normal, self.object_id, self.albedo, self.material_uv,
                           np.ascontiguousarray(other.t, dtype=np.float64),
                           np.ascontiguousarray(other.normal, dtype=np.float64),
                           np.ascontiguousarray(other.object_id),
                           np.ascontiguousarray(other.albedo, dtype=np.float64),
                           np.ascontiguousarray(uv, dtype=np.float64), np.int32(object_id))


@numba.njit(cache=True, inline="always")
def copy_hit_row(i, j, t, n, alb, uv, t2, n2, alb2, uv2):  # pragma: no cover - compiled
    """Row ``i`` of a hit record (t, normal, albedo, material uv) takes row ``j`` of another;
    the caller sets the object id."""
    t[i] = t2[j]
    alb[i] = alb2[j]
    for k in range(3):
        n[i, k] = n2[j, k]
    uv[i, 0] = uv2[j, 0]
    uv[i, 1] = uv2[j, 1]


@numba.njit(cache=True)
def _take_kernel(where, t, n, oid, alb, uv, t2, n2, oid2, alb2, uv2):  # pragma: no cover - compiled
    for i in range(t.shape[0]):
        if where[i]:
            copy_hit_row(i, i, t, n, alb, uv, t2, n2, alb2, uv2)
            oid[i] = oid2[i]


@numba.njit(cache=True)
def _merge_kernel(t, n, oid, alb, uv, t2, n2, oid2, alb2, uv2, new_id):  # pragma: no cover - compiled
    for i in range(t.shape[0]):
        if oid2[i] >= 0 and t2[i] < t[i]:
            copy_hit_row(i, i, t, n, alb, uv, t2, n2, alb2, uv2)
            oid[i] = new_id


@numba.njit(cache=True)
def _merge_rows_kernel(rows, t, n, oid, alb, uv, t2, n2, oid2, alb2, uv2, new_id):  # pragma: no cover
    for r in range(rows.shape[0]):
        i = rows[r]
        if oid2[r] >= 0 and t2[r] < t[i]:
            copy_hit_row(i, r, t, n, alb, uv, t2, n2, alb2, uv2)
            oid[i] = new_id


def as_rays(origins: np.ndarray, dirs: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
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


def is_fresh_hit(h: object, n: int) -> bool:
    """Whether ``h`` is a :class:`Hit` of ``n`` rays with writable arrays of the merge kernel's
    dtypes, owning its data (so a scene can keep it as its running nearest hit, no copy)."""
    if not isinstance(h, Hit):
        return False
    want = ((h.t, np.float64, (n,)), (h.normal, np.float64, (n, 3)), (h.object_id, np.int32, (n,)),
            (h.albedo, np.float64, (n,)), (h.material_uv, np.float64, (n, 2)))
    return all(isinstance(a, np.ndarray) and a.dtype == dt and a.shape == sh and a.flags.writeable
               and a.flags.c_contiguous and a.base is None for a, dt, sh in want)
