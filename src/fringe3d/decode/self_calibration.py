"""``compensate="disagreement"``: the projector's ripple estimated from the disagreement between
the capture's own fringe frequencies (after Xing & Guo 2018), corrected in two passes.

A nonlinear projector adds the same ripple ``e(phi_w)`` (rad, harmonics ``k N`` of the measured
wrapped phase) to the wrapped phase of every group of N equal steps, whatever its period. The
unwrapping combines those wrapped phases, so a correction of the result alone cannot remove it:

1. the plan's method unwraps the uncorrected groups (first pass);
2. each group's absolute phase follows from that result (``Phi_g = phi_g + 2 pi round((2 pi w /
   T_g - phi_g) / (2 pi))``, ``w = T Phi / (2 pi)`` projector px), and
   :func:`fringe3d.radiometry.disagreement_lut` fits ``e`` to the disagreement of the two
   narrowest groups of each step count N;
3. that table corrects the wrapped phase of EVERY group of N equal steps (the narrowest, whose
   phase is the result, and the coarser ones that choose its fringe orders);
4. the method unwraps the corrected groups again (second pass).

Assumes the first pass's orders right on most pixels (the fit drops the others as outliers), a
matte surface, and the same response and shifts for every group of a step count.
"""
from __future__ import annotations

from typing import Any, Callable, Sequence

import numpy as np

from fringe3d.decode.compensation import SAMPLE_PIXELS, steps_equal
from fringe3d.decode.context import DecodeContext, PhaseGroup, phase_groups
from fringe3d.decode.method_plans import plans_to_decode
from fringe3d.decode.result import Unwrapped
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.phase.psp import PhaseResult
from fringe3d.radiometry import disagreement_lut


def pairs_by_steps(groups: Sequence[PhaseGroup]) -> dict[int, list[PhaseGroup]]:
    """Groups of N >= 3 equal steps by N, narrowest period first, for the N that have at least two
    different periods (what the disagreement needs)."""
    out: dict[int, list[PhaseGroup]] = {}
    for g in sorted(groups, key=lambda g: g.period):
        if steps_equal(g.shifts) and all(not np.isclose(g.period, h.period) for h in out.get(len(g.shifts), [])):
            out.setdefault(len(g.shifts), []).append(g)
    return {n: gs for n, gs in out.items() if len(gs) >= 2}


def _plan_groups(ps: PatternSet, plan: DirectionPlan) -> list[PhaseGroup]:
    groups = phase_groups(ps, plan.direction)
    if not plan.periods:
        return groups
    return [g for g in groups if any(np.isclose(g.period, p) for p in plan.periods)]


def check_plans(ps: PatternSet, plans: Sequence[DirectionPlan]) -> None:
    """``ValueError`` naming the direction when a plan has no two phase groups of the same N >= 3
    equal steps at different periods (``compensate='disagreement'`` has nothing to compare)."""
    for plan in plans:
        groups = _plan_groups(ps, plan)
        if not pairs_by_steps(groups):
            have = ", ".join(f"{g.name} ({len(g.shifts)} steps, T={g.period:g})" for g in groups) or "none"
            raise ValueError(f"compensate='disagreement' needs, in every direction, two phase-shifted groups of the "
                             f"same number (>= 3) of equally shifted steps at different periods; direction "
                             f"{plan.direction!r} (method {plan.method}) has phase groups: {have}")


def check_compensation(ps: PatternSet, compensate: str | None) -> None:
    """:func:`check_plans` on the plans a decode of ``ps`` runs when ``compensate`` is
    ``"disagreement"`` (for a command, before anything is written); nothing otherwise."""
    if compensate == "disagreement":
        check_plans(ps, plans_to_decode(ps))


def _absolute(wrapped: np.ndarray, coordinate: np.ndarray, period: float) -> np.ndarray:
    """Absolute phase (rad) of a group of ``period`` from its wrapped phase and the projector
    coordinate ``w`` (px) of the first pass."""
    return wrapped + 2 * np.pi * np.round((2 * np.pi * coordinate / period - wrapped) / (2 * np.pi))


def _consistent(result: Unwrapped) -> np.ndarray:
    """(H, W) bool: valid pixels whose fringe-order estimates agree (the fit's pixels)."""
    ok = np.asarray(result.mask, bool) & np.isfinite(result.phase)
    return ok if result.order_inconsistent is None else ok & ~np.asarray(result.order_inconsistent, bool)


def estimate_and_correct(ctx: DecodeContext, raw: dict[str, PhaseResult], latest: Unwrapped,
                         period: float) -> list[dict[str, Any]]:
    """Fit the ripple of each step count to the uncorrected phases ``raw`` (by group name) with
    the fringe orders of ``latest`` (absolute phase at ``period`` px), and put every group of that
    N, corrected from ``raw``, in the context's cache; what was done (JSON-ready)."""
    h, w = latest.phase.shape
    step = max(1, int(np.ceil(np.sqrt(h * w / SAMPLE_PIXELS))))
    coordinate = np.asarray(latest.phase[::step, ::step], float) * period / (2 * np.pi)
    ok = _consistent(latest)[::step, ::step] & np.isfinite(coordinate)
    coordinate = np.where(ok, coordinate, 0.0)
    done: list[dict[str, Any]] = []
    groups = ctx.groups_for_plan()
    for n, (a, b) in ((n, gs[:2]) for n, gs in pairs_by_steps(groups).items()):
        info: dict[str, Any] = {"compensation": "disagreement", "steps": n, "with": [a.name, b.name],
                                "applied": False}
        pa, pb = (_absolute(np.asarray(raw[g.name].phase[::step, ::step], float), coordinate, g.period)
                  for g in (a, b))
        try:
            lut = disagreement_lut(pa, a.period, pb, b.period, n, ok)
        except ValueError as e:  # too few pixels: leave the groups as they are, and say so
            info["reason"] = str(e)
            done.append(info)
            continue
        for g in groups:
            if len(g.shifts) == n and steps_equal(g.shifts):
                pr = raw[g.name]
                corrected = PhaseResult(lut.correct(pr.phase).astype(pr.phase.dtype), pr.average, pr.modulation)
                ctx.cache[g.name] = (corrected,) + tuple(ctx.cache[g.name][1:])
                done.append({**info, "group": g.name, "applied": True, "ripple_rad": lut.amplitude})
    return done


#: Passes after the first: each refits the ripple with the fringe orders of the previous one (a
#: strong ripple breaks orders of the first pass where two close periods beat).
PASSES = 3


def self_calibrate(ctx: DecodeContext, first: Unwrapped, method: Callable[[DecodeContext], Unwrapped],
                   period: float) -> Unwrapped:
    """The last pass of ``method`` on the groups corrected with the orders of the pass before,
    starting from the first pass ``first`` (absolute phase at ``period`` px; see the module
    docstring); at most :data:`PASSES`, fewer once the order-consistent pixels stop growing. Records what was done in
    ``ctx.cache["radiometry"]["compensation"]``. ``first`` itself when nothing could be corrected."""
    raw = {g.name: ctx.group_phase(g) for g in ctx.groups_for_plan()}
    latest, done = first, []
    for _ in range(PASSES):
        done = estimate_and_correct(ctx, raw, latest, period)
        if not any(d["applied"] for d in done):
            break
        again = method(ctx)
        grew = _consistent(again).sum() > _consistent(latest).sum()
        latest = again  # the cache holds the groups this pass unwrapped
        if not grew:
            break
    ctx.cache.setdefault("radiometry", {}).setdefault("compensation", []).extend(done)
    return latest
