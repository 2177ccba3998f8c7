"""Saturation by what it breaks (issue 23, item 2).

Truth: closed-form clipped sinusoids (the true phase is known), the simulator's ground truth
(projector coordinates, lit mask = not in shadow or background) under overexposure, and clean
0 / full-scale frames as OpenCV's ``GrayCodePattern`` generates them.
"""
from __future__ import annotations

import dataclasses
import math
import warnings

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode import DecodeOptions, decode, edges
from fringe3d.decode.methods.code_only import decide_edges
from fringe3d.io.capture import read_capture
from fringe3d.patterns import sets
from fringe3d.patterns.layouts import opencv_graycode
from fringe3d.patterns.manifest import FrameSpec
from fringe3d.patterns.synthetic import frames_from_coordinates
from fringe3d.phase.clipping import clipping_bias, clipping_mask
from fringe3d.phase.quality import FrameQualityWarning
from fringe3d.sim import presets
from fringe3d.sim.render import render
from fringe3d.sim.simulate import make_scene


def _true_offset(phi: np.ndarray, clipped: np.ndarray, shifts: np.ndarray) -> np.ndarray:
    """The actual phase error of the least-squares phase of ``clipped`` samples (rad)."""
    n = shifts.size
    z = (2.0 / n) * np.exp(-1j * shifts) @ clipped
    return np.angle(np.exp(1j * (phi - np.angle(z))))


@pytest.mark.parametrize("steps", [4, 5, 9])
def test_clipping_bias_from_the_unclipped_samples_is_the_true_bias(steps):
    rng = np.random.default_rng(0)
    shifts = 2 * np.pi * np.arange(steps) / steps
    phi = rng.uniform(-np.pi, np.pi, 5000)
    true = 150.0 + 120.0 * np.cos(phi[None] + shifts[:, None])  # crest 270 counts
    clipped = np.minimum(true, 255.0)
    r = clipping_bias(clipped, shifts, 255.0)
    some = (true >= 255).any(axis=0)
    assert some.mean() > 0.5 and r.estimated[some].all()
    np.testing.assert_allclose(r.bias[some], _true_offset(phi, clipped, shifts)[some], atol=1e-9)
    np.testing.assert_allclose(r.modulation[some], 120.0, rtol=1e-9)
    assert (r.bias[~some] == 0).all()


@pytest.mark.parametrize(("a", "b"), [(150.0, 120.0), (200.0, 160.0)])
def test_three_step_clipping_bound_is_never_below_the_true_bias(a, b):
    rng = np.random.default_rng(1)
    shifts = 2 * np.pi * np.arange(3) / 3
    phi = rng.uniform(-np.pi, np.pi, 20000)
    true = a + b * np.cos(phi[None] + shifts[:, None])
    clipped = np.minimum(true, 255.0)
    r = clipping_bias(clipped, shifts, 255.0)
    some = (true >= 255).any(axis=0)
    assert some.any() and not r.estimated.any()     # 2 unclipped samples: a bound, not an estimate
    actual = np.abs(_true_offset(phi, clipped, shifts))
    assert (actual[some] <= r.bias[some] + 1e-9).all()
    assert np.median(r.bias[some]) < 1.0           # informative: well below pi


def test_a_sample_raised_to_the_level_that_clipping_cannot_explain_is_masked():
    shifts = 2 * np.pi * np.arange(4) / 4
    frames = (100.0 + 60.0 * np.cos(0.4 + shifts))[:, None, None] * np.ones((4, 2, 3))
    frames[1, 0, 0] = 255.0                         # a glint: the fit of the others says ~44 counts
    r = clipping_mask(frames.astype(np.uint8), range(4), shifts, 255.0, noise=1.0)
    assert r.clipped.sum() == 1 and r.broken[0, 0] and r.broken.sum() == 1


def test_a_code_bit_is_undecidable_only_where_both_frames_are_clipped():
    centres = np.array([1.5, 5.5, 13.5, 9.5])       # 2-bit Gray code, T = 4
    diff = np.array([[200.0, 0.0], [200.0, -200.0]], np.float32)[:, None, :]
    both = np.array([[False, True], [False, False]])[:, None, :]
    decided, straddling, *_ = decide_edges(diff, 5.0, centres, 4.0, edge_margin=0.0, undecidable=both)
    assert decided[0].tolist() == [True, False] and straddling[0].tolist() == [True, False]


