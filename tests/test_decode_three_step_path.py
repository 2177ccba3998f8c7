"""The 3-step decode path's kernels against their previous forms and their NumPy definitions:
the split-loop PSP kernel, the separable Laplacian noise sums, the group's valid phase in one pass
and the quality mask that copies nothing when it masks nothing."""
import math

import numpy as np
import pytest
from reference_implementations import (interior_laplacian_reference, psp_kernel_previous, run_psp_kernel,
                                      wrapped_phase_reference)

from fringe3d.decode import DecodeOptions, decode, edges
from fringe3d.decode import _finish_kernels as fk
from fringe3d.decode.texture import as_fraction
from fringe3d.patterns import sets
from fringe3d.patterns.synthetic import frames_from_coordinates
from fringe3d.phase import noise, psp
from fringe3d.phase._noise_kernel import _interior_laplacian, interior_laplacian
from fringe3d.phase.psp import lsq_coefficients, wrapped_phase


def _frames(dtype, n, rng, shape=(21, 300)):
    if np.dtype(dtype).kind == "f":
        f = rng.normal(120.0, 60.0, (n, *shape)).astype(dtype)
        f[1, 3, 5] = np.nan
        f[0, 4, 7] = np.inf
        return f
    top = np.iinfo(dtype).max
    return rng.integers(0, top, (n, *shape), endpoint=True).astype(dtype)


@pytest.mark.parametrize("dtype,shifts", [(np.uint8, 3), (np.uint8, (0.1, 2.0, 4.5, 5.0)), (np.float64, 3)])
def test_psp_kernel_equals_its_previous_single_loop_form_bit_for_bit(dtype, shifts):
    rng = np.random.default_rng(11)
    d = 2 * np.pi * np.arange(shifts) / shifts if isinstance(shifts, int) else np.array(shifts)
    f = _frames(dtype, d.size, rng)
    idx, coef, level = np.arange(d.size), lsq_coefficients(d), 200.0
    got = [np.empty(f.shape[1:], np.float32) for _ in range(3)] + [np.zeros(f.shape[1:], bool)]
    want = [np.empty(f.shape[1:], np.float32) for _ in range(3)] + [np.zeros(f.shape[1:], bool)]
    none = (np.empty((0, 0), bool), np.empty((0, 0), np.float32), np.empty((0, 0), np.uint8), np.zeros(0),
            np.zeros(0, np.int64))
    run_psp_kernel(f, idx, coef, level, *got, np.float32(0), *none)
    # the previous form on the frames as float64 (its float64 sums see the same values): compiled once
    psp_kernel_previous(f.astype(np.float64), idx, coef, level, *want)
    for g, w in zip(got, want):
        np.testing.assert_array_equal(g, w)


def test_three_step_phase_is_as_close_to_the_float64_truth_as_before():
    rng = np.random.default_rng(2)
    d = 2 * np.pi * np.arange(3) / 3
    phi = rng.uniform(-np.pi, np.pi, (64, 80))
    f = np.stack([100 + 80 * np.cos(phi + dk) for dk in d])
    ref = wrapped_phase_reference(f)
    got = wrapped_phase(f)
    assert np.abs(np.angle(np.exp(1j * (got.phase.astype(np.float64) - phi)))).max() < 5e-7
    np.testing.assert_allclose(got.modulation, ref.modulation, rtol=1e-6)
    np.testing.assert_allclose(got.average, ref.average, rtol=1e-6)


@pytest.mark.parametrize("shape", [(1, 5), (2, 9), (3, 3), (5, 2), (37, 3), (40, 57)])
def test_separable_laplacian_sums_equal_the_3x3_stencil_on_integer_images(shape):
    rng = np.random.default_rng(5)
    image = rng.integers(0, 256, shape).astype(np.uint8)
    mask = rng.random(shape) > 0.15
    sums, counts = interior_laplacian_reference(image, mask)
    # integer responses: every order of the float64 sums is exact, so the totals are equal
    assert interior_laplacian(image, mask) == (float(sums.sum()), int(counts.sum()))


