"""The manifest-driven decoder on closed-form synthetic captures (truth: the projector
coordinate each camera pixel sees)."""
import math
from dataclasses import replace

import numpy as np
import pytest
import tifffile

from fringe3d.decode import DecodeOptions, Decoded, Unwrapped, decode, decode_sequence
from fringe3d.patterns import sets
from fringe3d.patterns.render import sinusoid_value
from fringe3d.phase.quality import FrameQualityWarning
from fringe3d.decode import edges, methods

H, W = 96, 128
A, B = 110.0, 80.0


def projector_coords(shift=0.0):
    """(u_p, v_p) seen by each camera pixel: an affine map over most of an 800x600 projector."""
    v, u = np.mgrid[0:H, 0:W].astype(np.float64)
    return 7.3 + 5.85 * u + 0.4 * v + shift, 9.1 + 6.1 * v - 0.3 * u


def synthesize(ps, sigma=0.0, seed=0, dtype=np.uint8, shift=0.0):
    """Camera frames: phase frames from the closed form A + B cos(2 pi w / T + delta); code and
    white frames from the projected pattern value at the pixel's projector coordinate."""
    rng = np.random.default_rng(seed)
    up, vp = projector_coords(shift)
    out = []
    for f in ps.frames:
        if f.role == "phase":
            w = vp * math.cos(f.angle) + up * math.sin(f.angle)
            img = A + B * np.cos(2 * np.pi * w / f.period + f.shift)
        else:
            img = A - B + 2 * B * sinusoid_value(f, np.rint(up), np.rint(vp), ps.width, ps.height)
        out.append(img + (rng.normal(0, sigma, img.shape) if sigma else 0.0))
    fr = np.stack(out)
    return np.clip(np.round(fr), 0, 255).astype(np.uint8) if dtype == np.uint8 else fr.astype(dtype)


def true_phase(ps, direction, shift=0.0):
    plan = ps.plan(direction)
    up, vp = projector_coords(shift)
    w = vp * math.cos(plan.angle) + up * math.sin(plan.angle)
    return 2 * np.pi * w / plan.periods[0]


def order_errors(phase, truth):
    return np.round((phase - truth) / (2 * np.pi))


@pytest.mark.parametrize("fused", [True, False])
def test_three_frequency_set_decodes_exact_absolute_phase(fused):
    ps = sets.three_frequency("v")
    # float32 frames (the dtype float captures come in): exact to 1e-5 grey levels, and no float64
    # specialisation of the fused kernel to compile for this one test
    d = decode(synthesize(ps, dtype=np.float32), ps, options=DecodeOptions(fused=fused, bit_depth=8))
    truth = true_phase(ps, "v")
    assert d.mask["v"].all()
    assert np.abs(d.phase["v"] - truth).max() < 1e-4   # float32 output, phase up to 280 rad
    assert d.period["v"] == 18.0 and d.method["v"] == "heterodyne"
    assert np.allclose(d.modulation["v"], B, atol=1e-3) and np.allclose(d.average, A, atol=1e-3)
    # no white frame: texture = A + B as a fraction of full scale (255 for 8 bits)
    assert np.allclose(d.texture, (A + B) / 255, atol=1e-5)


def test_calibration_set_both_directions_uint8_with_noise_exact_orders():
    ps = sets.calibration()
    frames = synthesize(ps, sigma=3.0, seed=1)
    d = decode(frames, ps)
    up, vp = projector_coords()
    # the closed-form frames carry fringes beyond the projector (v_p < 0 in the top-right
    # corner), which no projector lights: exactly those and the edge band along every border
    # (both coordinates decoded) are masked in both directions
    margin = max(d.info["quality"][k]["edge_margin"] for k in ("v", "h"))
    band = edges.border_band(up, vp, ps.width, ps.height, margin)
    inner = edges.border_band(up, vp, ps.width, ps.height, margin - 0.1)  # decoded w carries noise
    for direction in ("v", "h"):
        assert not (~d.mask[direction] & ~band).any() and not (inner & d.mask[direction]).any()
        assert not order_errors(d.phase[direction], true_phase(ps, direction))[d.mask[direction]].any()
    off = decode(frames, ps, options=DecodeOptions(edge_mask=False))  # the method's own mask only
    assert off.mask["h"].all() and not order_errors(off.phase["h"], true_phase(ps, "h")).any()
    white = ps.indices(kind="white")[0]
    assert np.allclose(d.texture, frames[white] / 255.0, atol=1e-7)  # a fraction of full scale


