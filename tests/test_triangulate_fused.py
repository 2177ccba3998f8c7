"""The fused 3-step + geometric-constraint + triangulation kernel equals analytic truth."""
from __future__ import annotations

import math

import numpy as np
import pytest

from fringe3d.phase.psp import wrapped_phase
from fringe3d.reconstruct.triangulate import FastThreeStep, Triangulator
from fringe3d.unwrap.geometric import geometric_unwrap, minimum_phase

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
    """depth_fields: the same ray parameters as depth, bit for bit; w, A, B those of the
    step-by-step pipeline (the projector model of the depth, and wrapped_phase's average and
    modulation) to float32 rounding."""
    rig = small_rig()
    T = 18.0
    frames, X = sphere_frames(rig, T, np.uint8)
    fast = FastThreeStep(Triangulator(rig), minimum_phase(rig, 255.0, T), SHIFTS, min_modulation=10.0)
    f = fast.depth_fields(frames)
    np.testing.assert_array_equal(f.depth, fast.depth(frames))
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


def test_fringe_order_ceiling_is_the_integer_ceiling_kept_in_float64():
    # the kernel's k = ceil(x) stays float64 (no int64 round trip, so the pixel loop vectorises):
    # Python's integer ceiling wherever it fits int64, and for NaN, +-inf and values beyond int64
    # the value the x86-64 float -> int64 conversion gives (-2**63), as the int64 round trip did
    from fringe3d.reconstruct._kernels import ceil_as_int

    rng = np.random.default_rng(3)
    xs = np.concatenate([rng.uniform(-50, 50, 2000), np.arange(-5.0, 5.0, 0.25), [-0.0, 0.0, 1e-300, -1e-300],
                         np.ldexp(1.0, np.arange(0, 63)) + 0.5, -np.ldexp(1.0, np.arange(0, 63)) - 0.5,
                         [np.nextafter(2.0 ** 63, 0), -2.0 ** 63]])
    for x in xs:
        assert ceil_as_int(float(x)) == float(math.ceil(x))
    for x in (np.nan, np.inf, -np.inf, 2.0 ** 63, 1e300, -1e300):
        assert ceil_as_int(float(x)) == -(2.0 ** 63)
