"""The fused 3-step + geometric-constraint + triangulation kernel equals analytic truth."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.phase.psp import wrapped_phase
from fringe3d.reconstruct.triangulate import FastThreeStep, Triangulator
from fringe3d.unwrap.geometric import geometric_unwrap, minimum_phase

from reference_implementations import three_step_fields_float64
from test_triangulate import intersect_sphere, small_rig

SHIFTS = (-2 * np.pi / 3, 0.0, 2 * np.pi / 3)


def sphere_frames(rig, T, dtype=np.float32):
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    X = intersect_sphere(O, D, np.array([2.0, -3.0, 300.0]), 40.0)
    up = rig.projector.project(X)[..., 0]
    Phi = 2 * np.pi * up / T
    frames = np.stack([127.5 + 100.0 * np.cos(Phi + d) for d in SHIFTS])
    frames = np.where(np.isfinite(frames), frames, 20.0)  # background: no modulation
    if dtype == np.uint8:
        frames = np.round(frames)
    return frames.astype(dtype), X


def test_fused_kernel_equals_truth_noise_free():
    rig = small_rig()
    T = 18.0
    frames, X = sphere_frames(rig, T)
    tri = Triangulator(rig)
    fast = FastThreeStep(tri, minimum_phase(rig, 255.0, T), SHIFTS, min_modulation=10.0)
    pts = fast.points(frames)
    ok = np.isfinite(X[..., 0])
    assert np.array_equal(np.isfinite(pts[..., 0]), ok)
    assert np.max(np.abs(pts[ok] - X[ok])) < 1e-3


def test_fused_kernel_matches_step_by_step_pipeline_on_uint8():
    rig = small_rig()
    T = 18.0
    frames, X = sphere_frames(rig, T, np.uint8)
    mp = minimum_phase(rig, 255.0, T)
    fast = FastThreeStep(Triangulator(rig), mp, SHIFTS, min_modulation=10.0).points(frames)
    pr = wrapped_phase(frames, shifts=SHIFTS)
    Phi, mask = geometric_unwrap(pr.phase, mp, pr.modulation >= 10.0)
    slow = Triangulator(rig).points_from_phase(Phi, T, mask)
    ok = np.isfinite(X[..., 0])
    assert np.max(np.abs(fast[ok] - slow[ok])) < 1e-3
    rms = np.sqrt(np.mean((fast[ok] - X[ok]) ** 2))
    assert rms < 0.05  # 8-bit quantisation only, mm


def test_fused_kernel_rejects_wrong_frame_size():
    rig = small_rig()
    fast = FastThreeStep(Triangulator(rig), minimum_phase(rig, 255.0, 18.0))
    with pytest.raises(ValueError, match="sizes disagree"):
        fast.points(np.zeros((3, 100, 100), np.uint8))


def test_one_pass_fields_give_the_depth_and_what_the_quality_tests_read():
    """depth_fields: the ray parameters of depth (the same pixels, to a float32 rounding: the
    compiler may round the two loops' operations differently); w, A, B those of the
    step-by-step pipeline (the projector model of the depth, and wrapped_phase's average and
    modulation) to float32 rounding."""
    rig = small_rig()
    T = 18.0
    frames, X = sphere_frames(rig, T, np.uint8)
    fast = FastThreeStep(Triangulator(rig), minimum_phase(rig, 255.0, T), SHIFTS, min_modulation=10.0)
    f = fast.depth_fields(frames)
    np.testing.assert_allclose(f.depth, fast.depth(frames), rtol=2.0 ** -22, atol=0.0)  # NaN where NaN
    ok = np.isfinite(f.depth)
    assert ok.sum() > 100
    np.testing.assert_allclose(f.w[ok], fast.tri.fringe_coordinate_at(f.depth)[ok], atol=1e-3)
    pr = wrapped_phase(frames, shifts=SHIFTS)
    np.testing.assert_allclose(f.average, pr.average, rtol=1e-6, atol=1e-4)
    np.testing.assert_allclose(f.modulation, pr.modulation, rtol=1e-6, atol=1e-4)


def test_sigma_z_in_one_pass_equals_the_per_axis_sigma_bit_for_bit():
    """sigma_z_from_phase_noise is phase_sigma then point_sigma_from_w's z, the same bits."""
    from fringe3d.phase.noise import phase_sigma

    rig = small_rig()
    T = 18.0
    frames, X = sphere_frames(rig, T, np.uint8)
    fast = FastThreeStep(Triangulator(rig), minimum_phase(rig, 255.0, T), SHIFTS, min_modulation=10.0)
    f = fast.depth_fields(frames)
    mask = np.isfinite(f.depth)
    mod = f.modulation.copy()
    mod[0, :5] = 0.0  # no modulation: infinite sigma, as phase_sigma's
    mask[0, :5] = True
    sw = phase_sigma(0.8, mod, 3) * np.float32(T / (2 * np.pi))
    ref = fast.tri.point_sigma_from_w(f.w, sw, mask)[..., 2]
    got = fast.tri.sigma_z_from_phase_noise(f.w, mod, 0.8, 3, T, mask)
    np.testing.assert_array_equal(got, ref)
    assert np.isinf(got[0, :5]).all() and np.isnan(got[~mask]).all()


def _fringe_frames(rig, T, rng, dtype, average, amplitude, noise):
    """Three 3-step frames of the sphere scene with the given average, amplitude and Gaussian
    noise (counts), quantised to ``dtype``; the background is noise about the average."""
    O, D = rig.camera.rays(rig.camera.pixel_grid())
    X = intersect_sphere(O, D, np.array([2.0, -3.0, 300.0]), 40.0)
    Phi = 2 * np.pi * rig.projector.project(X)[..., 0] / T
    amp = np.where(np.isfinite(Phi), amplitude, 0.0)
    Phi = np.nan_to_num(Phi)
    frames = np.stack([average + amp * np.cos(Phi + d) + noise * rng.standard_normal(Phi.shape) for d in SHIFTS])
    top = np.iinfo(dtype).max
    return np.clip(np.round(frames), 0, top).astype(dtype)


@pytest.mark.parametrize("dtype, average, amplitude, noise, min_mod", [
    (np.uint8, 127.5, 100.0, 2.0, 10.0),  # 8-bit, well modulated
    (np.uint8, 128.0, 6.0, 3.0, 2.0),  # weak fringes: many pixels near the modulation threshold
    (np.uint16, 40000.0, 300.0, 40.0, 60.0),  # 16-bit, low modulation on a high average
])
def test_float32_pass_keeps_the_float64_validity_and_fringe_order(dtype, average, amplitude, noise, min_mod):
    """The fused kernels compute in float32 and redo in float64 the pixels whose fringe order or
    modulation test float32 might decide otherwise: against the float64 pass they replaced
    (tests/reference_implementations.py), the same valid pixels and fringe orders (w within a
    thousandth of a pixel, a period is 18 px), the ray parameters within a few float32 roundings,
    A and B to float32 rounding; on noisy frames, whose phases fall anywhere near the orders'
    boundaries."""
    rig = small_rig()
    T = 18.0
    rng = np.random.default_rng(7)
    frames = _fringe_frames(rig, T, rng, dtype, average, amplitude, noise)
    fast = FastThreeStep(Triangulator(rig), minimum_phase(rig, 255.0, T), SHIFTS, min_modulation=min_mod)
    s, w, A, B = three_step_fields_float64(fast, frames)
    f = fast.depth_fields(frames)
    ok = np.isfinite(s)
    assert 100 < ok.sum() < ok.size  # both kinds of pixel
    np.testing.assert_array_equal(np.isfinite(f.depth), ok)
    np.testing.assert_array_equal(np.isfinite(fast.depth(frames)), ok)
    np.testing.assert_allclose(f.w, w, rtol=0.0, atol=1e-3)
    np.testing.assert_allclose(f.depth[ok], s[ok], rtol=4e-6)
    np.testing.assert_allclose(fast.depth(frames)[ok], s[ok], rtol=4e-6)
    scale = float(np.abs(A).max())  # float32 sums of counts: rounding relative to the counts
    np.testing.assert_allclose(f.average, A, rtol=0.0, atol=4e-7 * scale)
    np.testing.assert_allclose(f.modulation, B, rtol=0.0, atol=4e-7 * scale)


def test_float32_pass_redoes_pixels_at_the_order_boundary_in_float64():
    """A pixel whose float32 phase lies on its fringe order's boundary (x an integer) is
    recomputed in float64: its outputs are the float64 pass's own bits."""
    rig = small_rig()
    T = 18.0
    frames, _ = sphere_frames(rig, T, np.uint8)
    mp = minimum_phase(rig, 255.0, T)
    fast = FastThreeStep(Triangulator(rig), mp, SHIFTS, min_modulation=10.0)
    s, w, A, B = three_step_fields_float64(fast, frames)
    i, j = np.argwhere(np.isfinite(s))[len(np.argwhere(np.isfinite(s))) // 2]
    # the minimum phase put exactly on this pixel's wrapped phase: the order's boundary
    phi = np.float32(np.angle(np.sum(np.exp(-1j * np.asarray(SHIFTS)) * frames[:, i, j].astype(float))))
    fast.phi_min[i, j] = phi
    s, w, A, B = three_step_fields_float64(fast, frames)
    f = fast.depth_fields(frames)
    for got, ref in zip(f, (s, w, A, B)):
        assert got[i, j].tobytes() == ref[i, j].tobytes()
    ok = np.isfinite(s)
    assert (f.depth[ok] != s[ok]).any()  # elsewhere float32's own roundings
