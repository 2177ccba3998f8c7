"""Per-point uncertainty: the phase noise of each direction propagated through the triangulation.

For a direction ``d`` with predicted phase standard deviation ``sigma_phi,d`` (rad,
:attr:`fringe3d.decode.Decoded.phase_sigma`, ``sqrt(2/N) sigma / B``), the point's covariance is
``C = sum_d J_d J_d^T sigma_phi,d^2`` with ``J_d = dX / dPhi_d`` (mm/rad), the central difference
of the triangulation (closed form or least squares, Eq. 2.37) at ``Phi_d +- h``; directions are
independent (separate frames). Reported: the per-axis standard deviations
``sigma_xyz = sqrt(diag C)`` (H, W, 3) and ``sigma_z`` (H, W), mm, NaN where invalid. First
order: exact while ``sigma_phi`` is small against the curvature of ``X(Phi)`` (always, for
fringe phase noise of a few hundredths of a radian).
"""
from __future__ import annotations

import dataclasses
from typing import Callable

import numpy as np

from fringe3d.decode.result import Decoded
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.reconstruct.depth import points_from_decoded
from fringe3d.reconstruct.triangulate import Triangulator

#: Phase step (rad) of the central difference.
STEP = 0.05


def sigma_from_jacobian(jacobians: list[np.ndarray], sigmas: list[np.ndarray]) -> np.ndarray:
    """(H, W, 3) float32 ``sqrt(sum_d (J_d sigma_d)^2)`` per axis from (H, W, 3) Jacobians (mm/rad)
    and (H, W) phase sigmas (rad)."""
    var = np.zeros(jacobians[0].shape, np.float64)
    for J, s in zip(jacobians, sigmas):
        var += (np.asarray(J, np.float64) * np.asarray(s, np.float64)[..., None]) ** 2
    return np.sqrt(var).astype(np.float32)


def central_difference(points_at: Callable[[float], np.ndarray], step: float = STEP) -> np.ndarray:
    """(H, W, 3) ``(X(+h) - X(-h)) / 2h`` of a function ``h -> (H, W, 3)`` points (mm per unit of h)."""
    hi = np.asarray(points_at(step), np.float64)
    lo = np.asarray(points_at(-step), np.float64)
    return (hi - lo) / (2.0 * step)


def point_sigma(decoded: Decoded, rig, method: str = "auto", directions=None, step: float = STEP,
                geometry: RigGeometry | None = None) -> np.ndarray:
    """(H, W, 3) float32 ``sigma_xyz`` (mm) of the points :func:`points_from_decoded` gives for
    ``decoded`` (same ``method`` / ``directions``; ``geometry`` the rig's :class:`RigGeometry`, else
    one is built for this call); NaN where a point or its phase sigma is invalid."""
    geometry = RigGeometry.of(rig, geometry)
    names = list(directions) if directions is not None else list(decoded.phase)
    jac, sig = [], []
    for d in names:
        s = decoded.phase_sigma.get(d)
        if s is None:
            s = np.full(decoded.phase[d].shape, np.nan, np.float32)

        def at(h: float, d: str = d) -> np.ndarray:
            shifted = dict(decoded.phase)
            shifted[d] = (decoded.phase[d] + np.float32(h)).astype(np.float32)
            return points_from_decoded(dataclasses.replace(decoded, phase=shifted), rig, method=method,
                                       directions=directions, geometry=geometry)
        jac.append(central_difference(at, step))
        sig.append(s)
    return sigma_from_jacobian(jac, sig)


def fast_point_sigma(tri: Triangulator, w: np.ndarray, sigma_w: np.ndarray, mask: np.ndarray) -> np.ndarray:
    """(H, W, 3) float32 ``sigma_xyz`` (mm) of the closed form :class:`Triangulator` for one fringe
    coordinate ``w`` (px) of standard deviation ``sigma_w`` (px): ``|dX/dw| sigma_w`` with the
    exact derivative along the pinhole ray
    (:meth:`~fringe3d.optics.rays.RayGeometry.point_sigma_from_w`); NaN where ``mask`` is False."""
    return tri.point_sigma_from_w(w, sigma_w, mask)
