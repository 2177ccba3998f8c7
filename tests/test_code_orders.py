"""Code-assisted fringe orders cannot land on the wrong side of a period boundary (issue 23).

A swept projector-coordinate ramp is rendered to 8-bit frames: a 3-step phase (whose frames
1 and 2 are equal on every period boundary, so the wrapped phase there is an exact 0 or a few
1e-16 rad) and Gray / binary code frames blurred over 0.7 projector px, for several stripe /
period ratios, noise-free and noisy. The truth is the ramp itself.
"""
import math

import numpy as np
import pytest

from fringe3d.decode import DecodeOptions, decode, edges
from fringe3d.io.capture import read_capture
from fringe3d.patterns import sets
from fringe3d.patterns.synthetic import frames_from_coordinates
from fringe3d.phase.psp import wrapped_phase
from fringe3d.sim.simulate import simulate_capture
from fringe3d.unwrap.sub_stripe import sub_stripe_coordinate
from fringe3d.unwrap.temporal import MAX_CODE_RESIDUAL, code_stripes, gray_code_order, heterodyne, hierarchical
from reference_engine import gray_code_order_reference

PERIOD = 16.0
ROWS, COLS = 8, 1024


def ramp():
    """(ROWS, COLS) projector coordinate 8 .. 136 px in steps of 1/64 px (every integer exactly)."""
    i, j = np.mgrid[0:ROWS, 0:COLS].astype(np.float64)
    return 8.0 + (j * ROWS + i) / 64.0


def codeword(w, stripe, code):
    c = np.floor(w / stripe).astype(np.int64)
    return c ^ (c >> 1) if code == "gray" else c


def render(w, stripe, nbits, code, sigma, seed, blur=0.7):
    """uint8 frames: 3 phase frames, nbits code frames, nbits inverse frames."""
    rng = np.random.default_rng(seed)
    phase = np.stack([120 + 80 * np.cos(2 * np.pi * w / PERIOD + s) for s in 2 * np.pi * np.arange(3) / 3])
    offsets = np.linspace(-2.5, 2.5, 21)
    weights = np.exp(-0.5 * offsets ** 2)
    weights /= weights.sum()
    bits = np.zeros((nbits,) + w.shape)
    for o, a in zip(offsets, weights):
        word = codeword(w + o * blur, stripe, code)
        for b in range(nbits):
            bits[b] += a * ((word >> (nbits - 1 - b)) & 1)
    frames = np.concatenate([phase, 20 + 180 * bits, 20 + 180 * (1 - bits)])
    if sigma:
        frames = frames + rng.normal(0.0, sigma, frames.shape)
    return np.clip(np.round(frames), 0, 255).astype(np.uint8)


def projector_stripes(stripe, nbits, code):
    wp = np.arange(0.0, 160.0, 1 / 16) + 1 / 32
    images = np.stack([(codeword(wp, stripe, code) >> (nbits - 1 - b)) & 1 for b in range(nbits)])
    return code_stripes(images, wp)


def off_by_a_period(phase, w):
    return np.round((phase - 2 * np.pi * w / PERIOD) / (2 * np.pi)) != 0


@pytest.mark.parametrize("ratio", [1.0, 0.5, 0.25])
@pytest.mark.parametrize("code", ["gray", "binary"])
@pytest.mark.parametrize("sigma", [0.0, 1.5])
def test_code_plus_phase_sweep_has_no_valid_pixel_off_by_a_period(ratio, code, sigma):
    """Every wrapped phase and every code boundary of the sweep, exact zeros included: the order
    is right on every pixel, none is masked, and the numba kernel equals the NumPy reference."""
    stripe = PERIOD * ratio
    nbits = int(math.ceil(math.log2(160 / stripe)))
    w = ramp()
    frames = render(w, stripe, nbits, code, sigma, seed=11)
    wr = wrapped_phase(frames, index=range(3)).phase
    assert (np.abs(wr) < 1e-12).sum() >= (2 if sigma else 8)    # the sweep holds exact-zero phases
    stripes = projector_stripes(stripe, nbits, code)
    bits, inverse = range(3, 3 + nbits), range(3 + nbits, 3 + 2 * nbits)
    contrast = 2 * wrapped_phase(frames, index=range(3)).modulation   # a clear bit's |D| (180) ~ 2 B (160)
    res = gray_code_order(frames, bits, wr, PERIOD, stripes, inverse_index=inverse, contrast=contrast)
    assert res.valid.all() and res.residual is not None
    kept = res.valid & (res.residual <= MAX_CODE_RESIDUAL)
    assert kept.all()
    assert not off_by_a_period(res.phase, w).any()
    ref = gray_code_order_reference(frames, bits, wr, PERIOD, stripes, inverse_index=inverse, contrast=contrast)
    assert np.array_equal(res.order, ref.order)


