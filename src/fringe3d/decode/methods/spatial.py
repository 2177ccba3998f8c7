"""Decoding method ``spatial``: relative phase per isolated object (ch. 5.2.5), and the
per-object unwrapping of one phase group shared with ``histogram``."""
from __future__ import annotations

import numpy as np

from fringe3d.decode.context import DecodeContext, PhaseGroup, not_saturated, require_geometry
from fringe3d.decode.result import Unwrapped
from fringe3d.phase.psp import PhaseResult
from fringe3d.unwrap.geometric import cached_minimum_phase
from fringe3d.unwrap.hybrid import carrier_from_minimum_phase, ftp_group_phase
from fringe3d.unwrap.segmentation import MODULATION_FRACTION, foreground_mask, modulation_mask, segment_objects
from fringe3d.unwrap.spatial import unwrap_objects


def unwrap_group_per_object(ctx: DecodeContext, group: PhaseGroup, phi_min: np.ndarray | None, min_size: int,
                            erode: int, by_modulation: bool = False) -> tuple[np.ndarray, np.ndarray, PhaseResult]:
    """Wrapped phase of one phase group, its isolated objects, each unwrapped spatially.

    FTP / modified-FTP groups (fewer than 3 frames) are analysed on the carrier the rig
    predicts (the gradient of ``phi_min``, the minimum-phase map of Eq. 4.19) when
    ``phi_min`` is given; phase-shifted groups by least squares. Objects are, with
    ``by_modulation`` (method ``spatial``), the valid pixels whose modulation reaches the plan
    option ``min_modulation_fraction`` (default 0.05) of the robust modulation level
    (:func:`fringe3d.unwrap.segmentation.modulation_mask`: fringe modulation, never average
    brightness, so dark but well-modulated surfaces stay); otherwise (``histogram``) the
    foreground of :func:`~fringe3d.unwrap.segmentation.foreground_mask` (option ``min_ratio``);
    split into connected regions of at least option
    ``min_size`` (default ``min_size``) pixels, eroded by option ``erode`` (default
    ``erode``). Returns ``(phi_r (H, W) relative phase, NaN outside objects, labels (H, W)
    int, the group's PhaseResult)``.
    """
    if len(group.indices) < 3 and phi_min is not None:
        pr = ftp_group_phase(ctx.frames[list(group.indices)], group.shifts, carrier_from_minimum_phase(phi_min),
                             window=str(ctx.method_option("ftp_window", "hanning")))
        valid = not_saturated(ctx, group.indices)
    else:
        pr = ctx.group_phase(group)
        valid = ctx.group_mask(group)
    if by_modulation:
        fg = modulation_mask(pr.modulation, valid,
                             float(ctx.plan.options.get("min_modulation_fraction", MODULATION_FRACTION)))
    else:
        fg = foreground_mask(pr.average, pr.modulation, float(ctx.method_option("min_ratio", 0.15))) & valid
    labels = segment_objects(fg, min_size=int(ctx.method_option("min_size", min_size)),
                             erode=int(ctx.method_option("erode", erode)))
    phi_r, labels = unwrap_objects(pr.phase, labels=labels)
    return phi_r, labels, pr


def unwrap_spatial(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="spatial"``: the narrowest group's wrapped phase unwrapped per object.

    RELATIVE phase: each object is off by an unknown ``2π·k`` (Eq. 5.12); use ``"histogram"``,
    ``"hybrid"`` or a temporal method for absolute 3D. For FTP groups, a rig and ``z_min``
    (when given) fix the carrier and thus the phase's sign; without them the decoder's
    carrier search decides it. Objects are cut on modulation
    (:func:`fringe3d.unwrap.segmentation.modulation_mask`). Options: ``min_size``, ``erode``,
    ``min_modulation_fraction`` (plan option), ``ftp_window``."""
    groups = sorted(ctx.groups_for_plan(), key=lambda g: g.period)
    if not groups:
        raise ValueError(f"direction {ctx.direction!r}: method 'spatial' found no phase group")
    g = groups[0]
    z_min = ctx.z_min if ctx.z_min is not None else ctx.plan.options.get("z_min")
    phi_min = None
    if len(g.indices) < 3 and ctx.rig is not None and z_min is not None:
        geo, z_min = require_geometry(ctx, "spatial")
        phi_min = cached_minimum_phase(geo, z_min, g.period, g.angle).phi_min
    phi_r, labels, _ = unwrap_group_per_object(ctx, g, phi_min, min_size=64, erode=0, by_modulation=True)
    return Unwrapped(phi_r, np.isfinite(phi_r), labels=labels)
