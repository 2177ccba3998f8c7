"""Depth maps and projector coordinates from decoded absolute phase.

* :func:`depth_map` - the z channel of an organized point map (mm, NaN where invalid).
* :func:`projector_coordinates` - turns a decoded capture's absolute phase per fringe
  direction into ``u_p``/``v_p`` (Eq. 4.13: ``w = Phi*T/(2*pi)``); two directions at arbitrary
  angles are solved for ``(u_p, v_p)`` (the rotation of Eq. 2.34).
* :func:`points_from_decoded` - absolute phase -> organized point map, fast closed form for one
  direction (:class:`~fringe3d.reconstruct.triangulate.Triangulator`) or least squares when two
  directions are given or the projector has distortion.
"""
from __future__ import annotations

import math

import numpy as np

from fringe3d.decode.result import Decoded
from fringe3d.optics.rays import camera_shape
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.conventions import phase_to_w
from fringe3d.reconstruct.triangulate import Triangulator, triangulate
from fringe3d.utils.camera_size import check_camera_size


class EmptyMaskError(ValueError):
    """No pixel of the decoded phase is valid, so there is nothing to triangulate."""


def depth_map(points: np.ndarray) -> np.ndarray:
    """Depth map ``(H, W)`` float32 (mm): the world z of an organized point map
    ``(H, W, 3)``; NaN where the point is invalid. For pinhole rigs world = camera frame, so this
    is the depth along the camera axis.

    Parameters
    ----------
    points : (H, W, 3) array_like
        Organized point map (mm), NaN where invalid.

    Returns
    -------
    ndarray
        ``(H, W)`` float32 world z (mm), NaN where invalid.
    """
    points = np.asarray(points)
    if points.ndim != 3 or points.shape[-1] != 3:
        raise ValueError(f"expected an organized point map of shape (H, W, 3), got {points.shape}")
    return np.ascontiguousarray(points[..., 2], dtype=np.float32)


def direction_coordinate(phase: np.ndarray, period: float) -> np.ndarray:
    """Projector coordinate along a fringe direction, ``w = Phi*T/(2*pi)`` (Eq. 4.13), pixels."""
    if not period > 0:
        raise ValueError(f"fringe period must be positive (projector pixels), got {period}")
    return phase_to_w(np.asarray(phase, np.float64), period)


def projector_coordinates(decoded: Decoded, directions=None) -> dict:
    """Projector coordinates from a :class:`fringe3d.decode.Decoded`.

    Returns ``{"w": {direction: (H, W)}, "angle": {direction: rad}, "up": map or None,
    "vp": map or None, "mask": (H, W) bool}``. ``up``/``vp`` are filled directly for
    directions at pi/2 / 0 and solved from two directions at other angles
    (``w_k = v_p cos(a_k) + u_p sin(a_k)``).

    Parameters
    ----------
    decoded : fringe3d.decode.Decoded
        Absolute phase (rad), period (px), angle (rad) and mask per fringe direction.
    directions : sequence of str, optional
        The directions to use (default every direction of ``decoded.phase``).

    Returns
    -------
    dict
        As above; the ``w``, ``up`` and ``vp`` maps are in projector pixels.
    """
    names = list(directions) if directions is not None else list(decoded.phase)
    if not names:
        raise ValueError("the decoded capture has no absolute phase for any fringe direction")
    w = {d: direction_coordinate(decoded.phase[d], decoded.period[d]) for d in names}
    ang = {d: float(decoded.angle[d]) for d in names}
    mask = np.ones(np.shape(w[names[0]]), bool)
    for d in names:
        mask &= np.asarray(decoded.mask[d], bool) & np.isfinite(w[d])
    up = vp = None
    for d in names:
        if abs(ang[d] - math.pi / 2) < 1e-9:
            up = w[d]
        elif abs(ang[d]) < 1e-9:
            vp = w[d]
    if up is None and vp is None and len(names) >= 2:
        a, b = names[:2]
        M = np.array([[math.cos(ang[a]), math.sin(ang[a])], [math.cos(ang[b]), math.sin(ang[b])]])
        if abs(np.linalg.det(M)) < 1e-6:
            raise ValueError(f"fringe directions {a!r} and {b!r} are parallel; cannot solve (u_p, v_p)")
        inv = np.linalg.inv(M)
        vp = inv[0, 0] * w[a] + inv[0, 1] * w[b]
        up = inv[1, 0] * w[a] + inv[1, 1] * w[b]
    return {"w": w, "angle": ang, "up": up, "vp": vp, "mask": mask}


def triangulator_for(geometry: RigGeometry, angle: float) -> Triangulator:
    """The closed-form :class:`Triangulator` of ``geometry.rig`` at fringe ``angle`` (rad), built
    once per :class:`RigGeometry` and angle: a sequence reuses the per-pixel ray coefficients
    (Eq. 2.37) instead of recomputing them every 3D frame (~28 ms at 1280x1024); its camera rays
    are the geometry's, shared with its minimum phase maps."""
    return geometry.memo(("triangulator", float(angle)),
                         lambda: Triangulator(geometry.rig, angle=angle, geometry=geometry))


def points_from_decoded(decoded: Decoded, rig: Rig, method: str = "auto", directions=None,
                        geometry: RigGeometry | None = None) -> np.ndarray:
    """Organized point map ``(H, W, 3)`` float32 (mm, NaN invalid) from decoded absolute phase.

    ``method``: ``"fast"`` (closed form, one direction; the first of ``directions``),
    ``"lsq"`` (least squares over every available coordinate, Eq. 2.37), or ``"auto"``
    (fast for a single direction and a distortion-free projector, least squares otherwise).

    Parameters
    ----------
    decoded : fringe3d.decode.Decoded
        Absolute phase (rad), period (px), angle (rad) and mask per fringe direction.
    rig : fringe3d.optics.Rig
        The calibrated camera-projector rig; its camera size must match the phase maps.
    method : {"auto", "fast", "lsq"}
        Triangulation method, as above.
    directions : sequence of str, optional
        The directions to use (default every decoded direction).
    geometry : fringe3d.optics.RigGeometry, optional
        The rig's geometry that keeps the closed form's coefficients (the engine's); built for
        this call when omitted.

    Returns
    -------
    ndarray
        ``(H, W, 3)`` float32 points in world coordinates (mm), NaN where invalid.
    """
    if method not in ("auto", "fast", "lsq"):
        raise ValueError(f"unknown triangulation method {method!r}; expected 'auto', 'fast' or 'lsq'")
    pc = projector_coordinates(decoded, directions)
    check_camera_size(pc["mask"].shape, camera_shape(rig))
    if not pc["mask"].any():
        raise EmptyMaskError("the decoded phase mask is empty: no pixel has a valid absolute phase "
                         "(check exposure, modulation threshold and that the scene is lit by the projector)")
    names = list(pc["w"])
    if method == "auto":
        method = "fast" if (len(names) == 1 and not rig.projector.dist.any()) else "lsq"
    if method == "fast":
        d = names[0]
        return triangulator_for(RigGeometry.of(rig, geometry), float(pc["angle"][d])).points(pc["w"][d], pc["mask"])
    if pc["up"] is None and pc["vp"] is None:  # one direction at a general angle
        d = names[0]
        a = pc["angle"][d]
        raise ValueError(f"least-squares triangulation needs u_p and/or v_p; direction {d!r} has angle "
                         f"{a:.4f} rad - use method='fast' for a single oblique direction")
    return triangulate(rig, up=pc["up"], vp=pc["vp"], mask=pc["mask"])
