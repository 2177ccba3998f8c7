"""Ray casting of the analytic scene primitives against closed forms."""
import numpy as np
import pytest

from fringe3d.sim.hits import Hit
from fringe3d.sim.primitives import Box, Plane, Sphere
from fringe3d.sim.scene import Scene
from fringe3d.sim.textures import Checker


def _random_dirs(rng, n, spread=0.3):
    d = np.column_stack([rng.uniform(-spread, spread, (n, 2)), np.ones(n)])
    return d / np.linalg.norm(d, axis=1, keepdims=True)


def test_sphere_hits_match_geometric_closed_form():
    rng = np.random.default_rng(1)
    c, r = np.array([10.0, -5.0, 300.0]), 40.0
    o = np.array([1.0, 2.0, -3.0])
    d = _random_dirs(rng, 5000)
    h = Sphere(c, r).intersect(o, d)
    # closed form: distance p from the centre to the ray line, t = (c-o)·d - sqrt(r² - p²)
    w = c - o
    along = d @ w
    p2 = w @ w - along**2
    expect_hit = p2 < r * r
    assert expect_hit.sum() > 500 and (~expect_hit).sum() > 500
    np.testing.assert_array_equal(h.mask, expect_hit)
    t_true = along[expect_hit] - np.sqrt(r * r - p2[expect_hit])
    np.testing.assert_allclose(h.t[expect_hit], t_true, rtol=0, atol=1e-9)
    X = o + h.t[expect_hit, None] * d[expect_hit]
    np.testing.assert_allclose(h.normal[expect_hit], (X - c) / r, atol=1e-9)
    assert np.all(np.einsum("ij,ij->i", h.normal[expect_hit], d[expect_hit]) < 0)
    assert np.all(np.isinf(h.t[~expect_hit])) and np.all(h.object_id[~expect_hit] == -1)
    assert np.all(np.isnan(h.normal[~expect_hit])) and np.all(np.isnan(h.material_uv[~expect_hit]))


def test_sphere_hit_from_inside_returns_exit_with_normal_facing_ray():
    h = Sphere((0, 0, 0), 10.0).intersect(np.zeros(3), np.array([[0.0, 0, 2.0]]))
    assert h.t[0] == pytest.approx(5.0)  # non-unit direction: t is the ray parameter
    np.testing.assert_allclose(h.normal[0], [0, 0, -1])


def test_plane_hits_match_closed_form_and_respect_size():
    rng = np.random.default_rng(2)
    p, n = np.array([0.0, 0.0, 250.0]), np.array([0.2, -0.1, -1.0])
    n_unit = n / np.linalg.norm(n)
    o = np.zeros(3)
    d = _random_dirs(rng, 2000) * rng.uniform(0.5, 2.0, (2000, 1))
    h = Plane(p, n, albedo=0.7).intersect(o, d)
    t_true = (p - o) @ n_unit / (d @ n_unit)
    np.testing.assert_allclose(h.t, t_true, rtol=1e-12)
    X = h.points(o, d)
    np.testing.assert_allclose((X - p) @ n_unit, 0, atol=1e-9)
    np.testing.assert_allclose(np.abs(h.normal @ n_unit), 1, atol=1e-12)
    np.testing.assert_allclose(h.albedo, 0.7)
    # finite plane: hits exactly where |u| <= w/2 and |v| <= h/2 in the plane's axes
    fin = Plane(p, n, size=(60, 30), u_axis=(1, 0, 0))
    hf = fin.intersect(o, d)
    uv = np.column_stack([(X - p) @ fin.e1, (X - p) @ fin.e2])
    inside = (np.abs(uv[:, 0]) <= 30) & (np.abs(uv[:, 1]) <= 15)
    assert 100 < inside.sum() < 1900
    np.testing.assert_array_equal(hf.mask, inside)
    np.testing.assert_allclose(hf.material_uv[inside], uv[inside], atol=1e-9)


def test_plane_behind_origin_or_parallel_is_missed():
    pl = Plane((0, 0, -10), (0, 0, 1))
    h = pl.intersect(np.zeros(3), np.array([[0, 0, 1.0], [1.0, 0, 0]]))
    assert not h.mask.any()


def test_box_front_face_and_rotated_face_distance():
    box = Box((0, 0, 200), (40, 20, 10))
    h = box.intersect(np.zeros(3), np.array([[0, 0, 1.0], [0.05, 0.02, 1.0], [0.3, 0, 1.0]]))
    np.testing.assert_allclose(h.t[:2], 195.0)
    np.testing.assert_allclose(h.normal[:2], [[0, 0, -1]] * 2)
    assert not h.mask[2]
    # rotated 30° about y: the ray along z meets the tilted front face at 200 - 5/cos(30°)
    rot = Box((0, 0, 200), (40, 20, 10), R=(0, np.radians(30), 0))
    h = rot.intersect(np.zeros(3), np.array([[0, 0, 1.0]]))
    assert h.t[0] == pytest.approx(200 - 5 / np.cos(np.radians(30)), abs=1e-9)
    np.testing.assert_allclose(h.normal[0], [-np.sin(np.radians(30)), 0, -np.cos(np.radians(30))], atol=1e-12)