def _opencv_view(shape=(60, 80)):
    """A camera seeing every fifth projector pixel (+0.2 px: inside the pixel's stripe)."""
    v, u = np.mgrid[0:shape[0], 0:shape[1]].astype(float)
    return 100 + 5 * u + 0.2, 50 + 5 * v + 0.2


@pytest.mark.parametrize("bit_depth", [8, 12])
def test_clean_full_scale_opencv_gray_frames_decode_everywhere(bit_depth):
    ps = opencv_graycode(1024, 768)
    u_p, v_p = _opencv_view()
    top = 2.0 ** bit_depth - 1
    frames = frames_from_coordinates(ps, u_p, v_p, a=0.0, b=top, dtype=np.uint8 if bit_depth == 8 else np.uint16)
    assert frames.max() == top and frames.min() == 0      # hard 0 / full scale, as generate() makes them
    with warnings.catch_warnings():
        warnings.simplefilter("error", FrameQualityWarning)  # full-scale binary frames are by design
        d = decode(frames, ps, options=DecodeOptions(bit_depth=bit_depth))
    for direction, true in (("v", u_p), ("h", v_p)):
        assert d.mask[direction].all()
        np.testing.assert_allclose(d.projector_coordinate(direction), np.round(true), atol=1e-4)
        assert d.info["quality"][direction]["saturation"]["code"]["masked"] == 0.0


def test_black_reference_and_code_frames_are_not_dark_frames_but_a_black_white_frame_is():
    ps = opencv_graycode(1024, 768)
    u_p, v_p = _opencv_view()
    frames = frames_from_coordinates(ps, u_p, v_p, a=0.0, b=200.0, dtype=np.uint8)
    black, white = len(ps) - 1, len(ps) - 2
    assert ps.frames[black].kind == "black" and ps.frames[white].kind == "white"
    assert frames[black].max() == 0 and frames[20].max() == 0  # the view sees only the off half of row bit 0
    with warnings.catch_warnings():
        warnings.simplefilter("error", FrameQualityWarning)
        d = decode(frames, ps)
    checks = d.info["frame_checks"]
    assert checks["dark"] == [] and black in checks["dark_by_design"] and 20 in checks["dark_by_design"]
    assert d.mask["v"].all() and d.mask["h"].all()              # no masking because of them
    frames[white] = 1                                           # the white frame came out black: a real fault
    with pytest.warns(FrameQualityWarning, match=rf"1 dark frame\(s\).*\[{white}\]"):
        decode(frames, ps)


@pytest.fixture(scope="module")
def tiny():
    p = presets.get("tiny")
    ref = presets.get("well-designed").settings
    noisy = p.settings.replace(read_noise=ref.read_noise, shot_noise=ref.shot_noise, bit_depth=8, seed=3)
    return p, noisy


def _gray_set(p, inverse: bool, stripe: float = 8.0):
    w, h = p.rig.projector.width, p.rig.projector.height
    ps = sets.gray_code(stripe, "v", width=w, height=h, inverse=inverse)
    return dataclasses.replace(ps, frames=ps.frames + (FrameSpec(kind="white", role="texture"),
                                                       FrameSpec(kind="black", role="reference")))


@pytest.mark.parametrize(("inverse", "lost"), [(True, 0.01), (False, 0.06)], ids=["inverses", "white-black"])
def test_gray_code_only_with_clipped_bright_frames_keeps_the_lit_pixels(tiny, inverse, lost):
    p, noisy = tiny
    ps = _gray_set(p, inverse)
    frames, truth = render(make_scene("sphere", p), p.rig, ps, noisy.replace(gain=2.5), progress=False)
    lit = truth.mask
    assert (frames[:-2] >= 255)[:, lit].mean() > 0.3                 # the bright frame of most pairs clips
    d = decode(frames, ps)
    m = d.mask["v"]
    assert not (m & ~lit).any()
    # with inverses every lit pixel is decided; thresholded against a clipped white frame the
    # edge pixels between the clipped and the true threshold are undecidable (a few points)
    assert lit.mean() - m.mean() <= lost, (m.mean(), lit.mean())
    same = np.floor((d.projector_coordinate("v")[m] + 0.5) / 8) == np.floor((truth.up[m] + 0.5) / 8)
    assert same.mean() >= 0.999


