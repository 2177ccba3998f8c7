"""A calibration made by OpenCV (cv2.calibrateCamera + cv2.stereoCalibrate, saved with cv2.FileStorage)
imports into a fringe3d Rig that reconstructs exactly what fringe3d's own calibration file does."""
from __future__ import annotations

import dataclasses

import cv2
import numpy as np
import pytest

from fringe3d.calibrate import observe_session
from fringe3d.calibrate.calibration_file import Calibration, load_calibration
from fringe3d.calibrate.opencv_file import load_opencv_calibration
from fringe3d.calibrate.session import calibrate_observations
from fringe3d.cli import main
from fringe3d.optics import PinholeDevice, Rig
from fringe3d.reconstruct import triangulate
from fringe3d.sim.calibration_session import SessionImaging, simulate_session

CRIT = (cv2.TERM_CRITERIA_COUNT | cv2.TERM_CRITERIA_EPS, 200, 1e-12)


@pytest.fixture(scope="module")
def calibrated(tmp_path_factory):
    """fringe3d's calibration of a tiny simulated session, and OpenCV's of the same observations."""
    ss = simulate_session("tiny", n_poses=5, seed=3, progress=False, imaging=SessionImaging(noise=False))
    obs, info = observe_session(ss.poses, ss.board, progress=False)
    cal, _ = calibrate_observations(obs, info, ss.board, camera_dist="k1k2p")
    obj = ss.board.object_points().astype(np.float32)
    keep = [np.all(np.isfinite(o.projector_uv), axis=1) for o in obs]
    O = [obj[k].reshape(-1, 1, 3) for k in keep]
    C = [o.camera_uv[k].astype(np.float32).reshape(-1, 1, 2) for o, k in zip(obs, keep)]
    P = [o.projector_uv[k].astype(np.float32).reshape(-1, 1, 2) for o, k in zip(obs, keep)]
    _, K1, D1, _, _ = cv2.calibrateCamera(O, C, info.camera_size, None, None, flags=cv2.CALIB_FIX_K3, criteria=CRIT)
    _, K2, D2, _, _ = cv2.calibrateCamera(O, P, info.projector_size, None, None,
                                          flags=cv2.CALIB_FIX_K3, criteria=CRIT)
    out = cv2.stereoCalibrate(O, C, P, K1, D1, K2, D2, info.camera_size, flags=cv2.CALIB_FIX_INTRINSIC,
                              criteria=CRIT)
    cv = {"K1": K1, "D1": D1, "K2": K2, "D2": D2, "R": out[5], "T": out[6]}
    info = {**dataclasses.asdict(info), "depth": float(np.median([np.ravel(t)[2] for _, t in ss.board_poses]))}
    return cal, cv, info


def _write_filestorage(path, nodes: dict) -> None:
    fs = cv2.FileStorage(str(path), cv2.FILE_STORAGE_WRITE)
    for k, v in nodes.items():
        fs.write(k, v)
    fs.release()


def _plane_coordinates(rig: Rig, depth: float):
    """Projector (u_p, v_p) for every camera pixel seeing the tilted plane z = depth + 0.1 x (mm)."""
    o, d = rig.camera.rays(rig.camera.pixel_grid().reshape(-1, 2))
    s = depth / (d[:, 2] - 0.1 * d[:, 0])
    X = o + s[:, None] * d
    uv = rig.projector.project(X).reshape(rig.camera.height, rig.camera.width, 2)
    return uv[..., 0], uv[..., 1], X.reshape(rig.camera.height, rig.camera.width, 3)


def test_opencv_stereo_calibration_imports_and_reconstructs_like_fringe3d_calibration(calibrated, tmp_path):
    cal, cv, info = calibrated
    yaml = tmp_path / "stereo.yaml"
    _write_filestorage(yaml, {"camera_matrix": cv["K1"], "D1": cv["D1"], "K2": cv["K2"], "D2": cv["D2"],
                              "rotation": cv["R"], "T": cv["T"] / 1000.0})  # T in metres
    rig_json = tmp_path / "imported.json"
    size = "--camera-size {}x{} --projector-size {}x{}".format(*info["camera_size"], *info["projector_size"])
    rc = main(["calibrate", "--import-opencv", str(yaml), "-o", str(rig_json), "--node", "cam_int=camera_matrix",
               "--node", "R=rotation", "--unit", "m", "-q", *size.split()])
    assert rc == 0
    imported = Rig.load(rig_json)
    # the same K/dist/R/T through fringe3d's own calibration file
    cam = PinholeDevice(K=cv["K1"], dist=cv["D1"], width=info["camera_size"][0], height=info["camera_size"][1])
    prj = PinholeDevice(K=cv["K2"], dist=cv["D2"], width=info["projector_size"][0],
                        height=info["projector_size"][1], R=cv["R"], t=cv["T"].ravel())
    own = Calibration(model="pinhole", rig=Rig(cam, prj), camera=cal.camera, projector=cal.projector,
                      board=cal.board, periods=cal.periods, angles=cal.angles, poses=cal.poses, rms=cal.rms)
    own.save(tmp_path / "own.json")
    native = load_calibration(tmp_path / "own.json").rig
    depth = info["depth"]
    up, vp, X = _plane_coordinates(native, depth)
    a, b = triangulate(native, up, vp), triangulate(imported, up, vp)
    both = np.isfinite(a).all(-1)
    assert both.mean() > 0.9 and np.array_equal(both, np.isfinite(b).all(-1))
    assert np.abs(a[both].astype(np.float64) - b[both]).max() <= 1e-6
    # and both reconstruct the plane itself (float32 point maps)
    assert np.abs(b[both] - X[both]).max() < 1e-3 * depth


