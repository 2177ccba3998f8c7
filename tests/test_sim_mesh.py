"""Embree mesh ray casting and the analytic sculpture relief against closed forms."""
import numpy as np
import pytest
import trimesh

from fringe3d.optics import PinholeDevice, intrinsics
from fringe3d.sim.mesh import Mesh
from fringe3d.sim.primitives import Sphere
from fringe3d.sim.sculpture import HeightField, sculpture

CAM = PinholeDevice(intrinsics(400, 400, 79.5, 63.5), 160, 128)


def _rays():
    return CAM.rays(CAM.pixel_grid().reshape(-1, 2))


def test_icosphere_mesh_agrees_with_analytic_sphere_within_tessellation_error():
    c, r = np.array([3.0, -2.0, 200.0]), 30.0
    ico = trimesh.creation.icosphere(subdivisions=4, radius=r)
    mesh = Mesh(ico, center=c)
    o, d = _rays()
    hm, hs = mesh.intersect(o, d), Sphere(c, r).intersect(o, d)
    # tessellation bound from the mesh itself: every face lies between its plane distance and r
    r_in = np.min(np.einsum("ij,ij->i", ico.triangles_center, ico.face_normals))
    X = hm.points(o, d)[hm.mask]
    rad = np.linalg.norm(X - c, axis=1)
    assert rad.min() >= r_in - 1e-9 and rad.max() <= r + 1e-9
    assert r - r_in < 0.1  # the bound is tight enough to mean something
    # rays disagree only at the silhouette
    differ = hm.mask != hs.mask
    assert differ.sum() < 0.02 * hs.mask.sum()
    both = hm.mask & hs.mask
    depth_diff = np.abs(hm.t[both] - hs.t[both]) * np.linalg.norm(d[both], axis=1)
    assert np.median(depth_diff) < r - r_in
    # face normals are within the faces' angular size of the sphere normal
    cosang = np.sum(hm.normal[both] * hs.normal[both], axis=1)
    assert np.degrees(np.arccos(np.clip(cosang, -1, 1))).max() < 5.0


def test_mesh_hits_lie_exactly_on_the_hit_triangle_plane():
    box = trimesh.creation.box(extents=(40, 30, 20))
    R = trimesh.transformations.rotation_matrix(0.4, [1, 1, 0])[:3, :3]
    mesh = Mesh(box, center=(0, 0, 150), R=R)
    o, d = _rays()
    h = mesh.intersect(o, d)
    assert h.mask.mean() > 0.1
    X = mesh.to_body(h.points(o, d)[h.mask])
    # every hit is on the box surface: max |coordinate / half-extent| == 1
    np.testing.assert_allclose(np.max(np.abs(X) / [20, 15, 10], axis=1), 1.0, atol=1e-10)


def test_moving_mesh_translates_with_its_motion():
    from fringe3d.sim.motion import RigidMotion
    m = Mesh(trimesh.creation.icosphere(3, radius=10), center=(0, 0, 100),
             motion=RigidMotion(velocity=(0, 0, 1000.0)))
    d = np.array([[0, 0, 1.0]])
    t0, t1 = m.intersect(np.zeros(3), d, 0.0).t[0], m.intersect(np.zeros(3), d, 0.01).t[0]
    assert t1 - t0 == pytest.approx(10.0, abs=1e-9)


@pytest.mark.parametrize("ext", ["ply", "stl", "obj"])
def test_mesh_files_load_and_cast_like_the_in_memory_mesh(tmp_path, ext):
    ico = trimesh.creation.icosphere(subdivisions=3, radius=25)
    path = tmp_path / f"ball.{ext}"
    ico.export(path)
    o, d = _rays()
    a = Mesh(ico, center=(0, 0, 180)).intersect(o, d)
    b = Mesh(path, center=(0, 0, 180)).intersect(o, d)
    np.testing.assert_array_equal(a.mask, b.mask)
    # PLY/STL store float32 vertices (~1e-6 mm here), amplified at grazing incidence
    np.testing.assert_allclose(a.t[a.mask], b.t[b.mask], atol=1e-3)


def test_mesh_file_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no mesh file"):
        Mesh(tmp_path / "nope.ply")
    bad = tmp_path / "bad.ply"
    bad.write_text("this is not a mesh")
    with pytest.raises(ValueError, match="bad.ply"):
        Mesh(bad)
    with pytest.raises(ValueError, match="scale"):
        Mesh(trimesh.creation.box(), scale=0)


def test_sculpture_hits_satisfy_the_height_function_and_its_normal():
    s = sculpture(center=(0, 0, 300), size=(80, 60), relief=15, seed=2)
    o, d = _rays()
    h = s.intersect(o, d)
    assert h.mask.mean() > 0.3
    xb = s.to_body(h.points(o, d)[h.mask])
    f = s.height(xb[:, :2])
    np.testing.assert_allclose(xb[:, 2], f[:, 0], atol=1e-9)
    n_body = np.column_stack([-f[:, 1], -f[:, 2], np.ones(len(f))])
    n_body /= np.linalg.norm(n_body, axis=1, keepdims=True)
    np.testing.assert_allclose(np.abs(np.sum(h.normal[h.mask] * (n_body @ s.R.T), 1)), 1.0, atol=1e-9)
    np.testing.assert_allclose(h.material_uv[h.mask], xb[:, :2], atol=1e-9)


def test_sculpture_returns_the_first_crossing_along_oblique_rays():
    hf = HeightField(size=(60, 60), bumps=[(12, -8, 0, 4), (12, 8, 0, 4)], center=(0, 0, 0), R=np.eye(3))
    # grazing rays from the side at body z = 6: the first bump is hit before the second
    o = np.array([[-40.0, 0.0, 6.0], [-40.0, 0.5, 6.0]])
    d = np.array([[1.0, 0.0, 0.0], [1.0, 0.0, -0.01]])
    h = hf.intersect(o, d)
    tt = np.linspace(0, 80, 800001)
    for i in range(2):
        P = o[i] + tt[:, None] * d[i]
        g = P[:, 2] - hf.height(P[:, :2])[:, 0]
        inside = (np.abs(P[:, 0]) <= 30) & (np.abs(P[:, 1]) <= 30)
        first = tt[np.flatnonzero(inside[1:] & (np.sign(g[1:]) != np.sign(g[:-1])))[0]]
        assert h.t[i] == pytest.approx(first, abs=1e-3)
        assert h.points(o, d)[i, 0] < 0  # the nearer bump


def test_sculpture_mesh_tessellation_agrees_with_analytic_cast():
    s = sculpture(center=(0, 0, 300), size=(80, 60), relief=15, seed=1)
    m = Mesh(s.to_mesh(step=0.5), center=s.center, R=s.R)
    o, d = _rays()
    ha, hm = s.intersect(o, d), m.intersect(o, d)
    both = ha.mask & hm.mask
    assert both.sum() > 0.95 * ha.mask.sum()
    assert np.abs((ha.t[both] - hm.t[both]) * np.linalg.norm(d[both], axis=1)).max() < 0.05
