"""Temporal unwrapping gives the exact fringe order (closed-form synthetic fringes with noise)."""
import math

import numpy as np
import pytest

from fringe3d.phase.psp import default_shifts, wrapped_phase
from fringe3d.unwrap.temporal import (beat_chain, code_centers, code_stripes, coarse_window, gray_code_order,
                                      heterodyne, hierarchical, three_frequency_decode)
from reference_engine import gray_code_order_reference, heterodyne_reference, hierarchical_reference

H, W = 128, 160


def projector_w():
    """Projector fringe coordinate seen by each camera pixel: 2..785 px, slightly tilted."""
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    return 2.0 + u * 4.9 + v * 0.06 + 3.0 * np.sin(v / 9.0)


def fringes(w, period, n, sigma, rng, a=120.0, b=80.0):
    shifts = default_shifts(n)
    f = np.stack([a + b * np.cos(2 * np.pi * w / period + d) for d in shifts])
    return f + rng.normal(0.0, sigma, f.shape) if sigma else f


def order_errors(phase, w, period):
    """Fringe-order errors of an absolute phase against the truth Phi = 2 pi w / T."""
    return np.round((phase - 2 * np.pi * w / period) / (2 * np.pi)).astype(np.int64)


def test_beat_chain_of_calibration_set_is_126_then_1008():
    beats, signs = beat_chain([18, 21, 144])
    assert np.allclose(beats, [126.0, 1008.0]) and np.all(signs == 1)


@pytest.mark.parametrize("sigma", [0.0, 4.0])
def test_heterodyne_18_21_144_exact_order_on_every_pixel(sigma):
    rng = np.random.default_rng(3)
    w = projector_w()
    phases = [wrapped_phase(fringes(w, t, n, sigma, rng)).phase for t, n in ((18, 9), (21, 3), (144, 3))]
    res = heterodyne(phases, [18, 21, 144], w_range=(0, 799))
    assert not order_errors(res.phase, w, 18).any()
    ref = heterodyne_reference(phases, [18, 21, 144], w_range=(0, 799))
    assert np.array_equal(res.order, ref.order)
    assert np.abs(res.phase - ref.phase).max() < 1e-4   # float32 output of phases up to 280 rad


@pytest.mark.parametrize("sigma", [0.0, 4.0])
def test_hierarchical_exact_order_on_every_pixel(sigma):
    rng = np.random.default_rng(4)
    w = projector_w()
    periods = [16, 96, 1024]   # coarsest covers the 800 px projector with margin
    phases = [wrapped_phase(fringes(w, t, 4, sigma, rng)).phase for t in periods]
    res = hierarchical(phases, periods, w_range=(0, 799))
    assert not order_errors(res.phase, w, 16).any()
    ref = hierarchical_reference(phases, periods, w_range=(0, 799))
    assert np.array_equal(res.order, ref.order)
    if sigma == 0:
        assert np.abs(res.phase - 2 * np.pi * w / 16).max() < 1e-4


def test_fused_three_frequency_decode_equals_separate_steps():
    rng = np.random.default_rng(5)
    w = projector_w()
    groups = [(18, 9), (21, 3), (144, 3)]
    frames = np.concatenate([fringes(w, t, n, 3.0, rng) for t, n in groups])
    frames8 = np.clip(np.round(frames), 0, 255).astype(np.uint8)
    idx = [list(range(0, 9)), list(range(9, 12)), list(range(12, 15))]
    shifts = [default_shifts(9), default_shifts(3), default_shifts(3)]
    fused = three_frequency_decode(frames8, idx, shifts, (18, 21, 144), w_range=(0, 799), min_modulation=5.0,
                                   saturation_level=255)
    phases = [wrapped_phase(frames8, index=i).phase for i in idx]
    ref = heterodyne_reference(phases, [18, 21, 144], w_range=(0, 799))
    assert fused.mask.all()
    assert np.abs(fused.phase - ref.phase).max() < 1e-4
    assert not order_errors(fused.phase, w, 18).any()
    first = wrapped_phase(frames8, index=idx[0])
    assert np.abs(fused.modulation - first.modulation).max() < 1e-3
    assert np.abs(fused.average - first.average).max() < 1e-3
    assert np.abs(fused.wrapped - first.phase).max() < 1e-5
    # saturation and low modulation are masked, phase NaN there
    frames8[4, 10, 20] = 255
    frames8[:, 30, 40] = 100
    fused = three_frequency_decode(frames8, idx, shifts, (18, 21, 144), w_range=(0, 799), min_modulation=5.0,
                                   saturation_level=255)
    assert not fused.mask[10, 20] and not fused.mask[30, 40] and np.isnan(fused.phase[30, 40])
    assert fused.mask.sum() == H * W - 2


