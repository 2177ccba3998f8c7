"""Multi-view registration, fusion and meshing against the virtual turntable's truth."""
from __future__ import annotations

import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.devices.stage import rotation_about
from fringe3d.multiview.accuracy import coverage, pose_errors, rms, surface_distances
from fringe3d.multiview.axis import fit_axis, turntable_poses
from fringe3d.multiview.fuse import place
from fringe3d.multiview.merge import merge_views
from fringe3d.multiview.poses import read_poses, write_poses
from fringe3d.multiview.views import view_from_map
from fringe3d.sim import presets
from fringe3d.sim.turntable import (VirtualTurntable, default_turntable, sculpture_turntable, turntable_views,
                                    write_turntable)

ANGLES = np.arange(-30.0, 31.0, 20.0)  # 4 views, 20 degrees apart


@pytest.fixture(scope="module")
def scan():
    p = presets.get("tiny")  # 160 x 128 camera
    return turntable_views(sculpture_turntable(p, seed=0), p, ANGLES, sigma=0.05, seed=0)


@pytest.fixture(scope="module")
def views(scan):
    return [view_from_map(f"view-{i:02d}", P, s) for i, (P, s) in enumerate(zip(scan.points, scan.sigma))]


def _perturbed(poses, centre, seed=1):
    rng = np.random.default_rng(seed)
    out = [poses[0]]
    for P in poses[1:]:
        T = rotation_about(rng.normal(size=3), 0.01, centre)  # 10 mrad
        T[:3, 3] += rng.normal(size=3)  # ~1.7 mm
        out.append(P @ T)
    return np.stack(out)


def test_registration_from_rough_stage_poses_recovers_true_poses(scan, views):
    c = scan.truth_points.mean(0)
    m = merge_views(views, _perturbed(scan.true_poses, c), voxel=4.0, mesh="none")
    rot, tra = pose_errors(m.registration.poses, scan.true_poses, c)
    start_rot, _ = pose_errors(_perturbed(scan.true_poses, c), scan.true_poses, c)
    assert start_rot[1:].min() > 5.0
    assert rot.max() < 5.0 and tra.max() < 100.0  # mrad, um
    assert np.all(np.isfinite(m.registration.residual_rms_mm))
    assert np.all(m.registration.residual_rms_mm < 0.5)
    assert np.all(np.isfinite(m.registration.rotation_sigma_mrad))


def test_free_hand_converges_from_the_global_step_alone_on_the_sculpture(scan, views):
    c = scan.truth_points.mean(0)
    m = merge_views(views, None, voxel=4.0, mesh="none", seed=0)
    rot, tra = pose_errors(m.registration.poses, scan.true_poses, c)
    assert rot.max() < 5.0 and tra.max() < 100.0


def test_fused_cloud_is_no_worse_than_one_view_and_covers_the_visible_surface(scan, views):
    m = merge_views(views, scan.true_poses, voxel=4.0, mesh="poisson")
    single = rms(surface_distances(place(views[0], scan.true_poses[0]), scan.truth_points, scan.truth_normals))
    fused = rms(surface_distances(m.fused.points, scan.truth_points, scan.truth_normals))
    assert fused <= 1.2 * single
    assert coverage(m.fused.points, scan.truth_points, 2.0) >= 0.98
    assert m.fused.views.max() >= 2  # overlap really fused
    mesh_rms = rms(surface_distances(np.asarray(m.mesh.vertices), scan.truth_points, scan.truth_normals))
    assert mesh_rms < 0.5


def test_axis_fit_recovers_the_simulated_turntable_axis():
    table = default_turntable(presets.get("tiny"))
    table = VirtualTurntable(table.axis + [0.05, 0.0, 0.1], table.point + [3.0, -2.0, 5.0])
    board = np.eye(4)
    board[:3, 3] = table.point + [40.0, 10.0, -20.0]
    rng = np.random.default_rng(3)
    poses = []
    for a in (0, 30, 60, 90, 120):
        table.move_to(a)
        noise = rotation_about(rng.normal(size=3), 1e-4, board[:3, 3])
        poses.append(table.transform() @ noise @ board)
    axis, point = fit_axis(poses)
    assert 1e3 * np.arccos(min(1.0, axis @ table.axis)) < 1.0  # mrad
    off = point - table.point
    assert np.linalg.norm(off - (off @ table.axis) * table.axis) < 0.1  # mm from the true axis line
    back = turntable_poses(axis, point, [0, 30])
    table.move_to(30)
    E = back[1] @ table.transform()  # view 1 -> model after the table's own motion: identity
    assert np.abs(E[:3, :3] - np.eye(3)).max() < 1e-3 and np.abs(E[:3, 3]).max() < 0.2


