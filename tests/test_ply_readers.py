"""Every PLY path writes one flavour that other tools read whole: finite normals, ``scalar_*``
fields, units and a non-empty command in the header; checked with Open3D and meshio (independent
readers) on point maps with holes, borders and lone pixels."""
from __future__ import annotations

import numpy as np
import pytest

import fringe3d
from fringe3d.io.ply_standard import write_measurement_ply, write_standard_ply
from fringe3d.io.point_attributes import grid_normals
from fringe3d.io.pointcloud import write_ply
from fringe3d.utils.provenance import use_command_line


def holey_plane(h=24, w=32):
    """A tilted plane z = 400 + 0.1 x + 0.05 y (mm) with a hole, a ragged border and a lone pixel."""
    v, u = np.mgrid[0:h, 0:w].astype(np.float64)
    P = np.stack([u, v, 400.0 + 0.1 * u + 0.05 * v], -1).astype(np.float32)
    P[8:12, 10:15] = np.nan        # a hole: its rim has one neighbour on one side
    P[:, 20:22] = np.nan           # a gap isolating ...
    P[:, 23:] = np.nan
    P[:5, 22] = np.nan             # ... a one-pixel-wide strand (column 22, rows 5..)
    P[:, 22][6:] = np.nan          # and leaving (5, 22) a lone pixel
    return P


PLANE_NORMAL = -np.array([-0.1, -0.05, 1.0]) / np.linalg.norm([-0.1, -0.05, 1.0])


def test_grid_normals_are_exact_on_a_plane_at_holes_and_borders_and_line_of_sight_for_a_lone_pixel():
    P = holey_plane()
    N = grid_normals(P)
    ok = np.isfinite(P[..., 0])
    assert np.isfinite(N[ok]).all() and np.isnan(N[~ok]).all()
    lone = np.zeros_like(ok)
    lone[5, 22] = True
    np.testing.assert_allclose(N[ok & ~lone], np.broadcast_to(PLANE_NORMAL, N[ok & ~lone].shape), atol=1e-4)
    np.testing.assert_allclose(N[5, 22], -P[5, 22] / np.linalg.norm(P[5, 22]), atol=1e-6)


@pytest.mark.parametrize("binary", [True, False])
def test_measurement_ply_keeps_every_point_scalar_and_finite_normal_in_open3d(tmp_path, binary):
    o3d = pytest.importorskip("open3d")
    P = holey_plane()
    tex = np.linspace(0, 1, P.shape[0] * P.shape[1]).reshape(P.shape[:2])
    path = write_measurement_ply(tmp_path / "p.ply", P, tex, binary=binary)
    ok = np.isfinite(P[..., 0])
    t = o3d.t.io.read_point_cloud(str(path))
    np.testing.assert_allclose(t.point.positions.numpy(), P[ok], atol=1e-4)
    assert "scalar_roughness_mm" in t.point and "quality" not in t.point
    normals = t.point.normals.numpy()
    assert np.isfinite(normals).all() and np.allclose(np.linalg.norm(normals, axis=1), 1, atol=1e-5)
    legacy = o3d.io.read_point_cloud(str(path))
    assert legacy.has_normals() and np.isfinite(np.asarray(legacy.normals)).all()
    assert len(legacy.points) == ok.sum()


def test_measurement_ply_scalar_is_the_roughness_read_back_by_meshio(tmp_path):
    import meshio

    from fringe3d.io.grid_mesh import local_roughness

    P = holey_plane()
    P[..., 2] += np.random.default_rng(0).normal(0, 0.02, P.shape[:2]).astype(np.float32)
    m = meshio.read(write_measurement_ply(tmp_path / "r.ply", P))
    ok = np.isfinite(P[..., 0])
    np.testing.assert_allclose(m.point_data["scalar_roughness_mm"], local_roughness(P)[ok], atol=1e-6,
                               equal_nan=True)