def test_scene_keeps_nearest_hit_and_numbers_objects():
    scene = Scene([Plane((0, 0, 300), (0, 0, 1), albedo=0.5), Sphere((0, 0, 250), 20, albedo=0.9)])
    d = np.array([[0, 0, 1.0], [0.2, 0, 1.0], [0, 0, -1.0]])
    h = scene.intersect(np.zeros(3), d)
    np.testing.assert_array_equal(h.object_id, [1, 0, -1])
    assert h.t[0] == pytest.approx(230.0)
    assert h.t[1] == pytest.approx(300.0)
    np.testing.assert_allclose(h.albedo, [0.9, 0.5, 0.0])


def test_per_ray_origins_parallel_rays_hit_sphere_at_closed_form_depth():
    # telecentric case: parallel rays from a grid of origins
    xy = np.stack(np.meshgrid(np.linspace(-30, 30, 41), np.linspace(-30, 30, 41)), -1).reshape(-1, 2)
    o = np.column_stack([xy, np.full(len(xy), -100.0)])
    d = np.tile([0, 0, 1.0], (len(xy), 1))
    h = Sphere((0, 0, 0), 20).intersect(o, d)
    rho2 = np.sum(xy**2, axis=1)
    inside = rho2 < 400
    np.testing.assert_array_equal(h.mask, inside)
    np.testing.assert_allclose(h.t[inside], 100 - np.sqrt(400 - rho2[inside]), atol=1e-9)


def test_moving_sphere_is_hit_at_its_closed_form_centre():
    v, a = np.array([100.0, 0, 0]), np.array([0, 9806.65, 0])
    s = Sphere((0, 0, 300), 20, velocity=v, acceleration=a)
    for time in (0.0, 0.01, 0.05):
        c = np.array([0, 0, 300.0]) + v * time + 0.5 * a * time**2
        h = s.intersect(np.zeros(3), (c / np.linalg.norm(c))[None], time=time)
        assert h.t[0] == pytest.approx(np.linalg.norm(c) - 20, abs=1e-9)


def test_spinning_sphere_texture_turns_with_the_ball():
    s0 = Sphere((0, 0, 300), 20, texture=Checker(period=0.5), spin=(0, 2 * np.pi, 0))
    d = np.array([[0.01, 0.02, 1.0]])
    uv0 = s0.intersect(np.zeros(3), d, time=0.0).material_uv[0]
    uv_q = s0.intersect(np.zeros(3), d, time=0.125).material_uv[0]  # 45° later
    uv_full = s0.intersect(np.zeros(3), d, time=1.0).material_uv[0]  # one full turn
    assert abs(uv_q[0] - uv0[0]) == pytest.approx(np.pi / 4, abs=0.05)
    np.testing.assert_allclose(uv_full, uv0, atol=1e-9)


def test_textured_albedo_is_base_times_texture():
    pl = Plane((0, 0, 100), (0, 0, -1), albedo=0.8, texture=Checker(period=10, contrast=0.5), u_axis=(1, 0, 0))
    h = pl.intersect(np.zeros(3), np.array([[0.05, 0.05, 1.0], [0.15, 0.05, 1.0]]))
    # uv = (5, ±5) and (15, ±5): cells differ in parity -> albedos 0.8 and 0.4
    assert sorted(h.albedo.round(12)) == [0.4, 0.8]


@pytest.mark.parametrize("origins,dirs", [(np.zeros(2), np.ones((4, 3))), (np.zeros((3, 3)), np.ones((4, 3))),
                                          (np.zeros(3), np.ones((4, 2))), (np.zeros(3), np.ones(3))])
def test_bad_ray_shapes_raise(origins, dirs):
    with pytest.raises(ValueError, match="shape"):
        Sphere((0, 0, 0), 1).intersect(origins, dirs)


def test_bad_primitive_parameters_raise():
    with pytest.raises(ValueError, match="radius"):
        Sphere((0, 0, 0), -1)
    with pytest.raises(ValueError, match="albedo"):
        Plane((0, 0, 0), (0, 0, 1), albedo=1.5)
    with pytest.raises(ValueError, match="normal"):
        Plane((0, 0, 0), (0, 0, 0))
    with pytest.raises(ValueError, match="size"):
        Box((0, 0, 0), (1, -1, 1))
    with pytest.raises(ValueError, match="at least one"):
        Scene([])


def test_miss_hit_has_documented_fill_values():
    h = Hit.miss(3)
    assert h.object_id.dtype == np.int32 and not h.mask.any() and np.all(np.isinf(h.t))


