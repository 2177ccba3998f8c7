"""The renderer's fast paths (distance-only shadow rays, reused buffers, the projector-image
cache, the numba mesh refinement) give the same answers as the plain full casts."""
import numpy as np
import pytest
import trimesh

from fringe3d.optics.defocus import blur_pattern
from fringe3d.patterns import sets
from fringe3d.patterns.render import render_frame
from fringe3d.sim import presets
from fringe3d.sim.geometry import cast
from fringe3d.sim.hits import Hit
from fringe3d.sim.mesh import Mesh
from fringe3d.sim.motion import RigidMotion
from fringe3d.sim.primitives import Box, Plane, Sphere
from fringe3d.sim.projector_sampling import IMAGE_CACHE, projector_image
from fringe3d.sim.rays import camera_rays, occluded
from fringe3d.sim.render import render as render_capture
from fringe3d.sim.scene import Scene


def _rays(n=4000, seed=0):
    rng = np.random.default_rng(seed)
    o = rng.normal(0.0, 5.0, (n, 3)) + np.array([0.0, 0.0, -200.0])
    d = rng.normal(0.0, 0.15, (n, 3)) + np.array([0.0, 0.0, 1.0])
    return o, d / np.linalg.norm(d, axis=1, keepdims=True)


def _objects():
    ico = trimesh.creation.icosphere(subdivisions=3, radius=30.0)
    ico.visual = trimesh.visual.TextureVisuals(uv=0.5 + 0.5 * ico.vertices[:, :2] / 30.0)
    spin = RigidMotion(velocity=(3.0, 0.0, 0.0), angular_velocity=(0.0, 0.5, 0.2))
    return [Sphere((5.0, 0.0, 0.0), 25.0, velocity=(0.0, 20.0, 0.0)),
            Plane((0.0, 0.0, 40.0), (0.1, 0.0, -1.0), size=(150.0, 120.0)),
            Plane((0.0, 0.0, 90.0), (0.0, 0.0, -1.0)),
            Box((-10.0, 5.0, -20.0), (20.0, 30.0, 10.0), R=(0.2, 0.3, 0.0)),
            Mesh(ico, center=(0.0, 10.0, 10.0), R=(0.1, 0.2, 0.3), motion=spin),
            Mesh(ico, center=(0.0, -10.0, 0.0), smooth=True)]


@pytest.mark.parametrize("k", range(6))
def test_hit_distance_equals_the_full_intersect_t(k):
    ob = _objects()[k]
    o, d = _rays()
    h = ob.intersect(o, d, time=0.3)
    t = ob.hit_distance(o, d, time=0.3)
    assert (h.object_id >= 0).sum() > 100  # the rays do hit the object
    np.testing.assert_array_equal(t, np.where(h.object_id >= 0, h.t, np.inf))


def test_occlusion_matches_the_nearest_hit_of_a_full_scene_cast():
    scene = Scene(_objects())
    o, d = _rays(seed=1)
    tmax = np.random.default_rng(2).uniform(150.0, 320.0, len(d))
    h = scene.intersect(o, d, time=0.3)
    expect = (h.object_id >= 0) & (h.t < tmax)
    assert 0 < expect.sum() < len(d)
    np.testing.assert_array_equal(occluded(scene, o, d, tmax, 0.3), expect)


def test_scene_numbers_objects_when_the_first_object_is_missed_or_hit():
    o, d = _rays(seed=3)
    objects = _objects()
    for order in ([0, 2, 4], [4, 0, 2], [1, 3, 5]):
        obs = [objects[i] for i in order]
        h = Scene(obs).intersect(o, d, time=0.1)
        each = [ob.intersect(o, d, time=0.1) for ob in obs]
        t_all = np.stack([np.where(e.object_id >= 0, e.t, np.inf) for e in each])
        nearest = np.argmin(t_all, axis=0)
        hit = np.isfinite(t_all.min(axis=0))
        np.testing.assert_array_equal(h.object_id, np.where(hit, nearest, -1))
        np.testing.assert_array_equal(h.t, t_all.min(axis=0))
        for i, e in enumerate(each):  # rows taken from object i carry its normal and albedo
            rows = h.object_id == i
            np.testing.assert_array_equal(h.normal[rows], e.normal[rows])
            np.testing.assert_array_equal(h.albedo[rows], e.albedo[rows])


