"""The decoder's fused three-frequency pass with its assessment maps
(:mod:`fringe3d.decode._fused_assess`) and its last per-pixel passes
(:mod:`fringe3d.decode._finish_kernels`) equal the separate passes they replace (kept as the
references): the decode outputs and clipping flags bit for bit, the disagreement and the
coarsest modulation (from the decode's float32 sums) to float32 rounding, the blur within
1e-4 px, the float32 fit-residual variance within 1e-4 (phase sigma within 1e-4 or 1e-6 rad),
and a whole ``decode()`` with the same masks, quality bits and texture as the path that
re-reads the frames."""
from __future__ import annotations

import warnings

import numpy as np
import pytest

from fringe3d.decode import DecodeOptions, decode, edges
from fringe3d.decode import _finish_kernels as fk
from fringe3d.decode._fused_assess import three_frequency_assess
from fringe3d.decode.methods import temporal as temporal_method
from fringe3d.decode.texture import as_fraction
from fringe3d.patterns import sets
from fringe3d.patterns.conventions import phase_to_w
from fringe3d.patterns.synthetic import frames_from_coordinates
from fringe3d.phase import noise
from fringe3d.phase.psp import wrapped_phase
from fringe3d.unwrap.temporal import three_frequency_decode

LEVEL = 255.0


@pytest.fixture(scope="module")
def capture():
    """A 48 x 64 three-frequency capture: a depth step, a dark band and clipped crests."""
    ps = sets.three_frequency("v", width=912, height=570)
    v, u = np.mgrid[0:48, 0:64].astype(np.float64)
    u_p = 100 + 1.3 * u + 40 * (u > 32) + 2 * np.sin(v / 7)
    amp = 120 + 60 * np.cos(u / 9)
    amp[:6] = 2
    frames = frames_from_coordinates(ps, u_p, np.full_like(u_p, 300.0), amp + 10, amp + 20, noise=1.5,
                                     rng=np.random.default_rng(2), dtype=np.uint8)
    groups = [ps.indices(group=g) for g in ps.groups("v", "phase")]
    shifts = [[ps.frames[i].shift for i in g] for g in groups]
    plan = ps.plan("v")
    return ps, frames, groups, shifts, plan.periods, tuple(plan.options["w_range"])


def test_fused_assessment_equals_the_separate_passes(capture):
    _, frames, groups, shifts, periods, wr = capture
    a = three_frequency_assess(frames, groups, shifts, periods, wr, (5.0, 0.5 * np.pi, LEVEL))
    ref = three_frequency_decode(frames, groups, shifts, periods, w_range=wr, min_modulation=5.0,
                                 max_residual=0.5 * np.pi)
    for got, want in zip(a.decoded[:5], ref[:5]):
        np.testing.assert_array_equal(got, want)  # the same float32 arithmetic
    # no texture plane: the decode's is average + modulation, which a caller adds
    assert a.decoded.texture is None
    np.testing.assert_array_equal(ref.texture, ref.average + ref.modulation)
    # w of the phase as phase_to_w makes it (one float32 product), NaN off the mask, finite on it
    np.testing.assert_array_equal(a.coordinate, phase_to_w(ref.phase, periods[0]))
    assert a.finite and np.isfinite(a.coordinate[ref.mask]).all()
    for g, idx in enumerate(groups):
        np.testing.assert_array_equal(a.clipped[g], (frames[idx] >= LEVEL).any(axis=0))
    assert a.clipped.any() and not a.clipped.all()
    assert a.clip_counts == tuple(int(np.count_nonzero(c)) for c in a.clipped)
    np.testing.assert_allclose(a.variance, noise.fit_residual_variance(frames, groups[0], shifts[0]),
                               rtol=1e-4, atol=1e-3)  # float32 sums against float64
    # the coarser groups from the decode's float32 sums, against the float64 sums of the separate
    # passes: B_3 within float32 rounding of the sums (a few ulp of the frames' grey levels), the
    # disagreement within 2e-6 rad (the phases' rounding over B >= 5 grey levels)
    coarse = [wrapped_phase(frames, shifts[g], groups[g]) for g in (1, 2)]
    np.testing.assert_allclose(a.modulation3, coarse[1].modulation, rtol=1e-6, atol=2e-5)
    residual = edges.disagreement(ref.phase, periods[0], [c.phase for c in coarse], periods[1:])
    np.testing.assert_allclose(a.residual, residual, rtol=0, atol=2e-6)
    assert (a.residual[~ref.mask] == 0).all()


def test_fused_assessment_of_a_three_step_first_group_has_no_variance(capture):
    _, frames, groups, shifts, periods, wr = capture
    g3 = [groups[0][:3], groups[1], groups[2]]
    s3 = [shifts[0][:3], shifts[1], shifts[2]]
    a = three_frequency_assess(frames, g3, s3, periods, wr, (5.0, 0.5 * np.pi, np.inf))
    assert a.variance is None and not a.clipped.any() and a.clip_counts == (0, 0, 0)


