"""The renderer with the scene catalogue, a telecentric camera, binary defocusing and timing."""
import numpy as np
import pytest

from fringe3d.optics import Rig, TelecentricCamera
from fringe3d.patterns.manifest import FrameSpec, PatternSet
from fringe3d.sim import RenderSettings, presets, render
from fringe3d.sim.catalog import named_scene
from fringe3d.sim.primitives import Plane, Sphere
from fringe3d.sim.scene import Scene

TINY = presets.get("tiny")
CLEAN = RenderSettings(ideal=True, defocus="none", ambient=0.0, brightness=0.8, shot_noise=False,
                       read_noise=0.0, bit_depth=None)


def n_step(N, T, width=256, height=200, kind="sinusoid", direction="v"):
    angle = np.pi / 2 if direction == "v" else 0.0
    frames = tuple(FrameSpec(kind=kind, direction=direction, angle=angle, period=T, shift=2 * np.pi * k / N,
                             step=k, steps=N, group=f"{direction}/T{T}") for k in range(N))
    return PatternSet(width=width, height=height, frames=frames, bit_depth=1 if kind == "square" else 8)


def wrapped(frames):
    I = np.asarray(frames, float)
    d = 2 * np.pi * np.arange(len(I))[:, None, None] / len(I)
    return np.arctan2(-(I * np.sin(d)).sum(0), (I * np.cos(d)).sum(0))


def phase_error(frames, truth, direction="v"):
    return np.angle(np.exp(1j * (wrapped(frames) - truth.phase[direction])))[truth.mask]


def test_wing_truth_is_per_frame_with_material_coordinates_and_strain():
    scene = named_scene("wing", TINY)
    wing = scene.objects[0]
    s = CLEAN.replace(frame_rate=200.0)
    _, truth = render(scene, TINY.rig, n_step(3, 18), s, progress=False)
    assert truth.per_frame and truth.material_uv.shape == (3, 128, 160, 2)
    for k in range(3):
        tk = truth.frame(k)
        m = tk.object_id == 0
        assert m.sum() > 100
        uv = tk.material_uv[m].astype(float)
        X = wing.material_to_world(uv, k / 200.0)
        assert np.abs(X - tk.xyz[m]).max() < 1e-3  # float32 storage at ~400 mm
        strain = wing.dominant_strain(uv, k / 200.0)
        assert np.allclose(tk.extras["dominant_strain"][m], strain, rtol=1e-5, atol=1e-9)
    assert not np.allclose(truth.xyz[0][m], truth.xyz[2][m], equal_nan=True)  # it flaps


def test_board_circle_centres_are_in_the_truth_metadata():
    from fringe3d.sim.simulate import named_scene as sim_scene
    scene = sim_scene("board", TINY)
    _, truth = render(scene, TINY.rig, n_step(3, 18), CLEAN, progress=False)
    board = scene.objects[0]
    X = np.array(truth.meta["board_0_centres_xyz"])
    assert np.allclose(X, board.circle_centers())
    assert np.allclose(truth.meta["board_0_centres_camera_px"], TINY.rig.camera.project(X))


def small_microscope():
    """The microscope preset's rig with its telecentric camera binned 8x (160x128)."""
    p = presets.get("microscope")
    M = p.rig.camera.M / 8.0
    M[:, 3] += 0.5 / 8.0 - 0.5  # pixel centres of the binned sensor
    return p, Rig(TelecentricCamera(M=M, width=160, height=128), p.rig.projector)


def test_telecentric_render_truth_projects_to_pixel_centres_and_decodes():
    p, rig = small_microscope()
    scene = Scene([Sphere(p.center, 3.0), Plane(p.center + [0, 0, 2.0], (0, 0, -1.0))])
    ps = n_step(4, 18, width=800, height=600)
    frames, truth = render(scene, rig, ps, CLEAN, progress=False)
    m = truth.mask
    assert m.mean() > 0.5
    uv = rig.camera.project(truth.xyz[m].astype(float))
    assert np.abs(uv - rig.camera.pixel_grid()[m]).max() < 1e-3
    on = truth.object_id[m] == 0
    assert np.abs(np.linalg.norm(truth.xyz[m][on] - p.center, axis=1) - 3.0).max() < 1e-4
    assert np.abs(phase_error(frames, truth)).max() < 1e-3


