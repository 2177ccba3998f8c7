"""Export tracked points with their strain: a CSV with units, and binary VTK XML per frame (meshio)
with a ParaView ``.pvd`` time series.

Every writer goes through :func:`fringe3d.utils.atomic.atomic_path`, so a reader never sees a
half-written file. Columns / point-data arrays (:data:`FIELDS`, units in :data:`UNITS`): ``x, y,
z`` (mm), the strain components ``E11, E12, E22`` (material basis), the principal values ``E_min,
E_max`` and the dominant principal value ``E_dominant`` (all dimensionless, mm/mm), the image
position ``u, v`` (px), the tracking residual (mm) and ``ok`` (1 = tracked and fitted, 0 = flagged;
the strain columns are NaN where ``ok`` is 0, and ``x, y, z`` NaN where the point was lost). The
PVD time steps are seconds when the frame rate is known (``fringe3d strain --frame-rate``), else
frame numbers (the file says which in a comment).
The CSV header spells the unit into each name (``x_mm``, ``E11``, ``u_px``, ...; see :func:`csv_names`).

The per-frame files are VTK XML unstructured grids (``.vtu``, binary, zlib-compressed): meshio
writes no ``.vtp`` polydata, and ``.vtu`` opens the same way in ParaView, VisIt, pyvista and meshio.
Their cells are the triangles of the organized grid of tracked points (two per grid square whose
four corners were tracked in that frame; :func:`grid_triangles`), else one vertex per point.
"""
from __future__ import annotations

import os
from contextlib import ExitStack
from pathlib import Path
from typing import TextIO
from xml.sax.saxutils import quoteattr

import numpy as np

from fringe3d.utils.atomic import atomic_path

__all__ = ["STRAIN_FIELDS", "strain_table", "write_strain_csv", "StrainCsvWriter", "write_strain_frame",
           "write_strain_pvd", "grid_triangles", "csv_names", "FIELDS", "UNITS"]

FIELDS = ["x", "y", "z", "E11", "E12", "E22", "E_min", "E_max", "E_dominant", "u", "v", "residual", "ok"]
#: Unit of each column of :data:`FIELDS` ("" = dimensionless strain or a flag).
UNITS = {"x": "mm", "y": "mm", "z": "mm", "E11": "", "E12": "", "E22": "", "E_min": "", "E_max": "",
         "E_dominant": "", "u": "px", "v": "px", "residual": "mm", "ok": ""}


def csv_names(fields: list[str] | None = None) -> list[str]:
    """CSV column names with their unit: ``x_mm``, ``u_px``, ``residual_mm``; strain and ``ok`` as is.

    Parameters
    ----------
    fields : list of str, optional
        Column names (default :data:`FIELDS`).

    Returns
    -------
    list of str
        ``name_unit`` where the column has a unit, else ``name``.
    """
    return [f"{n}_{UNITS[n]}" if UNITS.get(n) else n for n in (FIELDS if fields is None else fields)]

#: Columns of :data:`FIELDS` that are strain (NaN at a point that is not ``ok``).
STRAIN_FIELDS = ("E11", "E12", "E22", "E_min", "E_max", "E_dominant")


def strain_table(xyz, E, principal, dominant, uv, residual, ok) -> np.ndarray:
    """Stack per-point quantities of one frame into an (N, 13) float64 table (columns FIELDS).

    A point that is not ``ok`` (lost by the tracker or not fitted) has NaN strain columns, and
    NaN ``x, y, z`` where its position is unknown: no finite strain at a point never measured."""
    xyz = np.asarray(xyz, float).reshape(-1, 3)
    n = xyz.shape[0]
    E = np.asarray(E, float).reshape(n, 2, 2)
    cols = [xyz, E[:, 0, 0:1], E[:, 0, 1:2], E[:, 1, 1:2], np.asarray(principal, float).reshape(n, 2),
            np.asarray(dominant, float).reshape(n, 1), np.asarray(uv, float).reshape(n, 2),
            np.asarray(residual, float).reshape(n, 1), np.asarray(ok, float).reshape(n, 1)]
    table = np.hstack(cols)
    bad = (table[:, -1] == 0) | ~np.isfinite(table[:, :3]).all(axis=1)
    table[np.ix_(bad, [FIELDS.index(f) for f in STRAIN_FIELDS])] = np.nan
    table[bad, -1] = 0
    return table


