"""Pre-flight checks of a scene against a rig: is every object where the devices can see it?

``scene_problems(scene, rig, times)`` returns human-readable problems (empty list = fine):
an object behind the camera or the projector, an object the camera does not see (outside its
view or hidden behind another object), an object the projector does not light (outside its
view). ``check_scene`` raises ``ValueError`` with all of them. Checks use each object's
bounding sphere plus a coarse ray cast (``grid`` rays across the camera image).
"""
from __future__ import annotations

import numpy as np

from fringe3d.optics import PinholeDevice, Rig, TelecentricCamera

from .primitives import Sphere
from .scene import Scene
from .scene_object import SceneObject


def _label(i: int, ob: SceneObject) -> str:
    return f"objects[{i}] ({ob.describe()})"


def _camera_rays(cam, grid, scene: Scene, time: float):
    """Coarse camera rays: (origins, dirs). Telecentric origins are moved back along the view
    direction in front of every object."""
    nu, nv = grid
    u = np.linspace(0, cam.width - 1, nu)
    v = np.linspace(0, cam.height - 1, nv)
    uv = np.stack(np.meshgrid(u, v), -1).reshape(-1, 2)
    o, d = cam.rays(uv)
    if isinstance(cam, TelecentricCamera):
        d = np.broadcast_to(d, o.shape)
        reach = 0.0
        for ob in scene.objects:
            c, r = ob.bounding_sphere(time)
            if np.isfinite(r):
                reach = max(reach, abs(float(c @ d[0])) + r)
        o = o - (reach + 1.0) * d
    return o, np.ascontiguousarray(d)


def _depth(device, X):
    """Depth of world point X along the device's optical axis (pinhole devices only)."""
    return float(device.to_device(X)[2])


def scene_problems(scene: Scene, rig: Rig, times=(0.0,), grid=(96, 77)) -> list[str]:
    """List what is wrong with ``scene`` for ``rig`` at each time in ``times`` (s).

    Parameters
    ----------
    scene : Scene
    rig : fringe3d.optics.Rig
    times : iterable of float, times to check (e.g. first and last frame of a moving scene).
    grid : (columns, rows) of the coarse camera ray grid.
    """
    cam, proj = rig.camera, rig.projector
    pinhole_cam = not isinstance(cam, TelecentricCamera)
    problems: list[str] = []
    for time in times:
        at = f" at t = {time:g} s" if scene.moving else ""
        front: list[bool] = []
        for i, ob in enumerate(scene.objects):
            c, r = ob.bounding_sphere(time)
            ok = True
            if np.isfinite(r):
                if pinhole_cam and _depth(cam, c) + r <= 0:
                    problems.append(f"{_label(i, ob)} is behind the camera{at} (centre depth "
                                    f"{_depth(cam, c):.1f} mm, radius {r:.1f} mm); move it to positive depth")
                    ok = False
                if _depth(proj, c) + r <= 0:
                    problems.append(f"{_label(i, ob)} is behind the projector{at} (centre depth "
                                    f"{_depth(proj, c):.1f} mm in the projector frame)")
                    ok = False
                inside = isinstance(cam, PinholeDevice) and np.linalg.norm(c - cam.center) < r
                if inside and isinstance(ob, Sphere):
                    problems.append(f"{_label(i, ob)} encloses the camera{at}")
                    ok = False
            front.append(ok)
        o, d = _camera_rays(cam, grid, scene, time)
        hit = scene.intersect(o, d, time)
        X = hit.points(o, d)
        for i, ob in enumerate(scene.objects):
            if not front[i]:
                continue
            rows = np.flatnonzero(hit.object_id == i)
            if rows.size == 0:
                problems.append(f"{_label(i, ob)} is not seen by the camera{at}: outside its "
                                f"{cam.width}x{cam.height} view or hidden behind another object")
                continue
            P = X[rows]
            zp = proj.to_device(P)[:, 2]
            uvp = proj.project(P)
            lit = ((zp > 0) & (uvp[:, 0] >= -0.5) & (uvp[:, 0] <= proj.width - 0.5)
                   & (uvp[:, 1] >= -0.5) & (uvp[:, 1] <= proj.height - 0.5))
            if not lit.any():
                problems.append(f"{_label(i, ob)} is outside the projector's view{at}: none of its "
                                f"visible points falls on the {proj.width}x{proj.height} projector image")
    return problems


def check_scene(scene: Scene, rig: Rig, times=(0.0,), grid=(96, 77)) -> None:
    """Raise ``ValueError`` listing every problem :func:`scene_problems` finds."""
    problems = scene_problems(scene, rig, times, grid)
    if problems:
        raise ValueError("scene does not fit the rig: " + "; ".join(problems))
