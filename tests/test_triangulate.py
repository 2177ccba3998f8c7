"""Triangulation reproduces analytically built ground truth (Eq. 2.37-2.38, Eq. 3.3).

Truth: camera rays (undistorted pixels) cast analytically at a tilted plane and a sphere; the
hit points projected into the projector give exact (u_p, v_p). Every truth point is checked to
re-project onto its own camera pixel with the forward distortion model, so the truth does not
depend on the code under test.
"""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.optics import PinholeDevice, Rig, TelecentricCamera, intrinsics
from fringe3d.reconstruct.depth import depth_map
from fringe3d.reconstruct.triangulate import Triangulator, triangulate
from fringe3d.utils.warning_types import ReconstructionWarning


def look_at(center, target):
    c = np.asarray(center, float)
    z = np.asarray(target, float) - c
    z /= np.linalg.norm(z)
    x = np.cross(z, [0.0, 1.0, 0.0])
    x /= np.linalg.norm(x)
    y = np.cross(z, x)
    R = np.stack([x, y, z])
    return R, -R @ c


def small_rig(cam_dist=(-0.12, 0.08, 0.001, -0.0015, 0.0), proj_dist=(0, 0, 0, 0, 0)):
    cam = PinholeDevice(K=intrinsics(220.0, 221.0, 79.3, 63.8, skew=0.2), width=160, height=128, dist=cam_dist)
    R, t = look_at([80.0, -20.0, 0.0], [0.0, 0.0, 300.0])
    proj = PinholeDevice(K=intrinsics(400.0, 400.0, 127.5, 99.5), width=256, height=200, dist=proj_dist, R=R, t=t)
    return Rig(cam, proj)


def intersect_plane(O, D, p0, n):
    s = ((p0 - O) @ n) / (D @ n)
    return O + s[..., None] * D


def intersect_sphere(O, D, c, r):
    oc = O - c
    a = np.einsum("...i,...i", D, D)
    b = 2 * np.einsum("...i,...i", D, oc)
    cc = np.einsum("...i,...i", oc, oc) - r * r
    disc = b * b - 4 * a * cc
    s = (-b - np.sqrt(np.where(disc >= 0, disc, np.nan))) / (2 * a)
    return O + s[..., None] * D


def scene_truth(rig, kind="plane"):
    """Truth points (H, W, 3) and exact projector coordinates for every camera pixel."""
    cam = rig.camera
    uv = cam.pixel_grid()
    O, D = cam.rays(uv)
    if kind == "plane":
        X = intersect_plane(O, D, np.array([0, 0, 300.0]), np.array([0.15, -0.1, 1.0]))
    else:
        X = intersect_sphere(O, D, np.array([3.0, -2.0, 310.0]), 45.0)
    # the truth must land on its own pixel through the forward distortion model
    ok = np.isfinite(X[..., 0])
    assert np.nanmax(np.abs(cam.project(X[ok]) - uv[ok])) < 1e-6
    uvp = rig.projector.project(X)
    return X, uvp[..., 0], uvp[..., 1]


@pytest.mark.parametrize("kind", ["plane", "sphere"])
def test_least_squares_with_up_only_equals_truth(kind):
    rig = small_rig()
    X, up, vp = scene_truth(rig, kind)
    pts = triangulate(rig, up=up)
    ok = np.isfinite(X[..., 0])
    assert pts.dtype == np.float32 and pts.shape == (128, 160, 3)
    assert np.all(np.isnan(pts[~ok]))
    assert np.max(np.abs(pts[ok] - X[ok])) < 1e-3  # mm


def test_least_squares_with_up_and_vp_equals_truth():
    rig = small_rig()
    X, up, vp = scene_truth(rig, "sphere")
    pts = triangulate(rig, up=up, vp=vp)
    ok = np.isfinite(X[..., 0])
    assert np.max(np.abs(pts[ok] - X[ok])) < 1e-3


def test_least_squares_with_vp_only_equals_truth():
    rig = small_rig()
    X, up, vp = scene_truth(rig, "plane")
    pts = triangulate(rig, vp=vp)
    # the rig's baseline is mostly horizontal: v_p is weakly depth sensitive, so allow float32 + conditioning
    assert np.max(np.abs(pts - X)) < 1e-3


