"""The default three-frequency decode of one direction with its assessment on the CUDA device
(``DecodeOptions.backend == "cuda"``): what :func:`fringe3d.decode.methods.temporal.unwrap_heterodyne`
(fused path) and :func:`fringe3d.decode.assess.assess` make on the CPU, from the device maps of
:class:`fringe3d.gpu.temporal_outputs.DeviceDecode`.

Per cycle the frames go up once; the absolute phase, its mask, the quality bits, the phase sigma
and the texture are made on the device and come back finished. Between the launches a few
numbers come back: each group's count of clipped pixels (only where a sample clipped are the
clipping flags copied back and the clipping test (:func:`fringe3d.decode.context.clipping_broken`)
run on the CPU), the reference point's 1/64 sample and the float64 moments of the noise model
(:func:`fringe3d.phase.noise.fit_noise_model`), and the radix histograms of the blur estimate's
median (:func:`fringe3d.decode.edges.estimate_blur`).

Equal to the CPU path (``tests/test_cuda_temporal.py``): the mask and the quality bits exactly,
the phase and the wrapped phase to float32 rounding (fused multiply-adds), the phase sigma to
1e-5 relative (the moments' float64 sums in another order), the texture to 1e-6.
"""
from __future__ import annotations

import math
from typing import Any

import numpy as np

from fringe3d.decode import edges
from fringe3d.decode.assess import Assessment
from fringe3d.decode.context import DecodeContext, PhaseGroup, clipping_broken
from fringe3d.decode.result import Unwrapped
from fringe3d.phase import quality
from fringe3d.phase.noise import _line_from_moments
from fringe3d.phase.psp import lsq_coefficients
from fringe3d.phase.quality import full_scale
from fringe3d.unwrap.temporal import beat_chain, coarse_window


def on_device(ctx: DecodeContext) -> bool:
    """Whether :func:`device_direction` decodes ``ctx``'s direction: the CUDA backend, method
    ``heterodyne`` by the fused kernel (three phase-shifted groups, option ``fused``, no
    compensation) whose narrowest group has 4 or more steps (its fit residual is the noise
    model's, as the default 15-frame set's 9-step group)."""
    opts = ctx.options
    if opts.backend != "cuda" or ctx.plan.method != "heterodyne" or not opts.fused or opts.compensate is not None:
        return False
    try:
        groups = ctx.groups_for_plan()
    except ValueError:
        return False
    return (len(groups) == 3 and all(len(g.indices) >= 3 for g in groups) and len(groups[0].indices) >= 4
            and all(g.period > groups[0].period * (1 + 1e-9) for g in groups[1:])
            and isinstance(ctx.frames, np.ndarray))


def assess_arrays(groups: list[PhaseGroup], w_range: tuple[float, float] | None,
                  thresholds: tuple[float, float, float]):
    """:class:`fringe3d.gpu.temporal_outputs.AssessArrays` of the three groups, as
    :func:`fringe3d.decode._fused_assess.three_frequency_assess` makes them (``thresholds`` =
    ``(min_modulation, max_residual, clipping level)``)."""
    from fringe3d.gpu.temporal_outputs import AssessArrays

    min_modulation, max_residual, level = (float(t) for t in thresholds)
    periods = [g.period for g in groups]
    coef64 = [lsq_coefficients(g.shifts) for g in groups]
    beats, signs = beat_chain(periods)
    params = np.array([signs[0], signs[1], beats[1] / beats[0], beats[0] / periods[0],
                       coarse_window(beats[-1], w_range), min_modulation, 3e38, max_residual,
                       min(level, 3e38)], dtype=np.float32)
    d = np.asarray(groups[0].shifts, np.float64)
    design = np.stack([np.ones_like(d), np.cos(d), np.sin(d)], axis=1).astype(np.float32)
    n1 = d.size
    scales = np.array([periods[0] / periods[1], periods[0] / periods[2], 1.0 / (n1 - 3) if n1 > 3 else 0.0])
    return AssessArrays(tuple(np.asarray(g.indices, np.int64) for g in groups),
                        tuple(c.astype(np.float32) for c in coef64), params, design, scales,
                        np.ascontiguousarray(np.concatenate(coef64[1:], axis=1)))


