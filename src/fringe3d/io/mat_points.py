"""Point clouds as MATLAB ``.mat`` files (scipy.io, MAT 5 format, readable by MATLAB and Octave).

Variables: ``points`` (N×3 double, mm), ``units`` (``'mm'``), ``colors`` (N×3 uint8) and
``normals`` (N×3 single) when present, ``row``/``col`` (N×1 double, 1-based pixel indices, as
MATLAB indexes) for an organized map, one N×1 single per scalar attribute (NaN kept) and
``fields`` (a struct: each variable's description with its units).
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.output_folder import provenance_comments

from .point_set import PointSet


def write_mat(path: str | os.PathLike, cloud: PointSet) -> Path:
    """Write ``cloud`` as a ``.mat`` file (module docstring for the variables)."""
    import scipy.io

    data: dict[str, object] = {"points": cloud.points, "units": "mm"}
    fields = {"points": "x, y, z in mm (camera frame)", "units": "length unit of points and of every *_mm field"}
    if cloud.colors is not None:
        data["colors"], fields["colors"] = cloud.colors, "red, green, blue, 0-255"
    if cloud.normals is not None:
        data["normals"], fields["normals"] = cloud.normals.astype(np.float32), "unit normals"
    if cloud.rows is not None and cloud.cols is not None:
        data["row"] = (cloud.rows + 1.0)[:, None]
        data["col"] = (cloud.cols + 1.0)[:, None]
        fields["row"] = fields["col"] = "1-based pixel row / column in the organized map"
    for name, (values, what) in cloud.scalars.items():
        if name in data:
            raise ValueError(f"attribute name {name!r} for {path} clashes with a fixed .mat variable")
        data[name], fields[name] = values.astype(np.float32)[:, None], what
    data["fields"] = fields
    data["provenance"] = "\n".join(provenance_comments())
    path = Path(path)
    with atomic_path(path) as tmp:
        scipy.io.savemat(str(tmp), data, do_compression=True, oned_as="column")
    return path
