"""Decoding methods of the temporal plans: ``none``, ``hierarchical``, ``heterodyne``,
``gray_code`` / ``binary_code`` (the array algorithms are :mod:`fringe3d.unwrap.temporal`).

Each returns, besides the absolute phase, the pixels whose two fringe-order estimates disagree
(``Unwrapped.order_inconsistent``, quality bit ``ORDER``): multi-frequency, a rounding residual
above ``max_residual`` rad (:attr:`fringe3d.decode.DecodeOptions.max_residual`); code + phase,
the unwrapped coordinate more than ``max_code_residual`` periods outside the codeword's stripe.
"""
from __future__ import annotations

import math

import numpy as np

from fringe3d.decode._fused_assess import three_frequency_assess
from fringe3d.decode.code_threshold import code_reference
from fringe3d.decode.context import DecodeContext, clipping_broken, combined_mask
from fringe3d.decode.result import Unwrapped
from fringe3d.patterns.conventions import point_at_fringe_coordinate, w_range
from fringe3d.patterns.render import sinusoid_value
from fringe3d.phase import quality
from fringe3d.unwrap.sub_stripe import sub_stripe_coordinate
from fringe3d.unwrap.temporal import (CodeStripes, code_stripes, gray_code_order, heterodyne, hierarchical,
                                      three_frequency_decode)


