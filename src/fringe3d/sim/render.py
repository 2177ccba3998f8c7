"""The virtual rig's renderer: scene + rig + pattern set -> camera frames and ground truth.

Per frame, at its own timestamp ``k / frame_rate`` (s):

1. cast each camera pixel's ray (pinhole: through the centre; telecentric: parallel rays) and
   take the first surface hit (``scene.intersect``);
2. project the hit into the projector, ``(u_p, v_p) = projector.project(X)`` (Eq. 2.8-2.18);
3. look up the pattern value there: analytically (``sinusoid_value``, ``ideal`` mode) or by
   bilinear sampling of the projector image (``render_frame``) blurred by the defocus OTF
   (Eq. 2.22-2.26, optionally growing with distance from the focal plane);
4. shade: projector gamma, Lambertian cosine toward the projector centre, projector shadow
   (a shadow ray toward the projector centre), ambient light, albedo / texture, exposure and
   gain (see :mod:`fringe3d.sim.settings`);
5. sense: camera blur, shot and read noise, quantisation (:mod:`fringe3d.sim.noise`).

A static scene is cast once and reused for every frame; a moving scene is re-cast per frame
(and per motion sub-sample when ``motion_samples > 1``).
"""
from __future__ import annotations

from collections import OrderedDict
from dataclasses import dataclass

import numba
import numpy as np

from fringe3d.utils.console import progress_bar
from fringe3d.optics.defocus import blur_pattern, defocus_size_at

from .noise import sense
from .scenes import copy_hit_row
from .settings import RenderSettings
from .truth import Truth, TruthFrames, directions_of, frame_truth, make_truth

#: Rays of a telecentric camera start this far (mm) before their min-norm origin.
TELECENTRIC_BACKOFF = 1.0e4


@dataclass
class Geometry:
    """Flattened per-pixel geometry of one instant (N = H*W pixels)."""

    hit: np.ndarray          # (N,) bool
    points: np.ndarray       # (N, 3) float64, NaN where no hit
    depth: np.ndarray        # (N,) float64
    normal: np.ndarray       # (N, 3) float64 (facing the camera)
    object_id: np.ndarray    # (N,) int32
    albedo: np.ndarray       # (N,) float64
    material_uv: np.ndarray | None
    up: np.ndarray           # (N,) float64
    vp: np.ndarray           # (N,) float64
    shade: np.ndarray        # (N,) cos(angle to the projector), 0 where unlit
    lit: np.ndarray          # (N,) bool: inside the projector, facing it, not shadowed
    proj_depth: np.ndarray   # (N,) distance along the projector axis (mm)
    extras: dict


# ----------------------------------------------------------------------------- rays
_RAY_CACHE: list = []  # [(camera, rays)], most recent last; cameras are frozen dataclasses


def camera_rays(camera) -> tuple[np.ndarray, np.ndarray, float]:
    """All pixel rays of ``camera`` (cached for the last few cameras; treat as read-only)."""
    for cam, rays in _RAY_CACHE:
        if cam is camera:
            return rays
    rays = _camera_rays(camera)
    _RAY_CACHE.append((camera, rays))
    del _RAY_CACHE[:-3]
    return rays


def _camera_rays(camera) -> tuple[np.ndarray, np.ndarray, float]:
    """All pixel rays of ``camera``: ``(origins (1 or N, 3), unit dirs (N, 3), depth_offset)``.

    Pinhole: one shared origin, the optical centre; depth is the camera-frame z.
    Telecentric: parallel rays starting :data:`TELECENTRIC_BACKOFF` mm before their
    min-norm origin; ``depth_offset`` is subtracted from the ray parameter to give depth.
    """
    uv = camera.pixel_grid().reshape(-1, 2)
    if getattr(camera, "kind", "pinhole") == "telecentric":
        origins, d = camera.rays(uv)
        d = np.asarray(d, float) / np.linalg.norm(d)
        origins = origins - TELECENTRIC_BACKOFF * d
        return np.ascontiguousarray(origins), np.ascontiguousarray(np.broadcast_to(d, origins.shape)), \
            TELECENTRIC_BACKOFF
    c, dirs = camera.rays(uv, normalize=True)
    return np.asarray(c, float).reshape(1, 3), np.ascontiguousarray(dirs), 0.0


