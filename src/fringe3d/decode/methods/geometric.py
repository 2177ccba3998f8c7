"""Decoding methods of the geometric constraint: ``geometric`` (Eq. 4.14-4.21) and
``two_frequency_geometric`` (ch. 5.3); the array algorithms are :mod:`fringe3d.unwrap.geometric`."""
from __future__ import annotations

import numpy as np

from fringe3d.decode.context import DecodeContext, require_geometry
from fringe3d.decode.result import Unwrapped
from fringe3d.optics.rig import Rig
from fringe3d.patterns.conventions import coarse_to_fine_order
from fringe3d.unwrap.geometric import TWO_PI, MinimumPhase, cached_minimum_phase, check_depth_range, geometric_unwrap


def warn_depth_range(ctx: DecodeContext, rig: Rig, mp: MinimumPhase, mask: np.ndarray) -> None:
    """:func:`fringe3d.unwrap.geometric.check_depth_range` when a ``z_max`` is known (the plan's
    ``options["z_max"]``, else the decoder's)."""
    z_max = ctx.plan.options.get("z_max", ctx.options.z_max)
    if z_max is not None:
        check_depth_range(rig, mp, float(z_max), mask)


def unwrap_geometric(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="geometric"``: the plan's (single) period unwrapped by Eq. (4.21)."""
    geo, z_min = require_geometry(ctx, "geometric")
    groups = ctx.groups_for_plan()
    if len(groups) != 1:
        raise ValueError(f"direction {ctx.direction!r}: method 'geometric' unwraps one phase group, the plan "
                         f"names periods {[g.period for g in groups]}")
    g = groups[0]
    mp = cached_minimum_phase(geo, z_min, g.period, g.angle)
    Phi, mask = geometric_unwrap(ctx.group_phase(g).phase, mp, ctx.group_mask(g))
    warn_depth_range(ctx, geo.rig, mp, mask)
    return Unwrapped(Phi, mask)


def unwrap_two_frequency_geometric(ctx: DecodeContext) -> Unwrapped:
    """Plan ``method="two_frequency_geometric"``, periods ``(T_high, T_low)`` (ch. 5.3): the
    low-frequency phase is unwrapped by the geometric constraint, then unwraps the high one
    hierarchically, ``k = round((T_l/T_h * Phi_l - phi_h)/2pi)`` (Eq. 1.5)."""
    geo, z_min = require_geometry(ctx, "two_frequency_geometric")
    groups = ctx.groups_for_plan()
    if len(groups) != 2:
        raise ValueError(f"direction {ctx.direction!r}: method 'two_frequency_geometric' needs two phase groups "
                         f"(high, low frequency), the plan names periods {[g.period for g in groups]}")
    hi, lo = sorted(groups, key=lambda g: g.period)
    mp = cached_minimum_phase(geo, z_min, lo.period, lo.angle)
    Phi_l, mask_l = geometric_unwrap(ctx.group_phase(lo).phase, mp, ctx.group_mask(lo))
    warn_depth_range(ctx, geo.rig, mp, mask_l)
    phi_h = ctx.group_phase(hi).phase.astype(np.float64)
    k = coarse_to_fine_order(Phi_l, phi_h, lo.period / hi.period)
    Phi = (phi_h + TWO_PI * k).astype(np.float32)
    mask = mask_l & ctx.group_mask(hi) & np.isfinite(Phi)
    Phi[~mask] = np.nan
    return Unwrapped(Phi, mask)