def test_clean_full_scale_simulated_opencv_capture_is_valid_wherever_lit(tiny):
    p, _ = tiny
    ps = opencv_graycode(p.rig.projector.width, p.rig.projector.height)
    clean = p.settings.replace(ideal=True, ambient=0.0, gain=50.0, read_noise=0.0, shot_noise=False, bit_depth=8)
    frames, truth = render(make_scene("sphere", p), p.rig, ps, clean, progress=False)
    lit = truth.mask
    assert np.isin(frames[:, lit], (0, 255)).mean() > 0.99                # hard 0 / 255 frames
    d = decode(frames, ps)
    for direction, true in (("v", truth.up), ("h", truth.vp)):
        m = d.mask[direction]
        assert (m & lit).sum() >= 0.99 * lit.sum() and not (m & ~lit).any()
        # the simulator's ideal code frames put stripe j on [j, j + 1): within one projector pixel
        assert (np.abs(d.projector_coordinate(direction)[m] - true[m]) < 1.0).mean() >= 0.99


def test_phase_pixels_with_clipped_samples_are_kept_where_the_bias_is_within_noise(tiny):
    p, noisy = tiny
    ps = sets.psp_with_gray_code(16, 9, "v", width=p.rig.projector.width, height=p.rig.projector.height)
    frames, truth = render(make_scene("sphere", p), p.rig, ps, noisy.replace(gain=2.0), progress=False)
    lit = truth.mask
    clipped = (frames[:9] >= 255).any(axis=0)
    assert clipped[lit].mean() > 0.8                                   # most lit pixels have a clipped sample
    d = decode(frames, ps)
    m = d.mask["v"]
    assert (m & lit).sum() >= 0.9 * lit.sum()
    err = d.projector_coordinate("v") - truth.up
    rms_clipped = np.sqrt(np.mean(err[m & clipped] ** 2))
    reference, _ = render(make_scene("sphere", p), p.rig, ps, noisy, progress=False)  # gain 1: nothing clips
    ref = decode(reference, ps)
    rms_ref = np.sqrt(np.nanmean((ref.projector_coordinate("v") - truth.up)[ref.mask["v"]] ** 2))
    assert rms_clipped <= 1.2 * rms_ref, (rms_clipped, rms_ref)       # the kept clipped pixels are not biased
    info = d.info["quality"]["v"]["saturation"]["v/T16"]
    assert info["clipped"] == pytest.approx(clipped.mean()) and 0 < info["masked"] < 0.05
    flagged = (d.quality["v"] & edges.SATURATED) != 0                # the reason bit, on the pixels masked for it
    assert flagged.mean() == pytest.approx(info["masked"]) and not (flagged & m).any()
    assert d.info["quality"]["v"]["masked"]["saturated"] == flagged.sum()


def test_bounded_three_step_group_masks_off_crest_clipping_against_a_stated_bound():
    shifts = 2 * np.pi * np.arange(3) / 3
    phi = np.linspace(-math.pi, math.pi, 64, endpoint=False)
    true = 150.0 + 120.0 * np.cos(phi[None] + shifts[:, None])
    frames = np.minimum(true, 255.0)[:, None, :].astype(np.float32)
    r = clipping_mask(frames, range(3), shifts, 255.0, noise=1.0, max_bias=0.05)
    actual = np.abs(_true_offset(phi, np.minimum(true, 255.0), shifts))
    # every pixel whose true bias exceeds the bound is masked; an unclipped one never is
    assert r.broken[0][actual > 0.05].all() and not r.broken[0][~r.clipped[0]].any()


