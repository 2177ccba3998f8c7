"""The phase ripple's size on the surface: projector pixels to micrometres through the rig.

At the rig's working point (the closest approach of the camera's and the projector's central
rays), a change of ``du`` projector pixels in the coordinate a fringe direction encodes moves
the triangulated point along the camera ray (Eq. 2.37-2.38) by ``|dX/du| du``; this module
gives ``|dX/du|`` in mm per projector pixel, so a ripple of ``e`` rad at period ``T`` is
``e T / (2 pi) |dX/du|`` on the surface (an estimate at the working point, exact for a
locally planar scene there).
"""
from __future__ import annotations

import numpy as np

from fringe3d.optics.rig import Rig


def _central_ray(device) -> tuple[np.ndarray, np.ndarray]:
    origin, d = device.rays(np.array([[device.width / 2.0, device.height / 2.0]]), normalize=True)
    o = np.asarray(origin, float).reshape(-1, 3)[0]
    return o, np.asarray(d, float).reshape(3)


def mm_per_projector_px(rig: Rig, direction: str = "v") -> float:
    """Displacement (mm) of the triangulated point per projector pixel at the working point.

    Parameters
    ----------
    rig : Rig
    direction : {"v", "h"}
        ``"v"``: vertical fringes encode the projector column; ``"h"``: the row.

    Returns
    -------
    float
        mm per projector pixel; NaN when the direction's coordinate does not change along the
        camera ray (a degenerate fringe direction for this rig).
    """
    oc, dc = _central_ray(rig.camera)
    op, dp = _central_ray(rig.projector)
    w = oc - op
    b = float(dc @ dp)
    den = 1.0 - b * b
    s = float((b * (dp @ w) - (dc @ w)) / den) if den > 1e-12 else float(np.linalg.norm(w))
    k = 0 if direction == "v" else 1
    step = max(abs(s), 1.0) * 1e-4
    u0 = rig.projector.project((oc + s * dc)[None])[0, k]
    u1 = rig.projector.project((oc + (s + step) * dc)[None])[0, k]
    du = abs(float(u1 - u0))
    return step / du if du > 0 else float("nan")