def _clipping(ctx: DecodeContext, dev, groups: list[PhaseGroup], level: float) -> np.ndarray | None:
    """The pixels clipping broke (or None), each group's record in ``ctx.cache`` as the CPU
    path leaves it; the flags come back from the device only where a sample clipped."""
    if not math.isfinite(level):
        return None
    counts = dev.clipped_counts()
    maps = dev.clipped_maps() if counts.any() else np.zeros((3,) + dev.shape, bool)
    for g, c in zip(groups, maps):
        ctx.cache[("clipped", g.name)] = c
    broken = [b for i, g in enumerate(groups) if (b := clipping_broken(ctx, g, order_only=i > 0)).any()]
    return np.logical_or.reduce(broken) if broken else None


def _noise_model(dev) -> tuple[float, float]:
    """``(c0, c1)`` of :func:`fringe3d.phase.noise.fit_noise_model` of the variance against the
    average over the mask, from the device's moments."""
    xs, ys, ms = dev.sample(8)
    sel = ms & np.isfinite(xs) & np.isfinite(ys)
    ref = ((float(np.mean(xs[sel], dtype=np.float64)), float(np.mean(ys[sel], dtype=np.float64)))
           if sel.any() else (0.0, 0.0))
    moments = dev.moments(None, 0.0, ref)
    if moments[0] < 10:
        return math.nan, math.nan
    c0, c1 = _line_from_moments(moments, ref)
    return _line_from_moments(dev.moments((c0, c1), 5.0, ref), ref)


def _blur(dev, period_fine: float, period_coarse: float) -> float:
    """:func:`fringe3d.decode.edges.estimate_blur` of group 1's and group 3's modulation over the
    mask, the median found on the device."""
    r = dev.ratio_median()
    if not 0 < r < 1:
        return 0.0
    den = 2 * math.pi ** 2 * (1 / period_fine ** 2 - 1 / period_coarse ** 2)
    return float(min(math.sqrt(-math.log(r) / den), period_fine))


def device_direction(ctx: DecodeContext) -> tuple[Unwrapped, Assessment]:
    """The method's result and the assessment of ``ctx``'s direction, made on the device (where
    :func:`on_device`): equal to :func:`~fringe3d.decode.methods.temporal.unwrap_heterodyne`'s and
    :func:`~fringe3d.decode.assess.assess`'s on the CPU (quality bits and mask exactly, float maps
    to float rounding; the texture is the assessment's, a fraction of full scale)."""
    from fringe3d.gpu.fused_outputs import QualitySettings
    from fringe3d.gpu.temporal_outputs import DeviceDecode, TemporalQuality

    opts = ctx.options
    groups = ctx.groups_for_plan()
    level = quality.saturation_level(ctx.frames, ctx.bit_depth)
    dev = DeviceDecode(ctx.frames, assess_arrays(groups, ctx.w_range(),
                                                 (ctx.min_modulation, float(opts.max_residual), level)))
    broken = _clipping(ctx, dev, groups, level)
    if broken is not None:
        dev.apply_broken(broken)
    info: dict[str, Any] = {}
    saturation = {key[1]: v for key, v in ctx.cache.items() if isinstance(key, tuple) and key[0] == "saturation"}
    if saturation:
        info["saturation"] = saturation
    model = _noise_model(dev)
    g1, g3 = groups[0], groups[-1]
    info["noise"] = {"c0": model[0] if math.isfinite(model[0]) else None,
                     "c1": model[1] if math.isfinite(model[1]) else None,
                     "source": f"fit residual ({g1.name}, {len(g1.indices)} steps)"}
    blur = _blur(dev, g1.period, g3.period)
    margin = edges.edge_margin(opts.edge_margin, blur)
    lo, hi = edges.pixel_extent(*ctx.w_range(), ctx.plan.angle)
    band = margin * edges.oblique_factor(ctx.plan.angle)
    tests = QualitySettings(bool(opts.edge_mask), lo + band, hi - band, float(opts.gradient_ratio),
                            edges.QualityTests.gradient_floor, float(opts.modulation_ratio), int(opts.rim),
                            full_scale(ctx.frames, ctx.bit_depth))
    dev.quality_map(TemporalQuality(tests, float(opts.max_disagreement), g1.period / (2.0 * math.pi)))
    maps = dev.finish(model, len(g1.indices), tests.full_scale)
    if opts.edge_mask:
        info.update({"blur": blur, "edge_margin": margin})
    if opts.edge_mask or math.isfinite(level):  # the CPU's: the edge tests ran, or the clipping test
        info["masked"] = edges.bit_counts(maps.quality)
    result = Unwrapped(maps.phase, maps.mask, wrapped=maps.wrapped, modulation=maps.modulation, average=maps.average,
                       phase_is_masked=True)
    return result, Assessment(maps.quality, maps.phase_sigma, info, maps.texture)
