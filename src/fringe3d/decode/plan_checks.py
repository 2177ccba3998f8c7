"""What a reconstruction checks on its unwrapping plans before anything is computed or written.

* Every direction that triangulates must have an absolute phase (:mod:`fringe3d.patterns.method_registry`):
  3D from a wrapped or relative phase is off by an unknown number of fringe periods along every
  ray, so :func:`check_plans` raises :class:`RelativePhaseError` naming, for each such direction,
  the absolute methods the manifest can feed (and, when ``z_min`` is known, how deep the
  geometric constraint then reaches), unless ``allow_relative`` asks for it anyway.
* A method of the geometric constraint needs the rig and ``z_min`` (:func:`check_geometry`,
  :class:`MissingGeometryError`); ``z_min`` itself is checked by computing the minimum phase
  map (Eq. 4.15-4.19) it is then reused from.

Errors use the library's words (parameter names: ``method``, ``z_min``, ``allow_relative``);
:meth:`RelativePhaseError.explain` spells the fixes with any other words (the command line's flags).
"""
from __future__ import annotations

import math
from dataclasses import dataclass
from typing import Callable

import numpy as np

from fringe3d.decode.method_plans import plan_for_method, plans_to_decode
from fringe3d.optics.rig import Rig
from fringe3d.optics.rig_geometry import RigGeometry
from fringe3d.patterns.manifest import DirectionPlan, PatternSet
from fringe3d.patterns.method_registry import WRAPPED, is_relative
from fringe3d.patterns.method_registry import method_facts as method_kind
from fringe3d.unwrap.geometric import cached_minimum_phase, depth_limit

#: Absolute methods offered instead of a relative plan, best first: the codes (no depth limit),
#: then the geometric constraint (needs ``z_min``; one fringe period of depth beyond it).
FIX_ORDER = ("gray_code", "binary_code", "two_frequency_geometric", "geometric", "histogram")
#: How many of them a message names.
FIXES_SHOWN = 2


@dataclass(frozen=True)
class RelativeDirection:
    """One direction whose plan gives relative phase: its ``method``, the manifest's own plan when
    that one is absolute (``method`` overrode it; else None), the absolute ``fixes`` the manifest
    can feed (best first) and, with a known ``z_min``, ``reach``: the median depth (mm) up to
    which the first geometric fix holds (``inf``: the whole ray)."""

    direction: str
    method: str
    manifest_method: str | None = None
    fixes: tuple[str, ...] = ()
    reach: float | None = None


class RelativePhaseError(ValueError):
    """Reconstruction asked of a plan whose phase is wrapped or relative (see the module docstring)."""

    def __init__(self, source: str, directions: tuple[RelativeDirection, ...], z_min: float | None):
        self.source, self.directions, self.z_min = source, directions, z_min
        super().__init__(self.explain(lambda m, z: f"method={m!r}, z_min={_mm(z)}" if method_kind(m).geometry
                                      else f"method={m!r}",
                                      "method=None", "allow_relative=True"))

    def explain(self, fix: Callable[[str, float | None], str], keep: str, allow: str) -> str:
        """The message with the fixes spelled by ``fix(method, z_min or None)``, the manifest's
        own plan by ``keep`` and the opt-in by ``allow``."""
        parts = [_explain_one(d, self.source, self.z_min, fix, keep) for d in self.directions]
        return " ".join(parts) + f" Or pass {allow} to triangulate the relative phase anyway."


class MissingGeometryError(ValueError):
    """A geometric-constraint method without the rig (``missing="rig"``) or ``z_min``."""

    def __init__(self, direction: str, method: str, missing: str):
        self.direction, self.method, self.missing = direction, method, missing
        what = ("the calibrated rig (parameter rig)" if missing == "rig" else
                "z_min, the nearest depth of the measurement volume in mm (parameter z_min, or the plan's "
                "options['z_min'])")
        super().__init__(f"direction {direction!r}: method {method!r} needs {what}, and none was given")


def _mm(z: float | None) -> str:
    return "MM" if z is None else f"{z:g}"


def _explain_one(d: RelativeDirection, source: str, z_min: float | None,
                 fix: Callable[[str, float | None], str], keep: str) -> str:
    kind = ("wrapped, relative phase" if method_kind(d.method).phase == WRAPPED else
            "relative phase, one unknown offset per object")
    head = (f"direction {d.direction!r} of {source} is unwrapped with {d.method!r} ({kind}): its 3D would be "
            "off by an unknown number of fringe periods in depth.")
    if d.manifest_method is not None:
        return f"{head} The manifest's own plan {d.manifest_method!r} is absolute: use it ({keep})."
    if not d.fixes:
        return (f"{head} The manifest has no frames an absolute method can use in this direction (add code frames "
                "or a coarser period, or measure with the geometric constraint's rig and z_min).")
    shown = " or ".join(f"`{fix(m, z_min)}`" for m in d.fixes[:FIXES_SHOWN])
    note = ""
    if any(method_kind(m).geometry for m in d.fixes[:FIXES_SHOWN]):
        if z_min is None:
            note = (" (MM: the scene's nearest depth in mm; the geometric constraint holds for one fringe period "
                    "of depth beyond it)")
        elif d.reach is not None:
            note = (f" (from z_min = {z_min:g} mm the geometric constraint holds up to "
                    + ("the ray's end" if math.isinf(d.reach) else f"z = {d.reach:.0f} mm, median over the image")
                    + ")")
    return f"{head} Unwrap it absolutely: {shown}{note}."