def write_strain_csv(path: str | os.PathLike, table: np.ndarray, frame: np.ndarray | None = None,
                     wing: np.ndarray | None = None) -> None:
    """Write the strain table as CSV, the units in the header row (:func:`csv_names`).

    Parameters
    ----------
    path : path-like
        CSV file to write (atomically).
    table : (N, 13) float
        From :func:`strain_table` (columns :data:`FIELDS`).
    frame, wing : (N,) int, optional
        Leading integer columns ``frame`` and ``wing``.
    """
    table = np.asarray(table, float)
    if table.ndim != 2 or table.shape[1] != len(FIELDS):
        raise ValueError(f"table must have shape (N, {len(FIELDS)}); got {table.shape}")
    with StrainCsvWriter(path, frame is not None, wing is not None) as w:
        w.append(table, frame, wing)


class StrainCsvWriter:
    """``strain.csv`` written as the frames come (:func:`write_strain_csv` in pieces, same text).

    Parameters
    ----------
    path : path-like
        CSV file; written under a temporary name and renamed into place when the block ends
        without an error.
    frame, wing : bool
        Whether the rows carry the leading ``frame`` / ``wing`` columns.

    Use as a context manager and :meth:`append` each piece of the table in row order.
    """

    def __init__(self, path: str | os.PathLike, frame: bool = True, wing: bool = True):
        self.path, self.lead = Path(path), [n for n, on in (("frame", frame), ("wing", wing)) if on]
        self._stack = ExitStack()
        self._fh: TextIO | None = None

    def __enter__(self) -> "StrainCsvWriter":
        tmp = self._stack.enter_context(atomic_path(self.path))
        fh = self._fh = self._stack.enter_context(open(tmp, "w"))
        fh.write(",".join(self.lead + csv_names()) + "\n")
        return self

    def __exit__(self, *exc) -> bool:
        return bool(self._stack.__exit__(*exc))

    def append(self, table: np.ndarray, frame=None, wing=None) -> None:
        """Write the rows of ``table`` (N, 13) (:data:`FIELDS`); ``frame``, ``wing``: (N,) int or one
        int for every row (required when the writer has that column)."""
        table = np.asarray(table, float)
        if table.ndim != 2 or table.shape[1] != len(FIELDS):
            raise ValueError(f"table must have shape (N, {len(FIELDS)}); got {table.shape}")
        lead = []
        for name, col in (("frame", frame), ("wing", wing)):
            if name in self.lead:
                if col is None:
                    raise ValueError(f"{self.path.name} has a {name} column; give each row's {name}")
                lead.append(np.broadcast_to(np.asarray(col).reshape(-1, 1), (table.shape[0], 1)))
        assert self._fh is not None, "StrainCsvWriter used outside its with block"
        for i in range(table.shape[0]):
            head = [str(int(c[i, 0])) for c in lead]
            vals = [("nan" if not np.isfinite(x) else f"{x:.9g}") for x in table[i, :-1]]
            self._fh.write(",".join(head + vals + [str(int(table[i, -1]))]) + "\n")


def grid_triangles(uv: np.ndarray, step: int, ok: np.ndarray | None = None) -> np.ndarray:
    """Triangles ``(M, 3)`` of tracked points that sit on a regular reference grid.

    Parameters
    ----------
    uv : (N, 2) float
        Reference pixel of each point (multiples of ``step``, as :func:`fringe3d.analyze.anchors.query_grid`
        makes them).
    step : int
        Grid spacing (px).
    ok : (N,) bool, optional
        Points usable in this frame; a square with an unusable corner gets no triangles.

    Returns
    -------
    (M, 3) int64
        Point indices, two triangles per grid square whose four corners are present (and ok).
    """
    uv = np.asarray(uv, float).reshape(-1, 2)
    if len(uv) == 0:
        return np.zeros((0, 3), np.int64)
    g = np.round(uv / max(int(step), 1)).astype(np.int64)
    g -= g.min(axis=0)
    index = np.full((int(g[:, 1].max()) + 2, int(g[:, 0].max()) + 2), -1, np.int64)
    use = np.ones(len(uv), bool) if ok is None else np.asarray(ok, bool).reshape(-1)
    index[g[use, 1], g[use, 0]] = np.flatnonzero(use)
    a, b, c, d = index[:-1, :-1], index[:-1, 1:], index[1:, :-1], index[1:, 1:]
    full = (a >= 0) & (b >= 0) & (c >= 0) & (d >= 0)
    a, b, c, d = a[full], b[full], c[full], d[full]
    return np.concatenate([np.stack([a, b, d], 1), np.stack([a, d, c], 1)]).astype(np.int64)