def test_separable_laplacian_on_a_float32_average_matches_the_3x3_stencil():
    rng = np.random.default_rng(6)
    f = rng.integers(0, 256, (3, 70, 333)).astype(np.uint8)
    pr = wrapped_phase(f)
    mask = pr.modulation > 20
    sums, counts = interior_laplacian_reference(pr.average, mask)
    total, n = interior_laplacian(pr.average, mask)
    assert n == int(counts.sum())
    # each pixel's response is exact in float64; only the order of the row sums may move the last bits
    assert total == pytest.approx(float(sums.sum()), rel=1e-13)


@pytest.mark.parametrize("threshold", [5.1, np.float64(5.1), np.float32(5.1), 5, 0.0, 1e40, -1e40, math.nan,
                                       math.inf, np.float64(-1e300)])
def test_float32_threshold_compares_like_numpy(threshold):
    base = np.float32(5.1)
    x = np.array([np.nextafter(base, np.float32(np.inf)), base, np.nextafter(base, np.float32(0)), 5.0, 0.0, -0.0,
                  np.inf, -np.inf, np.nan, 3.4028235e38, -3.4028235e38, 1e-45], np.float32)
    with np.errstate(over="ignore"):
        want = x >= threshold
    np.testing.assert_array_equal(x >= fk.float32_threshold(threshold), want)


@pytest.mark.parametrize("threshold", [5.1, np.float64(5.1), 0.0])
def test_valid_phase_is_the_group_mask_and_the_phase_nan_outside_it(threshold):
    rng = np.random.default_rng(8)
    phase = rng.uniform(-3, 3, (19, 37)).astype(np.float32)
    phase[0, :3] = [np.nan, np.inf, -np.inf]
    mod = rng.uniform(0, 10, phase.shape).astype(np.float32)
    mod[1, :3] = [np.float32(5.1), np.nextafter(np.float32(5.1), np.float32(0)), np.nan]
    sat = rng.random(phase.shape) > 0.8
    mask, out = fk.valid_phase(phase, mod, threshold, sat)
    want = (mod >= threshold) & ~sat & np.isfinite(phase)
    np.testing.assert_array_equal(mask, want)
    np.testing.assert_array_equal(out, np.where(want, phase, np.float32(np.nan)))


def test_quality_masked_phase_returns_its_inputs_unless_a_valid_pixel_is_masked():
    rng = np.random.default_rng(9)
    phase = rng.uniform(-3, 3, (23, 41)).astype(np.float32)
    mask = rng.random(phase.shape) > 0.3
    phase[~mask] = np.nan
    q = edges.order_bits(mask, None)  # INVALID outside the mask only
    m, p = fk.quality_masked_phase(phase, mask, q, 0xFF)
    assert m is mask and p is phase
    for i, j, what in ((4, 5, "bit"), (7, 8, "inf")):
        q2, ph2 = q.copy(), phase.copy()
        mask2 = mask.copy()
        mask2[i, j] = True
        if what == "bit":
            ph2[i, j] = 0.5
            q2[i, j] = edges.EDGE
        else:
            ph2[i, j] = np.inf
        m, p = fk.quality_masked_phase(ph2, mask2, q2, 0xFF)
        want_m, want_p = fk.masked_phase(ph2, mask2, q2, 0xFF)
        assert m is not mask2 and not m[i, j]
        np.testing.assert_array_equal(m, want_m)
        np.testing.assert_array_equal(p, want_p)


@pytest.fixture(scope="module", params=["clipped", "unclipped"])
def three_step(request):
    ps = sets.phase_shift(18, 3, "v", width=200, height=120)
    v, u = np.mgrid[0:60, 0:90].astype(np.float64)
    u_p = 5 + 0.9 * u + 2 * np.sin(v / 9)
    f = frames_from_coordinates(ps, u_p, np.full_like(u_p, 50.0), 20, 200, noise=1.0,
                                rng=np.random.default_rng(4), dtype=np.uint8)
    if request.param == "clipped":  # the mask from a pass of its own (the clipping test)
        f[:, 10:14, 20:30] = 255
    f[:, 40:44, 50:60] = 3  # no modulation
    return ps, f


