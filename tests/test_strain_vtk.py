"""Strain outputs other tools read: binary VTK XML frames (meshio, pyvista), a PVD series, a CSV with units."""
from __future__ import annotations

import xml.etree.ElementTree as ET

import meshio
import numpy as np
import pytest

from fringe3d.io.export_vtk import (FIELDS, csv_names, grid_triangles, strain_table, write_strain_csv,
                                    write_strain_frame, write_strain_pvd)


def _frame(step: int = 4, nu: int = 5, nv: int = 4, seed: int = 0):
    v, u = np.mgrid[0:nv * step:step, 0:nu * step:step]
    uv = np.stack([u.ravel(), v.ravel()], 1).astype(float)
    n = len(uv)
    rng = np.random.default_rng(seed)
    xyz = np.column_stack([uv * 0.1, 500 + rng.normal(0, 0.01, n)])
    ok = np.ones(n, bool)
    ok[3] = False
    xyz[7] = np.nan  # lost point: written with NaN position and strain, ok = 0
    ok[7] = False
    E = rng.normal(0, 1e-3, (n, 2, 2))
    residual = np.abs(rng.normal(0, 0.01, n))
    table = strain_table(xyz, E, rng.normal(0, 1e-3, (n, 2)), rng.normal(0, 1e-3, n), uv, residual, ok)
    return table, uv, ok


def test_grid_triangles_cover_the_squares_with_all_corners_ok():
    _, uv, ok = _frame()
    tri = grid_triangles(uv, 4)
    assert tri.shape == (2 * 4 * 3, 3)  # 5 x 4 points: 4 x 3 squares, two triangles each
    tri_ok = grid_triangles(uv, 4, ok)
    assert not np.isin(tri_ok, np.flatnonzero(~ok)).any() and len(tri_ok) < len(tri)
    assert grid_triangles(np.zeros((0, 2)), 4).shape == (0, 3)


def test_frames_and_series_read_back_with_meshio_and_pyvista(tmp_path):
    files = []
    tables = []
    for f in range(3):
        table, uv, ok = _frame(seed=f)
        tables.append(table)
        files.append(write_strain_frame(tmp_path / "vtk" / f"frame_{f:05d}.vtu", table, grid_triangles(uv, 4, ok)))
    pvd = write_strain_pvd(tmp_path / "strain.pvd", files, times=[0.0, 0.5, 1.0])
    assert b"<AppendedData" in files[0].read_bytes() or b'format="binary"' in files[0].read_bytes()
    m = meshio.read(files[1])
    table = tables[1]
    assert m.points.shape == (len(table), 3) and "triangle" in m.cells_dict
    assert not np.isin(m.cells_dict["triangle"], [3, 7]).any()
    for j, name in enumerate(FIELDS[3:], start=3):
        want = table[:, j] if name != "ok" else table[:, j] * np.isfinite(table[:, :3]).all(axis=1)
        np.testing.assert_allclose(m.point_data[name], want, err_msg=name, equal_nan=True)
    assert np.isnan(m.points[7]).all() and m.point_data["ok"][7] == 0
    root = ET.parse(pvd).getroot()
    sets = root.findall("./Collection/DataSet")
    assert [d.get("file") for d in sets] == [f"vtk/frame_{f:05d}.vtu" for f in range(3)]
    assert [float(d.get("timestep")) for d in sets] == [0.0, 0.5, 1.0]
    pv = pytest.importorskip("pyvista")
    grid = pv.read(files[1])
    assert grid.n_points == len(table) and "E_dominant" in grid.point_data
    series = pv.get_reader(str(pvd))
    assert len(series.time_values) == 3
    series.set_active_time_value(1.0)
    last = series.read()
    assert last[0].n_points == len(tables[2])


def test_vertex_cells_without_triangles(tmp_path):
    table, _, _ = _frame()
    m = meshio.read(write_strain_frame(tmp_path / "f.vtu", table))
    assert m.cells_dict["vertex"].shape == (len(table) - 1, 1)  # none for the lost point 7


def test_csv_header_carries_units(tmp_path):
    table, _, _ = _frame()
    write_strain_csv(tmp_path / "s.csv", table, frame=np.zeros(len(table)), wing=np.zeros(len(table)))
    header = (tmp_path / "s.csv").read_text().splitlines()[0].split(",")
    assert header == ["frame", "wing"] + csv_names()
    assert header[2:5] == ["x_mm", "y_mm", "z_mm"] and "u_px" in header and "residual_mm" in header
    assert "E_dominant" in header and header[-1] == "ok"
    data = np.genfromtxt(tmp_path / "s.csv", delimiter=",", names=True)
    np.testing.assert_allclose(data["E_dominant"], table[:, FIELDS.index("E_dominant")])


def test_untracked_points_have_nan_position_and_nan_strain_in_vtu_and_csv(tmp_path):
    pv = pytest.importorskip("pyvista")  # VTK's reader, independent of the meshio writer
    table, _, ok = _frame()
    grid = pv.read(write_strain_frame(tmp_path / "f.vtu", table))
    pts = np.asarray(grid.points)
    assert np.isnan(pts[7]).all() and np.isfinite(np.delete(pts, 7, axis=0)).all()
    for name in ("E11", "E12", "E22", "E_min", "E_max", "E_dominant"):
        values = np.asarray(grid.point_data[name])
        np.testing.assert_array_equal(np.isnan(values), ~ok, err_msg=name)  # point 3 flagged, point 7 lost
    write_strain_csv(tmp_path / "s.csv", table)
    data = np.genfromtxt(tmp_path / "s.csv", delimiter=",", names=True)
    assert np.isnan(data["x_mm"][7]) and np.isnan(data["E_dominant"][[3, 7]]).all() and data["ok"][7] == 0


def test_pvd_time_steps_in_seconds_from_a_frame_rate_else_frame_numbers(tmp_path):
    pv = pytest.importorskip("pyvista")
    table, uv, ok = _frame()
    files = [write_strain_frame(tmp_path / f"f{k}.vtu", table) for k in range(3)]
    pvd = write_strain_pvd(tmp_path / "s.pvd", files, frame_rate=250.0)
    np.testing.assert_allclose(pv.get_reader(str(pvd)).time_values, [0.0, 0.004, 0.008], atol=1e-12)
    assert "timestep unit: s" in pvd.read_text()
    plain = write_strain_pvd(tmp_path / "p.pvd", files)
    np.testing.assert_allclose(pv.get_reader(str(plain)).time_values, [0, 1, 2])
    assert "frame index" in plain.read_text()
    with pytest.raises(ValueError, match="frame_rate"):
        write_strain_pvd(tmp_path / "x.pvd", files, frame_rate=0.0)
