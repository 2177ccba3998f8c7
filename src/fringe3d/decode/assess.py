"""Per-direction quality and phase noise of a decoded direction (what the decoder adds after
the method ran): the quality map of :mod:`fringe3d.decode.edges` and ``sigma_phi`` of
:mod:`fringe3d.phase.noise`."""
from __future__ import annotations

import math
from typing import Any, NamedTuple

import numpy as np

from fringe3d.decode import edges
from fringe3d.decode.context import DecodeContext, PhaseGroup
from fringe3d.patterns.conventions import phase_to_w
from fringe3d.patterns.method_registry import is_relative
from fringe3d.phase import noise


class Assessment(NamedTuple):
    """Quality map (H, W) uint8, phase sigma (H, W) float32 rad (NaN where unknown), a
    small JSON-friendly dict (blur, margin, noise model, bit counts) and, when asked for and
    the phase sigma had a noise model, the texture fraction of the average and modulation
    from the same pass (else None); ``keeps_mask`` True where it is known that no pixel of the
    mask has a non-finite phase or a quality bit set (the decoder then masks nothing more)."""

    quality: np.ndarray
    phase_sigma: np.ndarray
    info: dict[str, Any]
    texture: np.ndarray | None = None
    keeps_mask: bool = False


#: The bits a pixel of the method's mask can carry (INVALID and SATURATED are set outside it only).
_INSIDE_BITS = ("edge", "inconsistent", "gradient", "mod_drop", "rim", "order")


def _psp_groups(ctx: DecodeContext) -> list[PhaseGroup]:
    try:
        groups = ctx.groups_for_plan() if ctx.phase_groups() else []
    except ValueError:
        return []
    return [g for g in groups if len(g.indices) >= 3]


def noise_model(ctx: DecodeContext, groups: list[PhaseGroup], average: np.ndarray,
                mask: np.ndarray) -> tuple[tuple[float, float], str]:
    """``((c0, c1), source)``: the capture's noise model ``sigma^2 = c0 + c1 A`` (frames' units)
    from the first ``N >= 4``-step group's fit residual, else two 3-step groups' averages, else
    the Laplacian high-pass of the average image (``c1 = 0``); see :mod:`fringe3d.phase.noise`."""
    four = [g for g in groups if len(g.indices) >= 4]
    if four:
        g = four[0]
        var = ctx.cache.get(("fit_variance", g.name))  # from the fused pass, when it ran
        if var is None:
            var = noise.fit_residual_variance(ctx.frames, g.indices, g.shifts)
        return noise.fit_noise_model(var, average, mask), f"fit residual ({g.name}, {len(g.indices)} steps)"
    if len(groups) >= 2:
        a, b = groups[0], groups[1]
        var = noise.average_difference_variance(ctx.group_phase(a).average, len(a.indices),
                                                ctx.group_phase(b).average, len(b.indices))
        return noise.fit_noise_model(var, average, mask), f"average difference ({a.name}, {b.name})"
    mp = ctx.cache.get(("mask_pass",))  # the sums of the PSP pass that made this mask, when it did
    s = (noise.laplacian_sigma(*mp.laplacian) if mp is not None and mp.mask is mask and mp.average is average
         else noise.laplacian_noise(average, mask))
    # the average of N frames carries sigma / sqrt(N)
    n = len(groups[0].indices) if groups else 1
    return (s * s * n, 0.0), "Laplacian of the average image"


def clipping_broken_map(ctx: DecodeContext) -> tuple[np.ndarray | None, bool]:
    """``(broken, tested)``: (H, W) bool where clipping broke a pixel of this direction (the phase
    groups' and the code's maps the method computed, cached in the context), None where no map
    can hold a pixel; ``tested`` whether the method computed any map. A phase group's map
    (:func:`fringe3d.decode.context.clipping_broken`) is known empty, and not read, when its
    saturation record counts no clipped pixel (a pixel breaks only where a sample clipped)."""
    maps = [(k, v) for k, v in ctx.cache.items()
            if isinstance(k, tuple) and k and k[0] in ("clipping_broken", "code_clipped")]
    live = [v for k, v in maps if not (k[0] == "clipping_broken"
                                       and ctx.cache.get(("saturation", k[1]), {}).get("clipped") == 0)]
    return (np.logical_or.reduce(live) if live else None), bool(maps)


