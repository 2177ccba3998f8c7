"""OpenCV's 8/12/14-coefficient distortion (rational k4-k6, thin prism s1-s4, tilt tau_x tau_y):
fringe3d's model against cv2.projectPoints / cv2.undistortPoints as the independent truth, kept in
the rig file, and used by triangulation end to end (a rig imported from a cv2.FileStorage YAML)."""
from __future__ import annotations

import cv2
import numpy as np
import pytest

from fringe3d.calibrate.opencv_file import load_opencv_calibration
from fringe3d.optics import Rig
from fringe3d.optics.distortion import as_coeffs, distort, undistort
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.reconstruct.depth import triangulator_for
from fringe3d.reconstruct.triangulate import triangulate

FIVE = [-0.12, 0.03, 0.001, -0.0015, 0.01]
EXTRA = {8: [0.04, -0.01, 0.002], 12: [0.04, -0.01, 0.002, 0.0015, -0.0008, 0.001, 0.0004],
         14: [0.04, -0.01, 0.002, 0.0015, -0.0008, 0.001, 0.0004, 0.015, -0.01]}
CRIT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-15)


def opencv_vector(n: int) -> np.ndarray:
    return np.array(FIVE + EXTRA[n]) if n > 5 else np.array(FIVE[:n])


def cv_distort(xy: np.ndarray, d: np.ndarray) -> np.ndarray:
    X = np.concatenate([xy, np.ones((len(xy), 1))], axis=1)
    return cv2.projectPoints(X, np.zeros(3), np.zeros(3), np.eye(3), d)[0].reshape(-1, 2)


@pytest.mark.parametrize("n", [4, 5, 8, 12, 14])
def test_distort_matches_cv2_project_points(n):
    xy = np.random.default_rng(n).uniform(-0.5, 0.5, (500, 2))
    d = opencv_vector(n)
    np.testing.assert_allclose(distort(xy, d), cv_distort(xy, d), atol=1e-14)


@pytest.mark.parametrize("n", [8, 12, 14])
def test_undistort_inverts_cv2_project_points_like_cv2_undistort_points(n):
    xy = np.random.default_rng(n).uniform(-0.4, 0.4, (500, 2))
    d = opencv_vector(n)
    xd = cv_distort(xy, d)
    np.testing.assert_allclose(undistort(xd, d), xy, atol=1e-12)
    cv = cv2.undistortPoints(xd.reshape(-1, 1, 2), np.eye(3), d, criteria=CRIT).reshape(-1, 2)
    np.testing.assert_allclose(undistort(xd, d), cv, atol=1e-9)


def test_zero_extra_terms_take_the_five_coefficient_path_bit_for_bit():
    xy = np.random.default_rng(0).uniform(-0.5, 0.5, (100, 2))
    long = np.concatenate([FIVE, np.zeros(9)])
    assert as_coeffs(long).shape == (5,) and as_coeffs(opencv_vector(12)).shape == (14,)
    assert np.array_equal(distort(xy, long), distort(xy, FIVE))
    assert np.array_equal(undistort(xy, long), undistort(xy, FIVE))


def test_more_than_14_coefficients_are_refused():
    with pytest.raises(ValueError, match="at most 14 .*k1 k2 p1 p2 k3 k4"):
        as_coeffs(np.zeros(15))


def _filestorage_rig(path, n: int) -> None:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    D1 = opencv_vector(n).reshape(1, -1)
    D2 = (0.5 * opencv_vector(n)).reshape(1, -1)
    for k, v in {"K1": np.array([[150.0, 0, 80], [0, 152, 60], [0, 0, 1]]), "D1": D1,
                 "K2": np.array([[200.0, 0, 100], [0, 200, 75], [0, 0, 1]]), "D2": D2,
                 "R": cv2.Rodrigues(np.array([0.0, -0.25, 0.02]))[0], "T": np.array([[120.0], [5.0], [10.0]]),
                 "cam_size": np.array([[160, 120]]), "proj_size": np.array([[200, 150]])}.items():
        fs.write(k, v)
    fs.release()