def test_smooth_textured_mesh_hit_interpolates_vertex_normals_and_uv_barycentrically():
    ico = trimesh.creation.icosphere(subdivisions=2, radius=20.0)
    uvv = np.column_stack([ico.vertices[:, 0] * 0.01 + 0.3, ico.vertices[:, 1] * 0.02 - 0.1])
    ico.visual = trimesh.visual.TextureVisuals(uv=uvv)
    m = Mesh(ico, smooth=True)
    o, d = _rays(800, seed=4)
    o = o * 0.5 + np.array([0.0, 0.0, 100.0])
    h = m.intersect(o, d)
    ok = h.object_id >= 0
    assert ok.sum() > 100
    # independent: trimesh's own ray/triangle test and barycentric coordinates
    loc, ray_idx, tri_idx = ico.ray.intersects_location(o[ok], d[ok], multiple_hits=False)
    order = np.argsort(ray_idx)
    loc, tri_idx = loc[order], tri_idx[order]
    np.testing.assert_allclose(o[ok] + h.t[ok, None] * d[ok], loc, atol=1e-6)
    bary = trimesh.triangles.points_to_barycentric(ico.triangles[tri_idx], loc)
    faces = ico.faces[tri_idx]
    np.testing.assert_allclose(h.material_uv[ok], np.einsum("ij,ijk->ik", bary, uvv[faces]), atol=1e-9)
    n = np.einsum("ij,ijk->ik", bary, ico.vertex_normals[faces])
    n /= np.linalg.norm(n, axis=1, keepdims=True)
    n *= -np.sign(np.einsum("ij,ij->i", n, d[ok]))[:, None]
    np.testing.assert_allclose(h.normal[ok], n, atol=1e-9)


def test_cast_into_reused_buffers_equals_a_fresh_cast():
    preset = presets.get("macro")
    cam = preset.rig.camera
    o, d, off = camera_rays(cam)
    o_s, d_s = o, d[::97].copy()  # a sparse subset of the macro camera's rays
    scene = Scene([Sphere(preset.center, 45.0, velocity=(0.0, 10.0, 0.0)),
                   Plane(preset.center + np.array([0.0, 0.0, 90.0]), (0.0, 0.0, -1.0), albedo=0.8)])
    work: dict = {}
    cast(scene, preset.rig, o_s, d_s, off, 0.0, True, work=work)  # fills the buffers once
    g1 = cast(scene, preset.rig, o_s, d_s, off, 0.05, True, work=work)
    g2 = cast(scene, preset.rig, o_s, d_s, off, 0.05, True)
    assert g1.points is work["points"]
    assert g1.lit.sum() > 100 and (~g1.lit & g1.hit).sum() > 0  # some hits are shadowed/unlit
    for name in ("hit", "points", "depth", "normal", "albedo", "up", "vp", "shade", "lit", "proj_depth"):
        np.testing.assert_array_equal(getattr(g1, name), getattr(g2, name), err_msg=name)


def test_cached_projector_image_is_the_blurred_rendered_frame_and_read_only():
    ps = sets.phase_shift(18, 3, "v", width=96, height=80)
    spec = ps.frames[1]
    a = projector_image(spec, 96, 80, "gaussian", 1.5)
    b = projector_image(spec, 96, 80, "gaussian", 1.5)
    assert a is b and not a.flags.writeable
    expect = blur_pattern(render_frame(spec, 96, 80).astype(np.float64), "gaussian", 1.5)
    np.testing.assert_array_equal(a, expect)
    other = projector_image(spec, 96, 80, "gaussian", 2.5)  # another blur is another entry
    assert not np.allclose(other, a)
    np.testing.assert_array_equal(projector_image(spec, 96, 80, "none", 1.5), render_frame(spec, 96, 80))


