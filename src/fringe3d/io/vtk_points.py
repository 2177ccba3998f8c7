"""Point clouds as VTK XML PolyData (``.vtp``): the file ParaView and PyVista read whole.

VTK's PLY reader (``vtkPLYReader``, behind ParaView's and PyVista's ``.ply``) keeps only points,
normals, colours and texture coordinates: every other vertex property (fringe3d's
``scalar_<name>`` fields) is dropped. A ``.vtp`` holds the same points with every field:

* points: ``Float32`` x, y, z in mm (the same numbers as the PLY);
* point data ``Normals`` (unit, 3 components; the active normals) when known, ``RGB`` (``UInt8``,
  3 components) when coloured, and one ``Float32`` array per scalar field under its plain name
  (``roughness_mm``, ``sigma_z_mm``; NaN where unknown);
* one vertex cell per point (so ParaView draws them as points);
* field data ``fringe3d``: one string per header line (``units: mm``, the fringe3d version,
  ``command:``, one ``<name>: <description>`` line per scalar field), as the PLY's comments.

Arrays are inline, base64 binary with a 64-bit length header (no compression: no extra
dependency, and VTK, ParaView and PyVista read it as is). The file appears only once it is
complete (:func:`fringe3d.utils.atomic.atomic_path`).
"""
from __future__ import annotations

import base64
import os
from pathlib import Path

import numpy as np

from fringe3d.utils.atomic import atomic_path
from fringe3d.utils.output_folder import provenance_comments

from .ply_standard import measurement_scalars
from .point_set import PointSet, point_set

#: VTK XML type name of each numpy dtype written.
_VTK_TYPES = {np.dtype("<f4"): "Float32", np.dtype("u1"): "UInt8", np.dtype("<i8"): "Int64"}


def _array(values: np.ndarray, name: str | None = None, indent: str = "        ") -> str:
    a = np.ascontiguousarray(values)
    a = a.astype(a.dtype.newbyteorder("<")) if a.dtype.byteorder == ">" else a
    comps = 1 if a.ndim == 1 else a.shape[1]
    data = a.tobytes()
    text = base64.b64encode(np.uint64(len(data)).tobytes() + data).decode("ascii")
    named = f' Name="{name}"' if name else ""
    return (f'{indent}<DataArray type="{_VTK_TYPES[a.dtype]}"{named} NumberOfComponents="{comps}" '
            f'format="binary">{text}</DataArray>')


def _strings(name: str, lines: list[str]) -> str:
    """A VTK ``String`` array in ASCII: each string's UTF-8 bytes as integers, each ended by 0."""
    codes = " ".join(" ".join([*(str(b) for b in s.encode("utf-8")), "0"]) for s in lines)
    return (f'      <FieldData>\n        <DataArray type="String" Name="{name}" NumberOfTuples="{len(lines)}" '
            f'format="ascii">{codes}</DataArray>\n      </FieldData>')


def _check_name(path, name: str) -> None:
    if not name or any(c in name for c in '<>&"\''):
        raise ValueError(f"cannot write the field {name!r} to {path}: a VTK array name must be non-empty "
                         "without <, >, &, or quotes")


def write_vtp(path: str | os.PathLike, cloud: PointSet) -> Path:
    """Write ``cloud`` as VTK XML PolyData (``.vtp``), atomically; see the module docstring.

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.vtp`` file.
    cloud : PointSet
        The valid points (mm), their colours, normals and scalar fields.

    Returns
    -------
    pathlib.Path
        The path written.

    Raises
    ------
    ValueError
        When a scalar field's name cannot be a VTK array name.
    """
    n = len(cloud.points)
    point_data = []
    if cloud.normals is not None:
        point_data.append(_array(np.asarray(cloud.normals, "<f4"), "Normals"))
    if cloud.colors is not None:
        point_data.append(_array(np.asarray(cloud.colors, np.uint8), "RGB"))
    notes = ["units: mm", *provenance_comments()]
    for name, (values, description) in cloud.scalars.items():
        _check_name(path, name)
        point_data.append(_array(np.asarray(values, "<f4"), name))
        notes.append(f"{name}: {description}")
    active = ' Normals="Normals"' if cloud.normals is not None else ""
    ids = np.arange(n, dtype="<i8")
    xml = "\n".join([
        '<?xml version="1.0"?>',
        '<VTKFile type="PolyData" version="1.0" byte_order="LittleEndian" header_type="UInt64">',
        "  <PolyData>",
        _strings("fringe3d", notes),
        f'    <Piece NumberOfPoints="{n}" NumberOfVerts="{n}" NumberOfLines="0" NumberOfStrips="0" '
        'NumberOfPolys="0">',
        f"      <PointData{active}>", *point_data, "      </PointData>",
        "      <Points>", _array(np.asarray(cloud.points, "<f4")), "      </Points>",
        "      <Verts>", _array(ids, "connectivity"), _array(ids + 1, "offsets"), "      </Verts>",
        "    </Piece>",
        "  </PolyData>",
        "</VTKFile>",
        ""])
    path = Path(path)
    with atomic_path(path) as tmp:
        Path(tmp).write_text(xml, encoding="utf-8")
    return path


def write_measurement_vtp(path: str | os.PathLike, points, colors=None, sigma_z=None, mask=None) -> Path:
    """A reconstructed point map as the ``.vtp`` beside its PLY: the same points, normals, colours
    and scalar fields (:func:`fringe3d.io.ply_standard.measurement_scalars`).

    Parameters
    ----------
    path : str or os.PathLike
        Output ``.vtp`` file.
    points : (H, W, 3) organized map, float, mm, NaN = no point
    colors : grey (H, W) or RGB (H, W, 3) texture, float [0, 1] or uint8, optional
    sigma_z : (H, W) predicted depth standard deviation (mm), optional
    mask : (H, W) bool, optional
        Points to keep (besides being finite).

    Returns
    -------
    pathlib.Path
        The path written.
    """
    P = np.asarray(points, np.float32)
    if mask is not None:
        P = np.where(np.asarray(mask, bool)[..., None], P, np.nan)
    return write_vtp(path, point_set(path, P, measurement_scalars(P, sigma_z), colors=colors))
