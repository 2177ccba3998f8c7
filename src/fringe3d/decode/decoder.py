"""Manifest-driven decoder: camera frames + PatternSet -> absolute phase per fringe direction.

For each :class:`~fringe3d.patterns.manifest.DirectionPlan` the unwrapping method is looked
up in :data:`fringe3d.unwrap.registry.UNWRAPPERS` and run on a
:class:`~fringe3d.unwrap.registry.DecodeContext`; the decoder itself knows no method.
A three-frequency heterodyne plan (e.g. 9-step T=18 + 3-step T=21 + 3-step T=144, the
calibration set) runs the fused single-pass kernel
(:func:`fringe3d.unwrap.temporal.three_frequency_decode`).
"""
from __future__ import annotations

import warnings
from typing import Iterator

import numpy as np

from fringe3d.decode.result import Decoded
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.phase import quality
from fringe3d.unwrap import temporal  # noqa: F401  (registers the temporal methods)
from fringe3d.unwrap.registry import DecodeContext, get_unwrapper, phase_groups

def as_frame_stack(frames) -> np.ndarray:
    """(F, H, W) array from an array or a list of (H, W) images, with clear errors."""
    if isinstance(frames, (list, tuple)):
        if not frames:
            raise ValueError("no frames given; expected an (F, H, W) stack")
        shapes = [np.shape(f) for f in frames]
        if len(set(shapes)) != 1:
            first = shapes[0]
            bad = [i for i, s in enumerate(shapes) if s != first]
            raise ValueError(f"frames have different shapes: frame 0 is {first}, frame(s) {bad[:10]} are "
                             f"{sorted(set(shapes[i] for i in bad))}; expected every frame to be {first}")
        frames = np.stack([np.asarray(f) for f in frames])
    frames = np.asarray(frames)
    if frames.ndim == 4 and frames.shape[-1] in (3, 4):
        raise ValueError(f"frames have shape {frames.shape} (colour?); expected single-channel (F, H, W) frames")
    if frames.ndim != 3:
        raise ValueError(f"frames must be an (F, H, W) stack, got shape {frames.shape}")
    if frames.dtype.kind not in "uif" or frames.dtype == np.bool_:
        raise ValueError(f"frames must be integer or float images, got dtype {frames.dtype}")
    return frames


def _check_count(n_frames: int, ps: PatternSet, sequence: bool) -> int:
    n = len(ps)
    if n == 0:
        raise ValueError("the pattern manifest lists no frames")
    if sequence:
        if n_frames % n:
            raise ValueError(f"got {n_frames} frames, which is not a whole number of cycles of the manifest's "
                             f"{n} frames ({ps.name or 'unnamed set'}); expected a multiple of {n}")
        return n_frames // n
    if n_frames != n:
        hint = (f" ({n_frames // n} cycles: use decode_sequence)" if n_frames % n == 0 else "")
        raise ValueError(f"got {n_frames} frames but the manifest ({ps.name or 'unnamed set'}) lists {n} frames; "
                         f"expected exactly {n}{hint}")
    return 1


def _plans(ps: PatternSet) -> list[DirectionPlan]:
    plans = list(ps.plans)
    planned = {p.direction for p in plans}
    for d in ps.directions():
        if d not in planned and ps.groups(direction=d, role="phase"):
            f = ps.frames[ps.indices(direction=d)[0]]
            plans.append(DirectionPlan(direction=d, angle=f.angle, method="none"))
    if not plans:
        raise ValueError("the pattern manifest has no phase frames and no unwrapping plans; nothing to decode")
    return plans


def decode(frames, patterns: PatternSet, rig=None, z_min: float | None = None, **opts) -> Decoded:
    """Decode one pattern cycle to absolute phase per fringe direction.

    Parameters
    ----------
    frames : (F, H, W) uint8, uint16 or float array (or list of (H, W) arrays)
        Captured frames in projection order, ``F == len(patterns)``.
    patterns : PatternSet
        The manifest of the projected set (with ``plans``).
    rig, z_min : passed to unwrappers that need geometry (geometric constraint, Eq. 4.15-4.21).
    bit_depth : int, optional
        Sensor bit depth (saturation level ``2**bit_depth - 1``); default from the dtype
        (8 / 16), no saturation check for float frames.
    min_modulation : float, optional
        Modulation threshold (frames' units); default 2 % of full scale.
    fused : bool
        Use the fused three-frequency kernel when the plan allows (default True).
    max_residual : float
        Fused three-frequency path: largest accepted unwrapping residual in rad (default pi/2;
        pixels above it are masked as inconsistent; ``math.pi`` disables the check).
    ftp_window, ftp_radius :
        Band-pass window (``"hanning"``/``"circular"``) and radius for FTP groups.
    Other keyword options reach the unwrappers as ``ctx.options``.

    Returns
    -------
    :class:`Decoded`. Invalid pixels (low modulation, saturated, undecodable) are False in
    ``mask`` and NaN in ``phase``. All-dark or heavily saturated frames give a
    :class:`fringe3d.phase.quality.FrameQualityWarning`; their pixels are masked.

    Raises ``ValueError`` for a wrong frame count (both numbers named), frames of different
    shapes, manifest groups with missing steps, or an unregistered unwrapping method.
    """
    frames = as_frame_stack(frames)
    _check_count(frames.shape[0], patterns, sequence=False)
    return _decode_cycle(frames, patterns, rig, z_min, opts)


