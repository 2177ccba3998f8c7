"""The renderer's photometry, defocus, geometry truth and errors, against closed forms."""
import numpy as np
import pytest
from scipy.special import j1

from fringe3d.optics import PinholeDevice, Rig, intrinsics
from fringe3d.patterns.manifest import FrameSpec, PatternSet
from fringe3d.patterns.render import sinusoid_value
from fringe3d.sim import RenderSettings, presets, render
from fringe3d.sim.primitives import Plane, Sphere
from fringe3d.sim.scene import Scene

TINY = presets.get("tiny")
CLEAN = RenderSettings(ideal=True, defocus="none", gamma=1.0, ambient=0.0, brightness=0.8,
                       shot_noise=False, read_noise=0.0, bit_depth=None)


def n_step(N, T, direction="v", width=256, height=200, kind="sinusoid"):
    angle = np.pi / 2 if direction == "v" else 0.0
    frames = [FrameSpec(kind=kind, role="phase", direction=direction, angle=angle, period=T,
                        shift=2 * np.pi * k / N, step=k, steps=N, group=f"{direction}/T{T}") for k in range(N)]
    return PatternSet(width=width, height=height, frames=tuple(frames), name=f"{N}-step")


def wrapped(frames):
    """N-step least-squares phase and modulation, Eq. (2.4) (closed form, independent of the package)."""
    I = np.asarray(frames, float)
    N = len(I)
    d = 2 * np.pi * np.arange(N)[:, None, None] / N
    s, c = (I * np.sin(d)).sum(0), (I * np.cos(d)).sum(0)
    return np.arctan2(-s, c), 2 / N * np.hypot(s, c)


def wrap(x):
    return np.angle(np.exp(1j * x))


def sphere_scene():
    return Scene([Sphere((0.0, 0.0, 400.0), 60.0), Plane((0.0, 0.0, 470.0), (0.0, 0.0, -1.0))])


def plane_scene(z=400.0, albedo=1.0):
    return Scene([Plane((0.0, 0.0, z), (0.0, 0.0, -1.0), albedo=albedo)])


# --------------------------------------------------------------------------- photometry
@pytest.mark.parametrize("N,direction", [(3, "v"), (9, "v"), (4, "h")])
def test_noise_free_n_step_decodes_to_truth_phase(N, direction):
    frames, truth = render(sphere_scene(), TINY.rig, n_step(N, 18, direction), CLEAN, progress=False)
    phi, _ = wrapped(frames)
    err = wrap(phi - truth.phase[direction])[truth.mask]
    assert truth.mask.sum() > 0.8 * truth.mask.size
    assert np.abs(err).max() < 1e-3


def test_sixteen_bit_noise_free_set_decodes_within_1e3_rad():
    s = CLEAN.replace(bit_depth=16)
    frames, truth = render(plane_scene(), TINY.rig, n_step(4, 18), s, progress=False)
    assert frames.dtype == np.uint16
    phi, _ = wrapped(frames)
    assert np.abs(wrap(phi - truth.phase["v"])[truth.mask]).max() < 1e-3


@pytest.mark.parametrize("N", [3, 4, 8])
def test_read_noise_gives_phase_noise_sqrt_2_over_N_sigma_over_B(N):
    sigma = 0.01
    ps = n_step(N, 18)
    clean, truth = render(plane_scene(), TINY.rig, ps, CLEAN, progress=False)
    noisy, _ = render(plane_scene(), TINY.rig, ps, CLEAN.replace(read_noise=sigma, seed=3), progress=False)
    phi0, B = wrapped(clean)
    phi, _ = wrapped(noisy)
    m = truth.mask
    normalised = wrap(phi - phi0)[m] * B[m] / sigma  # each pixel's error in units of sigma/B
    assert np.std(normalised) == pytest.approx(np.sqrt(2 / N), rel=0.10)


def test_shot_plus_read_noise_matches_the_phase_noise_formula():
    N, sigma_r, well = 6, 0.005, 5000.0
    ps = n_step(N, 18)
    s = CLEAN.replace(read_noise=sigma_r, shot_noise=True, full_well=well, ambient=0.1, seed=11)
    clean, truth = render(plane_scene(), TINY.rig, ps, CLEAN.replace(ambient=0.1), progress=False)
    noisy, _ = render(plane_scene(), TINY.rig, ps, s, progress=False)
    phi0, B = wrapped(clean)
    A = clean.mean(0)
    sigma = np.sqrt(sigma_r**2 + A / well)  # per-pixel intensity noise (full-scale units)
    m = truth.mask
    normalised = wrap(wrapped(noisy)[0] - phi0)[m] * B[m] / sigma[m]
    assert np.std(normalised) == pytest.approx(np.sqrt(2 / N), rel=0.10)