@numba.njit(cache=True)
def _map_hits(o, d, t, oid, nrm, cam_r2, cam_t2, telecentric, depth_off, PR, Pt, K, dist, pc, W, H,
              pts, depth, normal, up, vp, pdepth, cosine, inside, L, dist_p):  # pragma: no cover - compiled
    """Per ray: hit point, camera depth, camera-facing normal, projector pixel (Brown distortion,
    Eq. 2.12-2.16), projector-axis distance, unit direction and distance to the projector
    centre, Lambert cosine, and whether the projector lights it (before shadows)."""
    k1, k2, p1, p2, k3 = dist[0], dist[1], dist[2], dist[3], dist[4]
    shared = o.shape[0] == 1
    nan = np.nan
    for i in range(d.shape[0]):
        ti = t[i]
        if oid[i] < 0 or not np.isfinite(ti):
            for j in range(3):
                pts[i, j] = nan
                normal[i, j] = 0.0
                L[i, j] = 0.0
            depth[i] = nan
            up[i] = nan
            vp[i] = nan
            pdepth[i] = nan
            cosine[i] = 0.0
            inside[i] = False
            dist_p[i] = nan
            continue
        oi = 0 if shared else i
        X0 = o[oi, 0] + ti * d[i, 0]
        X1 = o[oi, 1] + ti * d[i, 1]
        X2 = o[oi, 2] + ti * d[i, 2]
        pts[i, 0] = X0
        pts[i, 1] = X1
        pts[i, 2] = X2
        n0, n1, n2 = nrm[i, 0], nrm[i, 1], nrm[i, 2]
        if n0 * d[i, 0] + n1 * d[i, 1] + n2 * d[i, 2] > 0:
            n0, n1, n2 = -n0, -n1, -n2
        normal[i, 0] = n0
        normal[i, 1] = n1
        normal[i, 2] = n2
        if telecentric:
            depth[i] = ti - depth_off
        else:
            depth[i] = cam_r2[0] * X0 + cam_r2[1] * X1 + cam_r2[2] * X2 + cam_t2
        xp = PR[0, 0] * X0 + PR[0, 1] * X1 + PR[0, 2] * X2 + Pt[0]
        yp = PR[1, 0] * X0 + PR[1, 1] * X1 + PR[1, 2] * X2 + Pt[1]
        zp = PR[2, 0] * X0 + PR[2, 1] * X1 + PR[2, 2] * X2 + Pt[2]
        pdepth[i] = zp
        l0, l1, l2 = pc[0] - X0, pc[1] - X1, pc[2] - X2
        r = np.sqrt(l0 * l0 + l1 * l1 + l2 * l2)
        l0 /= r
        l1 /= r
        l2 /= r
        L[i, 0] = l0
        L[i, 1] = l1
        L[i, 2] = l2
        dist_p[i] = r
        c = n0 * l0 + n1 * l1 + n2 * l2
        cosine[i] = c
        if zp <= 0:
            up[i] = nan
            vp[i] = nan
            inside[i] = False
            continue
        x = xp / zp
        y = yp / zp
        r2 = x * x + y * y
        radial = 1 + r2 * (k1 + r2 * (k2 + r2 * k3))
        xd = x * radial + 2 * p1 * x * y + p2 * (r2 + 2 * x * x)
        yd = y * radial + p1 * (r2 + 2 * y * y) + 2 * p2 * x * y
        u = K[0, 0] * xd + K[0, 1] * yd + K[0, 2]
        v = K[1, 1] * yd + K[1, 2]
        up[i] = u
        vp[i] = v
        inside[i] = (u >= -0.5) and (u <= W - 0.5) and (v >= -0.5) and (v <= H - 0.5) and (c > 0)


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


def _bounds(ob, time: float):
    """(centre, radius, R, lo, hi) of an object's culling volume: an oriented box for meshes
    (body-frame ``mesh.bounds``, radius -1), else its bounding sphere (R, lo, hi unused);
    None when the object is unbounded or does not say."""
    mesh = getattr(ob, "mesh", None)
    if mesh is not None and hasattr(mesh, "bounds") and callable(getattr(ob, "pose", None)):
        R, c = ob.pose(time)
        lo, hi = np.asarray(mesh.bounds, float)
        pad = 1e-6 * (1.0 + np.abs(hi - lo).max())
        return np.asarray(c, float), -1.0, np.asarray(R, float), lo - pad, hi + pad
    fn = getattr(ob, "bounding_sphere", None)
    if fn is None:
        return None
    c, r = fn(time)
    if not np.isfinite(r):
        return None
    return np.asarray(c, float), float(r) * (1 + 1e-9) + 1e-9, np.eye(3), np.zeros(3), np.zeros(3)


