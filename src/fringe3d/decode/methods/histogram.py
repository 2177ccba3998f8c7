"""Decoding method ``histogram`` (ch. 6): per-object fringe-order mode against a coarse
reference (the array algorithms are :mod:`fringe3d.unwrap.histogram`)."""
from __future__ import annotations

import numpy as np

from fringe3d.decode.context import DecodeContext, require_geometry
from fringe3d.decode.methods.spatial import unwrap_group_per_object
from fringe3d.decode.result import Unwrapped
from fringe3d.unwrap.geometric import cached_minimum_phase, geometric_unwrap
from fringe3d.unwrap.histogram import histogram_unwrap, minimum_phase_orders
from fringe3d.unwrap.segmentation import foreground_mask


def unwrap_histogram(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="histogram"`` (ch. 6): periods ``(T,)`` or ``(T, T_ref)``. The narrowest
    group (FTP, modified FTP or phase shifting) is unwrapped spatially per object; each
    object is shifted by the mode of its fringe-order difference to ``Φ_ref`` (the
    ``T_ref`` group unwrapped by the geometric constraint) or, with one group, to ``Φ_min``.
    Needs the rig and ``z_min``. Options: ``erode``, ``min_size``, ``min_ratio``."""
    geo, z_min = require_geometry(ctx, "histogram")
    groups = sorted(ctx.groups_for_plan(), key=lambda g: g.period)
    if len(groups) not in (1, 2):
        raise ValueError(f"direction {ctx.direction!r}: method 'histogram' takes one or two phase groups, "
                         f"the plan names periods {[g.period for g in groups]}")
    hi = groups[0]
    mp_hi = cached_minimum_phase(geo, z_min, hi.period, hi.angle)
    phi_r, labels, pr = unwrap_group_per_object(ctx, hi, mp_hi.phi_min, min_size=200, erode=2)
    if len(groups) == 2:
        lo = groups[1]
        mp_lo = cached_minimum_phase(geo, z_min, lo.period, lo.angle)
        prl = ctx.group_phase(lo)
        fg_l = foreground_mask(prl.average, prl.modulation, float(ctx.method_option("min_ratio", 0.15)))
        phi_ref, _ = geometric_unwrap(prl.phase, mp_lo, fg_l & ctx.group_mask(lo), check=False)
        phi_a, votes = histogram_unwrap(phi_r, labels, phi_ref, scale=lo.period / hi.period)
    else:
        phi_a, votes = minimum_phase_orders(phi_r, labels, mp_hi)
    return Unwrapped(phi_a, np.isfinite(phi_a), wrapped=pr.phase, modulation=pr.modulation, period=hi.period)