def test_gamma_ambient_albedo_and_lambert_shading_follow_the_photometric_model():
    gamma, ambient, albedo, bright = 2.2, 0.07, 0.6, 0.7
    s = CLEAN.replace(gamma=gamma, ambient=ambient, brightness=bright)
    ps = n_step(3, 24)
    frames, truth = render(plane_scene(albedo=albedo), TINY.rig, ps, s, progress=False)
    m = truth.mask
    P = sinusoid_value(ps.frames[1], truth.up[m], truth.vp[m])
    to_proj = TINY.rig.projector.center - truth.xyz[m].astype(float)
    cos = np.einsum("ij,ij->i", truth.normal[m], to_proj / np.linalg.norm(to_proj, axis=1, keepdims=True))
    expect = albedo * (ambient + bright * cos * P**gamma)
    assert np.allclose(frames[1][m], expect, atol=2e-6)


def test_quantisation_saturates_at_full_scale():
    s = CLEAN.replace(bit_depth=8, gain=4.0)
    frames, truth = render(plane_scene(), TINY.rig, n_step(3, 18), s, progress=False)
    assert frames.dtype == np.uint8
    assert frames.max() == 255 and (frames[:, truth.mask] == 255).mean() > 0.3
    s12 = CLEAN.replace(bit_depth=12, gain=4.0)
    f12, _ = render(plane_scene(), TINY.rig, n_step(3, 18), s12, progress=False)
    assert f12.dtype == np.uint16 and f12.max() == 4095


def test_same_seed_same_frames_other_seed_other_noise():
    ps = n_step(3, 18)
    s = TINY.settings.replace(read_noise=0.01, shot_noise=True, seed=5)
    a, _ = render(plane_scene(), TINY.rig, ps, s, progress=False)
    b, _ = render(plane_scene(), TINY.rig, ps, s, progress=False)
    c, _ = render(plane_scene(), TINY.rig, ps, s.replace(seed=6), progress=False)
    assert np.array_equal(a, b) and not np.array_equal(a, c)


# --------------------------------------------------------------------------- defocus through the renderer
def aligned_rig(width=180, height=20, pwidth=300, pheight=40, f=500.0):
    """Camera and projector sharing a centre and axes: a fronto-parallel plane maps camera
    pixel (u, v) to projector pixel (u + 60, v + 10) exactly, so the camera sees the
    projector image itself."""
    cam = PinholeDevice(K=intrinsics(f, f, (width - 1) / 2, (height - 1) / 2), width=width, height=height)
    proj = PinholeDevice(K=intrinsics(f, f, (width - 1) / 2 + 60, (height - 1) / 2 + 10), width=pwidth, height=pheight)
    return Rig(cam, proj)


def square_set(T=18):
    spec = FrameSpec(kind="square", role="phase", direction="v", angle=np.pi / 2, period=T, group="v")
    white = FrameSpec(kind="white", role="texture")
    return PatternSet(width=300, height=40, frames=(spec, white), bit_depth=1)


def rendered_harmonics(settings, T=18, z=400.0):
    rig = aligned_rig()
    frames, truth = render(plane_scene(z), rig, square_set(T), settings, progress=False)
    assert np.allclose(truth.up[10], np.arange(180) + 60, atol=1e-6)
    row = frames[0][10] / frames[1][10]  # divide by the white frame: removes shading
    periods = 180 // T
    spec = np.fft.rfft(row)
    return {k: spec[k * periods] for k in (1, 3, 5)}


def test_rendered_squared_binary_harmonics_fall_as_gaussian_otf():
    base = CLEAN.replace(ideal=False, shadows=False)
    h0 = rendered_harmonics(base)
    for sigma in (1.0, 2.0, 3.0):
        h = rendered_harmonics(base.replace(defocus="gaussian", defocus_size=sigma))
        for k in (3, 5):
            expect = np.exp(-2 * np.pi**2 * sigma**2 * (k / 18) ** 2)
            assert abs((h[k] / h0[k]).real - expect) <= 0.05 * expect