def test_ply_header_names_units_scalar_and_a_non_empty_command(tmp_path):
    use_command_line("")
    head = write_ply(tmp_path / "a.ply", holey_plane()).read_bytes().split(b"end_header")[0].decode()
    assert "comment units: mm" in head and "comment command: none (Python API)" in head
    assert "comment command: \n" not in head
    use_command_line("fringe3d reconstruct cap -o out")
    try:
        head = write_measurement_ply(tmp_path / "b.ply", holey_plane()).read_bytes().split(b"end_header")[0]
    finally:
        use_command_line("")
    assert b"comment command: fringe3d reconstruct cap -o out" in head
    assert b"comment scalar_roughness_mm: local roughness (mm)" in head


def test_reconstruction_save_ply_is_the_measurement_ply(tmp_path):
    o3d = pytest.importorskip("open3d")
    cap = tmp_path / "cap"
    fringe3d.simulate_capture(cap, preset="tiny", seed=0, progress=False)
    r = fringe3d.reconstruct_capture(cap, cap / "rig.json")
    t = o3d.t.io.read_point_cloud(str(r.save_ply(tmp_path / "r.ply")))
    np.testing.assert_allclose(t.point.positions.numpy(), r.points[r.mask], atol=1e-4)
    assert np.isfinite(t.point.normals.numpy()).all()
    assert "scalar_roughness_mm" in t.point and "colors" in t.point
    np.testing.assert_array_equal(t.point.scalar_sigma_z_mm.numpy()[:, 0], r.sigma_z[r.mask])


def test_vtp_holds_the_ply_points_normals_colours_and_every_scalar_with_nan_kept(tmp_path):
    pv = pytest.importorskip("pyvista")
    from fringe3d.io.point_set import point_set
    from fringe3d.io.pointcloud import read_ply
    from fringe3d.io.vtk_points import write_vtp

    P = holey_plane()
    ok = np.isfinite(P[..., 0])
    rng = np.random.default_rng(1)
    a = rng.normal(size=P.shape[:2]).astype(np.float32)
    a[ok.nonzero()[0][0], ok.nonzero()[1][0]] = np.nan  # unknown at the first point
    b = rng.uniform(size=P.shape[:2]).astype(np.float32)
    scalars = {"a_mm": (a, "a (mm)"), "b": (b, "b <unitless> & more")}
    tex = np.linspace(0, 1, a.size).reshape(a.shape)
    ply = read_ply(write_standard_ply(tmp_path / "p.ply", P, tex, scalars=scalars))
    use_command_line("fringe3d export out -o p.vtp --overwrite")
    try:
        vtp = pv.read(write_vtp(tmp_path / "p.vtp", point_set("p.vtp", P, scalars, colors=tex)))
    finally:
        use_command_line("")
    np.testing.assert_array_equal(vtp.points, ply.points)
    np.testing.assert_array_equal(vtp.point_data["Normals"], ply.normals)
    np.testing.assert_array_equal(vtp.point_data["RGB"], ply.colors)
    assert set(ply.scalars) == {"a_mm", "b"}
    for name, (values, _) in scalars.items():
        np.testing.assert_array_equal(vtp.point_data[name], values[ok])
        np.testing.assert_array_equal(ply.scalars[name], values[ok])
    assert list(vtp.field_data["fringe3d"])[2:] == ["command: fringe3d export out -o p.vtp --overwrite",
                                                    "a_mm: a (mm)", "b: b <unitless> & more"]


def test_vtp_of_a_point_list_has_one_vertex_per_point_and_refuses_a_name_vtk_cannot_hold(tmp_path):
    pv = pytest.importorskip("pyvista")
    from fringe3d.io.point_set import point_set
    from fringe3d.io.vtk_points import write_vtp

    pts = np.array([[0, 0, 400], [1, 0, 401], [np.nan, 0, 0]], np.float32)
    vtp = pv.read(write_vtp(tmp_path / "l.vtp", point_set("l.vtp", pts)))
    np.testing.assert_array_equal(vtp.points, pts[:2])
    assert vtp.n_cells == 2 and set(vtp.point_data.keys()) == set()
    with pytest.raises(ValueError, match=r"'a<b' to .*bad\.vtp"):
        write_vtp(tmp_path / "bad.vtp", point_set("bad.vtp", pts, {"a<b": (np.zeros(3), "x")}))
    assert not (tmp_path / "bad.vtp").exists()
