"""Fringe patterns (ch. 1, 2.2.1, Eq. 2.1-2.2): sinusoids at any angle and period, binary and dithered
approximations, Gray / simple binary codes, the :class:`PatternSet` manifest and the
fringe-coordinate conventions (:mod:`fringe3d.patterns.conventions`).

Typical use::

    from fringe3d.patterns import sets, render_set
    ps = sets.three_frequency("v", width=800, height=600)
    frames = render_set(ps)          # (15, 600, 800) uint8
"""
from fringe3d.patterns import sets
from fringe3d.patterns.binary import area_modulated, pulse_width_modulated, squared_binary
from fringe3d.patterns.codes import decode_bits, gray_decode, gray_encode
from fringe3d.patterns.conventions import (beat_period, coarse_to_fine_order, fringe_coordinate, phase_to_w,
                                           projector_coordinates, w_range, w_to_phase)
from fringe3d.patterns.dither import bayer_dither, floyd_steinberg
from fringe3d.patterns.manifest import DirectionPlan, FrameSpec, PatternSet
from fringe3d.patterns.render import render_frame, render_set, sinusoid_value
from fringe3d.patterns.synthetic import frames_from_coordinates

__all__ = ["DirectionPlan", "FrameSpec", "PatternSet", "render_frame", "render_set", "sinusoid_value", "sets",
           "frames_from_coordinates", "area_modulated", "pulse_width_modulated", "squared_binary", "decode_bits",
           "gray_decode", "gray_encode", "bayer_dither", "floyd_steinberg", "beat_period", "fringe_coordinate",
           "coarse_to_fine_order", "phase_to_w", "projector_coordinates", "w_range", "w_to_phase"]
