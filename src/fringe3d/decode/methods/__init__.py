"""The decoding methods, one explicit table keyed by ``DirectionPlan.method``.

Each entry is ``fn(ctx: DecodeContext) -> Unwrapped`` for one fringe direction: the plan's
absolute phase (narrowest period unless ``Unwrapped.period`` says otherwise), its mask and
optional overrides (see :class:`fringe3d.decode.result.Unwrapped`). A new method is one
function and one line here.
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


def method_for(name: str) -> Method:
    """The decoding method called ``name``; ``ValueError`` naming the known ones otherwise."""
    try:
        return METHODS[name]
    except KeyError:
        raise ValueError(f"unknown unwrapping method {name!r}; known methods: {sorted(METHODS)}") from None


def run_method(ctx: DecodeContext) -> Unwrapped:
    """Run the method of ``ctx.plan`` on ``ctx``."""
    return method_for(ctx.plan.method)(ctx)


__all__ = ["METHODS", "Method", "method_for", "run_method"]