def test_poses_file_errors_name_the_file_and_the_field(tmp_path):
    f = tmp_path / "poses.json"
    f.write_text("{not json")
    with pytest.raises(ValueError, match="not valid JSON"):
        read_poses(f)
    f.write_text(json.dumps({"format": "fringe3d-poses", "views": [{"name": "a", "matrix": [[1, 0], [0, 1]]}]}))
    with pytest.raises(ValueError, match=r"views\[0\]\.matrix"):
        read_poses(f)
    M = np.eye(4)
    M[0, 0] = 2.0
    write_poses(f, ["a"], [M])
    with pytest.raises(ValueError, match="not a rigid transform"):
        read_poses(f)


@pytest.fixture(scope="module")
def scan_folder(scan, tmp_path_factory):
    folder = tmp_path_factory.mktemp("turntable")
    return folder, write_turntable(folder, scan)


def test_merge_cli_writes_the_fused_cloud_mesh_and_registered_poses(scan_folder, tmp_path):
    folder, views = scan_folder
    out = tmp_path / "merged"
    args = ["merge", *map(str, views), "--poses", str(folder / "poses.json"), "-o", str(out), "--voxel", "4", "-q"]
    assert main(args) == 0
    import open3d as o3d
    assert len(o3d.io.read_point_cloud(str(out / "fused.ply")).points) > 1000
    assert len(o3d.io.read_triangle_mesh(str(out / "mesh.ply")).triangles) > 1000
    summary = json.loads((out / "merge.json").read_text())
    for v, view in zip(summary["views"], views):
        assert v["points"] == int(np.isfinite(np.load(view / "points.npy")).all(-1).sum())
        assert 0 < v["overlap_share"] <= 1
    assert 0 < summary["fused_overlap_share"] < 1
    got = read_poses(out / "poses.json")
    truth = np.load(folder / "truth.npz")
    rot, _ = pose_errors(np.stack([got[v.name] for v in views]), truth["poses"], truth["points"].mean(0))
    assert rot.max() < 5.0
    assert main(args) == 2  # an existing output is refused without --overwrite


@pytest.mark.parametrize("case, expected", [
    ("missing", "does not exist"),
    ("bad-json", "not valid JSON"),
    ("no-view", "no entry in 'views' for view(s) view-01"),
    ("neither", "exactly one of --poses FILE or --free-hand"),
])
def test_merge_cli_refuses_bad_poses_with_exit_2_before_writing(scan_folder, tmp_path, capsys, case, expected):
    folder, views = scan_folder
    poses = tmp_path / "poses.json"
    if case == "bad-json":
        poses.write_text('{"format": ')
    elif case == "no-view":
        write_poses(poses, ["view-00"], [np.eye(4)])
    flag = [] if case == "neither" else ["--poses", str(poses)]
    out = tmp_path / "merged"
    assert main(["merge", str(views[0]), str(views[1]), *flag, "-o", str(out)]) == 2
    assert expected in " ".join(capsys.readouterr().err.split())
    assert not out.exists()


def test_fusion_resolves_overlap_by_inverse_variance_weights():
    from fringe3d.multiview.fuse import fuse_views
    from fringe3d.multiview.views import View
    g = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0)), -1).reshape(-1, 2) + 0.5
    flat = np.column_stack([g, np.full(len(g), 0.5)])
    good = View("good", flat, np.full(len(g), 0.01))
    poor = View("poor", flat + [0.0, 0.0, 0.3], np.full(len(g), 0.1))
    f = fuse_views([good, poor], [np.eye(4), np.eye(4)], voxel=1.0)
    w1, w2 = 1 / 0.01 ** 2, 1 / 0.1 ** 2
    assert np.allclose(f.points[:, 2], (w1 * 0.5 + w2 * 0.8) / (w1 + w2))
    assert np.allclose(f.sigma, (w1 + w2) ** -0.5)
    assert np.all(f.views == 2)