def decode_sequence(frames, patterns: PatternSet, rig=None, z_min: float | None = None, progress: bool = False,
                    **opts) -> Iterator[Decoded]:
    """Decode a sequence of ``n_cycles`` repetitions of the manifest (``F = n_cycles * len``),
    yielding one :class:`Decoded` per cycle (frames may be a memory map; each cycle is read
    once). ``progress=True`` shows a progress bar."""
    frames = as_frame_stack(frames) if not isinstance(frames, np.ndarray) else frames
    if frames.ndim != 3:
        raise ValueError(f"frames must be an (F, H, W) stack, got shape {frames.shape}")
    cycles = _check_count(frames.shape[0], patterns, sequence=True)
    n = len(patterns)
    from fringe3d.utils.console import progress_bar
    with progress_bar("decoding", cycles, enabled=progress) as advance:
        for c in range(cycles):
            yield _decode_cycle(np.ascontiguousarray(frames[c * n:(c + 1) * n]), patterns, rig, z_min, opts)
            advance()


def _decode_cycle(frames: np.ndarray, ps: PatternSet, rig, z_min, opts: dict) -> Decoded:
    bit_depth = opts.get("bit_depth")
    min_mod = opts.get("min_modulation")
    min_mod = quality.default_min_modulation(frames, bit_depth) if min_mod is None else float(min_mod)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        checks = quality.check_frames(frames, bit_depth)
    for w in caught:  # re-issue so they point at the caller and are recorded in info
        warnings.warn(w.message, w.category, stacklevel=3)
    plans = _plans(ps)
    groups_of = {plan.direction: phase_groups(ps, plan.direction) for plan in plans}  # validate before any work
    out = Decoded(info={"frame_checks": checks, "warnings": [str(w.message) for w in caught],
                        "min_modulation": min_mod})
    first_ctx = None
    for plan in plans:
        ctx = DecodeContext(frames=frames, patterns=ps, direction=plan.direction, plan=plan, rig=rig, z_min=z_min,
                            options=dict(opts), bit_depth=bit_depth, min_modulation=min_mod)
        if not groups_of[plan.direction]:
            raise ValueError(f"direction {plan.direction!r} has an unwrapping plan ({plan.method}) but no phase frames "
                             "in the manifest; the decoder needs phase-shifted or FTP frames (a code-only set "
                             "gives no phase: combine it with phase frames, e.g. psp_with_gray_code)")
        result = get_unwrapper(plan.method)(ctx)
        phi, mask = result[0], result[1]
        extras = result[2] if len(result) > 2 else {}
        # narrowest group of the plan (= ctx.groups_for_plan()[0] without re-reading the manifest thrice)
        g = ctx.group_for_period(plan.periods[0]) if plan.periods else groups_of[plan.direction][0]
        if "wrapped" in extras and "modulation" in extras:
            wrapped, modulation = extras["wrapped"], extras["modulation"]
        else:
            pr = ctx.group_phase(g)
            wrapped, modulation = extras.get("wrapped", pr.phase), extras.get("modulation", pr.modulation)
        if extras.get("masked") and phi.dtype == np.float32:  # the unwrapper already set NaN exactly where mask is False
            phase, mask = phi, mask
        else:
            mask = np.asarray(mask, dtype=bool) & np.isfinite(phi)
            phase = np.where(mask, phi, np.nan).astype(np.float32)
        d = plan.direction
        out.phase[d], out.mask[d] = phase, mask
        out.wrapped[d] = np.asarray(wrapped, np.float32)
        out.modulation[d] = np.asarray(modulation, np.float32)
        out.period[d] = float(extras.get("period", g.period))
        out.angle[d] = float(plan.angle)
        out.method[d] = plan.method
        if first_ctx is None:
            first_ctx = (ctx, g, extras)
    ctx, g, extras = first_ctx
    average = extras.get("average")
    if average is None:
        average = ctx.group_phase(g).average
    out.average = np.asarray(average, np.float32)
    white = ps.indices(kind="white")
    if white:
        out.texture = frames[white[0]].astype(np.float32)
    elif extras.get("texture") is not None:  # the fused kernel wrote average + modulation
        out.texture = np.asarray(extras["texture"], np.float32)
    else:
        out.texture = np.add(out.average, out.modulation[plans[0].direction], dtype=np.float32)  # one pass
    return out
