"""The numba assessment passes (disagreement, fit residual, noise-model fit) equal their
plain-NumPy references (tests/reference_implementations.py) within stated tolerances."""
from __future__ import annotations

import math

import numpy as np
import pytest
from reference_implementations import (disagreement_reference, estimate_blur_reference, fit_noise_model_reference,
                                       fit_residual_variance_reference, quality_map_reference)

from fringe3d.decode import edges
from fringe3d.decode._ratio_median import ratio_median
from fringe3d.phase import noise


def test_disagreement_equals_the_complex_exponential_reference():
    rng = np.random.default_rng(3)
    phase = rng.uniform(0, 320, (37, 53)).astype(np.float32)
    phase[rng.random(phase.shape) < 0.05] = np.nan
    wrapped = [rng.uniform(-np.pi, np.pi, phase.shape).astype(np.float32) for _ in range(2)]
    wrapped[1][rng.random(phase.shape) < 0.05] = np.nan
    got = edges.disagreement(phase, 18.0, wrapped, [21.0, 144.0])
    ref = disagreement_reference(phase, 18.0, wrapped, [21.0, 144.0])
    assert got.dtype == np.float32 and got.shape == phase.shape
    np.testing.assert_allclose(got, ref, rtol=0, atol=1e-6)  # both float64 inside: rounding only
    assert (got == 0)[np.isnan(phase)].all()


def test_disagreement_of_a_residual_beyond_pi_is_wrapped():
    phase = np.full((3, 4), 100.0, np.float32)
    for delta in (0.3, 2.9, -2.9, 3.5, -6.0):
        coarse = (phase.astype(np.float64) * 18 / 144 + delta).astype(np.float32)  # not wrapped: same residual
        want = abs(np.angle(np.exp(1j * delta)))
        np.testing.assert_allclose(edges.disagreement(phase, 18.0, [coarse], [144.0]), want, atol=1e-5)


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.float32])
def test_fit_residual_variance_equals_the_tensordot_reference(dtype):
    rng = np.random.default_rng(4)
    n = 9
    shifts = 2 * np.pi * np.arange(n) / n + 0.1
    phi = rng.uniform(-np.pi, np.pi, (23, 31))
    frames = 100 + 60 * np.cos(phi[None] + shifts[:, None, None]) + rng.normal(0, 2, (n, 23, 31))
    stack = np.concatenate([frames, frames[:2]]).clip(0, 255).astype(dtype)  # two frames of another group
    index = list(range(n))
    got = noise.fit_residual_variance(stack, index, shifts)
    ref = fit_residual_variance_reference(stack, index, shifts)
    assert got.dtype == np.float32
    np.testing.assert_allclose(got, ref, rtol=1e-4, atol=1e-3)  # the reference sums in float32


def test_noise_model_fit_equals_the_lstsq_reference_with_outliers_and_nan():
    rng = np.random.default_rng(5)
    avg = rng.uniform(20, 200, (96, 80)).astype(np.float32)
    var = ((1.5 + 0.05 * avg) * rng.chisquare(6, avg.shape) / 6).astype(np.float32)
    var[rng.random(avg.shape) < 0.02] *= 40  # moving / mixed pixels: dropped by the robust step
    var[0, :5] = np.nan
    mask = rng.random(avg.shape) > 0.1
    got = noise.fit_noise_model(var, avg, mask)
    ref = fit_noise_model_reference(var, avg, mask)
    np.testing.assert_allclose(got, ref, rtol=1e-9, atol=1e-12)


def test_noise_model_with_a_negative_slope_or_constant_average_is_the_mean_variance():
    avg = np.linspace(20, 200, 400, dtype=np.float32).reshape(20, 20)
    var = (10 - 0.02 * avg).astype(np.float32)
    mask = np.ones(avg.shape, bool)
    assert noise.fit_noise_model(var, avg, mask) == pytest.approx(fit_noise_model_reference(var, avg, mask))
    flat = np.full(avg.shape, 4.0, np.float32)
    c0, c1 = noise.fit_noise_model(var, flat, mask)
    assert c1 == 0.0 and c0 == pytest.approx(float(var.astype(np.float64).mean()))
    assert np.isnan(noise.fit_noise_model(var, avg, np.zeros(avg.shape, bool))).all()


