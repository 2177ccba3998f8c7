"""Judging a calibration by what it measures: decoded directions -> projector coordinates ->
points (Eq. 2.30-2.34, 2.37), and calibrated-vs-true rig parameters. The calibration
experiments render the test objects with :func:`fringe3d.sim.calibration_session.render_and_decode`."""
from __future__ import annotations

import numpy as np

from fringe3d.optics import Rig
from fringe3d.reconstruct.triangulate import triangulate

from .phase_mapping import FringeDirection, projector_maps


def directions_of(decoded, patterns) -> list[FringeDirection]:
    """The decoder's per-direction maps as :class:`FringeDirection` (plan order)."""
    return [FringeDirection(phase=np.asarray(decoded.phase[p.direction]), angle=float(decoded.angle[p.direction]),
                            period=float(decoded.period[p.direction]),
                            modulation=np.asarray(decoded.modulation[p.direction]),
                            mask=np.asarray(decoded.mask[p.direction])) for p in patterns.plans]


def measure_points(rig: Rig, directions: list[FringeDirection]) -> np.ndarray:
    """(H, W, 3) float64 points (mm) from a calibrated rig and decoded directions: the two
    projector coordinates (any two fringe angles, Eq. 2.30-2.34) and least-squares
    triangulation (``reconstruct.triangulate``: Eq. 2.37, and Eq. 3.3-3.4 for telecentric rigs;
    ``calibrate.telecentric.triangulate_telecentric`` is the sub-pixel point version).

    Parameters
    ----------
    rig : Rig
        The calibrated rig (mm, px).
    directions : list of FringeDirection
        Two or more decoded fringe directions of non-parallel angles (:func:`projector_maps`).

    Returns
    -------
    (H, W, 3) ndarray (float64)
        Points, mm; NaN where the pixel was not triangulated.
    """
    up, vp = (np.ascontiguousarray(a) for a in projector_maps(directions))
    return np.asarray(triangulate(rig, up=up, vp=vp), np.float64)


def rotation_angle_deg(Ra: np.ndarray, Rb: np.ndarray) -> float:
    """Angle (degrees) of the rotation ``Ra Rb^T`` (robust near zero).

    >>> round(rotation_angle_deg(np.eye(3), np.eye(3)), 6)
    0.0
    """
    return float(np.degrees(2 * np.arcsin(min(1.0,
                                              np.linalg.norm(np.asarray(Ra) - np.asarray(Rb)) / (2 * np.sqrt(2))))))


def compare_to_truth(est: Rig, true: Rig) -> dict:
    """Calibrated vs true pinhole rig: relative focal-length errors, principal-point errors (px),
    projector translation error (mm, max abs component and norm) and rotation error (deg).

    Parameters
    ----------
    est : Rig
        The calibrated rig.
    true : Rig
        The true rig (e.g. the simulator's ``rig.json``).

    Returns
    -------
    dict
        ``<device>_focal_rel_error`` and ``<device>_principal_point_error_px`` for each pinhole
        device; for a pinhole rig also ``translation_error_mm``, ``translation_error_norm_mm``
        and ``rotation_error_deg``.
    """
    out = {}
    for name in ("camera", "projector"):
        e, t = getattr(est, name), getattr(true, name)
        if not hasattr(e, "K"):
            continue
        out[f"{name}_focal_rel_error"] = float(max(abs(e.K[0, 0] / t.K[0, 0] - 1), abs(e.K[1, 1] / t.K[1, 1] - 1)))
        out[f"{name}_principal_point_error_px"] = float(np.abs(e.K[:2, 2] - t.K[:2, 2]).max())
    if not est.telecentric:
        out["translation_error_mm"] = float(np.abs(est.projector.t - true.projector.t).max())
        out["translation_error_norm_mm"] = float(np.linalg.norm(est.projector.t - true.projector.t))
        out["rotation_error_deg"] = rotation_angle_deg(est.projector.R, true.projector.R)
    return out
