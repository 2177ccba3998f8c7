"""Scene files (errors name the field), scene/rig validation, named scenes, falling balls."""
import json

import numpy as np
import pytest
import trimesh

from fringe3d.optics import PinholeDevice, Rig, intrinsics
from fringe3d.sim.catalog import NAMES, named_scene
from fringe3d.sim.primitives import Plane, Sphere
from fringe3d.sim.scene import Scene
from fringe3d.sim.scene_file import load_scene, scene_from_dict
from fringe3d.sim.validate import check_scene, scene_problems
from fringe3d.sim.wing import Wing, WingBeat, WingDots


def _rig():
    cam = PinholeDevice(intrinsics(200, 200, 79.5, 63.5), 160, 128)
    R = np.array([[np.cos(0.2), 0, -np.sin(0.2)], [0, 1, 0], [np.sin(0.2), 0, np.cos(0.2)]])
    C = np.array([90.0, 0, 0])
    proj = PinholeDevice(intrinsics(290, 290, 127.5, 99.5), 256, 200, R=R, t=-R @ C)
    return Rig(cam, proj)


def _write(tmp_path, d, name="scene.json"):
    p = tmp_path / name
    p.write_text(json.dumps(d))
    return p


def test_scene_file_builds_every_object_type(tmp_path):
    trimesh.creation.icosphere(2, radius=10).export(tmp_path / "ball.ply")
    d = {"format": "fringe3d-scene", "name": "all", "ambient": 0.1, "objects": [
        {"type": "plane", "point": [0, 0, 500], "normal": [0, 0, -1], "albedo": 0.8},
        {"type": "sphere", "center": [0, 0, 420], "radius": 30, "texture": {"type": "checker", "period": 0.5}},
        {"type": "falling_ball", "center": [50, -40, 430], "radius": 15, "velocity": [0, 1000, 0]},
        {"type": "box", "center": [-60, 40, 450], "size": [20, 20, 10], "R": [0, 0.3, 0],
         "motion": {"velocity": [10, 0, 0]}},
        {"type": "board", "cols": 4, "rows": 3, "spacing": 10, "t": [0, 0, 480]},
        {"type": "heightfield", "size": [40, 30], "bumps": [[5, 0, 0, 6]], "center": [0, 0, 470]},
        {"type": "sculpture", "center": [0, 0, 460], "size": [40, 30], "relief": 8},
        {"type": "mesh", "path": "ball.ply", "center": [40, 40, 440]},
        {"type": "wing", "root": [-75, 35, 420], "frequency": 25, "anchors": [[5, 5], [5, 60]]},
    ]}
    scene = load_scene(_write(tmp_path, d))
    assert len(scene) == 9 and scene.name == "all" and scene.ambient == 0.1 and scene.moving
    ball = scene[2]
    np.testing.assert_allclose(ball.center_at(0.01), [50, -40 + 10.0 + 0.5 * 9806.65e-4, 430])
    h = scene.intersect(np.zeros(3), np.array([[0, 0, 1.0]]))
    assert h.object_id[0] == 1 and h.t[0] == pytest.approx(390.0)


@pytest.mark.parametrize("obj,match", [
    ({"type": "cone", "center": [0, 0, 1]}, r"objects\[0\]\.type: unknown object type 'cone'"),
    ({"center": [0, 0, 1]}, r"objects\[0\]: missing field 'type'"),
    ({"type": "sphere", "center": [0, 0, 1]}, r"objects\[0\]: missing field 'radius' for a sphere"),
    ({"type": "sphere", "center": [0, 0], "radius": 1}, r"objects\[0\]\.center: expected a list of 3 numbers"),
    ({"type": "sphere", "center": [0, 0, 1], "radius": "big"}, r"objects\[0\]\.radius: expected a number"),
    ({"type": "sphere", "center": [0, 0, 1], "radius": -2}, r"objects\[0\]: sphere radius must be > 0"),
    ({"type": "sphere", "center": [0, 0, 1], "radius": 1, "colour": 3}, r"objects\[0\]\.colour: unknown field"),
    ({"type": "plane", "point": [0, 0, 1], "normal": [0, 0, 1], "texture": {"type": "plaid"}},
     r"objects\[0\]\.texture\.type: unknown texture 'plaid'"),
    ({"type": "box", "center": [0, 0, 1], "size": [1, 1, 1], "motion": {"speed": 3}}, r"objects\[0\]\.motion\.speed"),
    ({"type": "box", "center": [0, 0, 1], "size": [1, 1, 1], "R": [[1, 0], [0, 1]]},
     r"objects\[0\]\.R: expected a rotation"),
    ({"type": "wing", "anchors": [[1, 2, 3]]}, r"objects\[0\]\.anchors: expected a list of \[x, y\] pairs"),
])
def test_scene_file_errors_name_the_field(tmp_path, obj, match):
    with pytest.raises(ValueError, match=match):
        load_scene(_write(tmp_path, {"objects": [obj]}))


