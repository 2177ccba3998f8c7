"""``fringe3d export``: a reconstruct folder (or a PLY) in every exchange format, read back by an
independent reader; and the reconstruct PLY opened by Open3D, PyVista, MeshLab (pymeshlab) and
CloudCompare's command line, each scalar field compared with the folder's own maps: Open3D and
CloudCompare keep every field, VTK's PLY reader and MeshLab's drop them (the ``.vtp`` beside the
PLY and :func:`fringe3d.io.pointcloud.read_ply` are their routes)."""
from __future__ import annotations

import os
import shutil
import subprocess

import numpy as np
import pytest
from scipy.spatial import cKDTree

import fringe3d
from fringe3d.cli import main
from fringe3d.io.grid_mesh import grid_faces, local_roughness
from fringe3d.io.images import read_image
from fringe3d.io.point_attributes import grid_normals


@pytest.fixture(scope="module")
def out(tmp_path_factory):
    """A reconstruct output folder of the simulator's tiny preset (points.ply with --ply)."""
    root = tmp_path_factory.mktemp("exp")
    fringe3d.simulate_capture(root / "cap", preset="tiny", seed=0, progress=False)
    assert main(["reconstruct", str(root / "cap"), "-c", str(root / "cap" / "rig.json"), "-o", str(root / "out"),
                 "--ply", "-q"]) == 0
    return root / "out"


def truth(out):
    P = np.load(out / "points.npy")
    ok = np.all(np.isfinite(P), axis=-1)
    return P, ok


def test_export_las_keeps_every_point_and_the_sigma_and_roughness_fields(out, tmp_path):
    laspy = pytest.importorskip("laspy")
    assert main(["export", str(out), "-o", str(tmp_path / "p.laz"), "-q"]) == 0
    P, ok = truth(out)
    las = laspy.read(tmp_path / "p.laz")
    np.testing.assert_allclose(np.stack([las.x, las.y, las.z], -1), P[ok], atol=0.5e-3 + 1e-6)
    sigma = read_image(out / "sigma_z.tif", grey=False)
    np.testing.assert_allclose(np.asarray(las["sigma_z_mm"]), sigma[ok], rtol=1e-6, equal_nan=True)
    np.testing.assert_allclose(np.asarray(las["roughness_mm"]), local_roughness(P)[ok], rtol=1e-5, equal_nan=True)


def test_export_e57_and_mat_hold_the_reconstructed_points(out, tmp_path):
    import scipy.io
    pye57 = pytest.importorskip("pye57")
    P, ok = truth(out)
    assert main(["export", str(out), "-o", str(tmp_path / "p.e57"), "-q"]) == 0
    assert main(["export", str(out), "-o", str(tmp_path / "p.mat"), "-q"]) == 0
    d = pye57.E57(str(tmp_path / "p.e57")).read_scan_raw(0)
    np.testing.assert_allclose(np.stack([d[f"cartesian{a}"] for a in "XYZ"], -1) * 1000, P[ok], atol=1e-6)
    np.testing.assert_allclose(scipy.io.loadmat(tmp_path / "p.mat")["points"], P[ok], atol=1e-6)


def test_export_stl_is_the_pixel_grid_mesh_read_by_meshio(out, tmp_path):
    import meshio

    P, ok = truth(out)
    assert main(["export", str(out), "-o", str(tmp_path / "m.stl"), "-q"]) == 0
    m = meshio.read(tmp_path / "m.stl")
    assert len(m.cells_dict["triangle"]) == len(grid_faces(P))
    corners = m.points[m.cells_dict["triangle"]].reshape(-1, 3)
    gap, _ = cKDTree(P[ok]).query(corners)  # every corner is a reconstructed point
    assert gap.max() < 1e-4


def test_export_refuses_an_existing_file_an_unknown_suffix_and_a_mesh_from_a_point_list(out, tmp_path):
    target = tmp_path / "p.las"
    target.write_bytes(b"keep")
    assert main(["export", str(out), "-o", str(target)]) == 2
    assert target.read_bytes() == b"keep"
    assert main(["export", str(out), "-o", str(tmp_path / "p.xyz")]) == 2
    assert main(["export", str(out / "points.ply"), "-o", str(tmp_path / "m.stl")]) == 2
    assert main(["export", str(tmp_path / "missing"), "-o", str(tmp_path / "q.las")]) == 2
    assert sorted(p.name for p in tmp_path.iterdir()) == ["p.las"]


