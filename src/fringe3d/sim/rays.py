"""Rays and shadows: the camera's pixel rays, scene casts culled per object, and the shadow test.

* :func:`camera_rays`: every pixel's ray (pinhole: through the centre; telecentric: parallel
  rays started :data:`TELECENTRIC_BACKOFF` mm back), cached for the last few cameras;
* :func:`intersect_culled`: ``scene.intersect`` with each object cast only on the rays that pass
  its :class:`~fringe3d.sim.scene_object.CullingVolume`;
* :func:`shadow_rays` and :func:`occluded`: rays from lit surface points toward the projector
  centre, and whether something blocks them (distance-only casts, ``hit_distance``).
"""
from __future__ import annotations

import numba
import numpy as np

from fringe3d.optics import PinholeDevice, TelecentricCamera

from .hits import Hit
from .scene import Scene
from .scene_object import CullingVolume

#: Rays of a telecentric camera start this far (mm) before their min-norm origin.
TELECENTRIC_BACKOFF = 1.0e4

Camera = PinholeDevice | TelecentricCamera

#: ``[(camera, margin, rays)]``, most recent last (cameras are frozen dataclasses, compared by identity).
_RAY_CACHE: list[tuple[Camera, int, tuple[np.ndarray, np.ndarray, float]]] = []


def camera_rays(camera: Camera, margin: int = 0) -> tuple[np.ndarray, np.ndarray, float]:
    """All pixel rays of ``camera`` (cached for the last few cameras; treat as read-only); with
    ``margin`` the grid extends ``margin`` pixels beyond the sensor on every side
    (``(H + 2 margin) * (W + 2 margin)`` rays, row-major from pixel ``(-margin, -margin)``)."""
    for cam, m, rays in _RAY_CACHE:
        if cam is camera and m == margin:
            return rays
    rays = _camera_rays(camera, margin)
    _RAY_CACHE.append((camera, margin, rays))
    del _RAY_CACHE[:-3]
    return rays


def _camera_rays(camera: Camera, margin: int = 0) -> tuple[np.ndarray, np.ndarray, float]:
    """All pixel rays of ``camera``: ``(origins (1 or N, 3), unit dirs (N, 3), depth_offset)``.

    Pinhole: one shared origin, the optical centre; depth is the camera-frame z.
    Telecentric: parallel rays starting :data:`TELECENTRIC_BACKOFF` mm before their
    min-norm origin; ``depth_offset`` is subtracted from the ray parameter to give depth.
    """
    uv = camera.pixel_grid()
    if margin:
        v, u = np.mgrid[-margin:camera.height + margin, -margin:camera.width + margin].astype(float)
        uv = np.stack([u, v], axis=-1)
    uv = uv.reshape(-1, 2)
    if camera.kind == "telecentric":
        origins, d = camera.rays(uv)
        d = np.asarray(d, float) / np.linalg.norm(d)
        origins = origins - TELECENTRIC_BACKOFF * d
        return np.ascontiguousarray(origins), np.ascontiguousarray(np.broadcast_to(d, origins.shape)), \
            TELECENTRIC_BACKOFF
    c, dirs = camera.rays(uv, normalize=True)
    return np.asarray(c, float).reshape(1, 3), np.ascontiguousarray(dirs), 0.0


@numba.njit(cache=True)
def _rays_near(o, d, centers, radii, boxR, lo, hi, out):  # pragma: no cover - compiled
    """out[i] = ray i may hit some object: it passes within the object's bounding sphere
    (``radii[k] > 0``) or through its oriented bounding box (``radii[k] < 0``: body-frame
    box ``lo..hi`` posed by ``boxR[k]`` (body -> world) about ``centers[k]``; rays missing
    the box's circumscribed sphere are rejected before the slab test)."""
    shared = o.shape[0] == 1
    nk = centers.shape[0]
    bc = np.empty((nk, 3))  # world centre and squared radius of each box's circumscribed sphere
    br2 = np.empty(nk)
    for k in range(nk):
        m0, m1, m2 = 0.5 * (lo[k, 0] + hi[k, 0]), 0.5 * (lo[k, 1] + hi[k, 1]), 0.5 * (lo[k, 2] + hi[k, 2])
        for a in range(3):
            bc[k, a] = centers[k, a] + boxR[k, a, 0] * m0 + boxR[k, a, 1] * m1 + boxR[k, a, 2] * m2
        h0, h1, h2 = hi[k, 0] - lo[k, 0], hi[k, 1] - lo[k, 1], hi[k, 2] - lo[k, 2]
        rad = 0.5 * np.sqrt(h0 * h0 + h1 * h1 + h2 * h2) * (1 + 1e-9) + 1e-9
        br2[k] = rad * rad
    for i in range(d.shape[0]):
        oi = 0 if shared else i
        hit = False
        for k in range(centers.shape[0]):
            w0 = centers[k, 0] - o[oi, 0]
            w1 = centers[k, 1] - o[oi, 1]
            w2 = centers[k, 2] - o[oi, 2]
            if radii[k] > 0:
                along = w0 * d[i, 0] + w1 * d[i, 1] + w2 * d[i, 2]
                dd = d[i, 0] * d[i, 0] + d[i, 1] * d[i, 1] + d[i, 2] * d[i, 2]
                r2 = w0 * w0 + w1 * w1 + w2 * w2 - along * along / dd
                rr = radii[k] * radii[k]
                if r2 <= rr and (along > 0 or w0 * w0 + w1 * w1 + w2 * w2 <= rr):
                    hit = True
                    break
                continue
            s0 = bc[k, 0] - o[oi, 0]
            s1 = bc[k, 1] - o[oi, 1]
            s2 = bc[k, 2] - o[oi, 2]
            ss = s0 * s0 + s1 * s1 + s2 * s2
            along = s0 * d[i, 0] + s1 * d[i, 1] + s2 * d[i, 2]
            dd = d[i, 0] * d[i, 0] + d[i, 1] * d[i, 1] + d[i, 2] * d[i, 2]
            if ss - along * along / dd > br2[k] or (along <= 0 and ss > br2[k]):
                continue  # misses the circumscribed sphere, so the box too
            tmin = 0.0
            tmax = np.inf
            for a in range(3):  # slab test in the body frame
                ob = -(boxR[k, 0, a] * w0 + boxR[k, 1, a] * w1 + boxR[k, 2, a] * w2)
                db = boxR[k, 0, a] * d[i, 0] + boxR[k, 1, a] * d[i, 1] + boxR[k, 2, a] * d[i, 2]
                if abs(db) < 1e-300:
                    if ob < lo[k, a] or ob > hi[k, a]:
                        tmax = -1.0
                    continue
                t1 = (lo[k, a] - ob) / db
                t2 = (hi[k, a] - ob) / db
                if t1 > t2:
                    t1, t2 = t2, t1
                tmin = max(tmin, t1)
                tmax = min(tmax, t2)
            if tmax >= tmin:
                hit = True
                break
        out[i] = hit
    return out


