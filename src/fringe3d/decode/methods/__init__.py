"""The decoding methods' functions, one explicit table keyed by ``DirectionPlan.method``.

Each entry is ``fn(ctx: DecodeContext) -> Unwrapped`` for one fringe direction: the plan's
absolute phase (narrowest period unless ``Unwrapped.period`` says otherwise), its mask and
optional overrides (see :class:`fringe3d.decode.result.Unwrapped`). What each method needs (phase
groups, code frames, period rule, absolute or relative, rig) is its entry in the method registry,
:mod:`fringe3d.patterns.method_registry`, one layer down so that the manifest can check a plan's
method without the decoder. A new method is one function and one :func:`register_method` call,
from inside the package or outside it::

    register_method("my_method", unwrap_mine, groups=2, periods="all")
"""
from __future__ import annotations

from typing import Callable

from fringe3d.decode.context import DecodeContext
from fringe3d.decode.methods.code_only import unwrap_code, unwrap_code_only
from fringe3d.decode.methods.geometric import unwrap_geometric, unwrap_two_frequency_geometric
from fringe3d.decode.methods.histogram import unwrap_histogram
from fringe3d.decode.methods.hybrid import unwrap_hybrid
from fringe3d.decode.methods.spatial import unwrap_spatial
from fringe3d.decode.methods.temporal import unwrap_heterodyne, unwrap_hierarchical, unwrap_none
from fringe3d.decode.result import Unwrapped
from fringe3d.patterns.method_registry import ABSOLUTE, NARROWEST, MethodFacts, is_known, method_names, register_facts

Method = Callable[[DecodeContext], Unwrapped]

METHODS: dict[str, Method] = {
    "none": unwrap_none,
    "hierarchical": unwrap_hierarchical,
    "heterodyne": unwrap_heterodyne,
    "gray_code": unwrap_code,
    "binary_code": unwrap_code,
    "gray_code_only": unwrap_code_only,
    "geometric": unwrap_geometric,
    "two_frequency_geometric": unwrap_two_frequency_geometric,
    "spatial": unwrap_spatial,
    "histogram": unwrap_histogram,
    "hybrid": unwrap_hybrid,
}


def register_method(name: str, fn: Method, *, phase: str = ABSOLUTE, groups: int = 1, code: str | None = None,
                    periods: str = NARROWEST, geometry: bool = False, code_only: bool = False,
                    replace: bool = False) -> None:
    """Register unwrapping method ``name``: its function ``fn(ctx) -> Unwrapped`` here and its
    facts (:class:`fringe3d.patterns.method_registry.MethodFacts`) in the method registry, so
    that a manifest's plan, :func:`fringe3d.decode.with_method`, ``fringe3d decode --method`` and
    ``fringe3d reconstruct --method`` accept it.

    Parameters
    ----------
    name : str
        The name a plan's ``method`` gives.
    fn : callable
        ``(DecodeContext) -> Unwrapped`` for one direction.
    phase : str
        ``"absolute"`` (a projector coordinate: triangulates), ``"wrapped"`` or ``"relative"``.
    groups : int
        Phase groups (fringe periods) the method needs in a direction (0: code frames only).
    code : str or None
        Code frame kind the method needs (``"gray_code"``, ``"binary_code"``).
    periods : str
        The periods a default plan takes: ``"narrowest"``, ``"narrowest_and_coarsest"`` or ``"all"``.
    geometry : bool
        The method needs the calibrated rig and ``z_min``.
    code_only : bool
        The method decodes a direction with code frames and no phase frames.
    replace : bool
        Redefine a method already registered (else ValueError).
    """
    if not callable(fn):
        raise ValueError(f"method {name!r}: fn must be callable (DecodeContext) -> Unwrapped, got {fn!r}")
    register_facts(name, MethodFacts(phase, groups, code, periods, geometry, code_only), replace=replace)
    METHODS[name] = fn


def method_for(name: str) -> Method:
    """The decoding method called ``name``; ``ValueError`` naming the known ones otherwise."""
    try:
        return METHODS[name]
    except KeyError:
        why = ("has facts in the method registry but no function (register it with "
               "fringe3d.decode.register_method)" if is_known(name) else "is unknown")
        raise ValueError(f"unwrapping method {name!r} {why}; known methods: {sorted(METHODS)}") from None


def run_method(ctx: DecodeContext) -> Unwrapped:
    """Run the method of ``ctx.plan`` on ``ctx``."""
    return method_for(ctx.plan.method)(ctx)


if set(METHODS) != set(method_names()):  # the built-in tables cannot drift apart
    raise ImportError(f"decode.methods.METHODS {sorted(METHODS)} and the method registry {sorted(method_names())} "
                      "name different methods")

__all__ = ["METHODS", "Method", "method_for", "register_method", "run_method"]