def assess(ctx: DecodeContext, phase: np.ndarray, mask: np.ndarray, modulation: np.ndarray,
           average: np.ndarray | None, period: float, order: np.ndarray | None = None,
           texture_scale: float | None = None) -> Assessment:
    """Quality map and phase sigma of one direction.

    ``phase`` (H, W) absolute phase (rad, of ``period`` px), ``mask`` the method's mask,
    ``modulation`` / ``average`` of the narrowest group (``average`` None: a code-only method,
    no phase groups), ``order`` the method's ``order_inconsistent`` pixels (bit ORDER, always
    set). Only the INVALID and ORDER bits are set with
    ``ctx.options.edge_mask`` False, for code-only methods and FTP groups (no phase-shifted group
    of 3 or more steps; code stripes' ``w`` steps by design) and for ``method="none"`` (a wrapped
    phase is not a fringe coordinate). ``texture_scale`` (full scale, frames' units): also
    return ``clip(nan_to_num((average + modulation) / texture_scale), 0, 1)`` in float32 when
    the phase sigma's pass runs (``Assessment.texture``; None otherwise).
    """
    opts = ctx.options
    groups = _psp_groups(ctx) if average is not None else []
    info: dict[str, Any] = {}
    saturation = {key[1]: v for key, v in ctx.cache.items() if isinstance(key, tuple) and key[0] == "saturation"}
    if saturation:  # per phase group (and "code"): shares clipped and masked for it, and the rule
        info["saturation"] = saturation
    mask = np.asarray(mask, bool)
    sigma_phi = texture = None
    if groups:
        assert average is not None
        model, source = noise_model(ctx, groups, average, mask)
        info["noise"] = {"c0": model[0] if math.isfinite(model[0]) else None,
                         "c1": model[1] if math.isfinite(model[1]) else None, "source": source}
        steps = len(groups[0].indices)
        if math.isfinite(model[0]) and texture_scale is not None:  # one pass over A and B for both
            sigma_phi, texture = noise.model_phase_sigma_and_fraction(model[0], model[1], average, modulation,
                                                                      steps, texture_scale)
        elif math.isfinite(model[0]):
            sigma_phi = noise.model_phase_sigma(model[0], model[1], average, modulation, steps)
    if sigma_phi is None:  # no noise model: unknown
        sigma_phi = np.full(mask.shape, np.nan, np.float32)
    broken, clipping_tested = clipping_broken_map(ctx)
    if not opts.edge_mask or not groups or ctx.plan.method == "none":
        # code-only stripes and wrapped ("none") phases have no continuous w to test
        mp = ctx.cache.get(("mask_pass",))
        q = (mp.not_mask if edges.INVALID == 1 and order is None and broken is None and mp is not None
             and mp.mask is mask else edges.order_bits(mask, order, broken))  # the first: ~mask of the PSP pass
        if order is not None or clipping_tested:
            info["masked"] = edges.bit_counts(q)
        return Assessment(q, sigma_phi, info, texture)
    # the fused pass's w (finite on its mask, which holds this one), else from the phase: the
    # decoder's phase is NaN outside its mask already; w outside ``valid`` is never read
    w = ctx.cache.get(("coordinate", float(period))) if order is None else None
    finite_w = w is not None
    if w is None:
        valid = mask if order is None else mask & ~np.asarray(order, bool)
        w = phase_to_w(phase if order is None else np.where(valid, phase, np.nan),
                       period).astype(np.float32, copy=False)
    coarse = [g for g in groups if g.period > period * (1 + 1e-9)]
    blur = 0.0
    residual = None
    if coarse:
        c = coarse[-1]
        mod_c = ctx.cache.get(("modulation", c.name))  # the fused pass's, when it ran
        blur = edges.estimate_blur(modulation, ctx.group_phase(c).modulation if mod_c is None else mod_c,
                                   period, c.period, mask)
        residual = ctx.cache.get(("disagreement", *(g.name for g in coarse)))
        if residual is None:
            residual = edges.disagreement(phase, period, [ctx.group_phase(g).phase for g in coarse],
                                          [g.period for g in coarse])
    margin = edges.edge_margin(opts.edge_margin, blur)
    lo, hi = ctx.w_range()
    f = edges.oblique_factor(ctx.plan.angle)  # w-width of the band (edges docstring)
    # a relative phase (one unknown 2 pi k per object) has no place on the projector: no EDGE test
    extent = None if is_relative(ctx.plan.method) else edges.pixel_extent(lo, hi, ctx.plan.angle)
    tests = edges.QualityTests(margin=margin * f, max_disagreement=float(opts.max_disagreement),
                               gradient_ratio=float(opts.gradient_ratio),
                               modulation_ratio=float(opts.modulation_ratio), rim=int(opts.rim))
    if finite_w:
        assert average is not None  # a phase group's (groups is not empty)
        q = edges.quality_map_finite(mask, w, extent, modulation, average, residual, saturated=broken, tests=tests)
    else:
        q = edges.quality_map(mask, w, extent, modulation, average, residual, order=order, saturated=broken,
                              tests=tests)
    info.update({"blur": blur, "edge_margin": margin, "masked": edges.bit_counts(q)})
    # w (so the phase) finite on the mask, and no bit a pixel of the mask can carry set anywhere
    keeps = finite_w and not any(info["masked"][name] for name in _INSIDE_BITS)
    return Assessment(q, sigma_phi, info, texture, keeps)