def test_fused_assessment_without_clipping_shares_one_read_only_false_plane(capture):
    # no frame reaches the level: the three groups' flags are False everywhere, and read-only (the
    # plane is kept between calls, so no caller may write into it); the next call's flags reflect
    # its own frames, clipped or not
    _, frames, groups, shifts, periods, wr = capture
    f = np.minimum(frames, LEVEL - 1)
    for _ in range(2):
        a = three_frequency_assess(f, groups, shifts, periods, wr, (5.0, 0.5 * np.pi, LEVEL))
        assert a.clipped.shape == (3,) + f.shape[1:] and a.clip_counts == (0, 0, 0)
        assert not a.clipped.any() and not a.clipped.flags.writeable
        with pytest.raises(ValueError):
            a.clipped[0, 0, 0] = True
    b = three_frequency_assess(frames, groups, shifts, periods, wr, (5.0, 0.5 * np.pi, LEVEL))
    for g, idx in enumerate(groups):
        np.testing.assert_array_equal(b.clipped[g], (frames[idx] >= LEVEL).any(axis=0))
    assert not a.clipped.any()


def test_fused_assessment_counts_each_groups_clipped_pixels(capture):
    # one group clipped in a corner only, the others nowhere: the counts are those of the flags
    # the frames give, and the groups that clip nowhere have empty maps
    _, frames, groups, shifts, periods, wr = capture
    f = np.minimum(frames, LEVEL - 1)
    f[groups[1][2], 3:7, 50:61] = LEVEL
    a = three_frequency_assess(f, groups, shifts, periods, wr, (5.0, 0.5 * np.pi, LEVEL))
    assert a.clip_counts == (0, 4 * 11, 0)
    for g, idx in enumerate(groups):
        want = (f[idx] >= LEVEL).any(axis=0)
        np.testing.assert_array_equal(a.clipped[g], want)
        assert a.clip_counts[g] == np.count_nonzero(want)


def test_fused_assessment_flags_a_valid_pixel_whose_phase_is_not_finite(capture):
    _, frames, groups, shifts, periods, wr = capture
    f = frames.astype(np.float32)
    f[groups[0][0], 10, 20] = np.inf  # the group's sums are inf or NaN there
    f[groups[0][1], 10, 20] = -np.inf
    f[groups[1][0], 30, 40] = np.nan
    a = three_frequency_assess(f, groups, shifts, periods, wr, (5.0, 0.5 * np.pi, np.inf))
    ref = three_frequency_decode(f, groups, shifts, periods, w_range=wr, min_modulation=5.0,
                                 max_residual=0.5 * np.pi)
    np.testing.assert_array_equal(a.decoded.mask, ref.mask)
    np.testing.assert_array_equal(a.coordinate, phase_to_w(ref.phase, periods[0]))
    assert a.finite == bool(np.isfinite(ref.phase[ref.mask]).all())


def _decode_alone(ctx, groups, level):
    """The decode of the three groups without the fused assessment: the assessment (and the
    clipping test) then compute their own inputs from the frames, the path the fused pass replaces."""
    return three_frequency_decode(ctx.frames, [g.indices for g in groups], [g.shifts for g in groups],
                                  [g.period for g in groups], w_range=ctx.w_range(),
                                  min_modulation=ctx.min_modulation, saturation_level=np.inf,
                                  max_residual=float(ctx.options.max_residual))


def test_decode_with_the_fused_assessment_equals_the_path_that_rereads_the_frames(capture, monkeypatch):
    ps, frames, *_ = capture
    opts = DecodeOptions(min_modulation=5.0)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = decode(frames, ps, options=opts)

        monkeypatch.setattr(temporal_method, "_fused_with_assessment", _decode_alone)
        want = decode(frames, ps, options=opts)
    d = "v"
    np.testing.assert_array_equal(got.mask[d], want.mask[d])
    np.testing.assert_array_equal(got.phase[d], want.phase[d])
    np.testing.assert_array_equal(got.quality[d], want.quality[d])
    np.testing.assert_array_equal(got.texture, want.texture)
    # the noise model from the float32 variance: sigma within 1e-4 relative, or 1e-6 rad where the
    # model's c0 + c1 A nearly cancels (a negative c0 on this clipped scene)
    np.testing.assert_allclose(got.phase_sigma[d], want.phase_sigma[d], rtol=1e-4, atol=1e-6)
    qg, qw = got.info["quality"][d], want.info["quality"][d]
    assert qg["masked"] == qw["masked"] and qg["saturation"] == qw["saturation"]
    assert qg["masked"]["saturated"] > 0
    # the blur from B_1 / B_3 with B_3 of float32 sums: the median ratio r within float32 rounding;
    # sigma_b ~ sqrt(-ln r) magnifies that near r = 1 (no blur), hence an absolute bound in px
    np.testing.assert_allclose(qg["blur"], qw["blur"], rtol=0, atol=1e-4)
    assert abs(qg["edge_margin"] - qw["edge_margin"]) <= 2e-4
    np.testing.assert_allclose([qg["noise"]["c0"], qg["noise"]["c1"]], [qw["noise"]["c0"], qw["noise"]["c1"]],
                               rtol=1e-5)