def test_rendered_squared_binary_harmonics_fall_as_hopkins_otf():
    base = CLEAN.replace(ideal=False, shadows=False)
    h0 = rendered_harmonics(base)
    for omega in (0.3, 0.6):
        h = rendered_harmonics(base.replace(defocus="hopkins", defocus_size=omega))
        for k in (3, 5):
            a = 4 * np.pi * omega * k / 18
            expect = 2 * j1(a) / a
            assert abs((h[k] / h0[k]).real - expect) <= 0.05 * abs(expect)


def test_camera_blur_lowers_fringe_contrast_as_a_gaussian_psf():
    """Camera blur is optical: the fundamental of a T=18 fringe falls by exp(-2 pi^2 s^2 / T^2)."""
    rig = aligned_rig()
    ps = PatternSet(width=300, height=40, frames=(
        FrameSpec(kind="sinusoid", direction="v", angle=np.pi / 2, period=18.0, group="v"),
        FrameSpec(kind="white", role="texture")))

    def amplitude(settings):
        frames, truth = render(plane_scene(), rig, ps, settings, progress=False)
        row = (frames[0][10] / frames[1][10])[36:144]  # six whole periods away from the borders
        u = truth.up[10][36:144]
        A = np.stack([np.ones_like(u), np.cos(2 * np.pi * u / 18), np.sin(2 * np.pi * u / 18)], 1)
        coef = np.linalg.lstsq(A, row, rcond=None)[0]
        return np.hypot(coef[1], coef[2])

    base = CLEAN.replace(shadows=False)
    for sigma in (1.0, 2.0):
        ratio = amplitude(base.replace(camera_blur=sigma)) / amplitude(base)
        assert ratio == pytest.approx(np.exp(-2 * np.pi**2 * sigma**2 / 18**2), rel=0.01)


def test_defocus_grows_with_distance_from_the_focal_plane():
    base = CLEAN.replace(ideal=False, shadows=False, defocus="gaussian", defocus_size=0.5,
                         focus_distance=300.0, defocus_growth=0.01)
    h0 = rendered_harmonics(CLEAN.replace(ideal=False, shadows=False), z=400.0)
    h = rendered_harmonics(base, z=400.0)
    sigma = 0.5 + 0.01 * 100.0
    expect = np.exp(-2 * np.pi**2 * sigma**2 * (3 / 18) ** 2)
    assert abs((h[3] / h0[3]).real - expect) <= 0.05 * expect


# --------------------------------------------------------------------------- geometry truth
def test_truth_xyz_projects_to_pixel_centres_and_projector_coordinates():
    """Through a distorted camera: truth xyz -> camera model = pixel centres (< 1e-6 px),
    -> projector model = truth (u_p, v_p); sphere hits lie on the sphere."""
    cam = TINY.rig.camera
    distorted = PinholeDevice(K=cam.K, width=cam.width, height=cam.height, dist=(-0.08, 0.1, 1e-3, -1e-3, 0.0))
    rig = Rig(distorted, TINY.rig.projector)
    _, truth = render(sphere_scene(), rig, n_step(3, 18), CLEAN, progress=False)
    m = truth.hit
    X = truth.xyz[m]
    uv = rig.camera.project(X)
    assert np.abs(uv - rig.camera.pixel_grid()[m]).max() < 1e-6
    uvp = rig.projector.project(X)
    assert np.abs(uvp[:, 0] - truth.up[m]).max() < 1e-9 and np.abs(uvp[:, 1] - truth.vp[m]).max() < 1e-9
    on_sphere = truth.object_id[m] == 0
    assert np.abs(np.linalg.norm(X[on_sphere] - [0, 0, 400], axis=1) - 60).max() < 1e-9
    assert np.allclose(truth.depth[m], X[:, 2])


def test_shadow_of_a_sphere_on_a_plane_matches_the_segment_test():
    scene = Scene([Sphere((0.0, 0.0, 380.0), 40.0), Plane((0.0, 0.0, 470.0), (0.0, 0.0, -1.0))])
    _, truth = render(scene, TINY.rig, n_step(3, 18), CLEAN, progress=False)
    plane = truth.object_id == 1
    X = truth.xyz[plane].astype(float)
    C = TINY.rig.projector.center
    d = C - X
    s = np.clip(np.einsum("ij,ij->i", np.array([0, 0, 380.0]) - X, d) / np.einsum("ij,ij->i", d, d), 0, 1)
    closest = X + s[:, None] * d
    shadowed = np.linalg.norm(closest - [0, 0, 380.0], axis=1) < 40.0
    inside = ((truth.up[plane] >= -0.5) & (truth.up[plane] <= 255.5)
              & (truth.vp[plane] >= -0.5) & (truth.vp[plane] <= 199.5))
    assert shadowed.sum() > 50
    assert np.array_equal(truth.mask[plane], inside & ~shadowed)