def _near_rows(origins, dirs, bounds) -> np.ndarray | None:
    """Rows (M,) of the rays that may hit the object with culling volume ``bounds`` (see
    :func:`_bounds`); None when there is no volume or most rays pass it (cast them all)."""
    if bounds is None:
        return None
    c, r, R, lo, hi = bounds
    near = _rays_near(origins, dirs, c[None], np.array([r]), R[None], lo[None], hi[None],
                      np.empty(dirs.shape[0], np.bool_))
    idx = np.flatnonzero(near)
    return None if idx.size > 0.8 * dirs.shape[0] else idx


@numba.njit(cache=True)
def _merge_rows(rows, t, n, oid, alb, uv, t2, n2, oid2, alb2, uv2, new_id):  # pragma: no cover
    """Like ``Hit.merge_nearer`` for a subset: ray ``rows[r]`` takes row ``r`` of the second
    record when that is a hit nearer than its current one."""
    for r in range(rows.shape[0]):
        i = rows[r]
        if oid2[r] >= 0 and t2[r] < t[i]:
            copy_hit_row(i, r, t, n, alb, uv, t2, n2, alb2, uv2)
            oid[i] = new_id


def intersect_culled(scene, origins, dirs, time: float):
    """``scene.intersect`` with each object cast only on the rays that may hit it.

    Culling volumes: oriented bounding boxes for meshes, bounding spheres
    (``bounding_sphere(time)``) for the rest; unbounded objects (an infinite plane) or objects
    that say nothing get every ray. Returns a Hit with full-length ``t, normal, object_id,
    albedo, material_uv``, equal to ``scene.intersect`` (the volumes are conservative).
    """
    from .scenes import Hit, Scene

    ray_o = origins[0] if origins.shape[0] == 1 else origins
    if not isinstance(scene, Scene):
        return scene.intersect(ray_o, dirs, time=time)
    bounds = [_bounds(ob, time) for ob in scene.objects]
    if all(b is None for b in bounds):
        return scene.intersect(ray_o, dirs, time=time)
    n = dirs.shape[0]
    best = Hit.miss(n)
    for i, (ob, b) in enumerate(zip(scene.objects, bounds)):
        rows = _near_rows(origins, dirs, b)
        if rows is None:
            best.merge_nearer(ob.intersect(ray_o, dirs, time), i)
        elif rows.size:
            sub = ob.intersect(ray_o if origins.shape[0] == 1 else origins[rows], dirs[rows], time)
            uv = sub.material_uv if sub.material_uv is not None else np.full((rows.size, 2), np.nan)
            _merge_rows(rows, best.t, best.normal, best.object_id, best.albedo, best.material_uv,
                        np.ascontiguousarray(sub.t, dtype=np.float64), np.ascontiguousarray(sub.normal, dtype=np.float64),
                        np.ascontiguousarray(sub.object_id), np.ascontiguousarray(sub.albedo, dtype=np.float64),
                        np.ascontiguousarray(uv, dtype=np.float64), np.int32(i))
    return best


@numba.njit(cache=True)
def _shadow_rays(inside, pts, normal, L, dist, idx, o, d, tmax):  # pragma: no cover - compiled
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


def occluded(scene, origins, dirs, tmax, time: float) -> np.ndarray:
    """bool (M,): something in ``scene`` lies on ray ``m`` before ``tmax[m]`` (its first hit
    has ``t < tmax``), for shadow rays.

    A :class:`~fringe3d.sim.scenes.Scene` asks each object for its first-hit distance only
    (``hit_distance`` when the object has it: no normals, material coordinates or albedo)
    on the rays near its culling volume; any other scene is cast in full with ``scene.intersect``.
    """
    from .scenes import Scene

    if not isinstance(scene, Scene):
        h = scene.intersect(origins, dirs, time=time)
        return (np.asarray(h.object_id) >= 0) & (np.asarray(h.t) < tmax)
    blocked = np.zeros(len(dirs), np.bool_)
    for ob in scene.objects:  # each object on the rays near its culling volume only
        rows = _near_rows(origins, dirs, _bounds(ob, time))
        if rows is not None and not rows.size:
            continue
        o, d = (origins, dirs) if rows is None else (origins[rows], dirs[rows])
        fn = getattr(ob, "hit_distance", None)
        if callable(fn):
            t = fn(o, d, time)
        else:
            h = ob.intersect(o, d, time)
            t = np.where(np.asarray(h.object_id) >= 0, h.t, np.inf)
        if rows is None:
            blocked |= t < tmax
        else:
            blocked[rows] |= t < tmax[rows]
    return blocked