def test_fusion_counts_each_views_points_and_the_share_of_its_surface_another_view_saw():
    from fringe3d.multiview.fuse import fuse_views
    from fringe3d.multiview.views import View
    g = np.stack(np.meshgrid(np.arange(10.0), np.arange(10.0)), -1).reshape(-1, 2) + 0.5
    flat = np.column_stack([g, np.full(len(g), 0.5)])
    half = flat[:, 0] < 5  # the second view sees the left half only
    whole = View("whole", flat, np.full(len(g), 0.01))
    left = View("left", flat[half], np.full(int(half.sum()), 0.01))
    f = fuse_views([whole, left], [np.eye(4), np.eye(4)], voxel=1.0)
    assert f.view_points.tolist() == [100, 50]
    assert f.view_overlap.tolist() == [0.5, 1.0]  # half of the whole view's voxels, all of the left one's
    assert f.overlap_share == 0.5  # 50 of the 100 fused points were seen twice


def test_sphere_spacing_across_views_matches_the_simulated_bar():
    from fringe3d.analyze.vdi import multiview_sphere_spacing
    from fringe3d.multiview.fuse import fuse_views
    from fringe3d.sim.turntable import sphere_bar_scene
    p = presets.get("tiny")
    scene, centres, r = sphere_bar_scene(p)
    bar = turntable_views(scene, p, [0.0, 30.0, 330.0], sigma=0.05, seed=2)
    vs = [view_from_map(str(i), P, s) for i, (P, s) in enumerate(zip(bar.points, bar.sigma))]
    fused = fuse_views(vs, bar.true_poses, 1.0)
    true = float(np.linalg.norm(centres[1] - centres[0]))
    sp = multiview_sphere_spacing(fused.points, centres, r, true)
    assert abs(sp.error) < 0.05  # mm, with noise 0.05 mm and ~2 mm pixels
    one = multiview_sphere_spacing(place(vs[0], bar.true_poses[0]), centres, r, true)
    assert np.isfinite(one.error)


# --------------------------------------------------------------------------- simulated multi-view captures
@pytest.fixture(scope="module")
def bar_captures(tmp_path_factory):
    """``fringe3d simulate --views 2`` of the sphere bar (tiny rig, 9-frame phase-shift set)."""
    out = tmp_path_factory.mktemp("sim") / "bar"
    assert main(["simulate", "--scene", "sphere-bar", "--set", "phase-shift", "--views", "2",
                 "--turntable-step", "30", "--stage-sigma", "2,0.2", "-o", str(out), "-q"]) == 0
    return out


def test_simulated_views_put_the_true_surface_on_the_true_spheres_in_the_model_frame(bar_captures):
    from fringe3d.multiview.poses import read_stage_sigma, read_true_poses
    from fringe3d.sim.truth import Truth
    true = read_true_poses(bar_captures / "poses.json")
    spheres = json.loads((bar_captures / "spheres.json").read_text())["spheres"]
    table = default_turntable(presets.get("tiny"))
    expected = rotation_about(table.axis, -np.deg2rad(30.0), table.point)  # view 1 -> model: the turn undone
    assert np.allclose(true["view-01"], expected, atol=1e-9)
    assert np.allclose(true["view-00"], np.eye(4))
    assert read_stage_sigma(bar_captures / "poses.json") == (2.0, 0.2)
    for name in ("view-00", "view-01"):
        t = Truth.load(bar_captures / name / "truth")
        for k, s in enumerate(spheres):
            X = t.xyz[(t.object_id == k) & t.mask]
            assert len(X) > 50
            Xm = X @ true[name][:3, :3].T + true[name][:3, 3]
            assert np.abs(np.linalg.norm(Xm - s["centre_mm"], axis=1) - s["radius_mm"]).max() < 1e-6


def test_simulated_stage_poses_are_off_by_the_stated_stage_uncertainty(bar_captures):
    true = read_poses(bar_captures / "poses.json")  # what the stage reports
    from fringe3d.multiview.poses import read_true_poses
    truth = read_true_poses(bar_captures / "poses.json")
    rot, tra = pose_errors(np.stack([true["view-00"], true["view-01"]]),
                           np.stack([truth["view-00"], truth["view-01"]]), default_turntable(presets.get("tiny")).point)
    assert rot[0] == 0 and 0 < rot[1] < 5 * np.sqrt(3) * 2.0  # mrad: 2 mrad per axis
    assert 0 < tra[1] < 5 * np.sqrt(3) * 200.0  # um: 0.2 mm per axis