def near_rows(origins: np.ndarray, dirs: np.ndarray, volume: CullingVolume | None) -> np.ndarray | None:
    """Rows (M,) of the rays that may hit an object with culling ``volume``; None when there is
    no volume or most rays pass it (cast them all)."""
    if volume is None:
        return None
    c, r, R, lo, hi = volume
    near = _rays_near(origins, dirs, c[None], np.array([r]), R[None], lo[None], hi[None],
                      np.empty(dirs.shape[0], np.bool_))
    idx = np.flatnonzero(near)
    return None if idx.size > 0.8 * dirs.shape[0] else idx


def intersect_culled(scene: Scene, origins: np.ndarray, dirs: np.ndarray, time: float) -> Hit:
    """``scene.intersect`` with each object cast only on the rays that may hit it.

    Culling volumes (``culling_volume(time)``): oriented bounding boxes for meshes, bounding
    spheres for the rest; unbounded objects (an infinite plane) get every ray. ``origins`` is
    (1, 3) (shared) or (N, 3), ``dirs`` (N, 3). Returns a Hit with full-length ``t, normal,
    object_id, albedo, material_uv``, equal to ``scene.intersect`` (the volumes are conservative).
    """
    ray_o = origins[0] if origins.shape[0] == 1 else origins
    volumes = [ob.culling_volume(time) for ob in scene.objects]
    if all(v is None for v in volumes):
        return scene.intersect(ray_o, dirs, time=time)
    n = dirs.shape[0]
    best = Hit.miss(n)
    for i, (ob, v) in enumerate(zip(scene.objects, volumes)):
        rows = near_rows(origins, dirs, v)
        if rows is None:
            best.merge_nearer(ob.intersect(ray_o, dirs, time), i)
        elif rows.size:
            sub = ob.intersect(ray_o if origins.shape[0] == 1 else origins[rows], dirs[rows], time)
            best.merge_nearer_rows(rows, sub, i)
    return best


@numba.njit(cache=True)
def shadow_rays(inside, pts, normal, L, dist, idx, o, d, tmax):  # pragma: no cover - compiled
    """Shadow rays of the pixels ``inside`` marks: pixel index, origin (the hit point nudged
    by ``1e-6 * dist + 1e-9`` mm along normal + L, off its own surface), unit direction L to
    the projector centre, and the blocking range ``t < dist * (1 - 1e-6)``."""
    m = 0
    for i in range(inside.shape[0]):
        if not inside[i]:
            continue
        eps = 1e-6 * dist[i] + 1e-9
        for k in range(3):
            o[m, k] = pts[i, k] + eps * (normal[i, k] + L[i, k])
            d[m, k] = L[i, k]
        tmax[m] = dist[i] * (1 - 1e-6)
        idx[m] = i
        m += 1


def occluded(scene: Scene, origins: np.ndarray, dirs: np.ndarray, tmax: np.ndarray, time: float) -> np.ndarray:
    """bool (M,): something in ``scene`` lies on ray ``m`` before ``tmax[m]`` (its first hit
    has ``t < tmax``), for shadow rays ``origins`` (M, 3), ``dirs`` (M, 3).

    Each object is asked for its first-hit distance only (``hit_distance``: no normals,
    material coordinates or albedo) on the rays near its culling volume.
    """
    blocked = np.zeros(len(dirs), np.bool_)
    for ob in scene.objects:  # each object on the rays near its culling volume only
        rows = near_rows(origins, dirs, ob.culling_volume(time))
        if rows is not None and not rows.size:
            continue
        o, d = (origins, dirs) if rows is None else (origins[rows], dirs[rows])
        t = ob.hit_distance(o, d, time)
        if rows is None:
            blocked |= t < tmax
        else:
            blocked[rows] |= t < tmax[rows]
    return blocked