def _buffer(work: dict | None, name: str, shape, dtype=np.float64) -> np.ndarray:
    """``np.empty(shape, dtype)``, or the array kept under ``name`` in ``work`` (reused from an
    earlier frame when the shape and dtype match; fresh megapixel arrays cost page faults)."""
    if work is None:
        return np.empty(shape, dtype)
    a = work.get(name)
    if a is None or a.shape != tuple(shape) or a.dtype != dtype:
        a = work[name] = np.empty(shape, dtype)
    return a


def _where(mask, values, out):
    """``np.where(mask, values, 0.0)`` written into ``out``."""
    out.fill(0.0)
    np.copyto(out, values, where=mask)
    return out


def cast(scene, rig, origins, dirs, depth_offset, time: float, shadows: bool = True,
         work: dict | None = None) -> Geometry:
    """Intersect the camera rays with the scene at ``time`` and map hits into the projector.

    ``origins`` is (1, 3) for a pinhole camera (shared centre) or (N, 3); ``dirs`` (N, 3) unit.
    ``work``: a dict of buffers to write the Geometry's per-pixel arrays into (reused across
    calls with the same dict, so an earlier Geometry cast with it is overwritten).
    """
    h = intersect_culled(scene, origins, dirs, time)
    n_pix = dirs.shape[0]
    oid = np.ascontiguousarray(h.object_id, dtype=np.int32)
    cam, proj = rig.camera, rig.projector
    tele = getattr(cam, "kind", "pinhole") == "telecentric"
    cam_r2 = np.zeros(3) if tele else np.ascontiguousarray(cam.R[2], dtype=float)
    cam_t2 = 0.0 if tele else float(cam.t[2])
    pts, normal, L = (_buffer(work, k, (n_pix, 3)) for k in ("points", "normal", "L"))
    depth, up, vp, pdepth, cosine, dist = (_buffer(work, k, (n_pix,)) for k in
                                           ("depth", "up", "vp", "proj_depth", "cosine", "dist"))
    inside = _buffer(work, "inside", (n_pix,), np.bool_)
    _map_hits(origins, dirs, np.ascontiguousarray(h.t, dtype=float), oid,
              np.ascontiguousarray(h.normal, dtype=float), cam_r2, cam_t2, tele, float(depth_offset),
              np.ascontiguousarray(proj.R), np.ascontiguousarray(proj.t), np.ascontiguousarray(proj.K),
              np.ascontiguousarray(proj.dist), np.ascontiguousarray(proj.center), float(proj.width),
              float(proj.height), pts, depth, normal, up, vp, pdepth, cosine, inside, L, dist)
    hit = oid >= 0
    if shadows:
        m = int(np.count_nonzero(inside))
        if m:
            j, o, d, tmax = np.empty(m, np.int64), np.empty((m, 3)), np.empty((m, 3)), np.empty(m)
            _shadow_rays(inside, pts, normal, L, dist, j, o, d, tmax)
            inside[j[occluded(scene, o, d, tmax, time)]] = False
    shade = _where(inside, cosine, _buffer(work, "shade", (n_pix,)))
    muv = getattr(h, "material_uv", None)
    extras = object_extras(scene, oid, muv, time)
    return Geometry(hit=hit, points=pts, depth=depth, normal=normal, object_id=oid,
                    albedo=_where(hit, np.asarray(h.albedo, float), _buffer(work, "albedo", (n_pix,))),
                    material_uv=None if muv is None else np.asarray(muv, float),
                    up=up, vp=vp, shade=shade, lit=inside, proj_depth=pdepth, extras=extras)