@pytest.mark.parametrize("args, expected", [
    (["--turntable-step", "10"], "--turntable-step needs --views N"),
    (["--views", "1"], "--views must be between 2 and 360"),
    (["--views", "2", "--stage-sigma", "2"], "--stage-sigma: expected ROT_MRAD,TRANS_MM"),
])
def test_simulate_refuses_bad_multiview_flags_before_writing(tmp_path, capsys, args, expected):
    out = tmp_path / "x"
    assert main(["simulate", "--set", "phase-shift", *args, "-o", str(out), "-q"]) == 2
    assert expected in " ".join(capsys.readouterr().err.split())
    assert not out.exists()


# --------------------------------------------------------------------------- stage prior
STAGE_SIGMA = (2.0, 0.2)  # mrad, mm (1 sigma per axis)


@pytest.fixture(scope="module")
def dumbbell():
    """Two bare spheres on the turntable (no bar): their roll about the line of centres is
    invisible to every view. Returns the scan, its views, the stage's poses (true poses off by
    STAGE_SIGMA) and the bar's unit axis (model frame)."""
    from fringe3d.sim.turntable import sphere_bar_scene, stage_errors
    p = presets.get("tiny")
    scene, centres, _ = sphere_bar_scene(p, bar="none")
    scan = turntable_views(scene, p, np.arange(-60.0, 61.0, 30.0), sigma=0.05, seed=0)
    vs = [view_from_map(f"view-{i:02d}", P, s) for i, (P, s) in enumerate(zip(scan.points, scan.sigma))]
    c = centres.mean(0)
    cents = [np.linalg.inv(T)[:3, :3] @ c + np.linalg.inv(T)[:3, 3] for T in scan.true_poses]
    axis = (centres[1] - centres[0]) / np.linalg.norm(centres[1] - centres[0])
    return scan, vs, stage_errors(scan.true_poses, cents, *STAGE_SIGMA, seed=1), axis, c


def _roll_and_rest_mrad(poses, true, axis):
    """Per view: the rotation error about the bar axis and the rest of it (mrad)."""
    from scipy.spatial.transform import Rotation
    roll, rest = [], []
    for T, S in zip(true, poses):
        rv = Rotation.from_matrix((S @ np.linalg.inv(T))[:3, :3]).as_rotvec()  # model frame
        roll.append(1e3 * rv @ axis)
        rest.append(1e3 * np.linalg.norm(rv - (rv @ axis) * axis))
    return np.array(roll), np.array(rest)


def test_stage_prior_holds_an_unobservable_roll_at_the_stage_pose_and_reports_the_stage_sigma(dumbbell):
    from fringe3d.multiview.register import register_views
    scan, vs, stage, axis, c = dumbbell
    r = register_views(vs, stage, voxel=2.0, stage_sigma=STAGE_SIGMA)
    roll, rest = _roll_and_rest_mrad(r.poses, scan.true_poses, axis)
    stage_roll, stage_rest = _roll_and_rest_mrad(stage, scan.true_poses, axis)
    assert np.abs(roll - stage_roll).max() < 0.5 * STAGE_SIGMA[0]  # the roll stays where the stage put it
    assert stage_rest[1:].mean() > 1.5 and rest[1:].mean() < 0.7 * stage_rest[1:].mean()  # the others improve
    _, tra = pose_errors(r.poses, scan.true_poses, c)
    assert tra.max() < 100.0  # um at the bar centre
    # the roll is known to the stage's sigma, no better: the reported 1-sigma says so
    assert np.all((r.rotation_sigma_mrad[1:] > 0.7 * STAGE_SIGMA[0]) & (r.rotation_sigma_mrad[1:] <= STAGE_SIGMA[0]))


def test_without_the_stage_prior_an_unobservable_roll_is_not_reported_as_known(dumbbell):
    from fringe3d.multiview.register import register_views
    scan, vs, stage, axis, _ = dumbbell
    r = register_views(vs, stage, voxel=2.0)
    sig = r.rotation_sigma_mrad[1:]
    assert np.all(np.isnan(sig) | (sig > STAGE_SIGMA[0]))