def test_three_step_decode_equals_the_definitions_of_its_outputs(three_step):
    ps, f = three_step
    d = decode(f, ps, options=DecodeOptions(min_modulation=5.0))
    g = ps.indices(group=ps.groups("v", "phase")[0])
    pr, sat = wrapped_phase(f, [ps.frames[i].shift for i in g], index=g, saturation_level=255,
                            return_saturated=True)
    mask = (pr.modulation >= 5.0) & ~sat & np.isfinite(pr.phase)
    np.testing.assert_array_equal(d.mask["v"], mask)
    np.testing.assert_array_equal(d.phase["v"], np.where(mask, pr.phase, np.float32(np.nan)))
    np.testing.assert_array_equal(d.wrapped["v"], pr.phase)
    np.testing.assert_array_equal(d.quality["v"] != 0, ~mask)  # method "none": no edge tests
    np.testing.assert_array_equal(d.texture, as_fraction(np.add(pr.average, pr.modulation, dtype=np.float32),
                                                         f, None))
    sums, counts = interior_laplacian_reference(pr.average, mask)
    s = math.sqrt(math.pi / 2) * sums.sum() / counts.sum() / 6
    assert d.info["quality"]["v"]["noise"]["c0"] == pytest.approx(3 * s * s, rel=1e-12)
    # the PSP pass's sums (unclipped) or the standalone kernel's (clipped): the same number
    assert d.info["quality"]["v"]["noise"]["c0"] == 3 * noise.laplacian_noise(pr.average, mask) ** 2
    sigma = noise.phase_sigma(noise.noise_sigma((3 * s * s, 0.0), pr.average), pr.modulation, 3)
    np.testing.assert_allclose(d.phase_sigma["v"], sigma, rtol=1e-6)


@pytest.mark.parametrize("c0", [2.7, 1e-45, 3e38, 0.0, -1.0])
def test_phase_sigma_of_a_constant_noise_model_equals_noise_sigma_then_phase_sigma(c0):
    rng = np.random.default_rng(12)
    avg = rng.uniform(-5, 200, (17, 29)).astype(np.float32)
    avg[0, :3] = [np.nan, np.inf, -np.inf]
    mod = rng.uniform(-1, 60, avg.shape).astype(np.float32)
    mod[1, :4] = [np.nan, 0.0, np.inf, 1e-40]
    mod[0, 3:6] = [0.0, -1.0, 2.0]
    want = noise.phase_sigma(noise.noise_sigma((c0, 0.0), avg), mod, 3)
    np.testing.assert_array_equal(noise.model_phase_sigma(c0, 0.0, avg, mod, 3), want)


@pytest.mark.parametrize("model", [(2.7, 0.0), (1.7, 0.043), (-2.0, 0.05)])
def test_phase_sigma_and_texture_from_one_pass_equal_their_separate_kernels(model):
    rng = np.random.default_rng(13)
    avg = rng.uniform(-5, 300, (15, 31)).astype(np.float32)
    avg[0, :3] = [np.nan, np.inf, -np.inf]
    mod = rng.uniform(-1, 60, avg.shape).astype(np.float32)
    mod[1, :3] = [np.nan, 0.0, np.inf]
    sigma, texture = noise.model_phase_sigma_and_fraction(model[0], model[1], avg, mod, 4, 255.0)
    np.testing.assert_array_equal(sigma, noise.model_phase_sigma(model[0], model[1], avg, mod, 4))
    np.testing.assert_array_equal(texture, fk.texture_fraction(avg, mod, 255.0))


