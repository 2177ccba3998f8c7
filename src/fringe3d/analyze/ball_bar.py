"""VDI/VDE 2634 part 3 sphere spacing on a merged (multi-view) cloud.

A ball bar measured from several views and fused into one unorganised cloud (``fringe3d merge``'s
``fused.ply``) has no pixel grid to separate its spheres. They are picked either by their true
centres (a ``spheres.json`` of the simulator, :func:`read_spheres`) or, on a real bar of
calibrated sphere diameter, found by :func:`find_spheres` (each point votes for the centre one
radius behind it along its normal; the two strongest, well-separated votes win). Each sphere is
then the shell of points within ``margin`` of its nominal surface, fitted with a free radius under
the outlier rule (:func:`fringe3d.analyze.evaluation.spacing_figures`): the spacing error
``SD = |c_a − c_b| − L`` and each sphere's form error ``P_F``.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np
from fringe3d.utils.jsonfile import read_format_json
from scipy.spatial import cKDTree

SPHERES_FORMAT = "fringe3d-spheres"


def read_spheres(path: str | os.PathLike) -> tuple[np.ndarray, np.ndarray]:
    """True sphere centres (K, 3) and radii (K,) (mm) from a ``spheres.json`` (or a folder holding
    one: a simulated multi-view sequence); ValueError naming the file and field."""
    path = Path(path)
    f = path / "spheres.json" if path.is_dir() else path
    if not f.is_file():
        raise ValueError(f"no spheres.json at {path} (expected the folder of a simulated multi-view "
                         "sequence of a scene with spheres, or its spheres.json)")
    doc = read_format_json(f, "spheres file", SPHERES_FORMAT)
    spheres = doc.get("spheres")
    if not isinstance(spheres, list) or not spheres:
        raise ValueError(f"{f}: field 'spheres' must be a non-empty list")
    try:
        C = np.array([s["centre_mm"] for s in spheres], float)
        r = np.array([s["radius_mm"] for s in spheres], float)
    except (KeyError, TypeError, ValueError):
        raise ValueError(f"{f}: each of 'spheres' needs 'centre_mm' (3 numbers) and 'radius_mm'") from None
    if C.shape != (len(spheres), 3) or not (np.all(np.isfinite(C)) and np.all(r > 0)):
        raise ValueError(f"{f}: 'centre_mm' must be 3 finite numbers and 'radius_mm' > 0 for every sphere")
    return C, r


def bar_spheres(centres, radii) -> tuple[np.ndarray, float]:
    """The ball bar's two spheres among ``centres`` (K, 3) / ``radii`` (K,): the two largest (a
    knob or other small sphere is not one of them); ``(centres (2, 3), radius)``."""
    C, r = np.asarray(centres, float), np.asarray(radii, float)
    if len(C) < 2:
        raise ValueError(f"a ball bar has two spheres; the truth holds {len(C)}")
    k = np.argsort(-r, kind="stable")[:2]
    if not np.isclose(r[k[0]], r[k[1]], rtol=1e-6):
        raise ValueError(f"the two largest spheres differ in radius ({r[k[0]]:g} and {r[k[1]]:g} mm): not a ball bar")
    return C[np.sort(k)], float(r[k[0]])


def _normals(P: np.ndarray, k: int = 16) -> np.ndarray:
    _, idx = cKDTree(P).query(P, k=min(k, len(P)))
    Q = P[idx] - P[idx].mean(1, keepdims=True)
    _, vec = np.linalg.eigh(np.einsum("nki,nkj->nij", Q, Q))
    return vec[:, :, 0]


def find_spheres(points, radius: float, n: int = 2, max_points: int = 200_000, seed: int = 0) -> np.ndarray:
    """Centres (n, 3) mm of the ``n`` spheres of radius ``radius`` mm in an unorganised cloud.

    Every point (at most ``max_points``, a seeded subsample) votes for the two candidate
    centres ``p ± radius · n`` (``n`` its PCA normal over 16 neighbours) in cells of
    ``radius / 8``; the most voted cell, refined by the mean of its votes, is a centre, and the
    next is the most voted cell at least 1.5 radii from those found. ValueError when a sphere
    gets fewer than 30 votes.
    """
    P = np.asarray(points, float).reshape(-1, 3)
    P = P[np.all(np.isfinite(P), axis=1)]
    if not radius > 0:
        raise ValueError(f"radius must be > 0 mm, got {radius}")
    if len(P) > max_points:
        P = P[np.random.default_rng(seed).choice(len(P), max_points, replace=False)]
    if len(P) < 30 * n:
        raise ValueError(f"only {len(P)} points: too few to find {n} spheres")
    N = _normals(P)
    V = np.concatenate([P + radius * N, P - radius * N])
    cell = radius / 8
    keys, inv, counts = np.unique(np.floor(V / cell).astype(np.int64), axis=0, return_inverse=True,
                                  return_counts=True)
    inv = inv.ravel()
    order = np.argsort(-counts, kind="stable")
    found: list[np.ndarray] = []
    for kcell in order:
        if len(found) == n:
            break
        c0 = (keys[kcell] + 0.5) * cell
        if any(np.linalg.norm(c0 - f) < 1.5 * radius for f in found):
            continue
        votes = V[np.linalg.norm(V - c0, axis=1) < 2 * cell]
        if len(votes) < 30:
            break
        found.append(votes.mean(0))
    if len(found) < n:
        raise ValueError(f"found {len(found)} sphere(s) of radius {radius:g} mm in the cloud, need {n} "
                         "(check the calibrated diameter, or give the true centres)")
    return np.stack(found)


def shell_masks(points, centres, radius: float, margin: float) -> list[np.ndarray]:
    """Per centre, the points within ``margin`` mm of that sphere's nominal surface."""
    P = np.asarray(points, float).reshape(-1, 3)
    return [np.abs(np.linalg.norm(P - c, axis=1) - radius) < margin for c in np.asarray(centres, float)]
