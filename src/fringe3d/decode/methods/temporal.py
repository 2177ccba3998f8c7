"""Decoding methods of the temporal plans: ``none``, ``hierarchical``, ``heterodyne``,
``gray_code`` / ``binary_code`` (the array algorithms are :mod:`fringe3d.unwrap.temporal`)."""
from __future__ import annotations

import numpy as np

from fringe3d.decode.code_threshold import code_reference
from fringe3d.decode.context import DecodeContext, combined_mask
from fringe3d.decode.result import Unwrapped
from fringe3d.patterns.conventions import point_at_fringe_coordinate, w_range
from fringe3d.patterns.render import sinusoid_value
from fringe3d.phase import quality
from fringe3d.unwrap.temporal import (code_centers, gray_code_order, heterodyne, hierarchical,
                                      three_frequency_decode)


def unwrap_none(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="none"``: the wrapped phase of the narrowest group, returned as is."""
    g = ctx.groups_for_plan()[0]
    return Unwrapped(ctx.group_phase(g).phase.copy(), ctx.group_mask(g))


def unwrap_hierarchical(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="hierarchical"``: :func:`fringe3d.unwrap.temporal.hierarchical` (Eq. 1.5)."""
    groups = ctx.groups_for_plan()
    phases = [ctx.group_phase(g).phase for g in groups]
    res = hierarchical(phases, [g.period for g in groups], w_range=ctx.w_range())
    return Unwrapped(res.phase, combined_mask(ctx, groups))


def unwrap_heterodyne(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="heterodyne"``: three phase-shifted groups take the fused single-pass kernel
    (:func:`fringe3d.unwrap.temporal.three_frequency_decode`, option ``fused``), otherwise
    :func:`fringe3d.unwrap.temporal.heterodyne` on the groups' wrapped phases."""
    groups = ctx.groups_for_plan()
    if len(groups) == 3 and all(len(g.indices) >= 3 for g in groups) and ctx.options.fused:
        r = three_frequency_decode(ctx.frames, [g.indices for g in groups], [g.shifts for g in groups],
                                   [g.period for g in groups], w_range=ctx.w_range(),
                                   min_modulation=ctx.min_modulation,
                                   saturation_level=quality.saturation_level(ctx.frames, ctx.bit_depth),
                                   max_residual=float(ctx.options.max_residual), backend=ctx.options.backend)
        return Unwrapped(r.phase, r.mask, wrapped=r.wrapped, modulation=r.modulation, average=r.average,
                         texture=r.texture, phase_is_masked=True)
    phases = [ctx.group_phase(g).phase for g in groups]
    res = heterodyne(phases, [g.period for g in groups], w_range=ctx.w_range())
    return Unwrapped(res.phase, combined_mask(ctx, groups))


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


def projector_code_centers(ctx: DecodeContext, direct: list[int]) -> np.ndarray:
    """Codeword -> stripe centre table, from the projected code itself: the code frames are
    evaluated (:func:`fringe3d.patterns.render.sinusoid_value`) along the fringe coordinate
    ``w`` over the projector's range, every 1/16 px; cached in the context."""
    key = ("code_centers", ctx.direction)
    if key not in ctx.cache:
        ps = ctx.patterns
        lo, hi = w_range(ctx.plan.angle, ps.width, ps.height)
        step = 1.0 / 16.0
        w = np.arange(lo - 0.5, hi + 0.5, step) + 0.5 * step
        u, v = point_at_fringe_coordinate(w, ctx.plan.angle)
        images = np.stack([sinusoid_value(ps.frames[i], u, v, ps.width, ps.height) for i in direct])
        ctx.cache[key] = code_centers(images, w)
    return ctx.cache[key]


def unwrap_gray_code(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="gray_code"`` or ``"binary_code"``: the fringe order from the code frames,
    thresholded by their inverses, the white/black frames, the phase average or a fixed level
    (:func:`fringe3d.decode.code_threshold.code_reference`; :func:`fringe3d.unwrap.temporal.gray_code_order`)."""
    groups = ctx.groups_for_plan()
    g = groups[0]
    pr = ctx.group_phase(g)
    direct, inv = code_frames(ctx)
    inv, threshold = code_reference(ctx, inv, pr.average)
    centers = projector_code_centers(ctx, direct)
    res = gray_code_order(ctx.frames, direct, pr.phase, g.period, centers, inverse_index=inv, threshold=threshold)
    return Unwrapped(res.phase, combined_mask(ctx, groups) & res.valid)