def _quality_inputs(shape, seed, nan_order=True):
    """Maps with depth steps, holes, contrast drops, unlit pixels, order and clipping flags."""
    rng = np.random.default_rng(seed)
    H, W = shape
    w = np.linspace(-3, 103, W, dtype=np.float32)[None, :].repeat(H, 0)
    w += np.where(rng.random(shape) < 0.05, 6.0, 0.0).astype(np.float32)
    w += rng.normal(0, 0.05, shape).astype(np.float32)
    mask = rng.random(shape) > 0.1
    order = rng.random(shape) < 0.05
    w[~mask] = np.nan  # the decoder's w: NaN outside the method's mask ...
    if nan_order:
        w[order] = np.nan  # ... and on the order-inconsistent pixels
    average = rng.uniform(20, 200, shape).astype(np.float32)
    average[rng.random(shape) < 0.03] = 0.0
    modulation = (average * rng.uniform(0.3, 0.9, shape)).astype(np.float32)
    modulation[rng.random(shape) < 0.05] *= np.float32(0.2)
    residual = rng.uniform(0, 1.2, shape).astype(np.float32)
    residual[rng.random(shape) < 0.02] = np.nan
    saturated = rng.random(shape) < 0.2
    return dict(mask=mask, w=w, modulation=modulation, average=average, residual=residual, order=order,
                saturated=saturated)


def _quality_map(margin=2.0, max_disagreement=math.inf, rim=1, **maps):
    """:func:`fringe3d.decode.edges.quality_map` called with the reference's flat keywords."""
    tests = edges.QualityTests(margin=margin, max_disagreement=max_disagreement, rim=rim)
    return edges.quality_map(**maps, tests=tests)


@pytest.mark.parametrize("shape", [(1, 1), (3, 8), (47, 61)])
@pytest.mark.parametrize("extent", [(-0.5, 99.5), None])
@pytest.mark.parametrize("flags", [(), ("order",), ("saturated", "residual"), ("order", "saturated", "residual")])
def test_quality_map_equals_the_per_bit_numpy_reference(shape, extent, flags):
    for seed, rim in ((0, 1), (1, 2), (2, 0)):
        x = _quality_inputs(shape, seed, nan_order="order" in flags)
        for name in ("order", "saturated", "residual"):
            if name not in flags:
                x[name] = None
        kw = dict(extent=extent, margin=2.5, max_disagreement=0.9, rim=rim, **x)
        got = _quality_map(**kw)
        np.testing.assert_array_equal(got, quality_map_reference(**kw))


def test_quality_map_sets_every_bit_on_these_inputs():
    x = _quality_inputs((47, 61), 0)
    q = _quality_map(extent=(-0.5, 99.5), margin=2.5, max_disagreement=0.9, **x)
    for bit in edges.BITS:
        assert (q & bit).any(), edges.BITS[bit]


def test_quality_map_with_nan_on_valid_pixels_keeps_the_numpy_semantics():
    x = _quality_inputs((31, 40), 3)  # w NaN on order pixels, but order not passed: NaN on valid pixels
    x.update(order=None)
    kw = dict(extent=(-0.5, 99.5), margin=2.0, max_disagreement=0.9, **x)
    np.testing.assert_array_equal(_quality_map(**kw), quality_map_reference(**kw))


@pytest.mark.parametrize("shape", [(1, 1), (2, 3), (5, 7), (64, 49)])
def test_ratio_median_equals_numpy_median_with_ties_zeros_and_empty_masks(shape):
    rng = np.random.default_rng(sum(shape))
    for trial in range(12):
        fine = rng.uniform(0, 1, shape).astype(np.float32)
        if trial % 3 == 0:
            fine = np.round(fine * 8).astype(np.float32)  # ties and zeros
        coarse = rng.uniform(0, 1.5, shape).astype(np.float32)
        coarse[rng.random(shape) < 0.1] = 0  # excluded: no ratio
        mask = rng.random(shape) > 0.3
        m = mask & (coarse > 0)
        want = float(np.median(fine[m] / coarse[m])) if m.any() else float("nan")
        got = ratio_median(fine, coarse, mask)
        assert got == want or (np.isnan(got) and np.isnan(want))


def test_ratio_median_of_a_nan_ratio_is_nan_as_numpy():
    fine = np.ones((4, 4), np.float32)
    fine[1, 2] = np.nan
    assert np.isnan(ratio_median(fine, np.ones((4, 4), np.float32), np.ones((4, 4), bool)))