def test_hierarchical_set_exact_orders_with_noise():
    ps = sets.hierarchical((16, 128, 1024), (4, 4, 4), "h")
    d = decode(synthesize(ps, sigma=3.0, seed=2), ps)
    vp = projector_coords()[1]  # v_p < 0 in the top-right corner: off the projector, masked as edge
    margin = d.info["quality"]["h"]["edge_margin"]
    assert not (d.mask["h"] & (vp < -0.6 + margin)).any()
    assert d.mask["h"][vp > -0.4 + margin].all()
    assert not order_errors(d.phase["h"], true_phase(ps, "h"))[d.mask["h"]].any()


def test_phase_plus_half_period_gray_code_exact_orders_with_noise():
    ps = sets.psp_with_gray_code(16, steps=4, direction="v", code=sets.CodeFrames(period=8))
    d = decode(synthesize(ps, sigma=3.0, seed=3), ps)
    assert d.mask["v"].all()
    assert not order_errors(d.phase["v"], true_phase(ps, "v"))[d.mask["v"]].any()


@pytest.mark.parametrize("builder", [sets.ftp, sets.modified_ftp])
def test_ftp_sets_give_wrapped_phase(builder):
    ps = builder(20.0, "v")
    d = decode(synthesize(ps, dtype=np.float64), ps)
    truth = true_phase(ps, "v")
    err = np.angle(np.exp(1j * (d.wrapped["v"] - truth)))[32:-32, 32:-32]
    assert np.abs(err).max() < 0.02


def test_wrong_frame_count_names_both_numbers():
    ps = sets.three_frequency("v")
    frames = synthesize(ps)
    with pytest.raises(ValueError, match=r"got 14 frames.*lists 15 frames"):
        decode(frames[:14], ps)
    with pytest.raises(ValueError, match="decode_sequence"):
        decode(np.concatenate([frames, frames]), ps)


def test_frames_of_different_shapes_are_rejected():
    ps = sets.phase_shift(16, 3, "v")
    frames = [np.zeros((H, W), np.uint8), np.zeros((H, W), np.uint8), np.zeros((H, W + 1), np.uint8)]
    with pytest.raises(ValueError, match="different shapes"):
        decode(frames, ps)


def test_group_with_missing_step_is_rejected():
    ps = sets.three_frequency("v")
    broken = replace(ps, frames=ps.frames[:4] + ps.frames[5:])
    with pytest.raises(ValueError, match=r"declares 9 steps.*missing \[4\]"):
        decode(synthesize(broken), broken)


def test_all_dark_frames_warn_and_mask_everything():
    ps = sets.three_frequency("v")
    frames = np.full((15, H, W), 2, np.uint8)
    with pytest.warns(FrameQualityWarning, match="all frames are dark"):
        d = decode(frames, ps)
    assert not d.mask["v"].any() and np.isnan(d.phase["v"]).all()
    assert d.info["frame_checks"]["dark"] == list(range(15))