def test_stage_prior_leaves_a_well_constrained_sculpture_to_the_data(scan, views):
    from fringe3d.sim.turntable import stage_errors
    c = scan.truth_points.mean(0)
    cents = [np.linalg.inv(T)[:3, :3] @ c + np.linalg.inv(T)[:3, 3] for T in scan.true_poses]
    stage = stage_errors(scan.true_poses, cents, 5.0, 0.5, seed=1)
    m = merge_views(views, stage, voxel=4.0, mesh="none", stage_sigma=(5.0, 0.5))
    rot, tra = pose_errors(m.registration.poses, scan.true_poses, c)
    start_rot, start_tra = pose_errors(stage, scan.true_poses, c)
    assert start_rot[1:].min() > 4.0 and start_tra[1:].min() > 250.0
    assert rot.max() < 2.5 and tra.max() < 60.0  # mrad, um: the data win over a 5 mrad stage
    assert np.all(m.registration.rotation_sigma_mrad[1:] < 5.0)
    assert m.summary()["stage_prior"] == {"rotation_mrad": 5.0, "translation_mm": 0.5}


def test_merge_cli_takes_the_stage_sigma_from_the_poses_file_or_the_flag(scan_folder, tmp_path, capsys):
    from fringe3d.multiview.poses import stage_entry
    folder, views = scan_folder
    names = [v.name for v in views]
    poses = tmp_path / "poses.json"
    write_poses(poses, names, [read_poses(folder / "poses.json")[n] for n in names],
                stage=stage_entry({"kind": "test"}, 3.0, 0.3))
    base = ["merge", *map(str, views), "--poses", str(poses), "--voxel", "4", "--mesh", "none", "--json"]
    assert main([*base, "-o", str(tmp_path / "a")]) == 0
    assert json.loads((tmp_path / "a" / "merge.json").read_text())["stage_prior"] == {
        "rotation_mrad": 3.0, "translation_mm": 0.3}
    assert main([*base, "--stage-sigma", "1,0.1", "-o", str(tmp_path / "b")]) == 0
    assert json.loads((tmp_path / "b" / "merge.json").read_text())["stage_prior"]["rotation_mrad"] == 1.0
    assert main([*base, "--stage-sigma", "none", "-o", str(tmp_path / "c")]) == 0
    assert json.loads((tmp_path / "c" / "merge.json").read_text())["stage_prior"] is None
    capsys.readouterr()
    assert main([*base, "--stage-sigma", "0,0.1", "-o", str(tmp_path / "d")]) == 2
    assert "both sigmas must be > 0" in " ".join(capsys.readouterr().err.split())
    assert not (tmp_path / "d").exists()


# --------------------------------------------------------------------------- free-hand: right or refused
@pytest.fixture(scope="module")
def bar_folder(tmp_path_factory):
    """A real ball bar (two equal spheres on a square bar, no knob) at table angles 0 and 30 deg,
    written as view folders."""
    from fringe3d.sim.turntable import sphere_bar_scene
    p = presets.get("tiny")
    bar = turntable_views(sphere_bar_scene(p)[0], p, [0.0, 30.0], sigma=0.05, seed=0)
    folder = tmp_path_factory.mktemp("bar")
    return folder, write_turntable(folder, bar)


def test_free_hand_refuses_a_symmetric_ball_bar_naming_the_pair_and_the_remedy(bar_folder):
    from fringe3d.multiview.register import AmbiguousRegistration, register_views
    from fringe3d.multiview.views import read_view
    _, folders = bar_folder
    with pytest.raises(AmbiguousRegistration, match="ambiguous: two poses 180 degrees apart") as e:
        register_views([read_view(f) for f in folders], None, voxel=4.0)
    assert e.value.pair == (1, 0)
    assert "give the views' poses" in str(e.value)
    assert len(e.value.candidates) > 1


def test_free_hand_merge_cli_refuses_the_ball_bar_with_exit_2_and_writes_nothing(bar_folder, tmp_path, capsys):
    _, folders = bar_folder
    out = tmp_path / "merged"
    assert main(["merge", *map(str, folders), "--free-hand", "--voxel", "4", "-o", str(out)]) == 2
    err = " ".join(capsys.readouterr().err.split())
    assert "ambiguous" in err and "instead of free-hand registration" in err
    assert not out.exists()


def test_free_hand_refuses_views_that_do_not_overlap(views):
    from fringe3d.multiview.register import AmbiguousRegistration, register_views
    from fringe3d.multiview.views import View
    v = views[0]
    left = v.points[:, 0] < np.quantile(v.points[:, 0], 0.3)
    right = v.points[:, 0] > np.quantile(v.points[:, 0], 0.75)
    with pytest.raises(AmbiguousRegistration, match="slid onto each other where they do not overlap"):
        register_views([View("a", v.points[left], v.sigma[left]), View("b", v.points[right], v.sigma[right])],
                       None, voxel=4.0)


