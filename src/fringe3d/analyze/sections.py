"""Cross-section circle fits through a measured sphere, like the dissertation's figures.

The row and the column of an organized point map that pass closest to the fitted sphere's
centre are each a slice of the sphere by a plane through the camera centre, i.e. a circle.
Fitting a circle to each slice gives profile residuals that are easy to plot and read.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np
from scipy.sparse import coo_matrix
from scipy.sparse.csgraph import connected_components

from .fits import CircleFit, SphereFit, fit_circle, fit_sphere


@dataclass
class Section:
    """One cross section: ``axis`` ("row" or "column"), ``index`` (row or column number),
    ``pixels (N,)`` column (for a row) or row indices of the valid points, ``points (N, 3)``,
    ``fit`` (:class:`CircleFit`), ``residuals (N,)`` (mm)."""

    axis: str
    index: int
    pixels: np.ndarray
    points: np.ndarray
    fit: CircleFit

    @property
    def residuals(self) -> np.ndarray:
        return self.fit.residuals


def centre_pixel(points: np.ndarray, sphere: SphereFit, mask=None) -> tuple[int, int]:
    """(row, column) of the valid point whose ray passes closest to the sphere centre, i.e. the
    point nearest the centre after removing the depth along the line of sight."""
    P = np.asarray(points, float)
    valid = np.all(np.isfinite(P), axis=-1)
    if mask is not None:
        valid &= np.asarray(mask, bool)
    if not valid.any():
        raise ValueError("cross sections: no valid point under the mask")
    c = sphere.center
    u = c / np.linalg.norm(c)  # line of sight to the centre (camera at the origin)
    d = P - c
    lateral = d - (d @ u)[..., None] * u
    dist = np.where(valid, np.linalg.norm(lateral, axis=-1), np.inf)
    i, j = np.unravel_index(np.argmin(dist), dist.shape)
    return int(i), int(j)


def sphere_sections(points, mask=None, sphere: SphereFit | None = None, min_points: int = 10) -> dict:
    """Circle fits of the row and the column through the sphere centre.

    Raises ValueError when a section has fewer than ``min_points`` valid points.

    Parameters
    ----------
    points : (H, W, 3) array_like
        Organized point map, mm (NaN = invalid), camera at the origin.
    mask : (H, W) bool array, optional
        The sphere's pixels; default every finite point.
    sphere : SphereFit, optional
        A sphere already fitted; default :func:`fit_sphere` of ``points`` under ``mask``.
    min_points : int
        Fewest valid points a section may have.

    Returns
    -------
    dict
        ``{"sphere": SphereFit, "row": Section, "column": Section, "centre_pixel": (i, j)}``.
    """
    P = np.asarray(points, float)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"cross sections need an organized point map (H, W, 3), got {P.shape}")
    sphere = sphere or fit_sphere(P, mask)
    i, j = centre_pixel(P, sphere, mask)
    valid = np.all(np.isfinite(P), axis=-1)
    if mask is not None:
        valid &= np.asarray(mask, bool)
    out = {"sphere": sphere, "centre_pixel": (i, j)}
    for axis, line, ok in (("row", P[i], valid[i]), ("column", P[:, j], valid[:, j])):
        idx = np.flatnonzero(ok)
        if idx.size < min_points:
            raise ValueError(f"cross section along {axis} {i if axis == 'row' else j}: only {idx.size} valid points, "
                             f"need {min_points}")
        out[axis] = Section(axis, i if axis == "row" else j, idx, line[idx], fit_circle(line[idx]))
    return out


def segments(points, max_jump: float | None = None, min_size: int = 50) -> np.ndarray:
    """Label the smooth surface pieces of an organized point map.

    Neighbouring valid pixels (4-connectivity) belong to the same piece when their 3D distance
    is below ``max_jump`` (mm; default 8x the median neighbour spacing), so a sphere in front
    of a wall separates from it at its silhouette.

    Parameters
    ----------
    points : (H, W, 3) array_like
        Organized point map, mm (NaN = invalid).
    max_jump : float, optional
        Largest 3D distance between neighbours of one piece, mm; default 8x the median
        neighbour spacing.
    min_size : int
        Smallest piece kept, pixels.

    Returns
    -------
    (H, W) ndarray (int32)
        Labels 0..n-1, largest piece first; -1 for invalid pixels and pieces smaller than
        ``min_size``.
    """
    P = np.asarray(points, float)
    if P.ndim != 3 or P.shape[-1] != 3:
        raise ValueError(f"segmentation needs an organized point map (H, W, 3), got {P.shape}")
    H, W = P.shape[:2]
    valid = np.all(np.isfinite(P), axis=-1)
    idx = np.arange(H * W).reshape(H, W)
    pairs, dists = [], []
    for a, b in (((slice(None), slice(None, -1)), (slice(None), slice(1, None))),
                 ((slice(None, -1), slice(None)), (slice(1, None), slice(None)))):
        ok = valid[a] & valid[b]
        d = np.linalg.norm(P[a] - P[b], axis=-1)
        pairs.append(np.stack([idx[a][ok], idx[b][ok]], axis=1))
        dists.append(d[ok])
    pairs = np.concatenate(pairs)
    dists = np.concatenate(dists)
    labels = np.full(H * W, -1, np.int32)
    if len(dists) == 0:
        return labels.reshape(H, W)
    jump = 8.0 * float(np.median(dists)) if max_jump is None else float(max_jump)
    keep = dists < jump
    g = coo_matrix((np.ones(int(keep.sum())), (pairs[keep, 0], pairs[keep, 1])), shape=(H * W, H * W))
    _, comp = connected_components(g, directed=False)
    comp = np.where(valid.ravel(), comp, -1)
    ids, counts = np.unique(comp[comp >= 0], return_counts=True)
    order = np.argsort(-counts)
    for new, k in enumerate(o for o in order if counts[o] >= min_size):
        labels[comp == ids[k]] = new
    return labels.reshape(H, W)