def object_extras(scene, object_id: np.ndarray, material_uv, time: float) -> dict:
    """Scene-specific per-pixel truth (N, ...) from the objects that know it, NaN elsewhere.

    An object may define ``truth_fields(uv (M, 2), time) -> {name: (M, ...)}`` (the flapping
    wing: curvature, principal curvature and direction, dominant bending strain, Eq. 6.11-6.20).
    """
    objects = getattr(scene, "objects", [scene])
    out: dict = {}
    if material_uv is None or not any(callable(getattr(ob, "truth_fields", None)) for ob in objects):
        return out
    n = len(object_id)
    for i, ob in enumerate(objects):
        if not callable(getattr(ob, "truth_fields", None)):
            continue
        sel = np.flatnonzero(object_id == i)
        # an object out of view still declares its fields (all NaN), so every frame has them
        uv = np.asarray(material_uv, float)[sel] if sel.size else np.zeros((1, 2))
        fields = ob.truth_fields(uv, time)
        for name, val in fields.items():
            val = np.asarray(val, np.float32)
            if name not in out:
                out[name] = np.full((n,) + val.shape[1:], np.nan, np.float32)
            if sel.size:
                out[name][sel] = val
    return out


def scene_meta(scene, rig, time: float) -> dict:
    """Non-per-pixel truth: circle-board centres (world mm and camera pixels) per board object."""
    meta = {}
    for i, ob in enumerate(getattr(scene, "objects", [scene])):
        fn = getattr(ob, "circle_centers", None)
        if callable(fn):
            X = np.asarray(fn(time), float)
            meta[f"board_{i}_centres_xyz"] = X.tolist()
            meta[f"board_{i}_centres_camera_px"] = rig.camera.project(X).tolist()
            meta[f"board_{i}_centres_projector_px"] = rig.projector.project(X).tolist()
    return meta


# ----------------------------------------------------------------------------- sampling
@numba.njit(cache=True, parallel=False)
def bilinear(image, u, v, out):
    """Bilinear sample of ``image`` (H, W) at float coordinates (u column, v row), edge-clamped.

    Writes ``out[i]``; NaN coordinates give 0.
    """
    H, W = image.shape
    for i in range(u.shape[0]):
        x = u[i]
        y = v[i]
        if not (x == x and y == y):  # NaN
            out[i] = 0.0
            continue
        x = min(max(x, 0.0), W - 1.0)
        y = min(max(y, 0.0), H - 1.0)
        x0 = min(int(x), W - 2) if W > 1 else 0
        y0 = min(int(y), H - 2) if H > 1 else 0
        fx = x - x0
        fy = y - y0
        x1 = min(x0 + 1, W - 1)
        y1 = min(y0 + 1, H - 1)
        out[i] = ((1 - fy) * ((1 - fx) * image[y0, x0] + fx * image[y0, x1])
                  + fy * ((1 - fx) * image[y1, x0] + fx * image[y1, x1]))
    return out


def sample(image: np.ndarray, up: np.ndarray, vp: np.ndarray) -> np.ndarray:
    """Bilinear sample of a projector image at projector coordinates (pixels)."""
    out = np.empty(up.shape[0])
    return bilinear(np.ascontiguousarray(image, dtype=np.float64), np.ascontiguousarray(up, float),
                    np.ascontiguousarray(vp, float), out)


#: Blurred projector images shared by every render call: key -> read-only (H, W) float64.
_IMAGE_CACHE: "OrderedDict[tuple, np.ndarray]" = OrderedDict()
#: Most projector images kept in :data:`_IMAGE_CACHE` (about 8 MB each at 912 x 1140).
IMAGE_CACHE_SIZE = 12


def projector_image(spec, width: int, height: int, defocus: str, size: float) -> np.ndarray:
    """The projector image of frame ``spec`` (``render_frame``) blurred by the defocus OTF of
    ``size`` (Eq. 2.22-2.26), (height, width) float64, read-only.

    Kept in a small least-recently-used cache across render calls (a pattern set rendered
    again, e.g. a repeated capture or a benchmark, does not re-render and re-blur it)."""
    key = (spec, int(width), int(height), str(defocus), round(float(size), 6))
    img = _IMAGE_CACHE.get(key)
    if img is not None:
        _IMAGE_CACHE.move_to_end(key)
        return img
    from fringe3d.patterns.render import render_frame
    img = render_frame(spec, width, height).astype(np.float64)
    if defocus != "none" and size > 0:
        img = blur_pattern(img, defocus, size)
    img.setflags(write=False)
    _IMAGE_CACHE[key] = img
    while len(_IMAGE_CACHE) > IMAGE_CACHE_SIZE:
        _IMAGE_CACHE.popitem(last=False)
    return img


