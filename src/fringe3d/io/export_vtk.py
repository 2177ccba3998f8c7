"""Export tracked points with their strain: CSV and legacy-ASCII VTK polydata (ParaView, VisIt).

Both writers go through :func:`fringe3d.utils.atomic.atomic_path`, so a reader never sees a
half-written file. Columns / point-data arrays: ``x, y, z`` (mm), the strain components
``E11, E12, E22`` (material basis), the principal values ``E_min, E_max``, the dominant
principal value ``E_dominant``, the image position ``u, v`` (px), the tracking residual (mm)
and ``ok`` (1 = tracked and fitted, 0 = flagged).
"""
from __future__ import annotations

import os

import numpy as np

from fringe3d.utils.atomic import atomic_path

__all__ = ["strain_table", "write_strain_csv", "write_strain_vtk", "FIELDS"]

FIELDS = ["x", "y", "z", "E11", "E12", "E22", "E_min", "E_max", "E_dominant", "u", "v", "residual", "ok"]


def strain_table(xyz, E, principal, dominant, uv, residual, ok) -> np.ndarray:
    """Stack per-point quantities of one frame into an (N, 13) float64 table (columns FIELDS)."""
    xyz = np.asarray(xyz, float).reshape(-1, 3)
    n = xyz.shape[0]
    E = np.asarray(E, float).reshape(n, 2, 2)
    cols = [xyz, E[:, 0, 0:1], E[:, 0, 1:2], E[:, 1, 1:2], np.asarray(principal, float).reshape(n, 2),
            np.asarray(dominant, float).reshape(n, 1), np.asarray(uv, float).reshape(n, 2),
            np.asarray(residual, float).reshape(n, 1), np.asarray(ok, float).reshape(n, 1)]
    return np.hstack(cols)


def write_strain_csv(path: str | os.PathLike, table: np.ndarray, frame: np.ndarray | None = None,
                     wing: np.ndarray | None = None) -> None:
    """CSV with a header row; optional leading integer columns ``frame`` and ``wing``."""
    table = np.asarray(table, float)
    if table.ndim != 2 or table.shape[1] != len(FIELDS):
        raise ValueError(f"table must have shape (N, {len(FIELDS)}); got {table.shape}")
    lead, names = [], []
    for name, col in (("frame", frame), ("wing", wing)):
        if col is not None:
            lead.append(np.asarray(col).reshape(-1, 1))
            names.append(name)
    with atomic_path(path) as tmp, open(tmp, "w") as fh:
        fh.write(",".join(names + FIELDS) + "\n")
        for i in range(table.shape[0]):
            head = [str(int(c[i, 0])) for c in lead]
            vals = [("nan" if not np.isfinite(x) else f"{x:.9g}") for x in table[i, :-1]]
            fh.write(",".join(head + vals + [str(int(table[i, -1]))]) + "\n")


def write_strain_vtk(path: str | os.PathLike, table: np.ndarray, title: str = "fringe3d tracked points") -> None:
    """Legacy ASCII VTK POLYDATA: one vertex per point, every FIELDS column as POINT_DATA scalars.

    Points with non-finite coordinates are written at the origin with ``ok = 0`` so indices
    stay aligned with the CSV.
    """
    table = np.asarray(table, float)
    if table.ndim != 2 or table.shape[1] != len(FIELDS):
        raise ValueError(f"table must have shape (N, {len(FIELDS)}); got {table.shape}")
    n = table.shape[0]
    xyz = np.nan_to_num(table[:, :3], nan=0.0, posinf=0.0, neginf=0.0)
    ok = table[:, -1] * np.isfinite(table[:, :3]).all(axis=1)
    lines = ["# vtk DataFile Version 3.0", title[:255].replace("\n", " "), "ASCII", "DATASET POLYDATA",
             f"POINTS {n} double"]
    lines += [f"{a:.9g} {b:.9g} {c:.9g}" for a, b, c in xyz]
    lines += [f"VERTICES {n} {2 * n}"] + [f"1 {i}" for i in range(n)]
    lines += [f"POINT_DATA {n}"]
    for j, name in enumerate(FIELDS[3:], start=3):
        col = ok if name == "ok" else table[:, j]
        typ = "int" if name == "ok" else "double"
        lines += [f"SCALARS {name} {typ} 1", "LOOKUP_TABLE default"]
        if name == "ok":
            lines += [str(int(x)) for x in col]
        else:
            lines += [("nan" if not np.isfinite(x) else f"{x:.9g}") for x in col]
    with atomic_path(path) as tmp:
        tmp.write_text("\n".join(lines) + "\n")
