"""Manifest-driven decoder: camera frames + PatternSet -> absolute phase per fringe direction.

For each :class:`~fringe3d.patterns.manifest.DirectionPlan` the unwrapping method is looked
up in :data:`fringe3d.decode.methods.METHODS` and run on a
:class:`~fringe3d.decode.context.DecodeContext`; the decoder itself knows no method.
A three-frequency heterodyne plan (e.g. 9-step T=18 + 3-step T=21 + 3-step T=144, the
calibration set) runs the fused single-pass kernel
(:func:`fringe3d.unwrap.temporal.three_frequency_decode`).
"""
from __future__ import annotations

import math
import warnings
from typing import Any, Iterator

import numpy as np

from fringe3d.decode import compensation, edges, self_calibration
from fringe3d.decode._finish_kernels import masked_phase, quality_masked_phase, texture_fraction
from fringe3d.decode.assess import assess
from fringe3d.decode.device_temporal import device_direction, on_device
from fringe3d.decode.context import DecodeContext, phase_groups
from fringe3d.decode.method_plans import plans_to_decode as _plans
from fringe3d.decode.method_plans import with_method  # noqa: F401  (re-exported: fringe3d.decode.with_method)
from fringe3d.decode.methods import method_for
from fringe3d.decode.options import DecodeOptions
from fringe3d.decode.result import Decoded, Unwrapped
from fringe3d.decode.texture import as_fraction
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.conventions import w_range
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.patterns.method_registry import code_only_methods, is_relative, method_facts
from fringe3d.phase import quality
from fringe3d.phase.frames import as_frame_stack
from fringe3d.phase.quality import full_scale
from fringe3d.utils.console import progress_bar
from fringe3d.utils.freed_memory import keep_freed_memory


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


def decode(frames, patterns: PatternSet, rig: Rig | None = None, options: DecodeOptions | None = None,
           geometry: RigGeometry | None = None) -> Decoded:
    """Decode one pattern cycle to absolute phase per fringe direction.

    Parameters
    ----------
    frames : (F, H, W) uint8, uint16 or float array (or list of (H, W) arrays)
        Captured frames in projection order, ``F == len(patterns)``.
    patterns : PatternSet
        The manifest of the projected set (with ``plans``; each plan's ``method`` is a key of
        :data:`fringe3d.decode.METHODS`).
    rig : fringe3d.optics.Rig, optional
        Calibrated rig, for the methods that need geometry (geometric constraint,
        Eq. 4.15-4.21) and to orient FTP.
    options : DecodeOptions, optional
        ``z_min``, ``bit_depth``, ``min_modulation``, ``fused``, ``max_residual``, FTP and
        method options (see :class:`DecodeOptions`); default ``DecodeOptions()``.
    geometry : fringe3d.optics.rig_geometry.RigGeometry, optional
        The rig's precomputed geometry (minimum phase maps, Eq. 4.14-4.19), owned by the
        caller that decodes many cycles with one rig (the reconstruction engine); built for
        this call when omitted. Must belong to ``rig``.

    Returns
    -------
    :class:`Decoded`. Invalid pixels (low modulation, saturated, undecodable) are False in
    ``mask`` and NaN in ``phase``. All-dark or heavily saturated frames give a
    :class:`fringe3d.phase.quality.FrameQualityWarning`; their pixels are masked.

    Raises
    ------
    ValueError
        For a wrong frame count (both numbers named), frames of different shapes, manifest
        groups with missing steps, or an unknown unwrapping method.

    Examples
    --------
    >>> import numpy as np
    >>> from fringe3d.patterns import sets
    >>> from fringe3d.patterns.synthetic import frames_from_coordinates
    >>> ps = sets.three_frequency("v", width=800, height=600)        # 18/21/144 px, 15 frames
    >>> v_p, u_p = np.mgrid[0:48, 100:164].astype(float)              # a 64 x 48 camera's view
    >>> frames = frames_from_coordinates(ps, u_p, v_p, dtype=np.uint8)
    >>> d = decode(frames, ps, options=DecodeOptions(min_modulation=1.0))
    >>> bool(np.abs(d.projector_coordinate("v") - u_p).max() < 0.05)  # u_p = Phi T / 2 pi
    True
    """
    keep_freed_memory()
    frames = as_frame_stack(frames)
    _check_count(frames.shape[0], patterns, sequence=False)
    return _decode_cycle(frames, patterns, rig, options or DecodeOptions(), _geometry(rig, geometry))


