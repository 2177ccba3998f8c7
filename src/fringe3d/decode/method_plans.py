"""Choosing an unwrapping method for a capture: one plan per fringe direction, fed by what the
manifest holds.

:func:`with_method` replaces every direction's plan by ``method``; for a direction with phase
frames :func:`plan_for_method` also picks the periods the method needs (the narrowest; the
narrowest and the coarsest; all of them) or says what the manifest lacks; a code-only direction
(Gray/binary code frames, no phase) keeps its code and takes the method as given. What a method
needs and which periods it takes are its facts in :mod:`fringe3d.patterns.method_registry`.
"""
from __future__ import annotations

import dataclasses

from fringe3d.decode.context import phase_groups
from fringe3d.decode.methods import method_for
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.patterns.method_registry import ALL, NARROWEST_AND_COARSEST, method_facts

def _group_periods(ps: PatternSet, direction: str) -> list[float]:
    return [g.period for g in phase_groups(ps, direction)]


def plan_for_method(ps: PatternSet, direction: str, method: str) -> DirectionPlan:
    """A plan that unwraps ``direction`` of ``ps`` with ``method``, or a ValueError saying what
    the manifest lacks ("a method the manifest cannot feed")."""
    facts = method_facts(method)
    if facts.groups < 1:
        raise ValueError(f"method {method!r} reads code frames only; it takes no phase groups (periods)")
    for p in ps.plans:
        if p.direction == direction and p.method == method:
            return p
    need_groups, code = facts.groups, facts.code
    periods = sorted(_group_periods(ps, direction))
    label = ps.name or "unnamed set"
    if len(periods) < need_groups:
        raise ValueError(f"method {method!r} needs {need_groups} phase groups (fringe periods) in direction "
                         f"{direction!r}, but the manifest ({label}) has {len(periods)} "
                         f"(periods {periods}); choose a method the pattern set can feed")
    if code and not ps.indices(kind=code, direction=direction):
        raise ValueError(f"method {method!r} needs {code} frames for direction {direction!r}, but the manifest "
                         f"({label}) has none; choose a method the pattern set can feed")
    chosen: tuple[float, ...]
    if facts.periods == NARROWEST_AND_COARSEST:
        chosen = (periods[0], periods[-1])
    elif facts.periods == ALL:
        chosen = tuple(periods)
    else:
        chosen = (periods[0],)
    angle = ps.frames[ps.indices(direction=direction, role="phase")[0]].angle
    old = [p for p in ps.plans if p.direction == direction]
    options = dict(old[0].options) if old else {}  # keep e.g. the phase method and w_range
    return DirectionPlan(direction=direction, angle=angle, method=method, periods=chosen, options=options)


def with_method(ps: PatternSet, method: str | None) -> PatternSet:
    """``ps`` with every fringe direction's plan replaced by ``method``.

    A direction without a plan gets one.

    Parameters
    ----------
    ps : PatternSet
        The manifest.
    method : str or None
        A key of :data:`fringe3d.decode.METHODS`, e.g. ``"spatial"`` for a single 3-step set;
        None leaves ``ps`` unchanged.

    Returns
    -------
    PatternSet
        The manifest with the method in every direction's plan.

    Raises
    ------
    ValueError
        ``method`` is not a known method (the message names them).

    Examples
    --------
    >>> from fringe3d.patterns import sets
    >>> with_method(sets.phase_shift(16, 3, "v", width=64, height=48), "spatial").plans[0].method
    'spatial'
    """
    if method is None:
        return ps
    method_for(method)
    takes_groups = method_facts(method).groups > 0
    plans = []
    for d in ps.directions():
        old = next((p for p in ps.plans if p.direction == d), None)
        if ps.groups(direction=d, role="phase") and takes_groups:
            plans.append(plan_for_method(ps, d, method))
        elif old is not None:
            plans.append(dataclasses.replace(old, method=method))
        else:
            angle = ps.frames[ps.indices(direction=d)[0]].angle
            plans.append(DirectionPlan(direction=d, angle=angle, method=method))
    return dataclasses.replace(ps, plans=tuple(plans))


def plans_to_decode(ps: PatternSet) -> list[DirectionPlan]:
    """The plans the decoder runs: the manifest's, plus ``method="none"`` (wrapped phase) for
    every direction with phase frames but no plan; ValueError when there is nothing to decode."""
    plans = list(ps.plans)
    planned = {p.direction for p in plans}
    for d in ps.directions():
        if d not in planned and ps.groups(direction=d, role="phase"):
            f = ps.frames[ps.indices(direction=d)[0]]
            plans.append(DirectionPlan(direction=d, angle=f.angle, method="none"))
    if not plans:
        raise ValueError("the pattern manifest has no phase frames and no unwrapping plans; nothing to decode")
    return plans