def _reach(rig: Rig | None, z_min: float | None, plan: DirectionPlan,
           geometry: RigGeometry | None = None) -> tuple[bool, float | None]:
    """Whether the geometric constraint can unwrap ``plan`` on ``rig`` (its fringes change with
    depth at most pixels; True when unknown) and the median depth it reaches from ``z_min``."""
    if rig is None or z_min is None or not plan.periods:
        return True, None
    try:
        mp = cached_minimum_phase(RigGeometry.of(rig, geometry), z_min, plan.periods[-1], plan.angle)
    except ValueError:  # z_min behind the camera: said by check_geometry / the method itself
        return True, None
    if np.mean(mp.sign != 0) < 0.5:
        return False, None
    lim = depth_limit(rig, mp)
    lim = lim[~np.isnan(lim)]
    return True, (float(np.median(lim)) if lim.size else None)


def relative_direction(ps: PatternSet, plan: DirectionPlan, original: PatternSet | None, rig: Rig | None,
                       z_min: float | None, geometry: RigGeometry | None = None) -> RelativeDirection:
    """The :class:`RelativeDirection` of a relative ``plan`` of ``ps`` (``original``: the manifest
    before a method override; ``geometry``: the rig's :class:`RigGeometry`, else one is built)."""
    own = next((p for p in (original or ps).plans if p.direction == plan.direction), None)
    if own is not None and own.method != plan.method and not is_relative(own.method):
        return RelativeDirection(plan.direction, plan.method, manifest_method=own.method)
    fixes, reach = [], None
    for m in FIX_ORDER:
        try:
            candidate = plan_for_method(ps, plan.direction, m)
        except ValueError:  # the manifest cannot feed it
            continue
        if method_kind(m).geometry:
            allowed, r = _reach(rig, z_min, candidate, geometry)
            if not allowed:
                continue
            reach = r if reach is None else reach
        fixes.append(m)
    return RelativeDirection(plan.direction, plan.method, fixes=tuple(fixes), reach=reach)


def check_geometry(ps: PatternSet, rig: Rig | None, z_min: float | None, geometry: RigGeometry | None = None) -> None:
    """:class:`MissingGeometryError` when a plan of a geometric method lacks the rig or ``z_min``
    (the argument, else the plan's ``options["z_min"]``); the ValueError of
    :func:`fringe3d.unwrap.geometric.minimum_phase` for a ``z_min`` no camera ray reaches. The
    maps are kept in ``geometry`` (the rig's :class:`RigGeometry`) when given."""
    for p in plans_to_decode(ps):
        if not method_kind(p.method).geometry:
            continue
        if rig is None:
            raise MissingGeometryError(p.direction, p.method, "rig")
        z = z_min if z_min is not None else p.options.get("z_min")
        if z is None:
            raise MissingGeometryError(p.direction, p.method, "z_min")
        if p.periods:  # the coarsest period's map: the one every geometric method uses, cached for it
            cached_minimum_phase(RigGeometry.of(rig, geometry), float(z), float(p.periods[-1]), p.angle)


def check_plans(ps: PatternSet, rig: Rig | None, z_min: float | None, *, original: PatternSet | None = None,
                source: str = "the manifest", allow_relative: bool = False,
                geometry: RigGeometry | None = None) -> tuple[str, ...]:
    """Check that ``ps`` can give absolute 3D: :func:`check_geometry`, then
    :class:`RelativePhaseError` for the directions whose plan is relative (unless
    ``allow_relative``). Returns those directions (empty when every phase is absolute).

    ``original`` is the manifest before a method override (to point back to its own plan);
    ``source`` names the manifest in messages (e.g. ``CAPTURE/manifest.json``); ``geometry`` is
    the rig's :class:`RigGeometry` that keeps the minimum phase maps (else one is built).
    """
    geometry = None if rig is None else RigGeometry.of(rig, geometry)
    check_geometry(ps, rig, z_min, geometry)
    relative = [p for p in plans_to_decode(ps) if is_relative(p.method)]
    if relative and not allow_relative:
        found = tuple(relative_direction(ps, p, original, rig, z_min, geometry) for p in relative)
        raise RelativePhaseError(source, found, z_min)
    return tuple(p.direction for p in relative)