def test_defocus_does_not_move_the_phase_of_a_sinusoid():
    """Eq. (2.27)-(2.29): a real OTF lowers contrast but keeps the phase."""
    s = CLEAN.replace(ideal=False, defocus="gaussian", defocus_size=3.0)
    ps = n_step(4, 18)
    scene = Scene([Plane((0.0, 0.0, 400.0), (0.0, 0.0, -1.0))])
    frames, truth = render(scene, TINY.rig, ps, s, progress=False)
    sharp, _ = render(scene, TINY.rig, ps, CLEAN.replace(ideal=False), progress=False)
    err = phase_error(frames, truth)
    assert np.sqrt(np.mean(err**2)) < 5e-3
    # ...while the modulation falls by the Gaussian OTF at 1/T
    amp = np.ptp(frames[:, 60, 40:120], axis=1).mean()
    amp0 = np.ptp(sharp[:, 60, 40:120], axis=1).mean()
    assert amp / amp0 == pytest.approx(np.exp(-2 * np.pi**2 * 9 / 18**2), rel=0.1)


def test_binary_defocusing_turns_squared_binary_into_a_sinusoid():
    scene = Scene([Plane((0.0, 0.0, 400.0), (0.0, 0.0, -1.0))])
    ps = n_step(3, 18, kind="square")
    sharp, truth = render(scene, TINY.rig, ps, CLEAN.replace(ideal=False), progress=False)
    blurred, _ = render(scene, TINY.rig, ps, CLEAN.replace(ideal=False, defocus="gaussian", defocus_size=3.0),
                        progress=False)
    rms_sharp = np.sqrt(np.mean(phase_error(sharp, truth) ** 2))
    rms_blur = np.sqrt(np.mean(phase_error(blurred, truth) ** 2))
    # 3-step phase error of a square wave comes from its 5th and 7th harmonics (amplitudes 1/5, 1/7)
    assert rms_sharp > 0.05
    assert rms_blur < 0.01 and rms_blur < rms_sharp / 10


def test_exposure_scales_the_signal_and_motion_samples_blur_a_moving_object():
    scene = Scene([Plane((0.0, 0.0, 400.0), (0.0, 0.0, -1.0))])
    ps = n_step(3, 18)
    full, _ = render(scene, TINY.rig, ps, CLEAN.replace(frame_rate=100.0), progress=False)
    half, _ = render(scene, TINY.rig, ps, CLEAN.replace(frame_rate=100.0, exposure=0.005), progress=False)
    assert np.allclose(half, 0.5 * full, atol=1e-6)
    moving = Scene([Sphere((0.0, 0.0, 400.0), 40.0, velocity=(4000.0, 0.0, 0.0))])
    one, _ = render(moving, TINY.rig, ps, CLEAN, progress=False)
    smeared, _ = render(moving, TINY.rig, ps, CLEAN.replace(motion_samples=5), progress=False)
    row = np.s_[0, 64, :]
    # motion blur widens the sphere's silhouette along the motion
    assert (smeared[row] > 1e-3).sum() > (one[row] > 1e-3).sum()


def test_static_scene_is_cast_once_and_moving_scene_every_frame(monkeypatch):
    import importlib
    r = importlib.import_module("fringe3d.sim.render")  # the package exports the function as sim.render
    calls = []
    real = r.cast
    monkeypatch.setattr(r, "cast", lambda *a, **k: calls.append(1) or real(*a, **k))
    r.render(Scene([Sphere((0.0, 0.0, 400.0), 40.0)]), TINY.rig, n_step(4, 18), CLEAN, progress=False)
    assert len(calls) == 1
    calls.clear()
    r.render(Scene([Sphere((0.0, 0.0, 400.0), 40.0, velocity=(10.0, 0, 0))]), TINY.rig, n_step(4, 18), CLEAN,
             progress=False)
    assert len(calls) == 4


@pytest.mark.parametrize("name", ["mesh", "falling-balls", "wing"])
def test_ray_culling_gives_the_same_hits_as_casting_every_ray(name):
    from fringe3d.sim.rays import camera_rays, intersect_culled
    scene = named_scene(name, TINY)
    o, d, _ = camera_rays(TINY.rig.camera)
    for time in (0.0, 0.004):
        culled = intersect_culled(scene, o, d, time)
        full = scene.intersect(o[0], d, time)
        assert np.array_equal(culled.object_id, full.object_id)
        hit = full.object_id >= 0
        assert hit.any()
        assert np.array_equal(culled.t[hit], full.t[hit])
        assert np.array_equal(culled.albedo, full.albedo)