def test_estimate_blur_equals_the_numpy_median_reference():
    rng = np.random.default_rng(9)
    coarse = rng.uniform(10, 80, (40, 50)).astype(np.float32)
    fine = (coarse * rng.uniform(0.7, 1.0, coarse.shape)).astype(np.float32)
    mask = rng.random(coarse.shape) > 0.2
    for pair in ((18.0, 144.0), (21.0, 144.0), (144.0, 18.0)):
        assert edges.estimate_blur(fine, coarse, *pair, mask) == estimate_blur_reference(fine, coarse, *pair, mask)
    none = np.zeros(mask.shape, bool)
    assert edges.estimate_blur(fine, coarse, 18.0, 144.0, none) == 0.0 == estimate_blur_reference(
        fine, coarse, 18.0, 144.0, none)


def test_model_phase_sigma_equals_noise_sigma_then_phase_sigma_bit_for_bit():
    rng = np.random.default_rng(11)
    avg = rng.uniform(-5, 200, (33, 45)).astype(np.float32)  # c0 + c1 A < 0 on some: sigma 0
    avg[0, :3] = np.nan
    mod = rng.uniform(-1, 60, avg.shape).astype(np.float32)  # B <= 0: inf
    mod[1, :3] = np.nan
    for model, steps in (((1.7, 0.043), 9), ((-2.0, 0.05), 3), ((0.3, 0.0), 4)):
        want = noise.phase_sigma(noise.noise_sigma(model, avg), mod, steps)
        got = noise.model_phase_sigma(model[0], model[1], avg, mod, steps)
        np.testing.assert_array_equal(got, want)
        assert got.dtype == np.float32


def test_noise_model_of_a_mask_with_no_sampled_pixel_still_fits():
    rng = np.random.default_rng(12)
    avg = rng.uniform(20, 200, (40, 40)).astype(np.float32)
    var = (1.0 + 0.1 * avg).astype(np.float32)
    mask = np.zeros(avg.shape, bool)
    mask[3::8, 5::8] = True  # no pixel on the every-8th-row/column sample: sums about (0, 0)
    np.testing.assert_allclose(noise.fit_noise_model(var, avg, mask), fit_noise_model_reference(var, avg, mask),
                               rtol=1e-9)


def _ratios(shape, seed):
    rng = np.random.default_rng(seed)
    fine = np.round(rng.uniform(0, 1, shape) * 4000).astype(np.float32)  # ties
    coarse = rng.uniform(0, 1.5, shape).astype(np.float32)
    coarse[rng.random(shape) < 0.1] = 0
    return fine, coarse, rng.random(shape) > 0.3


@pytest.mark.parametrize("shape", [(400, 301), (257, 256)])
def test_ratio_median_selects_inside_the_sampled_bracket_exactly(shape, monkeypatch):
    from fringe3d.decode import _ratio_median
    for seed in range(4):
        fine, coarse, mask = _ratios(shape, seed)
        m = mask & (coarse > 0)
        want = float(np.median(fine[m] / coarse[m]))
        with monkeypatch.context() as mp:  # the bracket must hold the median: no fallback
            mp.setattr(_ratio_median, "_numpy_median", lambda *a: pytest.fail("fell back to numpy"))
            assert ratio_median(fine, coarse, mask) == want


def test_ratio_median_falls_back_when_the_sample_misleads():
    fine, coarse, mask = _ratios((200, 160), 5)
    fine[::8, ::8] = 1e6  # every sampled pixel far above the median: the bracket misses it
    m = mask & (coarse > 0)
    assert ratio_median(fine, coarse, mask) == float(np.median(fine[m] / coarse[m]))


def test_ratio_median_falls_back_when_the_bracket_overflows_its_buffer(monkeypatch):
    from fringe3d.decode import _ratio_median
    rng = np.random.default_rng(13)
    coarse = rng.uniform(1, 50, (160, 200)).astype(np.float32)
    fine = 2 * coarse                                    # every ratio exactly 2: all inside [2, 2]
    fine[:, :20] = 3 * coarse[:, :20]
    mask = np.ones(coarse.shape, bool)
    calls = []
    numpy_median = _ratio_median._numpy_median
    monkeypatch.setattr(_ratio_median, "_numpy_median", lambda *a: calls.append(1) or numpy_median(*a))
    assert ratio_median(fine, coarse, mask) == float(np.median(fine / coarse)) == 2.0
    assert calls == [1]