def test_period_wide_code_without_inverse_frames_takes_the_boundary_it_sits_at():
    """Thresholded against a mid-grey image instead of inverse frames, the period-wide Gray code
    still orders every exact-zero boundary pixel right."""
    w = ramp()
    frames = render(w, PERIOD, 4, "gray", 0.0, seed=0)[:7]
    wr = wrapped_phase(frames, index=range(3)).phase
    res = gray_code_order(frames, range(3, 7), wr, PERIOD, projector_stripes(PERIOD, 4, "gray"),
                          threshold=np.full(w.shape, 110.0))
    assert not off_by_a_period(res.phase, w).any()


@pytest.mark.parametrize("sigma", [0.0, 1.5])
def test_code_twice_the_period_orders_from_the_sub_stripe_coordinate(sigma):
    """Stripes two periods wide leave the order open inside a stripe: with the code's sub-stripe
    coordinate every pixel is right, without it every pixel is flagged (residual inf)."""
    stripe, nbits = 2 * PERIOD, 3
    w = ramp()
    frames = render(w, stripe, nbits, "gray", sigma, seed=5)
    wr = wrapped_phase(frames, index=range(3)).phase
    stripes = projector_stripes(stripe, nbits, "gray")
    diff = frames[3:3 + nbits].astype(np.float32) - frames[3 + nbits:].astype(np.float32)
    word = np.zeros(w.shape, np.int64)
    for plane in diff:
        word = word * 2 + (plane > 0)
    coordinate, refined = sub_stripe_coordinate(stripes.centre[word], diff, stripe)
    bits, inverse = range(3, 3 + nbits), range(3 + nbits, 3 + 2 * nbits)
    res = gray_code_order(frames, bits, wr, PERIOD, stripes, inverse_index=inverse,
                          coordinate=np.where(refined, coordinate, np.nan))
    kept = res.valid & (res.residual <= MAX_CODE_RESIDUAL)
    assert kept.mean() > 0.99
    assert not (kept & off_by_a_period(res.phase, w)).any()
    alone = gray_code_order(frames, bits, wr, PERIOD, stripes, inverse_index=inverse)
    assert np.isinf(alone.residual).all()


@pytest.mark.parametrize("sigma", [0.0, 2.0])
def test_multi_frequency_orders_on_exact_zero_phases_are_exact(sigma):
    """Hierarchical and heterodyne rounding on 8-bit frames with exact-zero wrapped phases on
    the period boundaries: no pixel off by a period, every rounding residual well below 1/4."""
    rng = np.random.default_rng(3)
    w = ramp()

    def phase(period, steps):
        shifts = 2 * np.pi * np.arange(steps) / steps
        f = np.stack([120 + 80 * np.cos(2 * np.pi * w / period + s) for s in shifts])
        f = f + rng.normal(0.0, sigma, f.shape) if sigma else f
        return wrapped_phase(np.clip(np.round(f), 0, 255).astype(np.uint8)).phase

    h = hierarchical([phase(16, 3), phase(64, 3), phase(256, 3)], [16, 64, 256], w_range=(8, 136))
    assert not off_by_a_period(h.phase, w).any() and h.residual.max() < 0.25
    het = heterodyne([phase(16, 3), phase(18, 3), phase(128, 3)], [16, 18, 128], w_range=(8, 136))
    assert not off_by_a_period(het.phase, w).any() and het.residual.max() < 0.25


def _simulated(tmp_path, code_period, seed=1):
    ps = sets.psp_with_gray_code(18, 3, "v", width=256, height=200, code=sets.CodeFrames(period=code_period))
    simulate_capture(tmp_path / "cap", preset="tiny", scene="sphere", patterns=ps, seed=seed, progress=False)
    cap = read_capture(tmp_path / "cap")
    with np.load(tmp_path / "cap" / "truth" / "truth.npz") as t:
        return cap, t["up"], t["hit"].astype(bool)