def test_opencv_and_fringe3d_calibrations_of_one_session_agree(calibrated):
    cal, cv, _ = calibrated
    assert np.abs(cv["K1"] - cal.rig.camera.K).max() / cal.rig.camera.K[0, 0] < 1e-2
    assert np.abs(cv["T"].ravel() - cal.rig.projector.t).max() < 0.5  # mm, no circle-bias correction in OpenCV's


def test_fringe3d_opencv_yaml_export_round_trips_to_the_identical_rig(calibrated, tmp_path):
    cal = calibrated[0]
    yaml = cal.export_opencv_yaml(tmp_path / "c.yaml")
    rig = load_opencv_calibration(yaml)
    for a, b in ((rig.camera, cal.rig.camera), (rig.projector, cal.rig.projector)):
        assert a.size == b.size
        for k in ("K", "dist", "R", "t"):
            assert np.array_equal(getattr(a, k), getattr(b, k)), k


def test_missing_node_names_the_node_and_the_file(tmp_path, capsys):
    yaml = tmp_path / "no_t.yaml"
    _write_filestorage(yaml, {"K1": np.eye(3), "D1": np.zeros((1, 5)), "K2": np.eye(3), "D2": np.zeros((1, 5)),
                              "R": np.eye(3)})
    with pytest.raises(ValueError, match=r"no_t\.yaml.*'T'"):
        load_opencv_calibration(yaml, camera_size=(64, 48), projector_size=(64, 48))
    rc = main(["calibrate", "--import-opencv", str(yaml), "-o", str(tmp_path / "r.json"),
               "--camera-size", "64x48", "--projector-size", "64x48"])
    assert rc == 2 and "'T'" in capsys.readouterr().err and not (tmp_path / "r.json").exists()
    _write_filestorage(yaml, {"K1": np.eye(3), "D1": np.zeros((1, 5)), "K2": np.eye(3), "D2": np.zeros((1, 5)),
                              "R": np.eye(3), "T": np.zeros((3, 1))})
    with pytest.raises(ValueError, match="cam_size.*`camera_size`"):
        load_opencv_calibration(yaml)


def test_long_distortion_vectors_load_and_keep_their_extra_terms(tmp_path):
    d8 = np.array([[0.1, -0.02, 0.001, 0.002, 0.003, 0, 0, 0]])
    nodes = {"K1": np.diag([100.0, 100, 1]), "D1": d8, "K2": np.diag([90.0, 90, 1]), "D2": np.zeros((1, 14)),
             "R": np.eye(3), "T": np.array([[50.0], [0], [0]]), "cam_size": np.array([[64, 48]])}
    _write_filestorage(tmp_path / "a.yaml", {**nodes, "proj_size": np.array([[80, 60]])})
    rig = load_opencv_calibration(tmp_path / "a.yaml")
    assert np.array_equal(rig.camera.dist, d8.ravel()[:5]) and rig.projector.size == (80, 60)
    nodes["D1"] = np.array([[0.1, -0.02, 0.001, 0.002, 0.003, 0.5, 0, 0]])
    _write_filestorage(tmp_path / "b.xml", {**nodes, "proj_size": np.array([[80, 60]])})
    d = load_opencv_calibration(tmp_path / "b.xml").camera.dist
    assert d.size == 14 and d[5] == 0.5 and np.array_equal(d[:8], nodes["D1"].ravel())
    nodes["D1"] = np.zeros((1, 6))
    _write_filestorage(tmp_path / "c.yaml", {**nodes, "proj_size": np.array([[80, 60]])})
    with pytest.raises(ValueError, match=r"c\.yaml.*'D1'.*\(12,\) or \(14,\), got 6 values"):
        load_opencv_calibration(tmp_path / "c.yaml")


K_CAM = np.array([[800.0, 0, 319.5], [0, 805.0, 239.5], [0, 0, 1]])
K_PRJ = np.array([[1500.0, 0, 455.5], [0, 1500.0, 1139.0], [0, 0, 1]])
D_CAM = np.array([[-0.12, 0.05, 0.001, -0.002, 0.0]])
R_RIG = cv2.Rodrigues(np.array([0.02, -0.3, 0.01]))[0]
T_RIG = np.array([[150.0], [-5.0], [20.0]])


