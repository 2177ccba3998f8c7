"""The three-pass quality map of the fused 3-step path equals edges.quality_map bit for bit."""
from __future__ import annotations

import numpy as np
import pytest

from fringe3d.decode import edges
from fringe3d.decode._fused_quality import fused_quality_map

SHAPES = [(1, 1), (2, 7), (6, 5), (61, 83)]
EXTENT = (-0.5, 99.5)
MARGIN = 2.0


def maps(shape, seed):
    """A fringe coordinate with depth steps, a mask with holes, contrast drops and unlit pixels."""
    rng = np.random.default_rng(seed)
    H, W = shape
    w = np.linspace(-3, 103, W, dtype=np.float32)[None, :].repeat(H, 0)
    w += np.where(rng.random(shape) < 0.05, 6.0, 0.0).astype(np.float32)  # isolated depth steps
    w += rng.normal(0, 0.05, shape).astype(np.float32)
    lo = np.float32(EXTENT[0] + MARGIN)
    w.flat[:: 7] = np.nextafter(lo, np.float32(np.inf))  # just inside the EDGE threshold ...
    w.flat[3:: 11] = lo  # ... on it (not in the band: the test is w < lo + margin in float32)
    valid = rng.random(shape) > 0.1
    w[~valid] = np.nan
    average = rng.uniform(20, 200, shape).astype(np.float32)
    average[rng.random(shape) < 0.03] = 0.0  # no contrast where A <= 0
    modulation = (average * rng.uniform(0.3, 0.9, shape)).astype(np.float32)
    modulation[rng.random(shape) < 0.05] *= np.float32(0.2)  # mixed pixels
    return valid, w, modulation, average


@pytest.mark.parametrize("shape", SHAPES)
@pytest.mark.parametrize("rim", [0, 1, 2])
def test_fused_quality_map_equals_quality_map(shape, rim):
    for seed in range(3):
        valid, w, mod, avg = maps(shape, seed)
        kw = dict(gradient_ratio=4.0, gradient_floor=1.0, modulation_ratio=0.5, rim=rim)
        ref = edges.quality_map(valid, w, EXTENT, mod, avg, None, tests=edges.QualityTests(margin=MARGIN, **kw))
        np.testing.assert_array_equal(fused_quality_map(valid, w, EXTENT, MARGIN, mod, avg, **kw), ref)


def test_every_bit_is_exercised():
    valid, w, mod, avg = maps((61, 83), 0)
    q = fused_quality_map(valid, w, EXTENT, MARGIN, mod, avg, rim=1)
    for bit in (edges.INVALID, edges.EDGE, edges.GRADIENT, edges.MOD_DROP, edges.RIM):
        assert (q & bit).any(), edges.BITS[bit]


def test_other_thresholds_match_too():
    valid, w, mod, avg = maps((40, 50), 4)
    kw = dict(gradient_ratio=2.5, gradient_floor=0.3, modulation_ratio=0.8, rim=1)
    tests = edges.QualityTests(margin=3.7, **kw)
    np.testing.assert_array_equal(fused_quality_map(valid, w, EXTENT, 3.7, mod, avg, **kw),
                                  edges.quality_map(valid, w, EXTENT, mod, avg, None, tests=tests))


@pytest.mark.parametrize("ratio", [4.0, 2.5, 1.0, 0.0, -1.5])
@pytest.mark.parametrize("floor", [1.0, 0.0])
def test_gradient_count_equals_the_median_test_on_tied_jumps(ratio, floor):
    """GRADIENT's count of the scaled jumps below the pixel's gives the test with the 5 x 5 median
    itself (the median network), also where many jumps are equal to each other and to the pixel's
    (jumps on a coarse grid: every tie of the strict comparison is met)."""
    from fringe3d.decode._fused_quality import _jump_count_kernel, _jump_test_kernel
    from fringe3d.decode._median_network import _median_kernel

    rng = np.random.default_rng(11)
    H, W = 23, 31
    gp = (rng.integers(0, 9, (H + 4, W + 4)) * 0.25).astype(np.float32)  # 0, 0.25, ... 2: ties everywhere
    gp[rng.random(gp.shape) < 0.1] = 7.0  # isolated large jumps
    valid = rng.random((H, W)) > 0.15
    ref = np.empty((H, W), np.float32)
    _median_kernel(gp, ref)
    want = np.empty((H, W + 2), np.uint8)
    got = np.empty((H, W + 2), np.uint8)
    _jump_test_kernel(valid, gp, ref, np.float32(ratio), np.float32(floor), want)
    _jump_count_kernel(valid, gp, np.float32(ratio), np.float32(floor), got)
    assert want[:, 1:-1].any() and not want[:, 1:-1].all()  # the test passes and fails somewhere
    np.testing.assert_array_equal(got, want)