@pytest.mark.parametrize("code_period", [9.0, 18.0])
def test_clean_simulated_gray_capture_orders_are_consistent(tmp_path, code_period):
    """A clean simulated Gray + phase capture (half-period and period-wide code): at most 0.1 %
    of the valid pixels fail the code/phase check, none is off by a period, and the share is in
    the decode summary."""
    cap, up, hit = _simulated(tmp_path, code_period)
    d = decode(cap.frames, cap.patterns, options=DecodeOptions(bit_depth=cap.bit_depth))
    share = d.summary()["directions"]["v"]["order_inconsistent"]
    assert share <= 0.001
    assert d.info["quality"]["v"]["masked"]["order"] <= 0.001 * (d.quality["v"] & edges.INVALID == 0).sum()
    w = d.projector_coordinate("v")
    valid = d.mask["v"] & hit
    assert valid.sum() > 0.8 * hit.sum()
    assert not (np.abs(w[valid] - up[valid]) > 9.0).any()


def test_corrupted_code_bit_is_masked_with_the_order_bit(tmp_path):
    """A pixel whose code frame and inverse swap for one bit (a wrong codeword of the other half
    period) gets the quality bit ORDER and is masked."""
    cap, up, hit = _simulated(tmp_path, 9.0)
    frames = np.array(cap.frames)
    code = [i for i, f in enumerate(cap.patterns.frames) if f.role == "code"]
    centre = hit & (np.abs(np.mod(up, 9.0) - 4.5) < 1.0)   # mid-stripe: the phase can tell
    candidates = np.argwhere(centre)
    picks = [tuple(candidates[i]) for i in np.linspace(0, len(candidates) - 1, 8).astype(int)]
    for n, (r, c) in enumerate(picks):
        bit = 2 * (n % (len(code) // 2))                      # one bit per pixel, MSB to LSB
        frames[code[bit], r, c], frames[code[bit + 1], r, c] = frames[code[bit + 1], r, c], frames[code[bit], r, c]
    d = decode(frames, cap.patterns, options=DecodeOptions(bit_depth=cap.bit_depth))
    ordered = [bool(d.quality["v"][r, c] & edges.ORDER) for r, c in picks]
    assert not any(d.mask["v"][r, c] for r, c in picks)
    # every pick is masked; all but those whose corrupted word is no stripe (INVALID) by the new bit
    assert all(o or d.quality["v"][r, c] & edges.INVALID for o, (r, c) in zip(ordered, picks))
    assert sum(ordered) >= 6
    clean = decode(frames, cap.patterns, options=DecodeOptions(bit_depth=cap.bit_depth, max_code_residual=math.inf))
    assert all(not clean.quality["v"][r, c] & edges.ORDER for r, c in picks)


def test_coarse_phase_off_by_over_a_quarter_period_is_masked_with_the_order_bit():
    """Hierarchical plan: pixels whose middle (T=96) phase is shifted by 0.55 of the fine period
    would round to the neighbouring order; their residual 0.45 > 1/4 sets ORDER and masks them,
    and the check is what removes them (max_residual=pi keeps them, off by a period)."""
    ps = sets.hierarchical((16, 96, 1024), 4, "v", width=800, height=600)
    v_p, u_p = np.mgrid[100:132, 100:164].astype(float)
    frames = frames_from_coordinates(ps, u_p, v_p, dtype=np.uint8)
    shifted = frames_from_coordinates(ps, u_p + 0.55 * 16, v_p, dtype=np.uint8)
    middle = [i for i, f in enumerate(ps.frames) if f.period == 96]
    picks = [(5, 7), (12, 30), (20, 50), (27, 13)]
    for r, c in picks:
        frames[middle, r, c] = shifted[middle, r, c]
    d = decode(frames, ps, options=DecodeOptions(min_modulation=1.0))
    for r, c in picks:
        assert d.quality["v"][r, c] & edges.ORDER and not d.mask["v"][r, c]
    assert d.info["quality"]["v"]["masked"]["order"] == len(picks)
    assert d.summary()["directions"]["v"]["order_inconsistent"] == pytest.approx(len(picks) / u_p.size)
    kept = decode(frames, ps, options=DecodeOptions(min_modulation=1.0, max_residual=math.pi, edge_mask=False))
    w = kept.projector_coordinate("v")
    assert all(kept.mask["v"][r, c] and abs(w[r, c] - u_p[r, c] - 16) < 0.5 for r, c in picks)