@pytest.mark.parametrize("steps", [(4, 5, 3), (7, 4, 6)])
def test_fused_decode_with_step_counts_not_multiple_of_three_equals_separate_steps(steps):
    """The fused kernel sums frames three at a time; groups of 4, 5 or 7 frames exercise its
    1- and 2-frame tail passes (and uint16 frames its other input type)."""
    rng = np.random.default_rng(11)
    w = projector_w()
    periods = (18, 21, 144)
    frames = np.concatenate([fringes(w, t, n, 2.0, rng, a=2000.0, b=1500.0) for t, n in zip(periods, steps)])
    frames16 = np.clip(np.round(frames), 0, 4095).astype(np.uint16)
    ends = np.cumsum((0,) + steps)
    idx = [list(range(ends[g], ends[g + 1])) for g in range(3)]
    shifts = [default_shifts(n) for n in steps]
    fused = three_frequency_decode(frames16, idx, shifts, periods, w_range=(0, 799), min_modulation=5.0,
                                   saturation_level=4095)
    phases = [wrapped_phase(frames16, index=i).phase for i in idx]
    ref = heterodyne_reference(phases, periods, w_range=(0, 799))
    first = wrapped_phase(frames16, index=idx[0])
    assert fused.mask.all()
    assert np.abs(fused.phase - ref.phase).max() < 1e-4
    assert not order_errors(fused.phase, w, 18).any()
    assert np.abs(fused.wrapped - first.phase).max() < 1e-5
    assert np.allclose(fused.modulation, first.modulation, rtol=1e-5)
    assert np.allclose(fused.average, first.average, rtol=1e-5)
    assert np.allclose(fused.texture, first.average + first.modulation, rtol=1e-5)


def test_coarse_window_centres_projector_range():
    lo = coarse_window(1008.0, (0.0, 799.0))
    w_lo = lo * 1008.0 / (2 * np.pi)
    assert math.isclose(w_lo, -(1008 - 799) / 2)
    with pytest.warns(UserWarning, match="shorter than"):
        coarse_window(1008.0, (0.0, 1279.0))


def _code_images(nbits, stripe, width, offset=0.0):
    """Gray-code projector rows (B, width) 0/1 for stripes [offset + c*stripe, ...) (MSB first)."""
    u = np.arange(width, dtype=np.float64)
    c = np.floor((u - offset) / stripe).astype(np.int64)
    g = c ^ (c >> 1)
    return np.stack([(g >> (nbits - 1 - b)) & 1 for b in range(nbits)]).astype(np.uint8), u