@pytest.mark.parametrize("kind", ["plane", "sphere"])
def test_fast_path_equals_truth_with_camera_distortion(kind):
    rig = small_rig()
    X, up, vp = scene_truth(rig, kind)
    tri = Triangulator(rig)
    pts = tri.points(up)
    ok = np.isfinite(X[..., 0])
    assert np.all(np.isnan(pts[~ok]))
    assert np.max(np.abs(pts[ok] - X[ok])) < 1e-3
    assert np.max(np.abs(depth_map(pts)[ok] - X[ok][:, 2])) < 1e-3


def test_fast_path_from_phase_of_horizontal_fringes():
    rig = small_rig()
    X, up, vp = scene_truth(rig, "plane")
    T = 18.0
    pts = Triangulator(rig, angle=0.0).points_from_phase(vp * 2 * np.pi / T, T)
    assert np.max(np.abs(pts - X)) < 2e-3  # vp is weakly depth sensitive on this rig


def test_fast_path_oblique_fringe_direction():
    rig = small_rig()
    X, up, vp = scene_truth(rig, "sphere")
    a = np.deg2rad(60.0)
    w = vp * np.cos(a) + up * np.sin(a)
    pts = Triangulator(rig, angle=a).points(w)
    ok = np.isfinite(X[..., 0])
    assert np.max(np.abs(pts[ok] - X[ok])) < 1e-3


def test_projector_distortion_least_squares_iterates_to_truth_fast_path_warns():
    rig = small_rig(proj_dist=(0.05, -0.02, 0.0005, 0.0003, 0.0))
    X, up, vp = scene_truth(rig, "plane")
    pts = triangulate(rig, up=up)
    assert np.max(np.abs(pts - X)) < 1e-3
    with pytest.warns(ReconstructionWarning, match="distortion"):
        tri = Triangulator(rig)
    assert tri.ignores_distortion
    fast = tri.points(up)
    assert np.max(np.abs(fast - X)) > 1e-2  # the ignored distortion is visible, as documented


def test_mask_and_nan_give_nan_points():
    rig = small_rig()
    X, up, vp = scene_truth(rig, "plane")
    mask = np.ones(up.shape, bool)
    mask[10:20, 30:40] = False
    up2 = up.copy()
    up2[50, 50] = np.nan
    for pts in (triangulate(rig, up=up2, mask=mask), Triangulator(rig).points(up2, mask)):
        assert np.all(np.isnan(pts[10:20, 30:40])) and np.all(np.isnan(pts[50, 50]))
        assert np.isfinite(pts[0, 0]).all()


def test_size_mismatch_is_a_clear_error():
    rig = small_rig()
    with pytest.raises(ValueError, match="sizes disagree"):
        triangulate(rig, up=np.zeros((100, 160)))
    with pytest.raises(ValueError, match="sizes disagree"):
        Triangulator(rig).points(np.zeros((128, 100)))
    with pytest.raises(ValueError, match="at least one projector coordinate"):
        triangulate(rig)


def telecentric_rig():
    proj = PinholeDevice(K=intrinsics(3000.0, 3000.0, 127.5, 99.5), width=256, height=200)
    tilt = np.deg2rad(-25.0)
    Ry = np.array([[np.cos(tilt), 0, np.sin(tilt)], [0, 1, 0], [-np.sin(tilt), 0, np.cos(tilt)]])
    R = Ry.T
    s = 0.62 / 0.0048
    uv0 = s * (R[:2] @ np.array([0, 0, 100.0]))
    cam = TelecentricCamera.from_pose(0.62, R, np.zeros(3), 79.5 - uv0[0], 63.5 - uv0[1], 160, 128, pixel_size=0.0048)
    return Rig(cam, proj)


def test_telecentric_least_squares_and_fast_path_equal_truth():
    rig = telecentric_rig()
    cam = rig.camera
    uv = cam.pixel_grid()
    O, D = cam.rays(uv)
    X = intersect_plane(O, D, np.array([0, 0, 100.0]), np.array([0.2, 0.1, 1.0]))
    assert np.max(np.abs(cam.project(X) - uv)) < 1e-9
    uvp = rig.projector.project(X)
    for pts in (triangulate(rig, up=uvp[..., 0]), triangulate(rig, up=uvp[..., 0], vp=uvp[..., 1]),
                Triangulator(rig).points(uvp[..., 0])):
        assert np.max(np.abs(pts - X)) < 1e-3
