"""PLY export/import round trip, normals, colours, atomic writes; the zarr sequence store."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.io import ply_standard
from fringe3d.io.pointcloud import organized_normals, read_ply, write_ply
from fringe3d.io.store import PointMapStore
from fringe3d.optics import PinholeDevice, intrinsics

from test_triangulate import intersect_plane, intersect_sphere


def sphere_map():
    cam = PinholeDevice(K=intrinsics(120.0, 120.0, 31.5, 23.5), width=64, height=48)
    O, D = cam.rays(cam.pixel_grid())
    return intersect_sphere(O, D, np.array([0.0, 0.0, 200.0]), 60.0).astype(np.float32)


def test_ply_round_trip_points_colours_normals(tmp_path):
    P = sphere_map()
    tex = np.linspace(0, 1, P.shape[0] * P.shape[1]).reshape(P.shape[:2])
    out = write_ply(tmp_path / "s.ply", P, colors=tex, normals=True)
    back = read_ply(out)
    ok = np.isfinite(P[..., 0])
    np.testing.assert_array_equal(back.points, P[ok])
    np.testing.assert_array_equal(back.colors[:, 0], np.round(tex[ok] * 255).astype(np.uint8))
    # normals of a sphere point away from its centre (one-sided differences at its rim)
    radial = back.points - np.array([0, 0, 200.0], np.float32)
    radial /= np.linalg.norm(radial, axis=1, keepdims=True)
    inner = np.isfinite(organized_normals(P)[ok][:, 0])
    assert np.min(np.sum(back.normals[inner] * radial[inner], axis=1)) > 0.999
    assert np.isfinite(back.normals).all() and np.min(np.sum(back.normals * radial, axis=1)) > 0.9


def test_ply_ascii_and_masked(tmp_path):
    P = sphere_map()
    mask = np.zeros(P.shape[:2], bool)
    mask[20:30, 20:40] = True
    back = read_ply(write_ply(tmp_path / "m.ply", P, mask=mask, binary=False))
    np.testing.assert_allclose(back.points, P[mask & np.isfinite(P[..., 0])], rtol=1e-6)
    assert back.colors is None and back.normals is None


def test_plane_normals_match_plane():
    cam = PinholeDevice(K=intrinsics(120.0, 120.0, 31.5, 23.5), width=64, height=48)
    O, D = cam.rays(cam.pixel_grid())
    n = np.array([0.2, -0.1, 1.0])
    X = intersect_plane(O, D, np.array([0, 0, 300.0]), n)
    N = organized_normals(X)
    ok = np.isfinite(N[..., 0])
    np.testing.assert_allclose(N[ok], np.broadcast_to(-n / np.linalg.norm(n), N[ok].shape), atol=1e-5)


def test_failure_midway_leaves_no_ply(tmp_path, monkeypatch):
    def half_then_fail(path, data):
        with open(path, "wb") as f:
            f.write(data[: len(data) // 2])
        raise OSError("disk full (simulated)")

    monkeypatch.setattr(ply_standard, "_write_bytes", half_then_fail)
    with pytest.raises(OSError, match="disk full"):
        write_ply(tmp_path / "x.ply", sphere_map())
    assert list(tmp_path.iterdir()) == []


def test_ply_bad_input(tmp_path):
    with pytest.raises(ValueError, match="no valid point"):
        write_ply(tmp_path / "e.ply", np.full((4, 4, 3), np.nan))
    with pytest.raises(ValueError, match="colours"):
        write_ply(tmp_path / "e.ply", sphere_map(), colors=np.zeros((3, 3)))
    with pytest.raises(FileNotFoundError):
        read_ply(tmp_path / "missing.ply")
    (tmp_path / "bad.ply").write_text("not a ply")
    with pytest.raises(ValueError, match="PLY"):
        read_ply(tmp_path / "bad.ply")
    assert not (tmp_path / "e.ply").exists()


def test_store_round_trip_and_resume(tmp_path):
    P = sphere_map()
    path = tmp_path / "seq.zarr"
    st = PointMapStore.open(path, 5, 48, 64, meta={"rig": "tiny"})
    assert st.pending() == [0, 1, 2, 3, 4]
    st.write(0, P)
    st.write(3, P + 1)
    # a new process resumes: the finished frames are known, the others are pending
    st2 = PointMapStore.open(path, 5, 48, 64)
    assert st2.pending() == [1, 2, 4] and st2.completed == 2
    np.testing.assert_array_equal(st2.read(3), P + 1)
    assert np.all(np.isnan(st2.read(1)))
    assert st2.meta == {"rig": "tiny"}
    with pytest.raises(ValueError, match="new output folder"):
        PointMapStore.open(path, 6, 48, 64)
    with pytest.raises(ValueError, match="shape"):
        st2.write(1, np.zeros((10, 10, 3)))


def test_store_compresses_point_maps(tmp_path):
    P = sphere_map()
    st = PointMapStore.open(tmp_path / "c.zarr", 4, 48, 64)
    for k in range(4):
        st.write(k, P)
    size = sum(f.stat().st_size for f in (tmp_path / "c.zarr").rglob("*") if f.is_file())
    assert size < 4 * P.nbytes
