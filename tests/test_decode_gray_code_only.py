"""Gray-code-only captures decode to projector columns and rows (issue 13, item 2).

Truth: the simulator's projector coordinates and shadow mask (``sim.truth``), and OpenCV's
documented ``GrayCodePattern`` layout transcribed below (opencv-contrib is not installed:
the layout is checked against frames rendered by this NumPy transcription of
``GrayCodePattern_Impl::generate``).
"""
from __future__ import annotations

import dataclasses
import json

import numpy as np
import pytest

from fringe3d.cli import main
from fringe3d.decode import METHODS, DecodeOptions, decode, with_method
from fringe3d.io.capture import read_capture, write_capture
from fringe3d.pipeline import reconstruct_capture
from fringe3d.patterns import render_set, sets
from fringe3d.patterns.layouts import opencv_graycode
from fringe3d.patterns.manifest import FrameSpec, PatternSet
from fringe3d.patterns.synthetic import frames_from_coordinates
from fringe3d.sim import presets
from fringe3d.sim.render import render
from fringe3d.sim.simulate import make_scene, simulate_capture
from fringe3d.sim.truth import Truth

STRIPE = 8.0


def gray_sets(width: int, height: int, inverse: bool, white_black: bool = True, stripe: float = STRIPE):
    ps = sets.gray_code(stripe, "v", width=width, height=height, inverse=inverse).concat(
        sets.gray_code(stripe, "h", width=width, height=height, inverse=inverse))
    if white_black:
        ps = dataclasses.replace(ps, frames=ps.frames + (FrameSpec(kind="white", role="texture"),
                                                         FrameSpec(kind="black", role="reference")))
    return ps


@pytest.fixture(scope="module")
def tiny_noisy():
    """The tiny rig with the well-designed preset's default sensor noise (read + shot)."""
    p = presets.get("tiny")
    ref = presets.get("well-designed").settings
    return p, p.settings.replace(read_noise=ref.read_noise, shot_noise=ref.shot_noise, seed=3)


def stripe_index(w: np.ndarray, stripe: float = STRIPE) -> np.ndarray:
    """Stripe of projector coordinate ``w`` (pixel centres at integers, stripe c covers
    pixels c*T .. c*T + T - 1)."""
    return np.floor((w + 0.5) / stripe)


@pytest.mark.parametrize(("stripe", "inverse", "exact"), [
    (8.0, True, 0.999), (8.0, False, 0.999), (4.0, True, 0.999),
    # at T = 4 without inverses no decision from a pixel's own frames reaches 99.9 % while masking
    # at most 1 point more than the shadow: keeping every edge pixel gives at best 99.59-99.63 %
    # (scripts/gray_code_only_accuracy.py, "bound"); edge_thr 3 gives 99.85-99.86 % at 0.9 point
    (4.0, False, 0.998)], ids=["T8-inverses", "T8-white-black-only", "T4-inverses", "T4-white-black-only"])
def test_gray_code_only_capture_decodes_the_true_stripe_and_masks_only_the_shadow(tiny_noisy, stripe, inverse,
                                                                                   exact):
    p, settings = tiny_noisy
    ps = gray_sets(p.rig.projector.width, p.rig.projector.height, inverse, stripe=stripe)
    frames, truth = render(make_scene("textured-spheres", p), p.rig, ps, settings, progress=False)
    d = decode(frames, ps)
    for direction, true_w in (("v", truth.up), ("h", truth.vp)):
        mask = d.mask[direction]
        assert not (mask & ~truth.mask).any()  # nothing shadowed or off the projector is kept
        masked, shadow = 1 - mask.mean(), 1 - truth.mask.mean()
        assert abs(masked - shadow) <= 0.01, (masked, shadow)  # stripe-edge pixels are decided too
        # the stripe containing the true projector coordinate at the pixel centre
        same = stripe_index(d.projector_coordinate(direction)[mask], stripe) == stripe_index(true_w[mask], stripe)
        assert same.mean() >= exact, same.mean()
        assert d.period[direction] == stripe and d.method[direction] == "gray_code"