@pytest.mark.parametrize("misalign", [-2.0, 2.0])
def test_gray_code_half_period_code_exact_despite_edge_misalignment(misalign):
    """Code stripes of T/2: camera-side code edges shifted by T/8 still give the exact order."""
    rng = np.random.default_rng(6)
    period, width = 16.0, 800
    images, u = _code_images(7, period / 2, width)
    stripes = code_stripes(images, u)
    w = projector_w()
    phase_frames = fringes(w, period, 4, 2.0, rng)
    pos = np.clip(np.floor(w + misalign).astype(int), 0, width - 1)   # code sampled at shifted edges
    code = images[:, pos].astype(np.float64) * 160 + 20 + rng.normal(0, 2.0, (7, H, W))
    inverse = (1 - images[:, pos]).astype(np.float64) * 160 + 20 + rng.normal(0, 2.0, (7, H, W))
    # float32 frames, as float captures come: no float64 specialisation of the code-order kernel
    frames = np.concatenate([phase_frames, code, inverse]).astype(np.float32)
    wr = wrapped_phase(frames, index=range(4)).phase
    res = gray_code_order(frames, range(4, 11), wr, period, stripes, inverse_index=range(11, 18))
    assert res.valid.all()
    assert not order_errors(res.phase, w, period).any()
    ref = gray_code_order_reference(frames, range(4, 11), wr, period, stripes, inverse_index=range(11, 18))
    assert np.array_equal(res.order, ref.order)


def test_full_period_code_misaligned_edges_cause_order_errors():
    """Why the half-period code is needed: with stripes of one period aligned to the phase
    wraps, misplaced code edges give +-1 order errors near the wraps."""
    rng = np.random.default_rng(7)
    period, width = 16.0, 800
    images, u = _code_images(6, period, width, offset=-period / 2)
    stripes = code_stripes(images, u)
    w = projector_w()
    phase_frames = fringes(w, period, 4, 0.0, rng)
    pos = np.clip(np.floor(w + 2.0).astype(int), 0, width - 1)
    code = images[:, pos].astype(np.float64) * 200
    frames = np.concatenate([phase_frames, code]).astype(np.float32)
    wr = wrapped_phase(frames, index=range(4)).phase
    res = gray_code_order(frames, range(4, 10), wr, period, stripes, threshold=np.full((H, W), 100.0))
    assert (order_errors(res.phase, w, period) != 0).mean() > 0.05


def test_unused_codewords_are_invalid_and_bad_inputs_raise():
    images, u = _code_images(3, 100.0, 300)
    centers = code_centers(images, u)
    assert np.isnan(centers).sum() == 8 - 3
    frames = np.zeros((3, 4, 4))
    with pytest.raises(ValueError, match="inverse frames or a threshold"):
        gray_code_order(frames, range(3), np.zeros((4, 4)), 16.0, code_stripes(images, u))
    with pytest.raises(ValueError, match="one period per phase"):
        hierarchical([np.zeros((4, 4))] * 2, [16.0])
    with pytest.raises(ValueError, match="distinct periods"):
        heterodyne([np.zeros((4, 4))] * 2, [16.0, 16.0])


def test_fused_three_frequency_masks_pixels_whose_orders_are_inconsistent():
    """A pixel whose coarse (T=144) phase disagrees with the fine ones by ~half a fine period
    at the 1008 -> 126 step is masked instead of getting a coin-toss fringe order."""
    from fringe3d.unwrap.temporal import three_frequency_decode

    h, w = 8, 64
    up = np.tile(np.linspace(50.0, 700.0, w), (h, 1))
    periods = (18.0, 21.0, 144.0)
    steps = (9, 3, 3)
    shifts = [2 * np.pi * np.arange(n) / n for n in steps]
    frames, indices, k = [], [], 0
    for T, sh in zip(periods, shifts):
        phi = 2 * np.pi * up / T
        if T == 144.0:
            phi = phi.copy()
            # corrupt one row's coarse phase by 0.45 rad: x8 (1008/126) it is 3.6 rad at the
            # 126-period step, beyond pi, so without the check that row's order would be wrong
            phi[3] += 0.45
        indices.append(list(range(k, k + len(sh))))
        k += len(sh)
        frames += [100 + 80 * np.cos(phi + s) for s in sh]
    res = three_frequency_decode(np.array(frames, np.float32), indices, shifts, periods)
    good = np.delete(np.arange(h), 3)
    assert res.mask[good].all()
    assert np.allclose(res.phase[good] * 18 / (2 * np.pi), up[good], atol=1e-3)
    assert not res.mask[3].any()
