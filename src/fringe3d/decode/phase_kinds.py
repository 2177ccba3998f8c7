"""Which unwrapping methods give an absolute phase: the one table the decoder, the quality
assessment, reconstruction and the command line read (:data:`METHOD_KINDS`).

An *absolute* phase ``Phi = 2 pi w / T`` is a projector fringe coordinate (Eq. 2.1) and
triangulates to the surface. A *wrapped* phase (method ``none``) and a *relative* phase
(``spatial``: one unknown ``2 pi k`` per object, Eq. 5.12) are off by an unknown whole number of
fringe periods, so 3D from them is off by as many period-depths along every camera ray (metres,
not millimetres, on a rig where one period spans tens of millimetres of depth). Both count as
relative here (:data:`RELATIVE_METHODS`).

The code methods (``gray_code``, ``binary_code``, ``gray_code_only``) are absolute: the codeword
names the projector stripe. The geometric methods (:data:`GEOMETRY_METHODS`) are absolute given
the calibrated rig and the nearest depth ``z_min`` (Eq. 4.15-4.21).

>>> RELATIVE_METHODS
('none', 'spatial')
>>> is_relative("gray_code_only"), is_relative("spatial")
(False, True)
"""
from __future__ import annotations

from typing import NamedTuple

from fringe3d.patterns.manifest import DirectionPlan, PatternSet

ABSOLUTE, WRAPPED, RELATIVE = "absolute", "wrapped", "relative"


class MethodKind(NamedTuple):
    """What a method's phase is (``ABSOLUTE``, ``WRAPPED`` or ``RELATIVE``), whether it needs
    the calibrated rig and ``z_min`` (the geometric constraint, Eq. 4.15-4.21) and whether it
    decodes a direction from its code frames alone when the direction has no phase frames."""

    phase: str
    geometry: bool = False
    code: bool = False


#: Every unwrapping method a plan may name (the keys equal
#: :data:`fringe3d.patterns.manifest.UNWRAP_METHODS` and :data:`fringe3d.decode.METHODS`).
METHOD_KINDS: dict[str, MethodKind] = {
    "none": MethodKind(WRAPPED),
    "spatial": MethodKind(RELATIVE),
    "hierarchical": MethodKind(ABSOLUTE),
    "heterodyne": MethodKind(ABSOLUTE),
    "gray_code": MethodKind(ABSOLUTE, code=True),
    "binary_code": MethodKind(ABSOLUTE, code=True),
    "gray_code_only": MethodKind(ABSOLUTE, code=True),
    "geometric": MethodKind(ABSOLUTE, geometry=True),
    "two_frequency_geometric": MethodKind(ABSOLUTE, geometry=True),
    "hybrid": MethodKind(ABSOLUTE, geometry=True),
    "histogram": MethodKind(ABSOLUTE, geometry=True),
}
#: Methods whose phase is not a projector coordinate (wrapped or relative).
RELATIVE_METHODS = tuple(m for m, k in METHOD_KINDS.items() if k.phase != ABSOLUTE)
#: Methods that need the rig and ``z_min``.
GEOMETRY_METHODS = tuple(m for m, k in METHOD_KINDS.items() if k.geometry)
#: Methods that decode a direction from its code frames alone when it has no phase frames.
CODE_METHODS = tuple(m for m, k in METHOD_KINDS.items() if k.code)


def method_kind(method: str) -> MethodKind:
    """The :class:`MethodKind` of ``method``; ValueError naming the known methods otherwise."""
    try:
        return METHOD_KINDS[method]
    except KeyError:
        raise ValueError(f"unknown unwrapping method {method!r}; expected one of {sorted(METHOD_KINDS)}") from None


def is_relative(method: str) -> bool:
    """True when ``method``'s phase is wrapped or relative (its 3D is off by whole periods)."""
    return method_kind(method).phase != ABSOLUTE


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