def fields(out):
    """What fringe3d wrote as the PLY's scalar fields, from the folder's own maps (not the PLY)."""
    P, ok = truth(out)
    return {"sigma_z_mm": read_image(out / "sigma_z.tif", grey=False)[ok], "roughness_mm": local_roughness(P)[ok]}


def test_reconstruct_ply_in_open3d_keeps_every_scalar_field_and_finite_normals(out):
    o3d = pytest.importorskip("open3d")
    P, ok = truth(out)
    t = o3d.t.io.read_point_cloud(str(out / "points.ply"))
    np.testing.assert_allclose(t.point.positions.numpy(), P[ok], atol=1e-4)
    kept = {k.removeprefix("scalar_") for k in dict(t.point.items()) if k.startswith("scalar_")}
    assert kept == set(fields(out))
    for name, values in fields(out).items():
        np.testing.assert_array_equal(t.point[f"scalar_{name}"].numpy()[:, 0], values)
    assert np.isfinite(t.point.normals.numpy()).all() and t.point.colors.numpy().shape == (ok.sum(), 3)


def test_vtk_ply_reader_keeps_only_points_normals_and_colours_so_pyvista_reads_the_vtp_beside_it(out):
    pv = pytest.importorskip("pyvista")
    P, ok = truth(out)
    cloud = pv.read(out / "points.ply")  # vtkPLYReader: a fixed set of properties
    assert set(cloud.point_data.keys()) == {"Normals", "RGB"}
    np.testing.assert_allclose(cloud.points, P[ok], atol=1e-4)
    assert np.isfinite(cloud.point_data["Normals"]).all()
    vtp = pv.read(out / "points.vtp")  # VTK's own format: every field
    assert set(vtp.point_data.keys()) == {"Normals", "RGB", *fields(out)}
    np.testing.assert_array_equal(vtp.points, cloud.points)
    np.testing.assert_array_equal(vtp.point_data["Normals"], cloud.point_data["Normals"])
    np.testing.assert_array_equal(vtp.point_data["RGB"], cloud.point_data["RGB"])
    for name, values in fields(out).items():
        np.testing.assert_array_equal(vtp.point_data[name], values)
    assert np.isfinite(vtp.point_data.active_normals).all() and vtp.n_cells == ok.sum()


def test_meshlab_ply_importer_drops_scalar_fields_and_read_ply_hands_them_over_exactly(out):
    pymeshlab = pytest.importorskip("pymeshlab")
    from fringe3d.io.pointcloud import read_ply

    P, ok = truth(out)
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(out / "points.ply"))
    m = ms.current_mesh()
    np.testing.assert_allclose(m.vertex_matrix(), P[ok], atol=1e-4)
    np.testing.assert_allclose(m.vertex_normal_matrix(), grid_normals(P)[ok], atol=1e-5)
    assert m.has_vertex_color() and not m.has_vertex_scalar()  # MeshLab keeps only a property named `quality`
    for name in fields(out):
        for stored in (name, f"scalar_{name}"):
            with pytest.raises(pymeshlab.PyMeshLabException):
                m.vertex_custom_scalar_attribute_array(stored)
    for name, values in read_ply(out / "points.ply").scalars.items():  # the documented hand-over
        m.add_vertex_custom_scalar_attribute(values.astype(np.float64), name)
    for name, values in fields(out).items():
        np.testing.assert_array_equal(m.vertex_custom_scalar_attribute_array(name), values.astype(np.float64))


@pytest.mark.skipif(shutil.which("CloudCompare") is None,
                    reason="CloudCompare not installed (scripts/ensure-system-packages.sh installs it)")
def test_reconstruct_ply_in_cloudcompare_keeps_every_scalar_field_and_finite_normals(out, tmp_path):
    P, ok = truth(out)
    shutil.copy(out / "points.ply", tmp_path / "points.ply")
    env = {**os.environ, "QT_QPA_PLATFORM": "offscreen"}
    subprocess.run(["CloudCompare", "-SILENT", "-O", str(tmp_path / "points.ply"), "-C_EXPORT_FMT", "ASC",
                    "-PREC", "9", "-ADD_HEADER", "-SAVE_CLOUDS"], check=True, env=env, timeout=120,
                   capture_output=True)
    (asc,) = tmp_path.glob("points_*.asc")
    header = asc.read_text().splitlines()[0].lstrip("/").split()
    assert header == ["X", "Y", "Z", "R", "G", "B", *fields(out), "Nx", "Ny", "Nz"]
    table = np.loadtxt(asc, comments="//")
    col = {name: table[:, i] for i, name in enumerate(header)}
    np.testing.assert_allclose(table[:, :3], P[ok], atol=1e-4)
    for name, values in fields(out).items():
        np.testing.assert_allclose(col[name], values, rtol=1e-6, atol=1e-9, equal_nan=True)
    normals = table[:, header.index("Nx"):header.index("Nx") + 3]
    assert np.isfinite(normals).all()
    np.testing.assert_allclose(normals, grid_normals(P)[ok], atol=5e-3)  # CloudCompare quantizes normals