def test_keeping_every_edge_pixel_masks_less_but_decodes_more_wrong_stripes(tiny_noisy):
    p, settings = tiny_noisy
    ps = gray_sets(p.rig.projector.width, p.rig.projector.height, True, stripe=4.0)
    frames, truth = render(make_scene("textured-spheres", p), p.rig, ps, settings, progress=False)
    wrong, kept = {}, {}
    for thr in (0.0, None):
        d = decode(frames, ps, options=DecodeOptions(edge_thr=thr))
        m = d.mask["v"]
        wrong[thr] = (stripe_index(d.projector_coordinate("v")[m], 4.0) != stripe_index(truth.up[m], 4.0)).sum()
        kept[thr] = m.sum()
    assert kept[0.0] > kept[None] and wrong[0.0] > 2 * wrong[None]


@pytest.mark.parametrize("inverse", [True, False], ids=["inverses", "white-black-only"])
def test_sub_stripe_coordinate_is_several_times_closer_to_the_truth_than_the_stripe_centre(tiny_noisy, inverse):
    p, settings = tiny_noisy
    ps = gray_sets(p.rig.projector.width, p.rig.projector.height, inverse)
    frames, truth = render(make_scene("sphere", p), p.rig, ps, settings, progress=False)
    rms = {}
    for sub in (False, True):
        d = decode(frames, ps, options=DecodeOptions(sub_stripe=sub))
        m = d.mask["v"]
        err = d.projector_coordinate("v")[m] - truth.up[m]
        rms[sub] = np.sqrt(np.mean(err[np.abs(err) <= STRIPE / 2] ** 2))
    assert rms[False] == pytest.approx(STRIPE / np.sqrt(12), rel=0.05)  # uniform within the stripe
    assert rms[True] < rms[False] / 5


def test_sub_stripe_coordinate_of_a_linear_ramp_is_exact():
    from fringe3d.unwrap.sub_stripe import sub_stripe_coordinate
    T = 4.0
    x = np.arange(40, dtype=float)
    w_true = 0.7 * x + 1.3                       # projector coordinate along the camera row
    centre = np.floor((w_true + 0.5) / T) * T + (T - 1) / 2
    s = ((w_true + 0.5) / T) % 2.0               # one bit, flipping at every stripe edge, linear across it
    diff = np.where(s < 1, np.minimum(s, 1 - s), -np.minimum(s - 1, 2 - s))[None]
    w, refined = sub_stripe_coordinate(np.tile(centre, (3, 1)), np.tile(diff[:, None, :], (1, 3, 1)), T)
    inner = refined[1] & (x > 3) & (x < 36)
    assert inner.sum() > 25
    np.testing.assert_allclose(w[1][inner], w_true[inner], atol=1e-9)


def test_opencv_layout_matches_opencvs_documented_generate_order():
    W, H = 40, 20
    ps = opencv_graycode(W, H)
    frames = render_set(ps)
    ncol, nrow = int(np.ceil(np.log2(W))), int(np.ceil(np.log2(H)))
    expect = np.zeros((2 * (ncol + nrow) + 2, H, W), np.uint8)
    for j in range(W):  # transcription of GrayCodePattern_Impl::generate (vertical stripes)
        num, prev = j, j % 2
        for k in range(ncol):
            num //= 2
            rem = num % 2
            flag = int(rem != prev)
            expect[2 * ncol - 2 * k - 2, :, j] = 255 * flag
            expect[2 * ncol - 2 * k - 1, :, j] = 255 * (1 - flag)
            prev = rem
    for i in range(H):  # horizontal stripes
        num, prev = i, i % 2
        for k in range(nrow):
            num //= 2
            rem = num % 2
            flag = int(rem != prev)
            expect[2 * ncol + 2 * nrow - 2 * k - 2, i, :] = 255 * flag
            expect[2 * ncol + 2 * nrow - 2 * k - 1, i, :] = 255 * (1 - flag)
            prev = rem
    expect[-2] = 255  # getImagesForShadowMasks: white, then black
    np.testing.assert_array_equal(frames, expect)


def test_opencv_layout_decodes_to_the_projector_pixel():
    ps = opencv_graycode(64, 48)
    v_p, u_p = np.mgrid[0:24, 10:42].astype(float) + 0.2  # a camera seeing one projector pixel per pixel
    frames = frames_from_coordinates(ps, u_p, 2 * v_p, dtype=np.uint8)
    d = decode(frames, ps)
    assert d.mask["v"].all() and d.mask["h"].all()
    # the stripe index is the projector pixel (float32 phase: 1e-4 px rounding)
    np.testing.assert_allclose(d.projector_coordinate("v"), np.round(u_p), atol=1e-4)
    np.testing.assert_allclose(d.projector_coordinate("h"), np.round(2 * v_p), atol=1e-4)