def simulated(shape, seed):
    """Maps decoded from three simulated 8-bit phase-shifted frames: a fringe coordinate ramp
    (0.8 projector px per camera px) over a box with depth steps and a slanted face, a dark
    region (no fringes: A = B = 0), a blown-out one (clipped at 255), stray light, NaN, noise."""
    from fringe3d.phase.psp import wrapped_phase

    rng = np.random.default_rng(seed)
    H, W = shape
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    w = 0.8 * u + 0.05 * v
    box = (abs(u - W / 2) < W / 4) & (abs(v - H / 2) < H / 4)
    w[box] += 7.0 + 0.9 * (u[box] - W / 2)  # a step, then a steeper face
    w += rng.normal(0, 0.03, shape)
    gain = np.full(shape, 160.0)
    gain[(u > 5 * W / 6) & (v < H / 3)] = 400.0  # blown out: clipped frames
    ambient = np.full(shape, 20.0)
    unlit = (u < W / 6) & (v > H / 2)  # no light at all: A = 0 where the noise rounds to 0
    gain[unlit], ambient[unlit] = 0.0, 0.0
    mixed = rng.random(shape) < 0.03  # stray light: a contrast drop
    ambient[mixed], gain[mixed] = 150.0, 100.0
    phi = 2 * np.pi * w / 18.0
    frames = np.stack([np.clip(np.round(ambient + gain * (0.5 + 0.5 * np.cos(phi + 2 * np.pi * k / 3))
                                        + rng.normal(0, 1.0, shape)), 0, 255) for k in range(3)]).astype(np.uint8)
    pr, saturated = wrapped_phase(frames, saturation_level=255, return_saturated=True)
    mask = (pr.modulation >= 8.0) & ~saturated
    w32 = np.where(mask, w, np.nan).astype(np.float32)
    w32[rng.random(shape) < 0.01] = np.nan  # NaN where the mask says valid: unwrapping failures
    order = mask & (rng.random(shape) < 0.01)
    residual = rng.exponential(0.3, shape).astype(np.float32)
    residual[rng.random(shape) < 0.02] = np.nan
    return mask, order, saturated, w32, pr.modulation, pr.average, residual


# odd sizes; 65 and 97 rows end in a block of one row (BLOCK = 32), 31 is within one block; 517 columns:
# rows counted in chunks (COUNT_CHUNK = 128), some skipped, the last chunk of 5 columns
SIM_SHAPES = [(1, 1), (1, 9), (7, 1), (3, 5), (31, 47), (65, 81), (97, 130), (33, 517)]


@pytest.mark.parametrize("shape", SIM_SHAPES)
def test_quality_map_equals_previous_kernels_on_simulated_frames(shape):
    """The row-blocked quality map and the branch-free finish equal the previous kernels
    (tests/reference_implementations.py) bit for bit, every option combination."""
    import reference_implementations as ref

    from fringe3d.decode._fused_quality import finish_quality_map

    extent = (-0.5, 0.8 * shape[1] + 0.5)
    for seed in range(2):
        mask, order, sat, w, mod, avg, res = simulated(shape, seed)
        valid = mask & ~order
        for rim in (0, 1, 2):
            for ratio, floor, mratio in ((4.0, 1.0, 0.5), (2.5, 0.3, 0.8), (0.0, 0.0, 0.5), (-1.0, 1.0, 1.0),
                                         (np.inf, 1.0, 0.5)):
                kw = dict(gradient_ratio=ratio, gradient_floor=floor, modulation_ratio=mratio, rim=rim)
                want = ref.fused_quality_map_previous(valid, w, extent, 2.0, mod, avg, **kw)
                got = fused_quality_map(valid, w, extent, 2.0, mod, avg, **kw)
                np.testing.assert_array_equal(got, want, err_msg=f"{shape} {seed} {kw}")
        for o, s, r, thr in ((order, sat, res, 0.5), (None, None, None, 0.5), (order, None, res, np.inf),
                             (None, sat, res.astype(np.float64), 0.9), (order, sat, None, 0.5)):
            want, got = want.copy(), want.copy()
            ref.finish_quality_map_previous(want, mask, o, s, r, thr)
            finish_quality_map(got, mask, o, s, r, thr)
            np.testing.assert_array_equal(got, want)