def _stereo_calib_files(folder, d1=D_CAM):
    """OpenCV's stereo_calib sample's two files, written by cv2.FileStorage: intrinsics.yml
    (M1 D1 M2 D2) and extrinsics.yml (R T R1 R2 P1 P2 Q, from cv2.stereoRectify)."""
    folder.mkdir(exist_ok=True)
    R1, R2, P1, P2, Q, _, _ = cv2.stereoRectify(K_CAM, D_CAM, K_PRJ, np.zeros(5), (640, 480), R_RIG, T_RIG)
    intrinsics = {"M1": K_CAM, "M2": K_PRJ, "D2": np.zeros((1, 5))} | ({} if d1 is None else {"D1": d1})
    _write_filestorage(folder / "intrinsics.yml", intrinsics)
    _write_filestorage(folder / "extrinsics.yml", {"R": R_RIG, "T": T_RIG, "R1": R1, "R2": R2, "P1": P1, "P2": P2,
                                                   "Q": Q})
    return folder / "intrinsics.yml", folder / "extrinsics.yml"


def test_opencv_two_file_stereo_layout_imports_from_the_cli(tmp_path, capsys):
    intr, extr = _stereo_calib_files(tmp_path / "cv")
    sizes = ["--camera-size", "640x480", "--projector-size", "912x1140"]
    two_files, folder = ["--import-opencv", intr, "--import-opencv", extr], ["--import-opencv", tmp_path / "cv"]
    for k, source in enumerate((two_files, folder)):
        out = tmp_path / f"rig{k}.json"
        assert main(["calibrate", *map(str, source), *sizes, "-o", str(out), "-q"]) == 0
        rig = Rig.load(out)
        np.testing.assert_array_equal(rig.camera.K, K_CAM)
        np.testing.assert_array_equal(rig.camera.dist, D_CAM.ravel())
        np.testing.assert_array_equal(rig.projector.K, K_PRJ)
        np.testing.assert_allclose(rig.projector.R, R_RIG, atol=1e-15)
        np.testing.assert_array_equal(rig.projector.t, T_RIG.ravel())
    capsys.readouterr()  # the intrinsics alone: R and T are missing, and the message says where they are
    assert main(["calibrate", "--import-opencv", str(intr), *sizes, "-o", str(tmp_path / "half.json")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "extrinsics.yml" in err and not (tmp_path / "half.json").exists()


def test_node_dist_none_imports_a_lens_without_distortion(tmp_path, capsys):
    intr, extr = _stereo_calib_files(tmp_path / "cv", d1=None)
    args = ["calibrate", "--import-opencv", str(intr), "--import-opencv", str(extr), "--camera-size", "640x480",
            "--projector-size", "912x1140"]
    assert main([*args, "-o", str(tmp_path / "no.json")]) == 2
    assert "cam_dist=none" in " ".join(capsys.readouterr().err.split())
    assert main([*args, "--node", "cam_dist=none", "-o", str(tmp_path / "rig.json"), "-q"]) == 0
    rig = Rig.load(tmp_path / "rig.json")
    assert not np.any(rig.camera.dist)
    pts = np.array([[100.0, -50.0, 900.0], [0.0, 30.0, 800.0]])
    uv = cv2.projectPoints(pts, np.zeros(3), np.zeros(3), K_CAM, None)[0].reshape(-1, 2)
    np.testing.assert_allclose(rig.camera.project(pts), uv, atol=1e-9)


def test_an_image_shape_in_rows_cols_order_never_gives_a_transposed_camera(tmp_path, capsys):
    base = {"K1": K_CAM, "D1": D_CAM, "K2": K_PRJ, "D2": np.zeros((1, 5)), "R": R_RIG, "T": T_RIG,
            "proj_size": np.array([[912, 1140]])}
    _write_filestorage(tmp_path / "shape.xml", {**base, "img_shape": np.array([[480, 640]])})  # numpy's (rows, cols)
    assert load_opencv_calibration(tmp_path / "shape.xml").camera.size == (640, 480)
    _write_filestorage(tmp_path / "wh.xml", {**base, "img_shape": np.array([[640, 480]])})  # [w, h] under that name
    with pytest.warns(UserWarning, match="img_shape.*640x480"):
        assert load_opencv_calibration(tmp_path / "wh.xml").camera.size == (640, 480)
    _write_filestorage(tmp_path / "sz.xml", {**base, "sz": np.array([[480, 640]])})
    with pytest.warns(UserWarning, match="rows, cols"):
        assert load_opencv_calibration(tmp_path / "sz.xml", {"cam_size": "sz"}).camera.size == (640, 480)
    # a principal point that cannot tell the order: refused, naming the node and the way out
    _write_filestorage(tmp_path / "amb.xml", {**base, "K1": np.diag([800.0, 800.0, 1.0]), "sz": np.array([[480, 640]])})
    assert main(["calibrate", "--import-opencv", str(tmp_path / "amb.xml"), "--node", "cam_size=sz",
                 "-o", str(tmp_path / "amb.json")]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "'sz'" in err and "--camera-size" in err and not (tmp_path / "amb.json").exists()