def test_patterns_gray_code_set_decodes_through_the_cli(tmp_path):
    assert main(["patterns", "--set", "gray-code", "--period", "8", "--width", "64", "--height", "48",
                 "-o", str(tmp_path / "pat"), "--quiet"]) == 0
    ps = PatternSet.load(tmp_path / "pat" / "manifest.json")
    v_p, u_p = np.mgrid[0:16, 3:60].astype(float)
    write_capture(tmp_path / "cap", frames_from_coordinates(ps, u_p, v_p, dtype=np.uint8), ps)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "out"), "--quiet"]) == 0
    w = np.load(tmp_path / "out" / "decoded.npz")
    phase = w[[k for k in w.files if k.startswith("phase")][0]]
    # one camera pixel per projector pixel, sharp binary frames: the stripe edges' zero crossings
    # lie half-way between camera pixels, so the sub-stripe coordinate is the projector pixel itself
    np.testing.assert_allclose(phase * 8 / (2 * np.pi), u_p, atol=1e-4)


def test_decode_method_overrides_the_plan_and_unknown_names_list_the_methods(tmp_path, capsys):
    ps = sets.phase_shift(16, 3, "v", width=256, height=200)
    simulate_capture(tmp_path / "cap", "tiny", "sphere", ps, progress=False)
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "o1"), "--method", "spatial",
                 "--json"]) == 0
    summary = json.loads(capsys.readouterr().out)
    assert summary["results"][0]["directions"]["v"]["method"] == "spatial"
    assert with_method(read_capture(tmp_path / "cap").patterns, "spatial").plans[0].method == "spatial"
    assert main(["decode", str(tmp_path / "cap"), "-o", str(tmp_path / "o2"), "--method", "nope"]) == 2
    err = capsys.readouterr().err
    assert "nope" in err and all(m.replace("_", "-") in err for m in METHODS)


def test_code_thresholds_are_options(tiny_noisy):
    ps = opencv_graycode(32, 16)
    v_p, u_p = np.mgrid[0:8, 0:16].astype(float)
    frames = frames_from_coordinates(ps, u_p, v_p, dtype=np.uint8) // 8 + 10  # contrast 31 counts
    assert not decode(frames, ps).mask["v"].any()                     # below OpenCV's black_thr 40
    assert decode(frames, ps, options=DecodeOptions(black_thr=20)).mask["v"].all()


def test_an_edge_pixels_undecided_bit_must_clear_edge_thr():
    from fringe3d.decode.methods.code_only import decide_edges
    centres = np.array([1.5, 5.5, 13.5, 9.5])        # 2-bit Gray code, T = 4: codewords 00 01 11 10
    # pixel 0: all bits clear 5; pixels 1-3: codeword 01 with the low bit at 1, 3, -3 counts
    # (flip -> codeword 00 or 01, the neighbouring stripe); pixel 4: codeword 10 (stripe 3) with the
    # high bit at 3 (flip -> 00, stripe 0, not adjacent)
    diff = np.array([[-20, -20, -20, -20, 3], [-20, 1, 3, -3, -20]], np.float32)[:, None, :]
    decided, *_ = decide_edges(diff, 5.0, centres, 4.0, edge_margin=2.0)
    assert decided[0].tolist() == [True, False, True, True, False]
    assert decide_edges(diff, 5.0, centres, 4.0)[0][0].tolist() == [True, True, True, True, False]


def test_opencv_gray_code_session_triangulates_unchanged(tmp_path):
    p = presets.get("tiny")
    simulate_capture(tmp_path, "tiny", "plane", opencv_graycode(256, 200), progress=False)
    r = reconstruct_capture(tmp_path, p.rig)
    truth = Truth.load(tmp_path / "truth")
    m = np.isfinite(r.points[..., 2]) & truth.mask
    err = np.linalg.norm(r.points[m] - truth.xyz[m], axis=1)
    footprint = np.nanmedian(truth.depth) / p.rig.projector.K[0, 0]  # mm per projector pixel at the plane
    assert m.mean() > 0.9
    # one-pixel stripes: the stripe centre alone is off by up to half a projector pixel in each
    # coordinate (median 3D error ~1.2 footprints); the sub-stripe coordinate is well inside it
    assert np.median(err) < 0.5 * footprint
