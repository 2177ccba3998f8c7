"""Point clouds as ASTM E57 files (written by pye57 / libE57Format).

E57 fixes its unit to the metre (ASTM E2807, cartesianX/Y/Z), so fringe3d's millimetres are
written as metres (mm / 1000, float64: exact to far below a micrometre) and the scan's name says
``units: m (from fringe3d mm)``. E57 has a fixed set of per-point fields: colours
(``colorRed/Green/Blue``), the pixel ``rowIndex``/``columnIndex`` of an organized map, and one
``intensity``: the first scalar attribute goes there (its name and units in the scan
description); other scalars and normals have no standard E57 field and are not written.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path

from .point_set import PointSet


def write_e57(path: str | os.PathLike, cloud: PointSet) -> Path:
    """Write ``cloud`` as one E57 scan (metres). Returns the path."""
    try:
        import pye57  # heavy optional dependency (the ``exchange`` extra)
    except ImportError:
        raise ImportError(f"writing E57 ({path}) needs pye57: pip install 'fringe3d[exchange]'") from None

    data: dict[str, np.ndarray] = {
        f"cartesian{a}": np.ascontiguousarray(cloud.points[:, i] / 1000.0) for i, a in enumerate("XYZ")}
    description = "fringe3d point cloud; units: m (from fringe3d mm)"
    if cloud.colors is not None:
        for i, c in enumerate(("colorRed", "colorGreen", "colorBlue")):
            data[c] = np.ascontiguousarray(cloud.colors[:, i])
    if cloud.rows is not None and cloud.cols is not None:
        data["rowIndex"] = cloud.rows.astype(np.uint16)
        data["columnIndex"] = cloud.cols.astype(np.uint16)
    if cloud.scalars:
        name, (values, what) = next(iter(cloud.scalars.items()))
        data["intensity"] = np.nan_to_num(values.astype(np.float32), nan=0.0)
        description += f"; intensity: {name} ({what}; NaN written as 0)"
    path = Path(path)
    with atomic_path(path) as tmp:
        e57 = pye57.E57(str(tmp), mode="w")
        try:
            e57.write_scan_raw(data, name=description)
        finally:
            e57.close()
    return path
