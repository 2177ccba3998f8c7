"""Phase unwrapping: temporal (hierarchical, heterodyne, Gray code) and the method registry.

Other methods (geometric, spatial, hybrid, histogram) live in their own modules here and
register themselves with :func:`fringe3d.unwrap.registry.register`.
"""
from fringe3d.unwrap.registry import UNWRAPPERS, DecodeContext, get_unwrapper, register

__all__ = ["UNWRAPPERS", "DecodeContext", "get_unwrapper", "register"]
