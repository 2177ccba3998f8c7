"""PLY for other tools: normals from the grid, a quality scalar, grid faces, header comments;
read back by meshio (an independent reader) and by fringe3d's trimesh-based reader."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.io.grid_mesh import grid_faces, local_roughness
from fringe3d.io.ply_standard import write_standard_ply
from fringe3d.io.pointcloud import read_ply


def plane(h=20, w=30, sigma=0.0, seed=0):
    v, u = np.mgrid[0:h, 0:w].astype(float)
    z = 400.0 + 0.1 * u + np.random.default_rng(seed).normal(0, sigma, (h, w)) if sigma else 400.0 + 0.1 * u
    return np.stack([u, v, z], -1)


def test_grid_faces_of_a_full_grid_and_across_a_hole_and_a_jump():
    P = plane()
    assert len(grid_faces(P)) == 2 * 19 * 29
    P[5, 5] = np.nan  # a missing pixel removes the 6 triangles touching it
    assert len(grid_faces(P)) == 2 * 19 * 29 - 6
    Q = plane()
    Q[:, 15:, 2] += 100.0  # a 100 mm depth step: no triangle bridges it
    F = grid_faces(Q)
    cols = (F % 30)
    assert not np.any((cols.min(axis=1) < 15) & (cols.max(axis=1) >= 15))


def test_roughness_is_zero_on_a_plane_and_tracks_the_noise():
    assert np.nanmax(local_roughness(plane())) < 1e-6
    r = local_roughness(plane(60, 60, sigma=0.05))
    assert 0.5 * 0.05 < np.nanmedian(r) < 0.05  # TLS on 9 points: about sqrt(6/9) sigma, biased low
    assert np.isnan(local_roughness(np.full((4, 4, 3), np.nan))).all()


@pytest.mark.parametrize("binary", [True, False])
def test_standard_ply_round_trips_through_meshio_and_trimesh(tmp_path, binary):
    import meshio

    P = plane().astype(np.float32)
    P[0, 0] = np.nan
    tex = np.linspace(0, 1, P.shape[0] * P.shape[1]).reshape(P.shape[:2])
    q = local_roughness(P)
    path = write_standard_ply(tmp_path / "p.ply", P, tex, scalars={"roughness_mm": (q, "local roughness (mm)")},
                              faces=True, comments=["frame: camera"], binary=binary)
    head = path.read_bytes().split(b"end_header")[0].decode()
    assert "comment units: mm" in head and "comment frame: camera" in head and "comment command: " in head
    assert "comment scalar_roughness_mm: local roughness (mm)" in head and "property float scalar_roughness_mm" in head
    m = meshio.read(path)
    valid = np.isfinite(P[..., 0]).ravel()
    np.testing.assert_allclose(m.points, P.reshape(-1, 3)[valid], atol=1e-4)
    tri = m.cells_dict["triangle"]
    assert len(tri) == 2 * 19 * 29 - 1  # the missing corner pixel had one triangle
    np.testing.assert_allclose(m.point_data["scalar_roughness_mm"], q.ravel()[valid], atol=1e-6, equal_nan=True)
    back = read_ply(path)
    assert len(back.points) == valid.sum() and back.normals is not None and back.colors is not None
    assert np.isfinite(back.normals).all()
    np.testing.assert_allclose(np.abs(back.normals @ np.array([-0.1, 0, 1]) / np.hypot(0.1, 1)), 1, atol=1e-5)


def test_reconstruct_mesh_writes_faces_and_provenance(tmp_path, capsys):
    import meshio

    from fringe3d.cli import main

    cap, out = tmp_path / "cap", tmp_path / "rec"
    assert main(["simulate", "-o", str(cap), "--scene", "sphere", "--ideal", "-q"]) == 0
    assert main(["reconstruct", str(cap), "-c", str(cap / "rig.json"), "-o", str(out), "--mesh", "-q"]) == 0
    head = (out / "points.ply").read_bytes().split(b"end_header")[0].decode()
    assert "command: fringe3d reconstruct" in head and "comment units: mm" in head
    m = meshio.read(out / "points.ply")
    assert len(m.cells_dict["triangle"]) > len(m.points)  # about two triangles per point
    P = np.load(out / "points.npy")
    assert len(m.points) == np.isfinite(P[..., 0]).sum()