def test_scene_file_top_level_errors(tmp_path):
    with pytest.raises(FileNotFoundError, match="no scene file"):
        load_scene(tmp_path / "none.json")
    bad = tmp_path / "bad.json"
    bad.write_text("{")
    with pytest.raises(ValueError, match="not valid JSON"):
        load_scene(bad)
    with pytest.raises(ValueError, match=r"objects: expected a non-empty list"):
        scene_from_dict({"objects": []})
    with pytest.raises(ValueError, match=r"\.lights: unknown field"):
        scene_from_dict({"objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1}], "lights": []})
    with pytest.raises(ValueError, match=r"ambient: expected a number in \[0, 1\]"):
        scene_from_dict({"objects": [{"type": "sphere", "center": [0, 0, 1], "radius": 1}], "ambient": 3})
    with pytest.raises(FileNotFoundError, match=r"objects\[0\]\.path: no mesh file"):
        load_scene(_write(tmp_path, {"objects": [{"type": "mesh", "path": "missing.stl"}]}))


def test_validation_reports_object_behind_camera_and_outside_projector():
    rig = _rig()
    good = Scene([Sphere((0, 0, 400), 30), Plane((0, 0, 500), (0, 0, -1))])
    assert scene_problems(good, rig) == []
    check_scene(good, rig)
    behind = Scene([Sphere((0, 0, 400), 30), Sphere((0, 0, -100), 20)])
    probs = scene_problems(behind, rig)
    assert all("objects[1]" in q for q in probs)
    assert any("behind the camera" in q for q in probs) and any("behind the projector" in q for q in probs)
    # visible to the camera (left edge of its view) but far outside the projector's (it looks right)
    side = Scene([Sphere((-140, 0, 400), 15)])
    probs = scene_problems(side, rig)
    assert len(probs) == 1 and "outside the projector's view" in probs[0]
    off = Scene([Sphere((0, 900, 400), 20), Sphere((0, 0, 400), 30)])
    with pytest.raises(ValueError, match=r"objects\[0\].*not seen by the camera"):
        check_scene(off, rig)


def test_validation_checks_moving_objects_at_each_time():
    rig = _rig()
    ball = Scene([Sphere((0, 0, 400), 20, velocity=(0, 0, -10000.0))])  # leaves through the camera
    assert scene_problems(ball, rig, times=(0.0,)) == []
    probs = scene_problems(ball, rig, times=(0.0, 0.05))
    assert probs and all("t = 0.05 s" in q for q in probs)
    assert any("behind the camera" in q for q in probs)


def test_falling_ball_centre_follows_closed_form_and_texture_spins():
    from fringe3d.sim import presets
    scene = named_scene("falling-balls", presets.get("tiny"))
    for ball in scene.objects:
        m = ball.motion
        for t in (0.0, 0.003, 0.02):
            c = ball.center + m.velocity * t + 0.5 * m.acceleration * t * t
            np.testing.assert_allclose(ball.center_at(t), c, atol=1e-12)
            # a ray through the closed-form centre hits at |c| - r (camera at the origin)
            h = ball.intersect(np.zeros(3), (c / np.linalg.norm(c))[None], time=t)
            assert h.t[0] == pytest.approx(np.linalg.norm(c) - ball.radius, abs=1e-9)
        assert np.linalg.norm(m.acceleration) == pytest.approx(9806.65)
        assert np.linalg.norm(m.angular_velocity) > 5
        # printed texture visibly moves between frames: material coordinates under a fixed ray change
        d = (ball.center_at(0.002) / np.linalg.norm(ball.center_at(0.002)))[None]
        uv0 = ball.intersect(np.zeros(3), d, time=0.0).material_uv[0]
        uv1 = ball.intersect(np.zeros(3), d, time=0.002).material_uv[0]
        assert np.linalg.norm(uv1 - uv0) > 1e-3


@pytest.mark.parametrize("name", NAMES)
def test_named_scenes_fit_the_tiny_rig(name):
    from fringe3d.sim import presets
    p = presets.get("tiny")
    scene = named_scene(name, p)
    assert scene_problems(scene, p.rig, times=(0.0, 0.01)) == []


def test_scene_truth_fields_carry_wing_curvature_only_on_wing_pixels():
    w = Wing(beat=WingBeat(kappa_mean=0.01))
    scene = Scene([Plane((0, 0, 600), (0, 0, -1)), w])
    cam = PinholeDevice(intrinsics(200, 200, 79.5, 63.5), 160, 128)
    o, d = cam.rays(cam.pixel_grid().reshape(-1, 2))
    h = scene.intersect(o, d, 0.003)
    tf = scene.truth_fields(h, 0.003)
    on = h.object_id == 1
    assert on.any() and (h.object_id == 0).any()
    np.testing.assert_allclose(tf["principal_curvature"][on], w.kappa(0.003), rtol=1e-6)
    assert np.isnan(tf["principal_curvature"][~on]).all()
    np.testing.assert_allclose(tf["dominant_strain"][on], 0.5 * w.thickness * w.kappa(0.003), rtol=1e-6)
    assert tf["curvature"].shape == (len(d), 3) and tf["principal_direction"].shape == (len(d), 3)


def test_scene_save_load_round_trip_casts_identically(tmp_path):
    from fringe3d.calibrate.boards import CircleBoard
    from fringe3d.sim.board import BoardLook, BoardTarget
    from fringe3d.sim.mesh import Mesh
    from fringe3d.sim.motion import RigidMotion
    from fringe3d.sim.primitives import Box
    from fringe3d.sim.scene_file import save_scene
    from fringe3d.sim.sculpture import sculpture
    from fringe3d.sim.textures import Blotches, Checker
    trimesh.creation.icosphere(2, radius=10).export(tmp_path / "ball.stl")
    scene = Scene([
        Plane((0, 0, 520), (0.1, 0, -1), albedo=0.7, texture=Checker(8.0), size=(400, 300)),
        Sphere((30, 10, 430), 25, texture=Checker(0.4), velocity=(0, 500, 0), spin=(1, 2, 3)),
        Box((-60, 30, 470), (20, 25, 10), R=(0.1, 0.2, 0.3), motion=RigidMotion(velocity=(5, 0, 0))),
        BoardTarget(CircleBoard(cols=4, rows=3, spacing=12, radius=3, asymmetric=True), t=(-40, -60, 480),
                    look=BoardLook(edge_width=0.5)),
        sculpture(center=(60, -50, 490), size=(50, 40), relief=10, seed=3),
        Mesh(tmp_path / "ball.stl", center=(-20, -20, 400), texture=Blotches(5.0)),
        Wing(beat=WingBeat(kappa_mean=0.01), root=(-75, 60, 450), dots=WingDots(anchors=[(5, 5)], markers=[(50, 30)])),
    ], ambient=0.05, name="round-trip")
    path = save_scene(scene, tmp_path / "scene.json")
    back = load_scene(path)
    assert back.name == "round-trip" and back.ambient == 0.05 and len(back) == len(scene)
    cam = PinholeDevice(intrinsics(150, 150, 79.5, 63.5), 160, 128)
    o, d = cam.rays(cam.pixel_grid().reshape(-1, 2))
    for t in (0.0, 0.004):
        a, b = scene.intersect(o, d, t), back.intersect(o, d, t)
        assert len(np.unique(a.object_id)) >= 7
        np.testing.assert_array_equal(a.object_id, b.object_id)
        np.testing.assert_allclose(a.t[a.mask], b.t[b.mask], rtol=1e-12)
        np.testing.assert_allclose(a.albedo, b.albedo, atol=1e-12)


def test_in_memory_mesh_cannot_be_saved(tmp_path):
    from fringe3d.sim.mesh import Mesh
    from fringe3d.sim.scene_file import save_scene
    with pytest.raises(ValueError, match="built in memory"):
        save_scene(Scene([Mesh(trimesh.creation.box())]), tmp_path / "x.json")
    assert not (tmp_path / "x.json").exists()