def decode_sequence(frames, patterns: PatternSet, rig: Rig | None = None, options: DecodeOptions | None = None,
                    progress: bool = False, geometry: RigGeometry | None = None) -> Iterator[Decoded]:
    """Decode a sequence of ``n_cycles`` repetitions of the manifest, one cycle at a time.

    Parameters
    ----------
    frames : (F, H, W) array
        ``F = n_cycles * len(patterns)`` frames; may be a memory map (each cycle is read once).
    patterns : PatternSet
        The manifest of one cycle.
    rig : Rig, optional
        As in :func:`decode`.
    options : DecodeOptions, optional
        As in :func:`decode`.
    progress : bool
        Show a progress bar.
    geometry : RigGeometry, optional
        As in :func:`decode`; built once for the whole sequence when omitted.

    Yields
    ------
    Decoded
        One per cycle, in order.
    """
    keep_freed_memory()
    frames = as_frame_stack(frames) if not isinstance(frames, np.ndarray) else frames
    if frames.ndim != 3:
        raise ValueError(f"frames must be an (F, H, W) stack, got shape {frames.shape}")
    cycles = _check_count(frames.shape[0], patterns, sequence=True)
    n = len(patterns)
    opts = options or DecodeOptions()
    geo = _geometry(rig, geometry)
    with progress_bar("decoding", cycles, enabled=progress) as advance:
        for c in range(cycles):
            yield _decode_cycle(np.ascontiguousarray(frames[c * n:(c + 1) * n]), patterns, rig, opts, geo)
            advance()


def _geometry(rig: Rig | None, geometry: RigGeometry | None) -> RigGeometry | None:
    """The caller's ``geometry`` (checked against ``rig``), a fresh one of ``rig``, or None
    without a rig."""
    if rig is None:
        if geometry is not None:
            raise ValueError("geometry was given without its rig (pass rig as well)")
        return None
    return RigGeometry.of(rig, geometry)