# --------------------------------------------------------------------------- VDI/VDE 2634-3 on a merged cloud
@pytest.fixture(scope="module")
def fused_bar(tmp_path_factory):
    """The ball bar seen at 0, 30 and 330 deg, fused at the true poses into fused.ply, with the
    simulator's spheres.json beside it; returns (folder, true length mm, radius mm)."""
    from fringe3d.io.ply_standard import write_standard_ply
    from fringe3d.multiview.fuse import fuse_views
    from fringe3d.sim.turntable import sphere_bar_scene, write_spheres
    p = presets.get("tiny")
    scene, centres, r = sphere_bar_scene(p)
    bar = turntable_views(scene, p, [0.0, 30.0, 330.0], sigma=0.05, seed=2)
    vs = [view_from_map(str(i), P, s) for i, (P, s) in enumerate(zip(bar.points, bar.sigma))]
    folder = tmp_path_factory.mktemp("fusedbar")
    fused = fuse_views(vs, bar.true_poses, 1.0)
    write_standard_ply(folder / "fused.ply", fused.points, normals=False)
    write_spheres(folder, scene)
    return folder, float(np.linalg.norm(centres[1] - centres[0])), r


def test_evaluate_ball_bar_on_a_merged_cloud_reports_the_spacing_error_against_the_simulated_length(fused_bar,
                                                                                                     capsys):
    folder, L, r = fused_bar
    assert main(["evaluate", str(folder / "fused.ply"), "--ball-bar", "--truth", str(folder), "--json"]) == 0
    bb = json.loads(capsys.readouterr().out)["ball_bar"]
    assert bb["true_distance"] == pytest.approx(L, abs=1e-9)
    assert abs(bb["error_um"]) < 50.0 and bb["error_um"] == pytest.approx(1e3 * bb["error"])
    assert bb["distance"] == pytest.approx(L, abs=0.05)
    for s in bb["spheres"]:
        assert s["diameter"] == pytest.approx(2 * r, abs=0.1)
        assert 0 < s["form"] < 1.0  # mm: P_F of 0.05 mm noise, ~2 mm pixels


def test_evaluate_ball_bar_finds_the_spheres_of_a_calibrated_bar_without_the_truth(fused_bar, capsys):
    folder, L, r = fused_bar
    assert main(["evaluate", str(folder / "fused.ply"), "--ball-bar", "--truth", str(folder), "--json"]) == 0
    with_truth = json.loads(capsys.readouterr().out)["ball_bar"]
    assert main(["evaluate", str(folder / "fused.ply"), "--ball-bar", "--diameter", str(2 * r),
                 "--distance", str(L), "--json"]) == 0
    found = json.loads(capsys.readouterr().out)["ball_bar"]
    assert found["error_um"] == pytest.approx(with_truth["error_um"], abs=5.0)
    assert main(["evaluate", str(folder / "fused.ply"), "--ball-bar"]) == 2
    assert "--truth SIMFOLDER" in " ".join(capsys.readouterr().err.split())


def test_simulated_sequence_truth_is_the_true_surface_in_the_model_frame(bar_captures):
    from fringe3d.sim.turntable import read_turntable_truth
    true, points, normals = read_turntable_truth(bar_captures, ["view-01", "view-00"])
    expected = rotation_about(default_turntable(presets.get("tiny")).axis, -np.deg2rad(30.0),
                              default_turntable(presets.get("tiny")).point)
    assert np.allclose(true[0], expected, atol=1e-9) and np.allclose(true[1], np.eye(4))
    assert np.allclose(np.linalg.norm(normals, axis=1), 1.0, atol=1e-5)
    for s in json.loads((bar_captures / "spheres.json").read_text())["spheres"]:
        d = np.linalg.norm(points - s["centre_mm"], axis=1) - s["radius_mm"]
        near = np.abs(d) < 0.5
        # mm: both views land on the true sphere (the rest within 0.5 mm: the bar where it meets the sphere)
        assert near.sum() > 100 and np.quantile(np.abs(d[near]), 0.8) < 1e-6
    with pytest.raises(ValueError, match="no true_matrix for view"):
        read_turntable_truth(bar_captures, ["view-07"])

