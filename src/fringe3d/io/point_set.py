"""One point list in the shape every point-cloud writer takes (:mod:`fringe3d.io.export`)."""
from __future__ import annotations

from dataclasses import dataclass, field

import numpy as np

from .point_attributes import colors_u8, grid_normals


@dataclass
class PointSet:
    """Valid points of a measurement, one row each.

    Attributes
    ----------
    points : (N, 3) float64, mm, finite
    colors : (N, 3) uint8 or None
    normals : (N, 3) float32 unit vectors or None
    scalars : ``name -> (values (N,) float32, description with units)``
    rows, cols : (N,) int pixel row / column of each point in its organized map, or None
    """

    points: np.ndarray
    colors: np.ndarray | None = None
    normals: np.ndarray | None = None
    scalars: dict[str, tuple[np.ndarray, str]] = field(default_factory=dict)
    rows: np.ndarray | None = None
    cols: np.ndarray | None = None


def point_set(path, points, attributes=None, *, colors=None, normals: bool = True, mask=None) -> PointSet:
    """The valid points of an organized map ``(H, W, 3)`` (with pixel rows/columns and grid
    normals) or a list ``(N, 3)`` (mm, NaN = no point), their colours (grey or RGB, float [0, 1]
    or uint8) and scalar ``attributes`` (``name -> (values of the points' leading shape,
    description)``). ValueError naming ``path`` when no point is valid or a shape disagrees."""
    P = np.asarray(points, np.float64)
    if P.ndim not in (2, 3) or P.shape[-1] != 3:
        raise ValueError(f"points for {path} must be an organized map (H, W, 3) or a list (N, 3) in mm, "
                         f"got {P.shape}")
    lead = P.shape[:-1]
    valid = np.all(np.isfinite(P), axis=-1)
    if mask is not None:
        if np.shape(mask) != lead:
            raise ValueError(f"mask for {path} has shape {np.shape(mask)}; expected {lead}")
        valid &= np.asarray(mask, bool)
    if not valid.any():
        raise ValueError(f"no valid point to write to {path} (all NaN or masked); expected at least one finite point")
    out = PointSet(P[valid])
    if P.ndim == 3:
        rows, cols = np.nonzero(valid)
        out.rows, out.cols = rows, cols
        if normals:
            out.normals = grid_normals(np.where(valid[..., None], P, np.nan))[valid]
    if colors is not None:
        out.colors = colors_u8(colors, lead)[valid]
    for name, (values, description) in (attributes or {}).items():
        v = np.asarray(values, np.float32)
        if v.shape != lead:
            raise ValueError(f"attribute {name!r} for {path} must be one value per point {lead}, got {v.shape}")
        out.scalars[name] = (v[valid], description)
    return out