def unwrap_none(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="none"``: the wrapped phase of the narrowest group, returned as is (NaN
    outside its mask)."""
    g = ctx.groups_for_plan()[0]
    mask, phase = ctx.valid_group_phase(g)
    return Unwrapped(phase, mask, phase_is_masked=True)


def unwrap_hierarchical(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="hierarchical"``: :func:`fringe3d.unwrap.temporal.hierarchical` (Eq. 1.5)."""
    groups = ctx.groups_for_plan()
    phases = [ctx.group_phase(g).phase for g in groups]
    res = hierarchical(phases, [g.period for g in groups], w_range=ctx.w_range())
    return Unwrapped(res.phase, combined_mask(ctx, groups), order_inconsistent=_beyond(ctx, res.residual))


def _beyond(ctx: DecodeContext, residual: np.ndarray | None) -> np.ndarray | None:
    """Multi-frequency pixels whose rounding residual (periods) exceeds ``max_residual`` (rad)."""
    return None if residual is None else residual > float(ctx.options.max_residual) / (2.0 * math.pi)


def unwrap_heterodyne(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="heterodyne"``: three phase-shifted groups take the fused single-pass kernel
    (:func:`fringe3d.unwrap.temporal.three_frequency_decode`, option ``fused``), otherwise
    :func:`fringe3d.unwrap.temporal.heterodyne` on the groups' wrapped phases. Clipped pixels
    are masked where clipping biases a group's phase beyond its noise
    (:func:`fringe3d.decode.context.clipping_broken`)."""
    groups = ctx.groups_for_plan()
    if len(groups) == 3 and all(len(g.indices) >= 3 for g in groups) and ctx.options.fused \
            and ctx.options.compensate is None:
        level = quality.saturation_level(ctx.frames, ctx.bit_depth)
        if ctx.options.backend == "cpu":  # the assessment's inputs from the same pass
            r = _fused_with_assessment(ctx, groups, level)
        else:
            r = three_frequency_decode(ctx.frames, [g.indices for g in groups], [g.shifts for g in groups],
                                       [g.period for g in groups], w_range=ctx.w_range(),
                                       min_modulation=ctx.min_modulation, saturation_level=np.inf,
                                       max_residual=float(ctx.options.max_residual), backend=ctx.options.backend)
        mask, phase = r.mask, r.phase
        if np.isfinite(level):
            broken = []
            for i, g in enumerate(groups):  # the coarser groups only choose fringe orders
                b = clipping_broken(ctx, g, order_only=i > 0)
                # a group whose saturation record counts no clipped pixel has an empty map: not read
                if ctx.cache.get(("saturation", g.name), {}).get("clipped") != 0 and b.any():
                    broken.append(b)
            if broken:  # else mask and phase stand as they are
                mask = mask & ~np.logical_or.reduce(broken)
                phase = np.where(mask, phase, np.float32(np.nan)).astype(np.float32, copy=False)
        return Unwrapped(phase, mask, wrapped=r.wrapped, modulation=r.modulation, average=r.average,
                         texture=r.texture, phase_is_masked=True)
    phases = [ctx.group_phase(g).phase for g in groups]
    res = heterodyne(phases, [g.period for g in groups], w_range=ctx.w_range())
    return Unwrapped(res.phase, combined_mask(ctx, groups), order_inconsistent=_beyond(ctx, res.residual))


def _fused_with_assessment(ctx: DecodeContext, groups: list, level: float):
    """:func:`three_frequency_decode` of the three groups (saturation ignored) by the one pass
    of :func:`fringe3d.decode._fused_assess.three_frequency_assess`, its assessment maps left in
    ``ctx.cache`` for :func:`fringe3d.decode.context.clipping_broken` (``("clipped", group)`` and
    its pixel count ``("clipped_count", group)``),
    :func:`fringe3d.decode.assess.assess` (``("fit_variance", group)``, ``("modulation",
    group)``, ``("disagreement", coarser groups)``, ``("coordinate", period)``: the fringe
    coordinate of the absolute phase, NaN outside the pass's mask and finite on it)."""
    a = three_frequency_assess(ctx.frames, [g.indices for g in groups], [g.shifts for g in groups],
                               [g.period for g in groups], ctx.w_range(),
                               (ctx.min_modulation, float(ctx.options.max_residual), level))
    for g, clipped, count in zip(groups, a.clipped, a.clip_counts):
        ctx.cache[("clipped", g.name)] = clipped
        ctx.cache[("clipped_count", g.name)] = count
    if a.variance is not None:
        ctx.cache[("fit_variance", groups[0].name)] = a.variance
    ctx.cache[("modulation", groups[2].name)] = a.modulation3
    ctx.cache[("disagreement", groups[1].name, groups[2].name)] = a.residual
    if a.finite:  # finite on the mask: the quality map needs no NaN test of its own
        ctx.cache[("coordinate", float(groups[0].period))] = a.coordinate
    return a.decoded


def code_frames(ctx: DecodeContext) -> tuple[list[int], list[int] | None]:
    """Frame indices of this direction's code bits (most significant first) and of their
    inverse frames (None without inverses); ``ValueError`` for an incomplete code."""
    ps = ctx.patterns
    code = [i for i, f in enumerate(ps.frames)
            if f.direction == ctx.direction and f.role == "code" and f.kind in ("gray_code", "binary_code")]
    direct = sorted((i for i in code if not ps.frames[i].inverse), key=lambda i: ps.frames[i].bit)
    inverse = {ps.frames[i].bit: i for i in code if ps.frames[i].inverse}
    if not direct:
        raise ValueError(f"direction {ctx.direction!r} uses method {ctx.plan.method!r} but the manifest has no "
                         "code frames (role 'code', kind 'gray_code' or 'binary_code') for it")
    bits = [ps.frames[i].bit for i in direct]
    if len(set(bits)) != len(bits):
        raise ValueError(f"direction {ctx.direction!r}: code bits repeat {bits}; expected each bit once")
    if inverse and any(b not in inverse for b in bits):
        raise ValueError(f"direction {ctx.direction!r}: inverse code frames cover bits {sorted(inverse)} but the "
                         f"code has bits {bits}; expected an inverse for every bit or none")
    inv = [inverse[b] for b in bits] if inverse else None
    return direct, inv


def projector_code_stripes(ctx: DecodeContext, direct: list[int]) -> CodeStripes:
    """Codeword -> stripe table (:func:`fringe3d.unwrap.temporal.code_stripes`), from the projected
    code itself: the code frames are evaluated (:func:`fringe3d.patterns.render.sinusoid_value`)
    along the fringe coordinate ``w`` over the projector's range, every 1/16 px; cached in the
    context."""
    key = ("code_stripes", ctx.direction)
    if key not in ctx.cache:
        ps = ctx.patterns
        lo, hi = w_range(ctx.plan.angle, ps.width, ps.height)
        step = 1.0 / 16.0
        w = np.arange(lo - 0.5, hi + 0.5, step) + 0.5 * step
        u, v = point_at_fringe_coordinate(w, ctx.plan.angle)
        images = np.stack([sinusoid_value(ps.frames[i], u, v, ps.width, ps.height) for i in direct])
        ctx.cache[key] = code_stripes(images, w)
    return ctx.cache[key]


def wide_stripe_coordinate(ctx: DecodeContext, direct: list[int], inverse: list[int] | None,
                           threshold: np.ndarray | None, stripes: CodeStripes, period: float) -> np.ndarray | None:
    """The code's sub-stripe projector coordinate (px, NaN where not found) when the code's stripes
    are wider than the fringe ``period`` (the codeword alone then leaves the order open), else None
    (:func:`fringe3d.unwrap.sub_stripe.sub_stripe_coordinate`)."""
    width = float(np.nanmedian(stripes.upper - stripes.lower))
    if not width > period * (1.0 + 1e-9):
        return None
    code = ctx.frames[direct].astype(np.float32)
    ref = ctx.frames[inverse].astype(np.float32) if inverse is not None else np.asarray(threshold, np.float32)
    diff = code - ref
    word = np.zeros(diff.shape[1:], np.int64)
    for plane in diff:
        word = word * 2 + (plane > 0)
    w, refined = sub_stripe_coordinate(stripes.centre[word], diff, width)
    return np.where(refined, w, np.nan)


def unwrap_gray_code(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="gray_code"`` or ``"binary_code"``: the fringe order from the code frames,
    thresholded by their inverses, the white/black frames, the phase average or a fixed level
    (:func:`fringe3d.decode.code_threshold.code_reference`), and the wrapped phase together
    (:func:`fringe3d.unwrap.temporal.gray_code_order`); pixels more than ``max_code_residual``
    periods outside their codeword's stripe are ``order_inconsistent``."""
    groups = ctx.groups_for_plan()
    g = groups[0]
    pr = ctx.group_phase(g)
    direct, inv = code_frames(ctx)
    inv, threshold = code_reference(ctx, inv, pr.average)
    stripes = projector_code_stripes(ctx, direct)
    coordinate = wide_stripe_coordinate(ctx, direct, inv, threshold, stripes, g.period)
    # a clear bit's |D| where code and fringes share the projector's range: 2 B with inverses, B without
    contrast = 2.0 * pr.modulation if inv is not None else pr.modulation
    res = gray_code_order(ctx.frames, direct, pr.phase, g.period, stripes, inverse_index=inv, threshold=threshold,
                          coordinate=coordinate, contrast=contrast)
    assert res.residual is not None
    limit = float(ctx.options.max_code_residual)
    return Unwrapped(res.phase, combined_mask(ctx, groups) & res.valid, order_inconsistent=res.residual > limit)
