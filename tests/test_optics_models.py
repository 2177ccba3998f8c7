"""Geometry "Must show": camera/projector models against ray-cast truth and OpenCV."""
import json

import cv2
import numpy as np
import pytest

from fringe3d.optics import PinholeDevice, Rig, TelecentricCamera, intrinsics
from fringe3d.optics.distortion import distort, undistort
from fringe3d.sim.motion import rotation_vector_to_matrix
from fringe3d.sim.primitives import Plane, Sphere
from fringe3d.sim.scene import Scene

DIST = np.array([-0.28, 0.12, 8e-4, -5e-4, -0.02])


def _camera(dist=DIST, w=160, h=128, skew=0.4):
    return PinholeDevice(intrinsics(190.0, 188.0, 81.3, 62.7, skew=skew), w, h, dist=dist)


def _projector():
    R = rotation_vector_to_matrix([0.02, -0.25, 0.01])
    C = np.array([120.0, -10.0, 5.0])  # projector centre in world (camera) frame, mm
    return PinholeDevice(intrinsics(220.0, 220.0, 95.5, 50.0), 192, 108, dist=[0.05, -0.01, 0, 0, 0],
                         R=R, t=-R @ C)


def _scene():
    return Scene([Plane((0, 0, 420), (0.1, 0.05, -1)), Sphere((5, -3, 330), 35)])


def test_projecting_truth_xyz_returns_camera_pixel_centres():
    cam = _camera()
    uv = cam.pixel_grid().reshape(-1, 2)
    o, d = cam.rays(uv)
    h = _scene().intersect(o, d)
    assert h.mask.all()
    X = h.points(o, d)
    err = np.abs(cam.project(X) - uv).max()
    assert err < 1e-6


def test_projector_round_trip_returns_projector_coordinates():
    prj = _projector()
    rng = np.random.default_rng(3)
    up_vp = rng.uniform([0, 0], [prj.width - 1, prj.height - 1], (3000, 2))
    o, d = prj.rays(up_vp)
    h = _scene().intersect(o, d)
    assert h.mask.all()
    X = h.points(o, d)
    assert np.abs(prj.project(X) - up_vp).max() < 1e-6


def test_distortion_round_trip_inside_image_below_1e6_px():
    cam = _camera()
    uv = cam.pixel_grid().reshape(-1, 2)
    xy = cam.pixels_to_normalized(uv)  # undistort
    back = cam.normalized_to_pixels(distort(xy, cam.dist))
    assert np.abs(back - uv).max() < 1e-6
    # and the other way: undistort(distort(x)) == x for normalised points covering the image
    xy2 = undistort(distort(xy, DIST), DIST)
    assert np.abs(xy2 - xy).max() * cam.K[0, 0] < 1e-6


def test_project_matches_cv2_projectPoints():
    prj = _projector()
    rng = np.random.default_rng(4)
    X = rng.uniform([-80, -60, 250], [80, 60, 500], (500, 3))
    rvec, _ = cv2.Rodrigues(prj.R)
    ref, _ = cv2.projectPoints(X.reshape(-1, 1, 3), rvec, prj.t, prj.K, prj.dist)
    np.testing.assert_allclose(prj.project(X), ref.reshape(-1, 2), atol=1e-8)
    cam = _camera(skew=0.0)  # OpenCV's model has no skew
    ref, _ = cv2.projectPoints(X.reshape(-1, 1, 3), np.zeros(3), np.zeros(3), cam.K, cam.dist)
    np.testing.assert_allclose(cam.project(X), ref.reshape(-1, 2), atol=1e-8)


def test_undistortion_matches_cv2_undistortPoints_iterative():
    cam = _camera(skew=0.0)  # OpenCV's model has no skew
    uv = cam.pixel_grid()[::7, ::7].reshape(-1, 2)
    crit = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)
    ref = cv2.undistortPoints(uv.reshape(-1, 1, 2), cam.K, cam.dist, None, None, None, crit).reshape(-1, 2)
    ours = cam.pixels_to_normalized(uv)
    # compare in pixels (times the focal length)
    assert np.abs(ours - ref).max() * cam.K[0, 0] < 1e-6


def test_rays_pass_through_projected_point_at_device_depth():
    prj = _projector()
    X = np.array([[10.0, 20.0, 400.0], [-30.0, 5.0, 300.0]])
    o, d = prj.rays(prj.project(X))
    depth = prj.to_device(X)[:, 2]
    np.testing.assert_allclose(o + depth[:, None] * d, X, atol=1e-9)


def test_telecentric_projection_and_back_projection():
    R = rotation_vector_to_matrix([0.3, -0.2, 0.1])
    cam = TelecentricCamera.from_pose(0.5, R, [1.0, -2.0, 50.0], 80.0, 64.0, 160, 128, pixel_size=0.0048)
    s = 0.5 / 0.0048
    rng = np.random.default_rng(5)
    X = rng.uniform(-5, 5, (200, 3))
    # closed form Eq. (3.3): uv = s * R[:2] X + s t[:2] + c
    expect = s * (X @ R[:2].T + [1.0, -2.0]) + [80.0, 64.0]
    np.testing.assert_allclose(cam.project(X), expect, atol=1e-9)
    # moving along the view direction does not change the image; rays hit the points
    np.testing.assert_allclose(cam.project(X + 3.7 * cam.view_direction), expect, atol=1e-9)
    np.testing.assert_allclose(cam.view_direction, R[2], atol=1e-12)
    o, d = cam.rays(expect)
    back = cam.project(o + 11.0 * d)
    np.testing.assert_allclose(back, expect, atol=1e-9)
    # the ray through each pixel passes through its point: X - o is parallel to d
    off = X - o
    np.testing.assert_allclose(np.cross(off, d), 0, atol=1e-9)


def test_rig_json_round_trip(tmp_path):
    rig = Rig(camera=_camera(), projector=_projector())
    path = rig.save(tmp_path / "rig.json")
    back = Rig.load(path)
    for a, b in ((rig.camera, back.camera), (rig.projector, back.projector)):
        for f in ("K", "dist", "R", "t"):
            np.testing.assert_array_equal(getattr(a, f), getattr(b, f))
        assert (a.width, a.height) == (b.width, b.height)
    assert back.baseline == pytest.approx(rig.baseline)
    tele = Rig(camera=TelecentricCamera(np.arange(8.0).reshape(2, 4) + 1, 64, 48), projector=_projector())
    back = Rig.load(tele.save(tmp_path / "tele.json"))
    assert back.telecentric
    np.testing.assert_array_equal(back.camera.M, tele.camera.M)


def test_rig_file_errors_name_the_problem(tmp_path):
    good = Rig(camera=_camera(), projector=_projector()).to_dict()
    with pytest.raises(FileNotFoundError, match="no rig file"):
        Rig.load(tmp_path / "missing.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        Rig.load(bad)
    d = dict(good)
    del d["projector"]
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"bad.json: field projector: required field is missing"):
        Rig.load(bad)
    d = json.loads(json.dumps(good))
    del d["camera"]["K"]
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"field camera.K: required field is missing"):
        Rig.load(bad)
    d = json.loads(json.dumps(good))
    d["projector"]["kind"] = "fisheye"
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"field projector.kind: Input should be 'pinhole' \(got 'fisheye'\)"):
        Rig.load(bad)
    d = json.loads(json.dumps(good))
    d["camera"]["K"] = [[1, 0], [0, 1]]
    bad.write_text(json.dumps(d))
    with pytest.raises(ValueError, match=r"field camera.K\[0\]: List should have at least 3 items"):
        Rig.load(bad)