def test_simulate_gain_overexposes_the_capture(tmp_path):
    assert main(["simulate", "-o", str(tmp_path / "cap"), "--preset", "tiny", "--scene", "plane",
                 "--set", "phase-shift", "--gain", "3", "-q"]) == 0
    frames = read_capture(tmp_path / "cap").frames
    assert (frames == 255).mean() > 0.2
    assert main(["simulate", "-o", str(tmp_path / "bad"), "--gain", "-1", "-q"]) == 2


def test_sub_stripe_crossing_is_interpolated_across_a_run_of_pixels_clipped_in_both_frames():
    from fringe3d.unwrap.sub_stripe import sub_stripe_coordinate
    T, gain, level = 4.0, 6.0, 1.0
    x = np.arange(60, dtype=float)
    w_true = 0.35 * x + 0.9                          # projector coordinate along the camera row
    centre = np.floor((w_true + 0.5) / T) * T + (T - 1) / 2
    # one bit, on in even stripes: the projected value P is the stripe value averaged over one
    # projector px (a linear ramp across each edge); code and inverse overexposed 6x clip
    u = w_true[:, None] + np.linspace(-0.5, 0.5, 2001)[None, :]
    pattern = (np.floor((u + 0.5) / T) % 2 == 0).mean(axis=1)
    diff = np.minimum(gain * pattern, level) - np.minimum(gain * (1 - pattern), level)
    plateau = (gain * pattern >= level) & (gain * (1 - pattern) >= level)
    assert plateau.sum() >= 5
    c = np.tile(np.where(plateau, np.nan, centre), (3, 1))
    d = np.tile(diff, (3, 1))[None].astype(np.float32)
    w, refined = sub_stripe_coordinate(c, d, T, plateau=np.tile(plateau, (3, 1)))
    inner = refined[1] & (x > 8) & (x < 52) & ~plateau
    assert inner.sum() > 25
    np.testing.assert_allclose(w[1][inner], w_true[inner], atol=0.1)
    w_without, _ = sub_stripe_coordinate(c, d, T)   # without the plateau the crossings are lost
    assert np.abs(w_without[1][inner] - w_true[inner]).max() > 0.3


def test_sub_stripe_coordinate_stays_accurate_when_both_frames_of_a_pair_clip(tiny):
    p, noisy = tiny
    ps = _gray_set(p, True)
    rms = {}
    for gain in (1.0, 5.0):
        frames, truth = render(make_scene("sphere", p), p.rig, ps, noisy.replace(gain=gain), progress=False)
        d = decode(frames, ps)
        m = d.mask["v"]
        err = d.projector_coordinate("v")[m] - truth.up[m]
        rms[gain] = np.sqrt(np.mean(err[np.abs(err) <= 4] ** 2))
        if gain > 1:
            both = d.info["quality"]["v"]["saturation"]["code"]["masked"]
            assert 0 < both < 0.08                        # stripe-edge pixels clipped in both frames
            assert truth.mask.mean() - m.mean() <= both + 0.01
    assert rms[5.0] <= 1.2 * rms[1.0], rms


@pytest.mark.parametrize("shifts", [2 * np.pi * np.arange(n) / n for n in (3, 4, 6, 9)]
                         + [np.array([0.0, 0.5, 1.3, 2.9, 4.0])], ids=["3", "4", "6", "9", "uneven-5"])
def test_clipping_kernel_equals_the_numpy_reference(shifts):
    from clipping_reference import clipping_bias_reference
    rng = np.random.default_rng(2)
    m = 4000
    a, b = rng.uniform(80, 220, m), rng.uniform(20, 200, m)
    phi = rng.uniform(-np.pi, np.pi, m)
    samples = np.round(np.minimum(a + b * np.cos(phi[None] + shifts[:, None]) + rng.normal(0, 2, (shifts.size, m)),
                                  255.0))
    got, want = clipping_bias(samples, shifts, 255.0), clipping_bias_reference(samples, shifts, 255.0)
    assert (samples >= 255).any(axis=0).mean() > 0.3
    np.testing.assert_array_equal(got.estimated, want.estimated)
    np.testing.assert_allclose(got.bias, want.bias, atol=1e-9)
    np.testing.assert_allclose(got.modulation, want.modulation, rtol=1e-9)
