"""Per-pixel geometry of one instant: cast the camera rays, map the hits into the projector,
test projector shadows.

:func:`cast` intersects the camera rays with the scene (:func:`~fringe3d.sim.rays.intersect_culled`),
then per hit: the point, camera depth, camera-facing normal, projector pixel ``(u_p, v_p)``
(Eq. 2.8-2.18 with Brown distortion, Eq. 2.12-2.16), distance along the projector axis, the
Lambert cosine toward the projector centre, and whether the projector lights it (inside its
image, facing it, not shadowed: :func:`~fringe3d.sim.rays.occluded`). The result is a flat
:class:`Geometry` (N = H*W rows) that the projector sampling, the radiometry and the truth use.
"""
from __future__ import annotations

from dataclasses import dataclass

import numba
import numpy as np

from fringe3d.optics import Rig, TelecentricCamera

from .rays import intersect_culled, occluded, shadow_rays
from .scene import Scene
from .scene_object import SupportsCircleCentres
from .specular import specular_factor


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
    specular: np.ndarray | None = None  # (N,) glossy lobe factor (:mod:`.specular`); None: all matte


def crop(geo: Geometry, shape: tuple[int, int], margin: int) -> Geometry:
    """``geo`` of a ``shape`` = (H + 2 margin, W + 2 margin) grid cropped to the inner (H, W)
    pixels (the sensor), still flat (N = H*W rows); ``margin`` 0 returns ``geo``."""
    if not margin:
        return geo
    Hp, Wp = shape

    def inner(a):
        if not isinstance(a, np.ndarray) or a.ndim == 0 or a.shape[0] != Hp * Wp:
            return a
        g = a.reshape((Hp, Wp) + a.shape[1:])[margin:Hp - margin, margin:Wp - margin]
        return np.ascontiguousarray(g).reshape((-1,) + a.shape[1:])

    fields = {f: inner(getattr(geo, f)) for f in geo.__dataclass_fields__ if f != "extras"}
    return Geometry(**fields, extras={k: inner(v) for k, v in geo.extras.items()})


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


def _buffer(work: dict | None, name: str, shape: tuple[int, ...], dtype=np.float64) -> np.ndarray:
    """``np.empty(shape, dtype)``, or the array kept under ``name`` in ``work`` (reused from an
    earlier frame when the shape and dtype match; fresh megapixel arrays cost page faults)."""
    if work is None:
        return np.empty(shape, dtype)
    a = work.get(name)
    if a is None or a.shape != tuple(shape) or a.dtype != dtype:
        a = work[name] = np.empty(shape, dtype)
    return a


def _where(mask: np.ndarray, values: np.ndarray, out: np.ndarray) -> np.ndarray:
    """``np.where(mask, values, 0.0)`` written into ``out``."""
    out.fill(0.0)
    np.copyto(out, values, where=mask)
    return out


def cast(scene: Scene, rig: Rig, origins: np.ndarray, dirs: np.ndarray, depth_offset: float, time: float,
         shadows: bool = True, work: dict | None = None) -> Geometry:
    """Intersect the camera rays with the scene at ``time`` and map hits into the projector.

    ``origins`` is (1, 3) for a pinhole camera (shared centre) or (N, 3); ``dirs`` (N, 3) unit.
    ``work``: a dict of buffers to write the Geometry's per-pixel arrays into (reused across
    calls with the same dict, so an earlier Geometry cast with it is overwritten).
    """
    if rig.projector.dist.size > 5:
        raise ValueError("the simulator models projector distortion k1 k2 p1 p2 k3 only; this projector has "
                         "OpenCV's rational / thin-prism / tilt terms (k4 .. tau_y)")
    h = intersect_culled(scene, origins, dirs, time)
    n_pix = dirs.shape[0]
    oid = np.ascontiguousarray(h.object_id, dtype=np.int32)
    cam, proj = rig.camera, rig.projector
    if isinstance(cam, TelecentricCamera):  # depth = ray parameter - depth_offset
        tele, cam_r2, cam_t2 = True, np.zeros(3), 0.0
    else:  # depth = camera-frame z = R[2] @ X + t[2]
        tele, cam_r2, cam_t2 = False, np.ascontiguousarray(cam.R[2], dtype=np.float64), float(cam.t[2])
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
            shadow_rays(inside, pts, normal, L, dist, j, o, d, tmax)
            inside[j[occluded(scene, o, d, tmax, time)]] = False
    shade = _where(inside, cosine, _buffer(work, "shade", (n_pix,)))
    muv = h.material_uv
    # scene-specific truth (the wing's curvature, Eq. 6.11-6.20); an object out of view still
    # declares its fields (all NaN), so every frame has them
    extras = {} if muv is None else scene.truth_fields(h, time)
    return Geometry(hit=hit, points=pts, depth=depth, normal=normal, object_id=oid,
                    albedo=_where(hit, np.asarray(h.albedo, float), _buffer(work, "albedo", (n_pix,))),
                    material_uv=None if muv is None else np.asarray(muv, float),
                    up=up, vp=vp, shade=shade, lit=inside, proj_depth=pdepth, extras=extras,
                    specular=specular_factor(scene.objects, oid, normal, L, -dirs, inside))


def scene_meta(scene: Scene, rig: Rig, time: float) -> dict:
    """Non-per-pixel truth: circle-board centres (world mm and camera pixels) per board object
    (:class:`~fringe3d.sim.scene_object.SupportsCircleCentres`)."""
    meta = {}
    for i, ob in enumerate(scene.objects):
        if isinstance(ob, SupportsCircleCentres):
            X = np.asarray(ob.circle_centers(time), float)
            meta[f"board_{i}_centres_xyz"] = X.tolist()
            meta[f"board_{i}_centres_camera_px"] = rig.camera.project(X).tolist()
            meta[f"board_{i}_centres_projector_px"] = rig.projector.project(X).tolist()
    return meta
