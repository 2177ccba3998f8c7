"""Cross-section circle fits through a measured sphere, like the dissertation's figures.

The row and the column of an organized point map that pass closest to the fitted sphere's
centre are each a slice of the sphere by a plane through the camera centre, i.e. a circle.
Fitting a circle to each slice gives profile residuals that are easy to plot and read.
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np

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

    Returns ``{"sphere": SphereFit, "row": Section, "column": Section, "centre_pixel": (i, j)}``.
    Raises ValueError when a section has fewer than ``min_points`` valid points.
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
