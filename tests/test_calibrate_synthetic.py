"""Calibration math on synthetic correspondences: board points projected through known devices."""
import cv2
import numpy as np
import pytest

from fringe3d.calibrate.boards import CircleBoard
from fringe3d.calibrate.stereo import PoseObservation, calibrate_pinhole_rig
from fringe3d.optics import PinholeDevice, intrinsics

BOARD = CircleBoard(cols=9, rows=9, spacing=12.0, radius=3.0)
CAM = PinholeDevice(K=intrinsics(1600, 1602, 322.3, 241.7), width=640, height=480, dist=[-0.08, 0.05, 0, 0, 0])
R_P, _ = cv2.Rodrigues(np.array([0.02, -0.30, 0.01]))
PRJ = PinholeDevice(K=intrinsics(1500, 1500, 455.0, 570.0), width=912, height=1140, R=R_P, t=[150.0, -5.0, 30.0])


def board_poses(n, seed=1):
    rng = np.random.default_rng(seed)
    poses = []
    centre = BOARD.object_points()[:, :2].mean(0)
    for _ in range(n):
        rv = rng.uniform(-0.45, 0.45, 3) * [1, 1, 0.3]
        R, _ = cv2.Rodrigues(rv)
        c3 = np.array([centre[0], centre[1], 0.0])
        t = np.array([rng.uniform(-15, 15), rng.uniform(-10, 10), rng.uniform(480, 560)]) - R @ c3
        poses.append((R, t))
    return poses


def to_world(R, t, Xb):
    return Xb @ R.T + t


def disk_centroid(device, R, t, centre_b, radius, n=60):
    """Centroid of the image of a board disk, by dense sampling weighted with the area Jacobian."""
    r = (np.arange(n) + 0.5) / n * radius
    a = (np.arange(4 * n) + 0.5) / (4 * n) * 2 * np.pi
    rr, aa = np.meshgrid(r, a)
    pts = np.stack([centre_b[0] + rr * np.cos(aa), centre_b[1] + rr * np.sin(aa), 0 * rr], -1).reshape(-1, 3)
    e = 1e-4
    p0 = device.project(to_world(R, t, pts))
    px = device.project(to_world(R, t, pts + [e, 0, 0]))
    py = device.project(to_world(R, t, pts + [0, e, 0]))
    J = np.abs((px - p0)[:, 0] * (py - p0)[:, 1] - (px - p0)[:, 1] * (py - p0)[:, 0])
    w = J * rr.ravel()  # polar area element
    return (p0 * w[:, None]).sum(0) / w.sum()


def board_point_seen(R, t, uv):
    """Board-plane point under camera pixel uv (true camera), in world coordinates."""
    _, d = CAM.rays(uv)
    n = R[:, 2]
    s = (n @ t) / (d @ n)
    return d * s[:, None]


def observations(poses, realistic_centres, noise=0.0, seed=2):
    rng = np.random.default_rng(seed)
    obs = []
    Xb = BOARD.object_points()
    for k, (R, t) in enumerate(poses):
        if realistic_centres:
            cam = np.array([disk_centroid(CAM, R, t, c, BOARD.radius) for c in Xb])
        else:
            cam = CAM.project(to_world(R, t, Xb))
        cam = cam + rng.normal(0, noise, cam.shape)
        prj = PRJ.project(board_point_seen(R, t, cam))  # what phase mapping gives at the camera centre
        prj = prj + rng.normal(0, noise, prj.shape)
        obs.append(PoseObservation(name=f"pose{k:02d}", camera_uv=cam, projector_uv=prj))
    return obs


def rotation_error_deg(Ra, Rb):
    return np.degrees(np.linalg.norm(cv2.Rodrigues(Ra @ Rb.T)[0]))


def check_truth(cal, f_tol, c_tol, t_tol, r_tol):
    cam, prj = cal.rig.camera, cal.rig.projector
    for est, true in ((cam, CAM), (prj, PRJ)):
        assert abs(est.K[0, 0] / true.K[0, 0] - 1) < f_tol
        assert abs(est.K[1, 1] / true.K[1, 1] - 1) < f_tol
        assert np.abs(est.K[:2, 2] - true.K[:2, 2]).max() < c_tol
    assert np.abs(prj.t - PRJ.t).max() < t_tol
    assert rotation_error_deg(prj.R, PRJ.R) < r_tol


def test_exact_correspondences_recover_rig_to_noise_free_tolerances():
    obs = observations(board_poses(12), realistic_centres=False)
    cal = calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size, camera_dist="k1k2", correct_circle_bias=False)
    check_truth(cal, 1e-3, 0.1, 0.05, 0.01)
    assert cal.camera.rms < 0.01 and cal.projector.rms < 0.01
    assert np.allclose(cal.rig.camera.dist[:2], CAM.dist[:2], atol=1e-3)


def test_ellipse_centroid_bias_is_removed_by_correction():
    obs = observations(board_poses(12), realistic_centres=True)
    raw = calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size, camera_dist="k1k2", correct_circle_bias=False)
    fixed = calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size, camera_dist="k1k2", correct_circle_bias=True)
    check_truth(fixed, 1e-3, 0.1, 0.05, 0.01)
    assert fixed.camera.rms < 0.01 and fixed.projector.rms < 0.01
    assert raw.camera.rms > 2 * fixed.camera.rms  # the bias is real at these tilts


def test_noisy_correspondences_stay_close_to_truth():
    obs = observations(board_poses(15), realistic_centres=False, noise=0.05)
    cal = calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size, camera_dist="k1k2", correct_circle_bias=False)
    check_truth(cal, 5e-3, 2.0, 1.5, 0.1)
    assert 0.03 < cal.camera.rms < 0.1


def test_too_few_poses_is_an_error():
    obs = observations(board_poses(2), realistic_centres=False)
    with pytest.raises(ValueError, match="need at least 3"):
        calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size)


def test_phase_invalid_at_centres_is_an_error_naming_poses():
    obs = observations(board_poses(4), realistic_centres=False)
    for o in obs[1:]:
        o.projector_uv[:] = np.nan
    with pytest.raises(ValueError, match="phase is invalid at the circle centres.*pose01"):
        calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size)


def test_projector_distortion_is_recovered_when_modelled():
    global PRJ
    saved = PRJ
    try:
        PRJ = PinholeDevice(K=saved.K, width=saved.width, height=saved.height, R=saved.R, t=saved.t,
                            dist=[0.06, -0.1, 0, 0, 0])
        obs = observations(board_poses(14), realistic_centres=False)
        lin = calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size, camera_dist="k1k2", projector_dist="none",
                                    correct_circle_bias=False)
        dis = calibrate_pinhole_rig(BOARD, obs, CAM.size, PRJ.size, camera_dist="k1k2", projector_dist="k1k2",
                                    correct_circle_bias=False)
        assert lin.projector.rms > 0.02 and lin.projector.rms > 10 * dis.projector.rms  # linear model misfits
        assert dis.projector.rms < 0.01
        assert np.allclose(dis.rig.projector.dist[:2], [0.06, -0.1], atol=5e-3)
        check_truth(dis, 1e-3, 0.1, 0.05, 0.01)
    finally:
        PRJ = saved