def _decode_cycle(frames: np.ndarray, ps: PatternSet, rig: Rig | None, opts: DecodeOptions,
                  geometry: RigGeometry | None) -> Decoded:
    bit_depth = opts.bit_depth
    min_mod = opts.min_modulation
    min_mod = quality.default_min_modulation(frames, bit_depth) if min_mod is None else float(min_mod)
    with warnings.catch_warnings(record=True) as caught:
        warnings.simplefilter("always")
        checks = quality.check_frames(frames, bit_depth, dark_by_design=dark_by_design(ps),
                                      binary=binary_frames(ps))
    for w in caught:  # re-issue so they point at the caller and are recorded in info
        warnings.warn(w.message, w.category, stacklevel=3)
    plans = _plans(ps)
    groups_of = {plan.direction: phase_groups(ps, plan.direction) for plan in plans}  # validate before any work
    if opts.compensate == "disagreement":
        self_calibration.check_plans(ps, plans)
    out = Decoded(info={"frame_checks": checks, "warnings": [str(w.message) for w in caught],
                        "min_modulation": min_mod})
    first: tuple[DecodeContext, Any, Unwrapped] | None = None
    white = ps.indices(kind="white")
    texture = None  # the first direction's, from its phase sigma's pass
    for plan in plans:
        ctx = DecodeContext(frames=frames, patterns=ps, direction=plan.direction, plan=plan, rig=rig,
                            options=opts, min_modulation=min_mod, geometry=geometry,
                            cache={("phase_groups",): groups_of[plan.direction]})
        if not groups_of[plan.direction] and not method_facts(plan.method).code_only:
            raise ValueError(f"direction {plan.direction!r} has an unwrapping plan ({plan.method}) but no phase frames "
                             "in the manifest; the decoder needs phase-shifted or FTP frames, or code frames with "
                             f"one of the code methods {list(code_only_methods())}")
        compensation.prefetch_sample(ctx, plan)  # the radiometry subsample, while the frames are cached
        # the CUDA backend's default three-frequency decode: method and assessment on the device
        device = device_direction(ctx) if opts.backend == "cuda" and on_device(ctx) else None
        result = device[0] if device is not None else method_for(plan.method)(ctx)
        # narrowest group of the plan (= ctx.groups_for_plan()[0] without re-reading the manifest thrice)
        g = (None if not groups_of[plan.direction] else
             ctx.group_for_period(plan.periods[0]) if plan.periods else groups_of[plan.direction][0])
        if opts.compensate == "disagreement":  # correct every group's wrapped phase, unwrap again
            result = self_calibration.self_calibrate(ctx, result, method_for(plan.method), float(
                result.period if result.period is not None else g.period))  # type: ignore[union-attr]
        phi, mask = result.phase, result.mask
        if result.wrapped is not None and result.modulation is not None:
            wrapped, modulation = result.wrapped, result.modulation
        else:
            assert g is not None  # a code-only method returns wrapped and modulation
            pr = ctx.group_phase(g)
            wrapped = pr.phase if result.wrapped is None else result.wrapped
            modulation = pr.modulation if result.modulation is None else result.modulation
        if result.phase_is_masked and phi.dtype == np.float32:  # NaN exactly where mask is False already
            phase, mask = phi, mask
        elif phi.dtype == np.float32:
            mask, phase = masked_phase(phi, mask)  # one pass
        else:
            mask = np.asarray(mask, dtype=bool) & np.isfinite(phi)
            phase = np.where(mask, phi, np.nan).astype(np.float32)
        d = plan.direction
        period = float(result.period if result.period is not None else g.period)  # type: ignore[union-attr]
        average = result.average if result.average is not None or g is None else ctx.group_phase(g).average
        a = device[1] if device is not None else assess(
            ctx, phase, mask, np.asarray(modulation, np.float32), average, period, order=result.order_inconsistent,
            texture_scale=full_scale(frames, bit_depth) if first is None and not white else None)
        if (opts.edge_mask or result.order_inconsistent is not None) and not a.keeps_mask \
                and not _quality_masks_nothing(plan, result, opts):
            # one read; a pass if it masks any pixel (known without it where the map's counts say none)
            mask, phase = quality_masked_phase(phase, mask, a.quality, 0xFF if opts.edge_mask else edges.ORDER)
        out.quality[d], out.phase_sigma[d] = a.quality, a.phase_sigma
        out.info.setdefault("quality", {})[d] = a.info
        out.phase[d], out.mask[d] = phase, mask
        out.wrapped[d] = np.asarray(wrapped, np.float32)
        out.modulation[d] = np.asarray(modulation, np.float32)
        out.period[d] = period
        out.angle[d] = float(plan.angle)
        out.method[d] = plan.method
        rad = compensation.radiometry_info(ctx, g, phase, mask)
        if rad is not None:
            out.info.setdefault("radiometry", {})[d] = rad
        if first is None:
            first, texture = (ctx, g, result), a.texture
    assert first is not None  # _plans returns at least one plan
    ctx, g, result = first
    average = result.average
    if average is None:
        assert g is not None  # a code-only method returns its average
        average = ctx.group_phase(g).average
    out.average = np.asarray(average, np.float32)
    if white:
        out.texture = as_fraction(frames[white[0]], frames, bit_depth)  # one meaning everywhere (decode.texture)
    elif texture is not None:  # as_fraction of average + modulation, made with the phase sigma (a method's
        # texture, the fused kernel's, is that float32 sum too: the same fraction, no pass of its own)
        out.texture = texture
    else:  # as_fraction of the fused kernel's average + modulation, or of their float32 sum: one pass
        out.texture = texture_fraction(out.average if result.texture is None else result.texture,
                                       out.modulation[plans[0].direction] if result.texture is None else None,
                                       full_scale(frames, bit_depth))
    if opts.edge_mask:
        mask_projector_border(out, ps, plans)
    return out