def test_renders_are_identical_with_a_warm_projector_image_cache():
    preset = presets.get("macro")
    rig = preset.rig
    ps = sets.phase_shift(18, 3, "v", width=rig.projector.width, height=rig.projector.height)
    scene = Scene([Sphere(preset.center, 45.0)])
    IMAGE_CACHE.clear()
    f1, _ = render_capture(scene, rig, ps, preset.settings, progress=False)
    f2, _ = render_capture(scene, rig, ps, preset.settings, progress=False)
    np.testing.assert_array_equal(f1, f2)


def test_hit_record_fields_keep_their_dtypes():
    h = Sphere((0.0, 0.0, 0.0), 10.0).intersect(np.array([0.0, 0.0, -50.0]), np.array([[0.0, 0.0, 1.0]] * 3))
    assert isinstance(h, Hit)
    assert h.t.dtype == np.float64 and h.object_id.dtype == np.int32 and h.material_uv.shape == (3, 2)
    np.testing.assert_allclose(h.t, 40.0)


def test_per_object_culling_equals_the_full_scene_cast_with_an_unbounded_plane():
    from fringe3d.sim.rays import intersect_culled
    scene = Scene(_objects())
    rng = np.random.default_rng(5)
    d = rng.normal(0.0, 0.3, (6000, 3)) + np.array([0.0, 0.0, 1.0])
    d /= np.linalg.norm(d, axis=1, keepdims=True)
    o = np.array([[0.0, 0.0, -200.0]])
    culled = intersect_culled(scene, o, d, 0.3)
    full = scene.intersect(o[0], d, 0.3)
    assert len(set(full.object_id.tolist())) == 7  # every object is seen, and some rays miss
    for name in ("t", "normal", "object_id", "albedo", "material_uv"):
        np.testing.assert_array_equal(getattr(culled, name), getattr(full, name), err_msg=name)


@pytest.mark.parametrize("over", [{}, {"read_noise": 0.0}, {"bit_depth": 12, "full_well": 300.0}])
def test_compiled_sensor_pass_gives_the_numpy_steps_frame_bit_for_bit(over):
    from reference_implementations import sense_reference

    from fringe3d.sim.noise import sense
    from fringe3d.sim.settings import RenderSettings

    s = RenderSettings(shot_noise=True, read_noise=0.004, bit_depth=8, full_well=1e4, seed=3).replace(**over)
    rng = np.random.default_rng(0)
    img = np.concatenate([rng.uniform(-0.01, 0.02, (40, 64)), rng.uniform(0.0, 1.3, (40, 64))])  # Poisson, clipped
    for k in (0, 5):
        assert np.array_equal(sense(img, s, k), sense_reference(img, s, k))


def test_threaded_frames_equal_one_thread_and_the_session_keeps_its_images(monkeypatch):
    import importlib

    from fringe3d.sim import projector_sampling
    from fringe3d.sim.calibration_session import default_board, render_board_poses, sample_board_poses

    render_mod = importlib.import_module("fringe3d.sim.render")
    p = presets.get("tiny")
    ps = sets.phase_shift(18, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    scene = Scene([Plane(p.center, (0, 0, -1))])
    monkeypatch.setattr(render_mod, "SHADE_THREAD_PIXELS", 1)
    monkeypatch.setattr(render_mod, "SHADE_THREADS", 3)
    threaded, _ = render_capture(scene, p.rig, ps, p.settings, progress=False)
    monkeypatch.setattr(render_mod, "SHADE_THREADS", 1)
    serial, _ = render_capture(scene, p.rig, ps, p.settings, progress=False)
    assert np.array_equal(threaded, serial)
    made = []
    real = projector_sampling.render_frame
    monkeypatch.setattr(projector_sampling, "render_frame", lambda *a: made.append(a[0]) or real(*a))
    monkeypatch.setattr(projector_sampling, "IMAGE_CACHE_SIZE", 2)  # fewer than the set's frames
    IMAGE_CACHE.clear()

    board = default_board(p.rig, p.volume)
    poses = sample_board_poses(p.rig, p.volume, board, 3, np.random.default_rng(0))
    render_board_poses(p.rig, p.settings, board, poses, ps, progress=False)
    assert len(made) == len(ps.frames)  # once per image, not once per pose
    assert len(IMAGE_CACHE) <= 2  # back to its usual size afterwards