@pytest.mark.parametrize("shape", [(0, 5), (1, 1), (3, 13), (9, 64), (2, 8 * 255 + 21)])
def test_bit_counts_equal_the_per_bit_numpy_counts(shape):
    q = np.random.default_rng(14).integers(0, 256, shape).astype(np.uint8)
    q[:, ::3] = 255  # every bit set in long runs (the byte lanes' sums reach their limit)
    want = {name: int(np.count_nonzero(q & bit)) for bit, name in edges.BITS.items()}
    assert edges.bit_counts(q) == want
    assert edges.bit_counts(q.astype(np.int64)) == want  # another dtype: the numpy counts


@pytest.mark.parametrize("dtype", [np.float32, np.float64])
def test_nan_where_is_numpys_masked_isnan_any(dtype):
    rng = np.random.default_rng(15)
    x = rng.random((11, 17)).astype(dtype)
    where = rng.random(x.shape) > 0.5
    assert edges.nan_where(x, where) is False
    x[~where] = np.nan
    x[0, 0] = np.inf
    assert edges.nan_where(x, where) is False  # NaN only where not asked, inf is no NaN
    i, j = np.argwhere(where)[3]
    x[i, j] = np.nan
    assert edges.nan_where(x, where) is True
    assert edges.nan_where(x[:, :1].ravel(), where[:, :1].ravel()) == bool(np.isnan(x[:, 0])[where[:, 0]].any())


def test_clipping_maps_of_groups_without_a_clipped_pixel_are_not_read():
    from types import SimpleNamespace

    from fringe3d.decode.assess import clipping_broken_map
    a, b = np.zeros((4, 5), bool), np.zeros((4, 5), bool)
    b[1, 2] = True
    cache = {("clipping_broken", "g1", False): a, ("saturation", "g1"): {"clipped": 0.0},
             ("clipping_broken", "g2", True): b, ("saturation", "g2"): {"clipped": 0.05}}
    broken, tested = clipping_broken_map(SimpleNamespace(cache=cache))
    np.testing.assert_array_equal(broken, a | b)
    assert tested
    cache[("saturation", "g2")] = {"clipped": 0.0}
    cache[("clipping_broken", "g2", True)] = np.zeros((4, 5), bool)
    assert clipping_broken_map(SimpleNamespace(cache=cache)) == (None, True)
    assert clipping_broken_map(SimpleNamespace(cache={})) == (None, False)


@pytest.mark.parametrize("x", [[0.0, 1e-6, -1e-6], [0.0, 2e-6], [np.nan, 0.0], [np.inf], [-np.inf, 0.0], []])
def test_equal_step_check_is_allclose_to_zero(x):
    from fringe3d.decode.compensation import _near_zero
    assert _near_zero(np.array(x, float)) == bool(np.allclose(np.array(x, float), 0.0, atol=1e-6))


@pytest.mark.parametrize("case", ["ties", "constant", "infinite"])
def test_ratio_median_selects_the_rank_inside_its_histogram_bin(case):
    rng = np.random.default_rng(16)
    coarse = rng.uniform(1, 50, (120, 170)).astype(np.float32)
    ratio = rng.uniform(0.5, 0.9, coarse.shape).astype(np.float32)
    if case == "ties":  # a third of the ratios on 5 values around the median: ranks across few bins
        ratio[rng.random(coarse.shape) < 0.33] = rng.choice(np.float32([0.69, 0.7, 0.7001, 0.71, 0.72]))
    elif case == "constant":  # the bracket has no width
        ratio[:] = np.float32(0.75)
    else:  # nearly half the ratios overflow to inf: the bracket reaches it
        big = rng.random(coarse.shape) < 0.49
        coarse[big] = np.float32(1e-38)
    fine = ratio * coarse
    if case == "infinite":
        fine[big] = np.float32(1e3)
        with np.errstate(over="ignore"):
            assert np.isinf(fine[big] / coarse[big]).all()
    for mask in (np.ones(coarse.shape, bool), rng.random(coarse.shape) > 0.3):
        m = mask & (coarse > 0)
        with np.errstate(over="ignore"):  # the infinite ratios
            want = float(np.median(fine[m] / coarse[m]))
            assert ratio_median(fine, coarse, mask) == want


@pytest.mark.parametrize("dtype", [np.uint8, np.uint16, np.int16, np.float32, np.float64])
@pytest.mark.parametrize("step", [1, 2, 9, 40])
def test_the_diagnostic_sample_is_numpys_strided_float32_copy(dtype, step):
    from fringe3d.decode.compensation import _strided_sample
    frames = (np.random.default_rng(17).random((5, 37, 53)) * 300.3).astype(dtype)
    want = np.stack([np.asarray(frames[i][::step, ::step], np.float32) for i in (0, 3, 4)])
    np.testing.assert_array_equal(_strided_sample(frames, [0, 3, 4], step), want)
    np.testing.assert_array_equal(_strided_sample(list(frames), [0, 3, 4], step), want)  # not an array: numpy's