def _quality_masks_nothing(plan: DirectionPlan, result: Unwrapped, opts: DecodeOptions) -> bool:
    """The quality map cannot mask a pixel of the method's mask, known without reading it: plan
    ``none`` without order estimates (its map, :func:`fringe3d.decode.edges.order_bits`, sets bits
    outside the mask only) whose phase is the group's valid phase (finite on the mask:
    :meth:`fringe3d.decode.context.DecodeContext.valid_group_phase`)."""
    return (plan.method == "none" and result.order_inconsistent is None and result.phase_is_masked
            and opts.compensate is None)


#: Frame kinds that project only full-on and full-off pixels (decided by comparison; their
#: full-scale pixels are by design, not a broken measurement).
BINARY_KINDS = ("gray_code", "binary_code", "white", "black")


def dark_by_design(ps: PatternSet) -> list[int]:
    """Indices of the frames that may be dark by design: kind ``black``, and the code frames (a
    code bit is black wherever the scene sees only its off stripes, or everywhere when it lights
    no projector pixel); the frame check does not call them dark frames unless all frames are."""
    return [i for i, f in enumerate(ps.frames) if f.kind in BINARY_KINDS and f.kind != "white"]


def binary_frames(ps: PatternSet) -> list[int]:
    """Indices of the binary code, white and black frames (:data:`BINARY_KINDS`)."""
    return [i for i, f in enumerate(ps.frames) if f.kind in BINARY_KINDS]


def _spans_projector(plan: DirectionPlan, ps: PatternSet) -> bool:
    """The plan's fringes cover the whole projector (no ``w_range`` narrower than its extent)."""
    wr = plan.options.get("w_range")
    return wr is None or bool(np.allclose(wr, w_range(plan.angle, ps.width, ps.height), atol=1e-6))


def mask_projector_border(out: Decoded, ps: PatternSet, plans: list[DirectionPlan]) -> None:
    """With two non-parallel absolute directions decoded, set EDGE in every direction where the
    projector pixel ``(u_p, v_p)`` (:func:`fringe3d.decode.edges.projector_position`) lies within
    the larger edge margin of any projector border, or where one direction's own band test set
    EDGE (the same projector pixel lights the pixel in every direction), in place; mask and phase
    follow. One oblique direction alone sees only part of that band (:mod:`fringe3d.decode.edges`)."""
    if len(plans) < 2:  # no pair of directions
        return
    usable = [p for p in plans if not is_relative(p.method) and _spans_projector(p, ps)
              and "edge_margin" in out.info.get("quality", {}).get(p.direction, {})]
    pair = next(((a, b) for i, a in enumerate(usable) for b in usable[i + 1:]
                 if abs(math.sin(a.angle - b.angle)) > 0.1), None)
    if pair is None:
        return
    a, b = pair
    u, v = edges.projector_position(out.projector_coordinate(a.direction), a.angle,
                                    out.projector_coordinate(b.direction), b.angle)
    margin = max(out.info["quality"][p.direction]["edge_margin"] for p in pair)
    band = edges.border_band(u, v, ps.width, ps.height, margin) & out.mask[a.direction] & out.mask[b.direction]
    for p in usable:  # one direction's band is a fact about the projector pixel: it holds for all
        band |= (out.quality[p.direction] & edges.EDGE) != 0
    if not band.any():
        return
    for d in out.directions:
        hit = band & out.mask[d]
        out.quality[d] = out.quality[d] | np.where(hit, edges.EDGE, 0).astype(np.uint8)
        out.mask[d] = out.mask[d] & ~hit
        out.phase[d] = np.where(out.mask[d], out.phase[d], np.float32(np.nan)).astype(np.float32, copy=False)
        if d in out.info.get("quality", {}):
            out.info["quality"][d]["masked"] = edges.bit_counts(out.quality[d])