def write_strain_frame(path: str | os.PathLike, table: np.ndarray, triangles: np.ndarray | None = None) -> Path:
    """One frame's tracked points as a binary VTK XML unstructured grid (``.vtu``, meshio).

    Parameters
    ----------
    path : path-like
        File to write (atomically); ``.vtu``.
    table : (N, 13) float
        From :func:`strain_table`; every column but ``x, y, z`` becomes point data (``ok`` as int32).
        Points with non-finite coordinates (untracked) keep NaN coordinates and NaN strain, with
        ``ok = 0``, so indices stay aligned with the CSV; no cell uses them.
    triangles : (M, 3) int, optional
        Surface cells (:func:`grid_triangles`); none or empty: one vertex cell per point.

    Returns
    -------
    Path
        The written file.
    """
    import meshio

    table = np.asarray(table, float)
    if table.ndim != 2 or table.shape[1] != len(FIELDS):
        raise ValueError(f"table must have shape (N, {len(FIELDS)}); got {table.shape}")
    finite = np.isfinite(table[:, :3]).all(axis=1)
    xyz = np.ascontiguousarray(table[:, :3])
    ok = (table[:, -1] * finite).astype(np.int32)
    strain = np.isin(FIELDS, STRAIN_FIELDS)
    if triangles is not None and len(triangles):
        cells = [("triangle", np.asarray(triangles, np.int64).reshape(-1, 3))]
    else:
        cells = [("vertex", np.flatnonzero(finite).astype(np.int64).reshape(-1, 1))]
    data = {name: (ok if name == "ok" else np.where(strain[j] & (ok == 0), np.nan, table[:, j]))
            for j, name in enumerate(FIELDS) if j >= 3}
    path = Path(path)
    with atomic_path(path) as tmp:
        meshio.write(tmp, meshio.Mesh(xyz, cells, point_data=data), file_format="vtu", binary=True,
                     compression="zlib")
    return path


def write_strain_pvd(path: str | os.PathLike, files: list[str | os.PathLike], times: list[float] | None = None,
                     frame_rate: float | None = None) -> Path:
    """A ParaView ``.pvd`` collection: the per-frame files as one time series.

    Parameters
    ----------
    path : path-like
        ``.pvd`` file to write (atomically); the frame files are referenced relative to its folder.
    files : list of path-like
        Per-frame files in frame order (:func:`write_strain_frame`).
    times : list of float, optional
        Time of each frame (s; default: from ``frame_rate``, else the frame index).
    frame_rate : float, optional
        Rate of the frames (Hz): frame ``k`` is at ``k / frame_rate`` s.

    Returns
    -------
    Path
        The written file.
    """
    path = Path(path)
    if frame_rate is not None and not frame_rate > 0:
        raise ValueError(f"frame_rate must be > 0 Hz, got {frame_rate}")
    unit = "s" if times is not None or frame_rate is not None else "frame index (frame rate unknown)"
    if times is None:
        times = [k / frame_rate for k in range(len(files))] if frame_rate else list(range(len(files)))
    times = list(times)
    if len(times) != len(files):
        raise ValueError(f"{len(files)} frame files but {len(times)} times")
    rows = [f'    <DataSet timestep="{t:.9g}" group="" part="0" file={quoteattr(os.path.relpath(f, path.parent))}/>'
            for t, f in zip(times, files)]
    text = ('<?xml version="1.0"?>\n<VTKFile type="Collection" version="0.1" byte_order="LittleEndian">\n'
            f"  <!-- timestep unit: {unit} -->\n  <Collection>\n" + "\n".join(rows) + "\n  </Collection>\n</VTKFile>\n")
    with atomic_path(path) as tmp:
        Path(tmp).write_text(text)
    return path
