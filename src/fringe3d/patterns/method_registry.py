"""The unwrapping methods a plan may name and what each needs: the one registry.

Every fact about a method lives in one :class:`MethodFacts` entry here: the phase it gives
(absolute, wrapped or relative), the phase groups (fringe periods) it needs from a direction, the
code frames it needs, which periods a default plan picks, whether it needs the calibrated rig and
``z_min`` (the geometric constraint, Eq. 4.15-4.21) and whether it decodes a direction from its
code frames alone. The manifest's plan validation (:class:`fringe3d.patterns.manifest.DirectionPlan`),
the default plans (:func:`fringe3d.decode.with_method`), the decoder, the quality assessment, the
relative-phase refusal of ``reconstruct``, the choices of ``fringe3d decode --method`` and the user
guide's table all read it. The method's *function* lives one layer up, in :data:`fringe3d.decode.METHODS`:
:func:`fringe3d.decode.register_method` adds a new method to both in one call, so a method
registered from outside the package can be named in a manifest like a built-in one.

An *absolute* phase ``Phi = 2 pi w / T`` is a projector fringe coordinate (Eq. 2.1) and
triangulates to the surface. A *wrapped* phase (method ``none``) and a *relative* phase
(``spatial``: one unknown ``2 pi k`` per object, Eq. 5.12) are off by an unknown whole number of
fringe periods, so 3D from them is off by as many period-depths along every camera ray; both count
as relative (:func:`is_relative`).

>>> relative_methods()
('none', 'spatial')
>>> method_facts("hybrid").periods, method_facts("hybrid").groups
('narrowest_and_coarsest', 2)
"""
from __future__ import annotations

from typing import Iterable, NamedTuple

ABSOLUTE, WRAPPED, RELATIVE = "absolute", "wrapped", "relative"
PHASE_KINDS = (ABSOLUTE, WRAPPED, RELATIVE)
#: Which phase groups a default plan (:func:`fringe3d.decode.with_method`) unwraps with: the
#: narrowest period only, the narrowest and the coarsest, or all (narrowest first).
NARROWEST, NARROWEST_AND_COARSEST, ALL = "narrowest", "narrowest_and_coarsest", "all"
PERIOD_RULES = (NARROWEST, NARROWEST_AND_COARSEST, ALL)
#: Code frame kinds a method may need.
CODE_KINDS = ("gray_code", "binary_code")


class MethodFacts(NamedTuple):
    """What one unwrapping method is and needs.

    Attributes
    ----------
    phase : str
        ``ABSOLUTE``, ``WRAPPED`` or ``RELATIVE``: what the method's phase is.
    groups : int
        Phase groups (fringe periods) the method needs in a direction; 0 for a method that
        reads code frames only (a default plan then keeps the direction's periods).
    code : str or None
        Code frame kind the method needs in a direction (``"gray_code"``, ``"binary_code"``).
    periods : str
        Period rule of a default plan: ``NARROWEST``, ``NARROWEST_AND_COARSEST`` or ``ALL``.
    geometry : bool
        The method needs the calibrated rig and ``z_min``.
    code_only : bool
        The method decodes a direction from its code frames alone when it has no phase frames.
    """

    phase: str = ABSOLUTE
    groups: int = 1
    code: str | None = None
    periods: str = NARROWEST
    geometry: bool = False
    code_only: bool = False

    def check(self, name: str) -> None:
        """ValueError naming the field of method ``name`` that is not one of its choices."""
        if self.phase not in PHASE_KINDS:
            raise ValueError(f"method {name!r}: phase must be one of {PHASE_KINDS}, got {self.phase!r}")
        if self.periods not in PERIOD_RULES:
            raise ValueError(f"method {name!r}: periods must be one of {PERIOD_RULES}, got {self.periods!r}")
        if self.code is not None and self.code not in CODE_KINDS:
            raise ValueError(f"method {name!r}: code must be None or one of {CODE_KINDS}, got {self.code!r}")
        if isinstance(self.groups, bool) or not isinstance(self.groups, int) or not 0 <= self.groups <= 16:
            raise ValueError(f"method {name!r}: groups must be a whole number 0-16, got {self.groups!r}")