def test_simulated_frames_exercise_every_bit():
    """The simulated maps of the test above set every bit somewhere (so equality means something)."""
    from fringe3d.decode._fused_quality import finish_quality_map

    mask, order, sat, w, mod, avg, res = simulated((97, 130), 0)
    q = fused_quality_map(mask & ~order, w, (-0.5, 104.5), 2.0, mod, avg, rim=1)
    finish_quality_map(q, mask, order, sat, res, 0.5)
    for bit in edges.BITS:
        assert (q & bit).any(), edges.BITS[bit]
    assert np.isnan(w[mask & ~order]).any() and (avg == 0).any()


def test_sparse_jumps_give_the_previous_map():
    """A smooth ramp (jumps below the floor) with a few depth steps: most column chunks of a row
    skip GRADIENT's count, the few with a step count it, and the map equals the previous kernels'."""
    import reference_implementations as ref

    rng = np.random.default_rng(5)
    H, W = 24, 700
    w = (0.5 * np.arange(W, dtype=np.float32))[None, :].repeat(H, 0) + rng.normal(0, 0.02, (H, W)).astype(np.float32)
    rows, cols = rng.integers(0, H, 8), rng.integers(0, W, 8)
    w[rows, cols] += np.float32(5.0)  # isolated steps: each row holds at most a few
    valid = rng.random((H, W)) > 0.02
    w[~valid] = np.nan
    avg = np.full((H, W), 100, np.float32)
    mod = rng.uniform(40, 80, (H, W)).astype(np.float32)
    kw = dict(gradient_ratio=4.0, gradient_floor=1.0, modulation_ratio=0.5, rim=1)
    want = ref.fused_quality_map_previous(valid, w, (-0.5, 350.5), 2.0, mod, avg, **kw)
    got = fused_quality_map(valid, w, (-0.5, 350.5), 2.0, mod, avg, **kw)
    assert (want & edges.GRADIENT).any()
    np.testing.assert_array_equal(got, want)


@pytest.mark.parametrize("seed", [0, 3])
def test_rows_finished_in_the_pass_equal_the_separate_finish(seed):
    """The decoder's one-pass map (:func:`finished_quality_map`: no ORDER, each row finished as it
    is made) equals the map then :func:`finish_quality_map` bit for bit, SATURATED and
    INCONSISTENT (residual on both sides of the threshold) included; with, without either map."""
    from fringe3d.decode._fused_quality import finish_quality_map, finished_quality_map

    mask, _, sat, w, mod, avg, res = simulated((97, 130), seed)
    w = np.where(mask, np.nan_to_num(w, nan=50.0), np.nan).astype(np.float32)  # finite on the mask
    res = res.astype(np.float32)
    res.flat[::5] = np.float32(0.5)  # on the threshold: not INCONSISTENT (res > thr)
    res.flat[1::5] = np.nextafter(np.float32(0.5), np.float32(1))
    for s, r, thr in ((sat, res, 0.5), (None, res, 0.5), (sat, None, 0.5), (None, None, 0.5), (sat, res, np.inf)):
        want = fused_quality_map(mask, w, (-0.5, 104.5), 2.0, mod, avg, rim=1)
        finish_quality_map(want, mask, None, s, r, thr)
        got = finished_quality_map(mask, w, (-0.5 + 2.0, 104.5 - 2.0), mod, avg, s, r, (4.0, 1.0, 0.5, thr))
        np.testing.assert_array_equal(got, want)
        if s is not None and r is not None and thr == 0.5:
            assert (got & edges.SATURATED).any() and (got & edges.INCONSISTENT).any()