@pytest.mark.parametrize("n", [12, 14])
def test_rig_with_full_opencv_distortion_reconstructs_a_plane_computed_with_cv2(tmp_path, n):
    _filestorage_rig(tmp_path / "stereo.yaml", n)
    rig = load_opencv_calibration(tmp_path / "stereo.yaml")
    rig = Rig.load(rig.save(tmp_path / "rig.json"))  # the rig file keeps the full vector
    np.testing.assert_array_equal(rig.camera.dist[:n], opencv_vector(n))
    np.testing.assert_array_equal(rig.projector.dist[:n], 0.5 * opencv_vector(n))
    # direct computation with OpenCV: each camera pixel's ray (cv2.undistortPoints) meets the plane
    # z = 400 + 0.1 x; the point projected into the projector with cv2.projectPoints
    v, u = np.mgrid[0:120, 0:160].astype(np.float64)
    fs = cv2.FileStorage(str(tmp_path / "stereo.yaml"), cv2.FILE_STORAGE_READ)
    K1, D1, K2, D2, R, T = (fs.getNode(k).mat() for k in ("K1", "D1", "K2", "D2", "R", "T"))
    xy = cv2.undistortPoints(np.stack([u, v], -1).reshape(-1, 1, 2), K1, D1, criteria=CRIT).reshape(-1, 2)
    z = 400.0 / (1 - 0.1 * xy[:, 0])
    X = np.column_stack([xy * z[:, None], z])
    uvp = cv2.projectPoints(X, cv2.Rodrigues(R)[0], T, K2, D2)[0].reshape(120, 160, 2)
    X = X.reshape(120, 160, 3)
    pts = triangulate(rig, uvp[..., 0], uvp[..., 1], iterations=30)
    np.testing.assert_allclose(pts, X, atol=2e-3)  # float32 points (mm)
    # the closed-form path (camera distortion only; the projector ideal)
    ideal = Rig(rig.camera, rig.projector.__class__(K=rig.projector.K, dist=None, width=200, height=150,
                                                    R=rig.projector.R, t=rig.projector.t))
    up = cv2.projectPoints(X.reshape(-1, 3), cv2.Rodrigues(R)[0], T, K2, None)[0].reshape(120, 160, 2)[..., 0]
    fast = triangulator_for(RigGeometry(ideal), np.pi / 2).points(up, np.ones(up.shape, bool))  # w = u (Eq. 2.1)
    np.testing.assert_allclose(fast, X, atol=2e-3)


def test_rig_file_refuses_a_distortion_vector_of_another_length_naming_the_lengths(tmp_path):
    path = write_rig_with_dist(tmp_path, [0.0] * 6)
    with pytest.raises(ValueError, match=r"dist: expected 0, 4, 5, 8, 12, 14 coefficients .*k1 k2 p1 p2"):
        Rig.load(path)


def write_rig_with_dist(tmp_path, dist):
    import json

    from fringe3d.sim import presets
    d = presets.get("tiny").rig.to_dict()
    d["camera"]["dist"] = dist
    (tmp_path / "rig.json").write_text(json.dumps(d))
    return tmp_path / "rig.json"


def test_compiled_undistortion_gives_the_numpy_newton_points_bit_for_bit():
    from reference_implementations import undistort_reference

    v, u = np.mgrid[0:48, 0:64]
    grid = np.stack([(u - 32) / 40.0, (v - 24) / 40.0], -1)  # up to |x| 0.8: several Newton steps
    for dist in ([-0.08, 0.1, 0.0, 0.0, 0.0], [-0.3, 0.1, 1e-3, -2e-3, 0.05]):
        assert np.array_equal(undistort(grid, dist), undistort_reference(grid, dist))
        assert np.array_equal(undistort(grid[5, 7], dist), undistort_reference(grid[5, 7], dist))