def test_export_vtp_holds_every_field_of_the_folder(out, tmp_path):
    pv = pytest.importorskip("pyvista")
    assert main(["export", str(out), "-o", str(tmp_path / "p.vtp"), "-q"]) == 0
    vtp = pv.read(tmp_path / "p.vtp")
    for name, values in fields(out).items():
        np.testing.assert_array_equal(vtp.point_data[name], values)
    assert "units: mm" in list(vtp.field_data["fringe3d"])


def test_reconstruct_format_writes_points_laz_and_mat_beside_points_npy(out, tmp_path):
    laspy = pytest.importorskip("laspy")
    import scipy.io

    cap = out.parent / "cap"
    assert main(["reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o", str(tmp_path / "r"), "--format", "laz",
                 "--format", "mat", "-q"]) == 0
    P, ok = truth(tmp_path / "r")
    las = laspy.read(tmp_path / "r" / "points.laz")
    np.testing.assert_allclose(np.stack([las.x, las.y, las.z], -1), P[ok], atol=0.5e-3 + 1e-6)
    assert {"sigma_z_mm", "roughness_mm"} <= set(las.point_format.extra_dimension_names)
    np.testing.assert_allclose(scipy.io.loadmat(tmp_path / "r" / "points.mat")["points"], P[ok], atol=1e-6)


def test_reconstruct_refuses_an_unknown_format_before_writing_anything(out, tmp_path):
    cap = out.parent / "cap"
    assert main(["reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o", str(tmp_path / "r"),
                 "--format", "xyz"]) == 2
    assert not (tmp_path / "r").exists()


def test_export_a_point_store_frame_to_las_with_its_sigma(tmp_path):
    laspy = pytest.importorskip("laspy")
    from fringe3d.io.store import PointMapStore, StoreSettings

    st = PointMapStore.open(tmp_path / "points.zarr", frames=2, height=6, width=7,
                            settings=StoreSettings(quality=True, sigma=True))
    v, u = np.mgrid[0:6, 0:7].astype(np.float32)
    P = np.stack([u, v, 300 + 0.1 * u], -1)
    sigma = np.full((6, 7), 0.25, np.float32)  # exact in the store's float16
    st.write_frame(1, P, quality=np.zeros((6, 7), np.uint8), sigma_z=sigma)
    st.mark_done([1])
    assert main(["export", str(tmp_path / "points.zarr"), "-o", str(tmp_path / "f.las")]) == 2  # no --frame
    assert main(["export", str(tmp_path / "points.zarr"), "--frame", "0", "-o", str(tmp_path / "f.las")]) == 2
    assert main(["export", str(tmp_path / "points.zarr"), "--frame", "1", "-o", str(tmp_path / "f.las"), "-q"]) == 0
    las = laspy.read(tmp_path / "f.las")
    np.testing.assert_allclose(np.stack([las.x, las.y, las.z], -1), P.reshape(-1, 3), atol=0.5e-3 + 1e-6)
    np.testing.assert_array_equal(np.asarray(las["sigma_z_mm"]), sigma.ravel())


def test_export_without_pye57_exits_2_naming_the_extra_and_writes_nothing(out, tmp_path, monkeypatch, capsys):
    import builtins

    real = builtins.__import__

    def no_pye57(name, *args, **kwargs):
        if name == "pye57" or name.startswith("pye57."):
            raise ImportError("No module named 'pye57'")
        return real(name, *args, **kwargs)
    monkeypatch.setattr(builtins, "__import__", no_pye57)
    assert main(["export", str(out), "-o", str(tmp_path / "p.e57")]) == 2
    assert "fringe3d[exchange]" in capsys.readouterr().err
    assert not list(tmp_path.iterdir())