def test_step_block_on_plane_gives_exact_step_height():
    # block of height 12 mm standing on a tilted base plane: hits on top vs base differ by 12 mm
    n = np.array([0.1, -0.05, -1.0])
    n /= np.linalg.norm(n)
    base = np.array([0.0, 0.0, 420.0])
    from fringe3d.sim.motion import rotation_vector_to_matrix
    # rotate body z onto -n so the block's top face is parallel to the plane, facing the camera
    axis = np.cross([0, 0, 1.0], -n)
    R = rotation_vector_to_matrix(axis / np.linalg.norm(axis) * np.arccos(-n[2]))
    block = Box(base + n * 6.0, (40, 30, 12), R=R)
    scene = Scene([block, Plane(base, n)])
    rng = np.random.default_rng(7)
    d = _random_dirs(rng, 4000, spread=0.15)
    h = scene.intersect(np.zeros(3), d)
    X = h.points(np.zeros(3), d)
    height = (X - base) @ n  # signed distance from the base plane towards the camera
    top = h.object_id == 0
    front = top & (np.abs(h.normal @ n - 1) < 1e-9)
    assert front.sum() > 100 and (h.object_id == 1).sum() > 100
    np.testing.assert_allclose(height[front], 12.0, atol=1e-9)
    np.testing.assert_allclose(height[h.object_id == 1], 0.0, atol=1e-9)


def test_rotation_vector_matches_cv2_rodrigues_and_motion_is_closed_form():
    import cv2

    from fringe3d.sim.motion import RigidMotion, rotation_vector_to_matrix
    for w in ([0.3, -0.2, 0.5], [0.0, 0.0, 2.5], [1e-9, 0, 0]):
        np.testing.assert_allclose(rotation_vector_to_matrix(w), cv2.Rodrigues(np.array(w))[0], atol=1e-12)
    m = RigidMotion(velocity=(1.0, 2.0, 3.0), acceleration=(0, 10.0, 0), angular_velocity=(0, 0, np.pi), t0=0.5)
    np.testing.assert_allclose(m.offset(1.5), [1.0, 2.0 + 5.0, 3.0])
    np.testing.assert_allclose(m.velocity_at(1.5), [1.0, 12.0, 3.0])
    np.testing.assert_allclose(m.rotation(1.5), np.diag([-1.0, -1.0, 1.0]), atol=1e-12)


def test_textures_stay_in_range_and_round_trip_through_dicts():
    from fringe3d.sim.textures import Blotches, Checker, Stripes, texture_from_dict
    uv = np.random.default_rng(0).uniform(-100, 100, (5000, 2))
    for tex in (Checker(7.0, 0.3), Stripes(5.0, 0.6), Blotches(12.0, 0.4, seed=3)):
        f = tex(uv)
        assert f.min() >= 1 - tex.contrast - 1e-12 and f.max() <= 1 + 1e-12
        assert f.max() - f.min() > 0.5 * tex.contrast
        np.testing.assert_array_equal(texture_from_dict(tex.to_dict())(uv), f)
    # stripes follow their closed form
    np.testing.assert_allclose(Stripes(5.0, 0.6)(uv), 1 - 0.3 * (1 + np.cos(2 * np.pi * uv[:, 0] / 5.0)))
    with pytest.raises(ValueError, match="unknown texture"):
        texture_from_dict({"type": "tartan"})
    with pytest.raises(ValueError, match="bad field"):
        texture_from_dict({"type": "checker", "size": 3})


def test_every_simulator_object_implements_the_scene_object_protocol():
    from fringe3d.sim import HeightField, Wing, sculpture
    from fringe3d.sim.board import BoardTarget
    from fringe3d.sim.scene_object import SceneObject, SupportsCircleCentres, SupportsTruthFields

    objects = [Plane((0, 0, 100), (0, 0, -1)), Sphere((0, 0, 100), 5), Box((0, 0, 100), (1, 2, 3)),
               HeightField(), sculpture(), Wing(), BoardTarget()]
    assert all(isinstance(ob, SceneObject) for ob in objects)
    assert [isinstance(ob, SupportsTruthFields) for ob in objects] == [False] * 5 + [True, False]
    assert [isinstance(ob, SupportsCircleCentres) for ob in objects] == [False] * 6 + [True]
    with pytest.raises(ValueError, match="has no intersect method"):
        Scene([object()])


def test_a_bare_object_renders_as_a_one_object_scene():
    from fringe3d.patterns import sets
    from fringe3d.sim import presets, render

    p = presets.get("tiny")
    ps = sets.phase_shift(18, 3, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    ob = Sphere(p.center, 40.0)
    bare, t1 = render(ob, p.rig, ps, p.settings, progress=False)
    wrapped, t2 = render(Scene([ob]), p.rig, ps, p.settings, progress=False)
    np.testing.assert_array_equal(bare, wrapped)
    np.testing.assert_array_equal(t1.depth, t2.depth)