class PatternSampler:
    """Pattern values at projector coordinates for one pattern set and render settings.

    Keeps the images it used (up to 64) and takes new ones from :func:`projector_image`
    (cached across calls).
    """

    def __init__(self, patterns, settings: RenderSettings):
        self.patterns = patterns
        self.settings = settings
        self._cache: dict = {}

    def _image(self, spec, size: float) -> np.ndarray:
        key = (spec, round(float(size), 6))
        if key not in self._cache:
            if len(self._cache) > 64:
                self._cache.clear()
            self._cache[key] = projector_image(spec, self.patterns.width, self.patterns.height,
                                               self.settings.defocus, size)
        return self._cache[key]

    def values(self, spec, geo: Geometry) -> np.ndarray:
        """Pattern value in [0, 1] (before gamma) at every lit pixel of ``geo``; 0 elsewhere."""
        s = self.settings
        out = np.zeros(geo.lit.shape[0])
        idx = np.flatnonzero(geo.lit)
        if not idx.size:
            return out
        up, vp = geo.up[idx], geo.vp[idx]
        if s.ideal:
            from fringe3d.patterns.render import sinusoid_value
            out[idx] = sinusoid_value(spec, up, vp, self.patterns.width, self.patterns.height)
            return out
        if s.defocus == "none" or s.focus_distance is None or s.defocus_growth == 0:
            out[idx] = sample(self._image(spec, s.defocus_size), up, vp)
            return out
        sizes = defocus_size_at(geo.proj_depth[idx], s.defocus_size, s.focus_distance, s.defocus_growth)
        lo, hi = float(sizes.min()), float(sizes.max())
        n = int(min(8, max(2, np.ceil((hi - lo) / 0.25) + 1)))
        levels = np.linspace(lo, hi, n) if hi > lo else np.array([lo, lo])
        samples = np.stack([sample(self._image(spec, z), up, vp) for z in levels])
        pos = np.interp(sizes, levels, np.arange(len(levels)))
        i0 = np.minimum(pos.astype(int), len(levels) - 2)
        f = pos - i0
        r = np.arange(idx.size)
        out[idx] = (1 - f) * samples[i0, r] + f * samples[i0 + 1, r]
        return out


# ----------------------------------------------------------------------------- render
def frame_times(n_frames: int, settings: RenderSettings, start: float = 0.0) -> np.ndarray:
    """Capture time (s) of each frame, ``start + k / frame_rate``."""
    return start + np.arange(n_frames) / settings.frame_rate


def is_static(scene) -> bool:
    """Whether ``scene`` does not change with time (its ``static`` attribute; default True)."""
    s = getattr(scene, "static", None)
    if callable(s):
        s = s()
    if s is None:
        s = not bool(getattr(scene, "moving", False))
    return bool(s)


def irradiance(geo: Geometry, pattern: np.ndarray, settings: RenderSettings,
               scene_ambient: float = 0.0) -> np.ndarray:
    """Noise-free camera signal (full-scale units) of each pixel, see :mod:`.settings`.

    Ambient light is ``settings.ambient + scene_ambient * settings.brightness`` (a scene's
    ambient level is relative to the projector's full white).
    """
    s = settings
    # No clipping for gamma = 1: the FFT defocus model is band-limited, so a blurred binary
    # pattern can overshoot [0, 1] by a few percent (Gibbs) while its harmonics follow the OTF.
    shaped = pattern if s.gamma == 1.0 else np.power(np.clip(pattern, 0.0, None), s.gamma)
    proj = s.brightness * geo.shade * shaped
    ambient = s.ambient + scene_ambient * s.brightness
    return s.gain * s.exposure_fraction * geo.albedo * (ambient + proj) * geo.hit