def test_moving_sphere_truth_is_per_frame_at_each_timestamp():
    v = np.array([0.0, 1200.0, 0.0])  # mm/s
    scene = Scene([Sphere((0.0, 0.0, 400.0), 50.0, velocity=v)])
    s = CLEAN.replace(frame_rate=100.0)
    frames, truth = render(scene, TINY.rig, n_step(3, 18), s, progress=False)
    assert truth.per_frame and truth.xyz.shape == (3, 128, 160, 3)
    for k in range(3):
        tk = truth.frame(k)
        c = np.array([0.0, 0.0, 400.0]) + v * k / 100.0
        r = np.linalg.norm(tk.xyz[tk.hit].astype(float) - c, axis=1)
        assert np.abs(r - 50).max() < 1e-3
    assert truth.meta["times"] == pytest.approx([0.0, 0.01, 0.02])


def test_static_truth_saves_and_loads(tmp_path):
    _, truth = render(sphere_scene(), TINY.rig, n_step(3, 18), CLEAN, progress=False)
    truth.save(tmp_path / "truth")
    back = type(truth).load(tmp_path)
    assert np.array_equal(back.mask, truth.mask)
    assert np.allclose(back.phase["v"], truth.phase["v"], equal_nan=True)
    assert back.meta["fringe"]["v"]["period"] == 18


# --------------------------------------------------------------------------- errors
def test_object_behind_the_camera_is_rejected():
    scene = Scene([Sphere((0.0, 0.0, -400.0), 60.0)])
    with pytest.raises(ValueError, match="behind the camera"):
        render(scene, TINY.rig, n_step(3, 18), CLEAN, progress=False)


def test_object_outside_the_projector_view_is_rejected():
    # the projector turned 60 degrees away from the camera's view
    R, t = presets.look_at((100.0, 0.0, 0.0), (100.0 + 400 * np.sin(1.05), 0.0, 400 * np.cos(1.05)))
    rig = Rig(TINY.rig.camera, TINY.rig.projector.with_pose(R, t))
    scene = Scene([Sphere((0.0, 0.0, 400.0), 60.0)])
    up, _ = rig.projector.project(np.array([[0.0, 0.0, 400.0]]))[0]
    assert up > 256 + 60 / 400 * 290  # the whole sphere is right of the projector image
    with pytest.raises(ValueError, match="outside the projector"):
        render(scene, rig, n_step(3, 18), CLEAN, progress=False)


def test_pattern_size_must_match_the_projector():
    with pytest.raises(ValueError, match="projector is 256x200"):
        render(plane_scene(), TINY.rig, n_step(3, 18, width=912, height=1140), CLEAN, progress=False)


@pytest.mark.parametrize("changes,match", [
    ({"frame_rate": 0.0}, "frame rate"), ({"frame_rate": float("nan")}, "frame rate"),
    ({"frame_rate": 100.0, "exposure": 0.02}, "longer than the frame period"),
    ({"exposure": -1e-3}, "exposure"), ({"bit_depth": 7}, "bit_depth"), ({"gamma": 0.0}, "gamma"),
    ({"defocus": "blurry"}, "defocus model"), ({"read_noise": -0.1}, "read_noise"),
])
def test_nonsensical_settings_are_rejected(changes, match):
    with pytest.raises(ValueError, match=match):
        RenderSettings(**changes)


@pytest.mark.parametrize("electrons", [3.0, 50.0, 200.0, 5000.0])
def test_shot_noise_has_poisson_mean_and_variance(electrons):
    from fringe3d.sim.noise import shot_noise
    well = 10000.0
    img = np.full(400_000, electrons / well)
    counts = shot_noise(img, well, np.random.default_rng(0)) * well
    assert counts.mean() == pytest.approx(electrons, rel=0.01)
    assert counts.var() == pytest.approx(electrons, rel=0.02)