def test_masked_phase_and_texture_fraction_equal_their_numpy_expressions():
    rng = np.random.default_rng(7)
    phase = rng.uniform(-5, 300, (17, 23)).astype(np.float32)
    phase[0, :3] = [np.nan, np.inf, -np.inf]
    mask = rng.random(phase.shape) > 0.2
    q = rng.integers(0, 256, phase.shape).astype(np.uint8)
    m, p = fk.masked_phase(phase, mask)
    want = mask & np.isfinite(phase)
    np.testing.assert_array_equal(m, want)
    np.testing.assert_array_equal(p, np.where(want, phase, np.nan).astype(np.float32))
    for bits in (0xFF, edges.ORDER):
        m, p = fk.masked_phase(phase, want, q, bits)
        keep = want & ((q & bits) == 0)
        np.testing.assert_array_equal(m, keep)
        np.testing.assert_array_equal(p, np.where(keep, phase, np.float32(np.nan)))
    frames = np.zeros((1, 2, 2), np.uint16)
    avg = rng.uniform(-100, 70000, phase.shape).astype(np.float32)
    avg[1, :3] = [np.nan, np.inf, -np.inf]
    mod = rng.uniform(0, 3000, phase.shape).astype(np.float32)
    np.testing.assert_array_equal(fk.texture_fraction(avg, mod, 65535.0),
                                  as_fraction(np.add(avg, mod, dtype=np.float32), frames, None))
    np.testing.assert_array_equal(fk.texture_fraction(avg, None, 65535.0), as_fraction(avg, frames, None))


@pytest.mark.parametrize("clean", [True, False])
def test_a_map_whose_counts_mask_nothing_skips_the_decoders_masking_read(capture, clean, monkeypatch):
    """Where the fused pass's ``w`` is finite on the mask and the map's counts set no bit a mask
    pixel can carry, the assessment says so (``keeps_mask``) and the decoder skips its read of
    the map: the outputs equal those of the decoder that reads it."""
    from fringe3d.decode import decoder

    ps, frames, *_ = capture
    if clean:  # a plain ramp well inside the projector: no bit on any pixel
        v, u = np.mgrid[0:48, 0:64].astype(np.float64)
        frames = frames_from_coordinates(ps, 300 + 1.1 * u, np.full_like(u, 300.0), 60, 120, noise=1.0,
                                         rng=np.random.default_rng(4), dtype=np.uint8)
    seen = []
    real = decoder.assess

    def spy(*args, **kwargs):
        a = real(*args, **kwargs)
        seen.append(a.keeps_mask)
        return a
    monkeypatch.setattr(decoder, "assess", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")  # the clipped crests of the capture
        got = decode(frames, ps)
        monkeypatch.setattr(decoder, "assess", lambda *a, **k: real(*a, **k)._replace(keeps_mask=False))
        want = decode(frames, ps)
    assert seen == [clean]
    for name in ("phase", "mask", "quality", "phase_sigma"):
        np.testing.assert_array_equal(getattr(got, name)["v"], getattr(want, name)["v"])
    if clean:
        assert got.mask["v"].all() and not got.quality["v"].any()


def test_groups_the_fused_pass_counts_unclipped_are_not_tested_again(capture, monkeypatch):
    """A group whose clipping flags the fused pass counted empty takes them as its clipping map:
    the same saturation record, masks and quality bits as the path that tests the frames."""
    from fringe3d.decode import context as decode_context
    ps, frames, *_ = capture
    dim = (frames // 2).astype(np.uint8)  # nothing reaches 255: every group unclipped
    opts = DecodeOptions(min_modulation=5.0)
    seen = []
    real = decode_context.clipping_broken

    def spy(ctx, group, order_only=False):
        out = real(ctx, group, order_only)
        seen.append((ctx.cache.get(("clipped_count", group.name)), out.flags.writeable, bool(out.any())))
        return out
    monkeypatch.setattr(temporal_method, "clipping_broken", spy)
    with warnings.catch_warnings():
        warnings.simplefilter("ignore")
        got = decode(dim, ps, options=opts)

        monkeypatch.setattr(temporal_method, "_fused_with_assessment", _decode_alone)
        want = decode(dim, ps, options=opts)
    # the fused decode's three groups: counted 0, their read-only all-False flags as the map
    assert seen[:3] == [(0, False, False)] * 3
    assert [c for c, *_ in seen[3:]] == [None] * 3  # the other path tests the frames
    d = "v"
    np.testing.assert_array_equal(got.mask[d], want.mask[d])
    np.testing.assert_array_equal(got.quality[d], want.quality[d])
    sat = got.info["quality"][d]["saturation"]
    assert sat == want.info["quality"][d]["saturation"]
    assert all(s["clipped"] == 0.0 and s["masked"] == 0.0 for s in sat.values())
