"""Decode captured fringe frames to absolute phase, driven by the pattern manifest.

``decode(frames, patterns, rig, options)`` -> :class:`Decoded`; ``decode_sequence`` for
repeated cycles; :class:`DecodeOptions` are the typed options. Each fringe direction's plan
names a method of :data:`METHODS`, a function ``(DecodeContext) -> Unwrapped``, whose needs are its
entry in :mod:`fringe3d.patterns.method_registry`; :func:`register_method` adds a method to both.
"""
from fringe3d.decode.capture_decode import decode_capture
from fringe3d.decode.context import DecodeContext, PhaseGroup
from fringe3d.decode.decoder import decode, decode_sequence, with_method
from fringe3d.decode.methods import METHODS, register_method
from fringe3d.decode.options import DecodeOptions
from fringe3d.decode.result import Decoded, DirectionMaps, Unwrapped

__all__ = ["METHODS", "DecodeContext", "DecodeOptions", "Decoded", "DirectionMaps", "PhaseGroup", "Unwrapped",
           "decode", "decode_capture", "decode_sequence", "register_method", "with_method"]