def test_saturated_frames_warn_and_saturated_pixels_are_masked():
    ps = sets.three_frequency("v")
    frames = synthesize(ps)
    frames[3, :, : W // 2] = 255
    with pytest.warns(FrameQualityWarning, match="saturated"):
        d = decode(frames, ps)
    assert not d.mask["v"][:, : W // 2].any()
    assert d.mask["v"][:, W // 2 + 1:].all()
    assert (d.quality["v"][:, W // 2] == edges.RIM).all()  # the one-pixel rim next to the saturated half


def test_unknown_method_error_names_method_and_known_ones(monkeypatch):
    ps = sets.three_frequency("v")
    monkeypatch.delitem(methods.METHODS, "heterodyne")
    with pytest.raises(ValueError, match=r"'heterodyne'.*known methods: \[.*'hierarchical'"):
        decode(synthesize(ps), ps)


def test_method_in_the_table_is_called_with_context(monkeypatch):
    ps = sets.ftp(20.0, "v", method="spatial")
    seen = {}

    def fake(ctx):
        seen["ctx"] = ctx
        g = ctx.groups_for_plan()[0]
        return Unwrapped(ctx.group_phase(g).phase + 2 * np.pi, ctx.group_mask(g))

    monkeypatch.setitem(methods.METHODS, "spatial", fake)
    d = decode(synthesize(ps, dtype=np.float64), ps, options=DecodeOptions(z_min=300.0, extra={"my_option": 5}))
    ctx = seen["ctx"]
    assert ctx.direction == "v" and ctx.z_min == 300.0 and ctx.options.extra["my_option"] == 5
    assert np.allclose(d.phase["v"] - d.wrapped["v"], 2 * np.pi, atol=1e-5)


def test_save_writes_npz_and_float32_tiffs_that_load_back(tmp_path):
    ps = sets.calibration()
    d = decode(synthesize(ps, sigma=2.0), ps)
    out = d.save(tmp_path / "dec")
    back = Decoded.load(out)
    for direction in ("v", "h"):
        assert np.array_equal(back.phase[direction], d.phase[direction], equal_nan=True)
        assert np.array_equal(back.mask[direction], d.mask[direction])
        tif = tifffile.imread(out / f"phase_{direction}.tif")
        assert tif.dtype == np.float32 and np.array_equal(tif, d.phase[direction], equal_nan=True)
    assert back.period == d.period and back.angle == d.angle
    assert not list(out.glob("*.part*"))
    assert (out / "decoded.json").exists()


def test_decode_sequence_yields_one_result_per_cycle():
    ps = sets.three_frequency("v")
    cycles = [synthesize(ps, shift=s, seed=s) for s in (0, 5, 10)]
    frames = np.concatenate(cycles)
    results = list(decode_sequence(frames, ps))
    assert len(results) == 3
    for s, d in zip((0, 5, 10), results):
        m = d.mask["v"]
        assert not order_errors(d.phase["v"], true_phase(ps, "v", shift=s))[m].any()
        # shifted by 10 px the view reaches the projector's right border: only that band is masked
        margin = d.info["quality"]["v"]["edge_margin"]
        assert (projector_coords(s)[0][~m] > ps.width - 0.5 - margin - 0.1).all()
    with pytest.raises(ValueError, match="not a whole number of cycles"):
        list(decode_sequence(frames[:-1], ps))


@pytest.mark.parametrize("angle", [0.7, 2.4])
def test_oblique_fringe_angle_decodes_exact_orders_including_negative_w(angle):
    """Angles above pi/2 give negative fringe coordinates; the absolute window still covers them."""
    ps = sets.three_frequency("a1", angle=angle)   # 800 x 600: fringe span < 1008 px
    d = decode(synthesize(ps, sigma=3.0, seed=4), ps)
    truth = true_phase(ps, "a1")
    if angle > math.pi / 2:
        assert truth.min() < 0
    assert d.mask["a1"].all()
    assert not order_errors(d.phase["a1"], truth).any()


def test_max_residual_option_masks_exactly_the_pixels_with_large_unwrapping_residuals():
    """Heavy noise (sigma 25 grey levels, B = 80): the default residual check (pi/2) masks pixels
    that ``max_residual=pi`` (no check) keeps, and most order errors are among them."""
    ps = sets.three_frequency("v")
    frames = synthesize(ps, sigma=25.0, seed=3, dtype=np.float32)
    truth = true_phase(ps, "v")
    # the fused kernel's residual check alone: the decoder's edge/mixed-pixel tests are off
    strict = decode(frames, ps, options=DecodeOptions(min_modulation=1.0, edge_mask=False))
    loose = decode(frames, ps, options=DecodeOptions(min_modulation=1.0, max_residual=math.pi, edge_mask=False))
    wrong_loose = loose.mask["v"] & (order_errors(loose.phase["v"], truth) != 0)
    wrong_strict = strict.mask["v"] & (order_errors(strict.phase["v"], truth) != 0)
    assert loose.mask["v"].all()          # only the residual check can mask here
    assert not (strict.mask["v"] & ~loose.mask["v"]).any()
    assert wrong_loose.sum() > 20 and wrong_strict.sum() < 0.5 * wrong_loose.sum()
    kept = strict.mask["v"]
    assert np.array_equal(strict.phase["v"][kept], loose.phase["v"][kept])


def test_phase_groups_are_read_once_per_set_and_still_checked_every_call():
    """The decoder reads a set's phase groups once (kept with the set while it lives): the same
    groups as the manifest's for each direction, a fresh list per call, a set made by
    ``replace`` read anew, and a broken set rejected on every call."""
    import gc

    from fringe3d.decode.context import _GROUPS, _read_phase_groups, phase_groups
    ps = sets.calibration(800, 600)
    for d in ("v", "h"):
        first = phase_groups(ps, d)
        assert first == _read_phase_groups(ps, d) and [g.period for g in first] == [18.0, 21.0, 144.0]
        first.clear()
        assert phase_groups(ps, d) == _read_phase_groups(ps, d)
    other = replace(ps, frames=tuple(replace(f, period=2 * f.period) if f.role == "phase" else f for f in ps.frames))
    assert [g.period for g in phase_groups(other, "v")] == [36.0, 42.0, 288.0]
    broken = replace(ps, frames=ps.frames[:5] + ps.frames[6:])
    for _ in range(2):
        with pytest.raises(ValueError, match=r"declares 9 steps.*missing \[4\]"):
            phase_groups(broken, "v")
    key = id(other)
    del other
    gc.collect()
    assert key not in _GROUPS or _GROUPS[key][0]() is not None
