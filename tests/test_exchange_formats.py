"""Point clouds and meshes written through :mod:`fringe3d.io.export`, each read back by a library
other than fringe3d (pye57, laspy, scipy.io, meshio, trimesh, pymeshlab, Open3D): coordinates
equal within the format's precision, units where the format carries them, scalar fields kept."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.io.export import MESH_SUFFIXES, POINT_SUFFIXES, write_mesh, write_points
from fringe3d.io.point_attributes import grid_normals


def organized(h=12, w=16, seed=0):
    """A bumpy organized map (mm) with a hole, an RGB texture and a sigma map."""
    rng = np.random.default_rng(seed)
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    P = np.stack([u * 0.37 - 3, v * 0.41 - 2, 450.0 + 0.1 * u + rng.normal(0, 0.05, u.shape)], -1)
    P[4:6, 5:9] = np.nan
    sigma = rng.uniform(0.001, 0.02, u.shape).astype(np.float32)
    sigma[0, 0] = np.nan  # unknown at one point: kept as NaN where the format can
    return P, rng.uniform(0, 1, (h, w, 3)), sigma


def test_e57_is_read_by_pye57_in_metres_with_colours_pixel_indices_and_first_scalar_as_intensity(tmp_path):
    pye57 = pytest.importorskip("pye57")
    P, tex, sigma = organized()
    ok = np.isfinite(P[..., 2])
    e57 = pye57.E57(str(write_points(tmp_path / "c.e57", P, {"sigma_z_mm": (sigma, "sigma z (mm)")}, colors=tex)))
    d = e57.read_scan_raw(0)
    xyz = np.stack([d["cartesianX"], d["cartesianY"], d["cartesianZ"]], -1)
    np.testing.assert_allclose(xyz * 1000.0, P[ok], atol=1e-9)
    rows, cols = np.nonzero(ok)
    np.testing.assert_array_equal(d["rowIndex"], rows)
    np.testing.assert_array_equal(d["columnIndex"], cols)
    np.testing.assert_array_equal(d["colorRed"], np.round(tex[..., 0] * 255)[ok].astype(np.uint8))
    np.testing.assert_allclose(d["intensity"], np.nan_to_num(sigma[ok]), rtol=1e-6)
    assert "units: m" in e57.get_header(0).node["name"].value()


@pytest.mark.parametrize("suffix", [".las", ".laz"])
def test_las_and_laz_are_read_by_laspy_to_the_micrometre_with_scalars_normals_and_units(tmp_path, suffix):
    laspy = pytest.importorskip("laspy")
    P, tex, sigma = organized()
    ok = np.isfinite(P[..., 2])
    path = write_points(tmp_path / f"c{suffix}", P, {"sigma_z_mm": (sigma, "sigma z (mm)")}, colors=tex)
    las = laspy.read(path)
    assert las.header.are_points_compressed == (suffix == ".laz")
    xyz = np.stack([las.x, las.y, las.z], -1)
    np.testing.assert_allclose(xyz, P[ok], atol=0.5e-3 + 1e-9)  # LAS scale 1 µm: half a step
    np.testing.assert_allclose(np.asarray(las["sigma_z_mm"]), sigma[ok], equal_nan=True)
    normals = np.stack([np.asarray(las[a]) for a in ("nx", "ny", "nz")], -1)
    np.testing.assert_allclose(normals, grid_normals(P)[ok], atol=1e-6)
    np.testing.assert_array_equal(np.asarray(las.green) // 257, np.round(tex[..., 1] * 255)[ok])
    assert "mm" in las.header.system_identifier
    assert any(b"units: mm" in v.record_data for v in las.header.vlrs if v.user_id == "fringe3d")


def test_mat_is_read_by_scipy_with_units_scalars_and_one_based_pixel_indices(tmp_path):
    import scipy.io

    P, tex, sigma = organized()
    ok = np.isfinite(P[..., 2])
    m = scipy.io.loadmat(write_points(tmp_path / "c.mat", P, {"sigma_z_mm": (sigma, "sigma z (mm)")}, colors=tex))
    np.testing.assert_array_equal(m["points"], P[ok])
    assert str(m["units"][0]) == "mm"
    np.testing.assert_array_equal(m["sigma_z_mm"][:, 0], sigma[ok])  # NaN kept: array_equal treats NaN == NaN
    rows, cols = np.nonzero(ok)
    np.testing.assert_array_equal(m["row"][:, 0], rows + 1)
    np.testing.assert_array_equal(m["col"][:, 0], cols + 1)
    np.testing.assert_allclose(m["normals"], grid_normals(P)[ok], atol=1e-6)


def test_ply_points_through_the_dispatcher_keep_every_scalar_in_open3d(tmp_path):
    o3d = pytest.importorskip("open3d")
    P, tex, sigma = organized()
    ok = np.isfinite(P[..., 2])
    t = o3d.t.io.read_point_cloud(str(write_points(tmp_path / "c.ply", P, {"sigma_z_mm": (sigma, "mm")}, colors=tex)))
    np.testing.assert_allclose(t.point.positions.numpy(), P[ok], atol=1e-4)
    np.testing.assert_allclose(t.point.scalar_sigma_z_mm.numpy()[:, 0], sigma[ok], equal_nan=True)
    assert np.isfinite(t.point.normals.numpy()).all()


def tetrahedron():
    V = np.array([[0.0, 0, 0], [10.5, 0, 0], [0, 12.25, 0], [0, 0, 7.125]]) + [100.0, -50.0, 400.0]
    F = np.array([[0, 2, 1], [0, 1, 3], [0, 3, 2], [1, 2, 3]])
    return V, F, np.array([[1.0, 0, 0], [0, 1, 0], [0, 0, 1], [0.5, 0.5, 0.5]])


def triangles(V, F):
    """The mesh's triangles, each as a sorted tuple of its corners (µm-rounded mm), in sorted order:
    independent of how a reader numbers or orders vertices and faces."""
    tris = [tuple(sorted(tuple(np.round(c, 3)) for c in np.asarray(V, float)[f])) for f in F]
    return np.array(sorted(tris))


def test_stl_is_read_by_meshio_with_the_same_triangles_in_mm_and_units_in_its_header(tmp_path):
    import meshio

    V, F, _ = tetrahedron()
    path = write_mesh(tmp_path / "m.stl", V, F)
    assert b"units: mm" in path.read_bytes()[:80]
    m = meshio.read(path)
    np.testing.assert_allclose(triangles(m.points, m.cells_dict["triangle"]), triangles(V, F), atol=1e-4)


def test_obj_is_read_by_meshio_with_vertices_faces_and_units_comment(tmp_path):
    import meshio

    V, F, C = tetrahedron()
    path = write_mesh(tmp_path / "m.obj", V, F, colors=C)
    assert "units: mm" in path.read_text().splitlines()[0]
    m = meshio.read(path)
    np.testing.assert_allclose(triangles(m.points[:, :3], m.cells_dict["triangle"]), triangles(V, F), atol=1e-6)
    rgb = {tuple(np.round(c * 255).astype(int)) for c in m.points[:, 3:6]}  # "v x y z r g b": 6 columns
    assert rgb == {tuple(np.round(c * 255).astype(int)) for c in C}  # 8-bit colours


def test_glb_is_read_by_trimesh_in_metres_with_vertex_colours(tmp_path):
    trimesh = pytest.importorskip("trimesh")
    V, F, C = tetrahedron()
    scene = trimesh.load(write_mesh(tmp_path / "m.glb", V, F, colors=C))
    mesh = next(iter(scene.geometry.values()))
    np.testing.assert_allclose(triangles(np.asarray(mesh.vertices) * 1000.0, mesh.faces), triangles(V, F), atol=1e-3)
    got = {tuple(c) for c in np.asarray(mesh.visual.vertex_colors)[:, :3]}
    assert got == {tuple(c) for c in np.round(C * 255).astype(int)}
    assert scene.metadata.get("units") == "m"


def test_ply_mesh_is_read_by_pymeshlab_and_open3d_with_faces_colours_and_scalar(tmp_path):
    pymeshlab = pytest.importorskip("pymeshlab")
    o3d = pytest.importorskip("open3d")
    V, F, C = tetrahedron()
    d = np.array([0.1, 0.2, np.nan, 0.4], np.float32)
    path = write_mesh(tmp_path / "m.ply", V, F, colors=C, attributes={"deviation_mm": (d, "deviation (mm)")})
    ms = pymeshlab.MeshSet()
    ms.load_new_mesh(str(path))
    mm = ms.current_mesh()
    np.testing.assert_allclose(mm.vertex_matrix(), V, atol=1e-4)
    np.testing.assert_array_equal(mm.face_matrix(), F)
    np.testing.assert_allclose(mm.vertex_color_matrix()[:, :3], np.round(C * 255) / 255, atol=1e-6)
    t = o3d.t.io.read_triangle_mesh(str(path))
    np.testing.assert_allclose(t.vertex.positions.numpy(), V, atol=1e-4)
    legacy = o3d.io.read_triangle_mesh(str(path))
    np.testing.assert_array_equal(np.asarray(legacy.triangles), F)
    import meshio
    np.testing.assert_array_equal(meshio.read(path).point_data["scalar_deviation_mm"], d)


@pytest.mark.parametrize("write, supported, name", [(write_points, POINT_SUFFIXES, "cloud.xyz"),
                                                    (write_mesh, MESH_SUFFIXES, "mesh.fbx")])
def test_unknown_suffix_is_refused_naming_the_file_and_every_supported_suffix(tmp_path, write, supported, name):
    V, F, _ = tetrahedron()
    args = (V,) if write is write_points else (V, F)
    with pytest.raises(ValueError) as e:
        write(tmp_path / name, *args)
    assert name in str(e.value) and all(s in str(e.value) for s in supported)
    assert not (tmp_path / name).exists()


def test_mesh_attributes_are_refused_for_formats_without_scalar_fields(tmp_path):
    V, F, _ = tetrahedron()
    with pytest.raises(ValueError, match=r"m\.stl"):
        write_mesh(tmp_path / "m.stl", V, F, attributes={"d": (np.zeros(4), "mm")})


def test_every_export_suffix_is_documented_with_its_units():
    from pathlib import Path

    doc = (Path(__file__).parents[1] / "docs" / "file-formats.md").read_text(encoding="utf-8")
    rows = [line.split("|") for line in doc.splitlines() if line.startswith("| `.")]
    for suffix in sorted(set(POINT_SUFFIXES) | set(MESH_SUFFIXES)):
        units = [r[3] for r in rows if f"`{suffix}`" in r[1]]
        assert units and any("mm" in u or "m " in u for u in units), f"{suffix} has no documented units"