def test_the_compiled_passes_leave_other_dtypes_to_numpy():
    from fringe3d.decode.compensation import _strided_sample
    rng = np.random.default_rng(18)
    half = rng.random((2, 9, 11)).astype(np.float16)
    np.testing.assert_array_equal(_strided_sample(half, [1], 2), half[1:, ::2, ::2].astype(np.float32))
    swapped = (rng.random((2, 9, 11)) * 300).astype(">u2")
    np.testing.assert_array_equal(_strided_sample(swapped, [0, 1], 3), swapped[:, ::3, ::3].astype(np.float32))
    x = half[0].copy()
    x[2, 3] = np.nan
    where = np.zeros(x.shape, bool)
    assert edges.nan_where(x, where) is False
    where[2, 3] = True
    assert edges.nan_where(x, where) is True


def test_ratio_median_bracket_is_numpys_inverted_cdf_quantiles_of_the_sample():
    from fringe3d.decode._ratio_median import STRIDE, _sample_bracket
    for seed, shape in enumerate([(90, 97), (200, 161), (403, 96)]):
        fine, coarse, mask = _ratios(shape, 20 + seed)
        sm = mask[::STRIDE, ::STRIDE] & (coarse[::STRIDE, ::STRIDE] > 0)
        sample = fine[::STRIDE, ::STRIDE][sm] / coarse[::STRIDE, ::STRIDE][sm]
        n, delta, lo, hi = _sample_bracket(fine, coarse, mask, STRIDE)
        assert n == sample.size and delta == min(0.5, 0.01 + 4.0 / np.sqrt(sample.size))
        want = np.quantile(sample, [max(0.0, 0.5 - delta), min(1.0, 0.5 + delta)], method="inverted_cdf")
        assert (lo, hi) == tuple(want)
    fine[0, 0] = np.nan
    assert _sample_bracket(fine, coarse, np.ones(fine.shape, bool), STRIDE)[0] == -1


@pytest.mark.parametrize("shape", [(200, 301), (260, 300)])  # one thread, and the chunked region beyond SERIAL_PIXELS
def test_ratio_median_on_either_side_of_the_serial_size_is_numpys(shape, monkeypatch):
    from fringe3d.decode import _ratio_median
    assert (shape[0] * shape[1] > _ratio_median.SERIAL_PIXELS) == (shape == (260, 300))
    fine, coarse, mask = _ratios(shape, 30)
    m = mask & (coarse > 0)
    monkeypatch.setattr(_ratio_median, "_numpy_median", lambda *a: pytest.fail("fell back to numpy"))
    for odd in (False, True):  # an even and an odd count of ratios
        if odd != bool(m.sum() % 2):
            mask[np.argwhere(m)[0][0], np.argwhere(m)[0][1]] = False
            m = mask & (coarse > 0)
        assert ratio_median(fine, coarse, mask) == float(np.median(fine[m] / coarse[m]))


def test_noise_reference_point_is_the_numpy_mean_of_its_finite_sample():
    rng = np.random.default_rng(31)
    for dx, dy in ((np.float32, np.float32), (np.float64, np.float32), (np.float32, np.float64)):
        x = rng.uniform(0, 255, (83, 130)).astype(dx)
        y = (rng.uniform(0, 30, x.shape) ** 2).astype(dy)
        x[rng.random(x.shape) < 0.05] = np.nan
        y[rng.random(x.shape) < 0.05] = np.inf
        mask = rng.random(x.shape) > 0.4
        for a, b, m in ((x, y, mask), (x.T, y.T, mask.T), (x[:, 1:], y[:, 1:], mask[:, 1:])):  # and views
            xs, ys, ms = a[::8, ::8], b[::8, ::8], m[::8, ::8]
            sel = ms & np.isfinite(xs) & np.isfinite(ys)
            want = (float(np.mean(xs[sel], dtype=np.float64)), float(np.mean(ys[sel], dtype=np.float64)))
            assert noise._reference_point(a, b, m) == want
    assert noise._reference_point(x, y, np.zeros(x.shape, bool)) == (0.0, 0.0)
