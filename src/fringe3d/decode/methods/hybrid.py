"""Decoding method ``hybrid``: FTP + PSP with motion compensation (ch. 5.2.5, Eq. 5.12-5.15);
the array algorithms are :mod:`fringe3d.unwrap.hybrid`."""
from __future__ import annotations

import numpy as np

from fringe3d.decode.context import DecodeContext, not_saturated, require_geometry
from fringe3d.decode.result import Unwrapped
from fringe3d.unwrap.geometric import cached_minimum_phase
from fringe3d.unwrap.hybrid import HybridSettings, carrier_from_minimum_phase, ftp_group_phase, hybrid_unwrap


def unwrap_hybrid(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="hybrid"``, periods ``(T, T_l)``: a 1-frame FTP group of period ``T`` and
    a 3-step group of period ``T_l`` (ch. 5.2.5). Options (plan or decoder): ``ftp_window``,
    ``erode``, ``min_size``, ``min_ratio``, ``max_shift``, ``cross_motion``. Returns ``Φ_a``
    with the FTP wrapped phase and modulation, the period ``T``, the object labels and each
    object's ``k_s``."""
    geo, z_min = require_geometry(ctx, "hybrid")
    groups = ctx.groups_for_plan()
    if len(groups) != 2:
        raise ValueError(f"direction {ctx.direction!r}: method 'hybrid' needs two phase groups (one FTP frame "
                         f"of the high frequency, 3 phase-shifted low-frequency frames); the plan names "
                         f"periods {[g.period for g in groups]}")
    hi, lo = sorted(groups, key=lambda g: g.period)
    if len(hi.indices) != 1 or len(lo.indices) < 3:
        raise ValueError(f"direction {ctx.direction!r}: method 'hybrid' needs 1 high-frequency frame and >= 3 "
                         f"low-frequency frames, the manifest has {len(hi.indices)} and {len(lo.indices)}")
    mp = cached_minimum_phase(geo, z_min, lo.period, lo.angle)
    carrier = carrier_from_minimum_phase(mp.phi_min, lo.period / hi.period)
    high = ftp_group_phase(ctx.frames[list(hi.indices)], hi.shifts, carrier,
                           window=str(ctx.method_option("ftp_window", "hanning")))
    d = HybridSettings()
    settings = HybridSettings(erode=int(ctx.method_option("erode", d.erode)),
                              min_size=int(ctx.method_option("min_size", d.min_size)),
                              min_ratio=float(ctx.method_option("min_ratio", d.min_ratio)),
                              max_shift=ctx.method_option("max_shift", d.max_shift),
                              cross_motion=bool(ctx.method_option("cross_motion", d.cross_motion)))
    res = hybrid_unwrap(high, ctx.group_phase(lo), mp, hi.period, lo.period, settings=settings,
                        valid_high=not_saturated(ctx, hi.indices), valid_low=ctx.group_mask(lo))
    mask = np.isfinite(res.phase)
    return Unwrapped(res.phase, mask, wrapped=high.phase, modulation=high.modulation, period=hi.period,
                     labels=res.labels, object_orders={l: v.k_s for l, v in res.votes.items()})
