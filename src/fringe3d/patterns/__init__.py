"""Fringe patterns (SPEC §2): sinusoids at any angle and period, binary and dithered
approximations, Gray / simple binary codes, and the :class:`PatternSet` manifest.

Typical use::

    from fringe3d.patterns import sets, render_set
    ps = sets.three_frequency("v", width=800, height=600)
    frames = render_set(ps)          # (15, 600, 800) uint8
"""
from fringe3d.patterns.manifest import DirectionPlan, FrameSpec, PatternSet
from fringe3d.patterns.render import render_frame, render_set, sinusoid_value
from fringe3d.patterns import sets
from fringe3d.patterns.synthetic import frames_from_coordinates

__all__ = ["DirectionPlan", "FrameSpec", "PatternSet", "render_frame", "render_set", "sinusoid_value", "sets",
           "frames_from_coordinates"]
