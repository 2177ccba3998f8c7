"""Is a surface piece a sphere or a plane? Decided by closed-form fits, no iteration.

The plane RMS is the square root of the smallest eigenvalue of the points' covariance
(total least squares); the sphere RMS is that of the radial residuals of the algebraic
(Kasa) sphere, :func:`fringe3d.analyze.fits.sphere_algebraic_rms`. Both cost one pass over
the points, so classifying a 1 M-point segment takes milliseconds instead of the seconds a
geometric Levenberg-Marquardt fit needs; only the model chosen is then refined.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

from .fits import sphere_algebraic_rms

#: segments larger than this are classified on an even subsample (the decision, not the figures)
MAX_CLASSIFY_POINTS = 200_000


@dataclass
class ShapeGuess:
    """Closed-form evidence for one piece (mm): ``plane_rms``, ``sphere_rms``, ``radius`` of the
    algebraic sphere, ``extent`` (diagonal of the bounding box), ``kind`` ("sphere"/"plane")."""

    plane_rms: float
    sphere_rms: float
    radius: float
    extent: float
    kind: str


def plane_rms(xyz: np.ndarray) -> float:
    """RMS distance (mm) of ``xyz (N, 3)`` to its total-least-squares plane:
    ``sqrt(lambda_min(cov))`` with ``cov = (X - mean)^T (X - mean) / N``."""
    d = xyz - xyz.mean(axis=0)
    return float(np.sqrt(max(np.linalg.eigvalsh(d.T @ d / len(d))[0], 0.0)))


def subsample(xyz: np.ndarray, limit: int = MAX_CLASSIFY_POINTS) -> np.ndarray:
    """Every k-th point so that at most ``limit`` remain (deterministic)."""
    step = max(1, -(-len(xyz) // limit))
    return xyz[::step]


def guess_shape(xyz: np.ndarray) -> ShapeGuess:
    """Sphere or plane for ``xyz (N, 3)`` mm (N >= 4).

    A piece is sphere-like when the algebraic sphere has a radius below twice the piece's
    extent and less than half the plane's RMS; every other piece is plane-like (the rule of
    the former Levenberg-Marquardt classification, with closed-form fits).
    """
    p = subsample(np.asarray(xyz, np.float64))
    extent = float(np.linalg.norm(p.max(axis=0) - p.min(axis=0)))
    prms = plane_rms(p)
    try:
        _, r, srms = sphere_algebraic_rms(p)
    except ValueError:
        r, srms = float("inf"), float("inf")
    kind = "sphere" if (r < 2 * extent and srms < 0.5 * prms) else "plane"
    return ShapeGuess(prms, srms, r, extent, kind)


def is_exact(xyz: np.ndarray, kind: str, rel: float = 1e-4) -> bool:
    """Whether noise-free truth points ``xyz (N, 3)`` lie on a ``kind`` surface: closed-form fit
    RMS below ``rel * max(radius, 1 mm)`` (spheres also need a radius below 1e5 mm)."""
    p = subsample(np.asarray(xyz, np.float64))
    if kind == "plane":
        return plane_rms(p) < rel
    try:
        _, r, srms = sphere_algebraic_rms(p)
    except ValueError:
        return False
    return bool(srms < rel * max(r, 1.0) and r < 1e5)