def render(scene, rig, patterns, settings: RenderSettings | None = None, times=None,
           progress: bool = True) -> tuple[np.ndarray, Truth]:
    """Render a capture: one camera frame per pattern frame (in projection order).

    Parameters
    ----------
    scene : object with ``intersect(origins (N,3), dirs (N,3), time) -> Hit``
    rig : fringe3d.optics.Rig
    patterns : PatternSet
        Its width/height must equal the projector's.
    settings : RenderSettings
    times : array_like (F,), optional
        Capture time of each frame (s). Default ``k / frame_rate``; pass more times than
        pattern frames to render a repeating sequence (frame ``k`` shows pattern ``k % P``).
    progress : bool
        Show a progress bar.

    Returns
    -------
    frames : (F, H, W) uint8 / uint16 / float32
    truth : Truth
        Per pixel; per frame (leading F axis) when the scene moves, taken at the frame's
        timestamp (at the middle motion sub-sample when ``motion_samples > 1``, see
        ``truth.meta["truth_times"]``).
    """
    s = settings or RenderSettings()
    check_inputs(rig, patterns)
    n_pat = len(patterns.frames)
    times = frame_times(n_pat, s) if times is None else np.asarray(times, float).ravel()
    if times.size == 0:
        raise ValueError("nothing to render: no frame times given")
    if not np.all(np.isfinite(times)):
        raise ValueError("frame times must be finite numbers of seconds")
    cam = rig.camera
    H, W = cam.height, cam.width
    origins, dirs, off = camera_rays(cam)
    static = is_static(scene)
    amb = float(getattr(scene, "ambient", 0.0) or 0.0)
    sampler = PatternSampler(patterns, s)
    dirs_info = directions_of(patterns)
    per_frame = TruthFrames(len(times))  # per-frame truth of a moving scene
    work = [{} for _ in range(max(1, s.motion_samples))]  # a moving scene's cast buffers
    truth_times: list[float] = []
    frames = []
    geo0 = cast(scene, rig, origins, dirs, off, float(times[0]), s.shadows) if static else None
    if geo0 is not None:
        check_visible(geo0, scene)
    with progress_bar("rendering", len(times), enabled=progress) as advance:
        for k, tk in enumerate(times):
            spec = patterns.frames[k % n_pat]
            if static:
                geo = geo0
                img = irradiance(geo, sampler.values(spec, geo), s, amb)
            else:
                sub = motion_subtimes(float(tk), s)
                img = np.zeros(H * W)
                for j, ts in enumerate(sub):  # buffers reused per sub-sample index across frames
                    g = cast(scene, rig, origins, dirs, off, ts, s.shadows, work=work[j])
                    if j == len(sub) // 2:  # truth at the middle sub-sample of the exposure
                        geo, t_truth = g, ts
                    img += irradiance(g, sampler.values(spec, g), s, amb) / len(sub)
                if k == 0:
                    check_visible(geo, scene)
                per_frame.put(k, frame_truth(geo, (H, W), dirs_info))
                truth_times.append(t_truth)
            frames.append(sense(img.reshape(H, W), s, k))
            advance()
    truth = make_truth(frame_truth(geo0, (H, W), dirs_info) if static else per_frame, dirs_info, times,
                       static, rig)
    truth.meta.update(scene_meta(scene, rig, float(times[0])))
    if not static:
        truth.meta["truth_times"] = truth_times  # differs from ``times`` when motion_samples > 1
    return np.stack(frames), truth


def motion_subtimes(t: float, s: RenderSettings) -> list[float]:
    """Sample times within frame ``t``'s exposure (only ``t`` itself when ``motion_samples=1``)."""
    if s.motion_samples <= 1:
        return [t]
    exp = s.exposure if s.exposure is not None else 1.0 / s.frame_rate
    return [t + (j + 0.5) / s.motion_samples * exp for j in range(s.motion_samples)]


def check_inputs(rig, patterns) -> None:
    proj = rig.projector
    if (patterns.width, patterns.height) != (proj.width, proj.height):
        raise ValueError(f"pattern set is {patterns.width}x{patterns.height} but the projector is "
                         f"{proj.width}x{proj.height}; build the patterns for the projector's size")
    if len(patterns.frames) == 0:
        raise ValueError("pattern set has no frames")


def check_visible(geo: Geometry, scene) -> None:
    """Reject scenes the camera cannot see or the projector cannot light."""
    if not geo.hit.any():
        raise ValueError("no scene object is in the camera's view (is it behind the camera or outside "
                         "its field of view?); place objects in front of the camera within the preset's "
                         "working volume")
    if not geo.lit.any():
        raise ValueError("the scene is outside the projector's view: no visible surface point is lit by "
                         "the projector; move the objects into the projector's field")
