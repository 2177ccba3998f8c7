"""Decode captured fringe frames to absolute phase, driven by the pattern manifest.

``decode(frames, patterns)`` -> :class:`Decoded`; ``decode_sequence`` for repeated cycles;
``three_frequency_decode`` is the fused single-pass path for the 18/21/144 set.
"""
from fringe3d.decode.decoder import as_frame_stack, decode, decode_sequence
from fringe3d.decode.result import Decoded
from fringe3d.unwrap.temporal import three_frequency_decode

__all__ = ["Decoded", "as_frame_stack", "decode", "decode_sequence", "three_frequency_decode"]