def test_wrapped_phase_and_mask_is_wrapped_phase_and_its_valid_phase():
    rng = np.random.default_rng(14)
    f = rng.normal(120, 60, (4, 23, 300)).astype(np.float32)
    f[2, 5, 7] = np.nan
    shifts, idx = (0.0, 1.6, 3.1, 4.7), (3, 1, 0, 2)
    pr, sat, valid = psp.wrapped_phase_and_mask(f, shifts, idx, 250.0, fk.float32_threshold(40.7))
    want, want_sat = wrapped_phase(f, shifts, idx, saturation_level=250.0, return_saturated=True)
    for g, w in zip((*pr, sat), (*want, want_sat)):
        np.testing.assert_array_equal(g, w)
    want_mask, want_phase = fk.valid_phase(want.phase, want.modulation, 40.7, want_sat)
    np.testing.assert_array_equal(valid.mask, want_mask)
    np.testing.assert_array_equal(valid.phase, want_phase)
    np.testing.assert_array_equal(valid.invalid, (~want_mask).astype(np.uint8))
    assert valid.laplacian == interior_laplacian(want.average, want_mask)
    assert 0 < valid.mask.sum() < valid.mask.size


def _laplacian_rows(image, mask):
    """Per-row sums and counts of the standalone Laplacian kernel (the rows the decoder adds up)."""
    sums, counts = np.zeros(image.shape[0]), np.zeros(image.shape[0], np.int64)
    if image.shape[1] >= 3:
        _interior_laplacian(image, mask, sums, counts)
    return sums, counts


@pytest.mark.parametrize("shape", [(1, 9), (2, 9), (3, 3), (7, 2), (64, 5), (65, 40), (130, 37), (191, 300)])
def test_psp_pass_laplacian_rows_equal_the_standalone_kernel_and_the_3x3_stencil(shape):
    # 64 rows a parallel item: 65, 130 and 191 rows put items' first and last rows (summed after
    # the parallel loop) at every place; integer frames (each row's sum exact, any order)
    rng = np.random.default_rng(15)
    f = rng.integers(0, 256, (3, *shape)).astype(np.uint8)
    pr, sat, valid = psp.wrapped_phase_and_mask(f, (0.0, 2.1, 4.2), (0, 1, 2), 255.0, fk.float32_threshold(30.0))
    sums, counts = np.zeros(shape[0]), np.zeros(shape[0], np.int64)
    h, w = shape
    out = [np.empty(shape, np.float32) for _ in range(3)] + [np.zeros(shape, bool), np.float32(30.0),
                                                             np.empty(shape, bool), np.empty(shape, np.float32),
                                                             np.empty(shape, np.uint8), sums, counts]
    run_psp_kernel(f, np.arange(3), lsq_coefficients((0.0, 2.1, 4.2)), 255.0, *out)
    want_sums, want_counts = _laplacian_rows(pr.average, valid.mask)
    np.testing.assert_array_equal(sums, want_sums)
    np.testing.assert_array_equal(counts, want_counts)
    ref_sums, ref_counts = interior_laplacian_reference(pr.average, valid.mask)
    np.testing.assert_array_equal(counts, ref_counts)
    np.testing.assert_allclose(sums, ref_sums, rtol=1e-13)
    assert valid.laplacian == (float(want_sums.sum()), int(want_counts.sum()))


def test_psp_pass_laplacian_of_float_frames_with_nan_and_inf_equals_the_standalone_kernel():
    rng = np.random.default_rng(16)
    f = _frames(np.float32, 4, rng, shape=(150, 77))
    f[2, 70:72, 10] = np.nan
    f[1, 100, 30:33] = -np.inf
    pr, sat, valid = psp.wrapped_phase_and_mask(f, (0.0, 1.6, 3.1, 4.7), (0, 1, 2, 3), np.inf,
                                                fk.float32_threshold(20.0))
    sums, counts = _laplacian_rows(pr.average, valid.mask)
    assert 0 < counts.sum() < valid.mask.size
    # NaN where a NaN average lies in an interior pixel's 3 x 3 window, in both
    np.testing.assert_array_equal(np.array(valid.laplacian), [sums.sum(), counts.sum()])