_CODE = MethodFacts(code_only=True)
_GEOMETRY = MethodFacts(geometry=True)
#: The registry: every method a plan may name, built-in ones first (read it through
#: :func:`method_names` / :func:`method_facts`; add to it with :func:`register_facts`).
_REGISTRY: dict[str, MethodFacts] = {
    "none": MethodFacts(WRAPPED),
    "hierarchical": MethodFacts(groups=2, periods=ALL),
    "heterodyne": MethodFacts(groups=2, periods=ALL),
    "gray_code": _CODE._replace(code="gray_code"),
    "binary_code": _CODE._replace(code="binary_code"),
    "gray_code_only": _CODE._replace(groups=0),
    "geometric": _GEOMETRY,
    "two_frequency_geometric": _GEOMETRY._replace(groups=2, periods=NARROWEST_AND_COARSEST),
    "hybrid": _GEOMETRY._replace(groups=2, periods=NARROWEST_AND_COARSEST),
    "spatial": MethodFacts(RELATIVE),
    "histogram": _GEOMETRY,
}

#: The methods that come with fringe3d (the registry before any :func:`register_facts`).
BUILTIN_METHODS = tuple(_REGISTRY)


def register_facts(name: str, facts: MethodFacts, replace: bool = False) -> None:
    """Add method ``name`` with ``facts`` to the registry (``replace``: overwrite an existing
    entry); ValueError for an empty or taken name or a fact out of its choices. Use
    :func:`fringe3d.decode.register_method`, which also registers the method's function."""
    if not isinstance(name, str) or not name.strip() or name != name.strip():
        raise ValueError(f"a method name must be a non-empty string without surrounding spaces, got {name!r}")
    if name in _REGISTRY and not replace:
        raise ValueError(f"unwrapping method {name!r} is already registered; pass replace=True to redefine it")
    facts.check(name)
    _REGISTRY[name] = facts


def unregister(name: str) -> None:
    """Remove method ``name`` from the registry (no error when it is absent)."""
    _REGISTRY.pop(name, None)


def method_names() -> tuple[str, ...]:
    """Every registered method's name, built-in ones first, in registration order."""
    return tuple(_REGISTRY)


def method_facts(name: str) -> MethodFacts:
    """The :class:`MethodFacts` of method ``name``; ValueError naming the known methods otherwise."""
    try:
        return _REGISTRY[name]
    except (KeyError, TypeError):
        raise ValueError(f"unknown unwrapping method {name!r}; expected one of {list(_REGISTRY)} (a method of "
                         "your own: fringe3d.decode.register_method before the manifest is read)") from None


def is_known(name: str) -> bool:
    """True when ``name`` is a registered method."""
    return name in _REGISTRY


def is_relative(name: str) -> bool:
    """True when method ``name``'s phase is wrapped or relative (its 3D is off by whole periods)."""
    return method_facts(name).phase != ABSOLUTE


def relative_methods() -> tuple[str, ...]:
    """Methods whose phase is not a projector coordinate (wrapped or relative)."""
    return tuple(m for m, f in _REGISTRY.items() if f.phase != ABSOLUTE)


def geometry_methods() -> tuple[str, ...]:
    """Methods that need the rig and ``z_min``."""
    return tuple(m for m, f in _REGISTRY.items() if f.geometry)


def code_only_methods() -> tuple[str, ...]:
    """Methods that decode a direction from its code frames alone when it has no phase frames."""
    return tuple(m for m, f in _REGISTRY.items() if f.code_only)


_YES = {True: "yes", False: ""}


def methods_table(names: Iterable[str] | None = None) -> str:
    """The registry (or its methods ``names``) as a Markdown table; ``docs/user-guide.md`` holds
    the built-in methods' table (a test keeps them equal)."""
    rows = ["| method | phase | phase groups | code frames | default periods | needs rig + z_min | code-only |",
            "|---|---|---|---|---|---|---|"]
    for name in (_REGISTRY if names is None else names):
        f = method_facts(name)
        rows.append(f"| `{name}` | {f.phase} | {f.groups} | {f.code or ''} | {f.periods.replace('_', ' ')} "
                    f"| {_YES[f.geometry]} | {_YES[f.code_only]} |")
    return "\n".join(rows)
