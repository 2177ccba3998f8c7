"""Point clouds as ASPRS LAS 1.4 / LAZ files (written by laspy; LAZ compressed by lazrs).

LAS stores integer coordinates times a scale: fringe3d writes mm with a scale of 0.001 mm
(1 µm), so coordinates round to the nearest micrometre. LAS has no unit field outside a
coordinate reference system (a measurement in camera coordinates has none): the header's
system identifier says ``fringe3d units: mm`` and a VLR (``fringe3d`` / 1) repeats it with each
extra field's description. Colours go to the standard 16-bit RGB (8-bit value × 257), scalar
attributes to float32 extra-bytes dimensions of the same name (NaN kept), normals to three
float32 extra dimensions ``nx``, ``ny``, ``nz``.
"""
from __future__ import annotations

import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path

from .point_set import PointSet

#: LAS coordinate resolution (mm).
LAS_SCALE_MM = 0.001


def write_las(path: str | os.PathLike, cloud: PointSet) -> Path:
    """Write ``cloud`` as LAS (``.las``) or LAZ (``.laz``, by suffix), mm with a 1 µm scale."""
    try:
        import laspy  # heavy optional dependency (the ``exchange`` extra)
    except ImportError:
        raise ImportError(f"writing LAS/LAZ ({path}) needs laspy: pip install 'fringe3d[exchange]'") from None

    header = laspy.LasHeader(point_format=7 if cloud.colors is not None else 6, version="1.4")
    header.scales = np.full(3, LAS_SCALE_MM)
    header.offsets = np.round(cloud.points.min(axis=0))
    header.system_identifier = "fringe3d units: mm"
    header.generating_software = "fringe3d"
    notes = ["units: mm (coordinates, and every extra field in mm unless its description says otherwise)"]
    extra = dict(cloud.scalars)
    if cloud.normals is not None:
        for i, a in enumerate(("nx", "ny", "nz")):
            extra[a] = (cloud.normals[:, i], "unit normal component")
    for name, (_, what) in extra.items():
        header.add_extra_dim(laspy.ExtraBytesParams(name=name, type=np.float32, description=what[:31]))
        notes.append(f"{name}: {what}")
    header.vlrs.append(laspy.VLR(user_id="fringe3d", record_id=1, description="units and fields",
                                 record_data="\n".join(notes).encode("utf-8")))
    las = laspy.LasData(header)
    las.x, las.y, las.z = (cloud.points[:, i] for i in range(3))
    if cloud.colors is not None:
        las.red, las.green, las.blue = (cloud.colors[:, i].astype(np.uint16) * 257 for i in range(3))
    for name, (values, _) in extra.items():
        las[name] = values.astype(np.float32)
    path = Path(path)
    with atomic_path(path) as tmp:
        las.write(str(tmp))
    return path
