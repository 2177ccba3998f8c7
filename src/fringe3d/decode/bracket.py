"""Decode an exposure-bracketed capture: fuse its exposures per pixel into one pattern cycle.

A capture folder whose ``capture.json`` has ``exposures`` (a list of exposure times, s, or relative
exposures, shortest first) holds one pattern cycle per exposure, exposure-major: frame ``e * F + k``
is pattern frame ``k`` at ``exposures[e]``. :func:`fuse_bracket` picks per pixel the cycle of one
exposure (:func:`fringe3d.phase.exposure_fusion.fuse_exposures`: the largest temporal range among
the exposures with no saturated sample), which then decodes as any single cycle; a pixel saturated
in every exposure keeps its least-saturated cycle, so the decoder's ``SATURATED`` quality bit marks
exactly the pixels no exposure could measure.
"""
from __future__ import annotations

import math

import numpy as np

from fringe3d.phase.exposure_fusion import Fusion, fuse_exposures, split_bracket
from fringe3d.phase.quality import saturation_level

#: Name of the per-pixel chosen-exposure map a bracketed decode writes (uint8 index into ``exposures``).
INDEX_NAME = "exposure_index.tif"


def check_bracket(exposures, where: str = "capture.json field exposures") -> list[float]:
    """``exposures`` as a list of positive finite numbers; ``ValueError`` naming ``where``."""
    if not isinstance(exposures, list) or not exposures or not all(
            isinstance(e, (int, float)) and not isinstance(e, bool) and math.isfinite(e) and e > 0 for e in exposures):
        raise ValueError(f"{where}: expected a non-empty list of positive exposure times (s), got {exposures!r}")
    return [float(e) for e in exposures]


def fuse_bracket(frames: np.ndarray, exposures, cycle_length: int, bit_depth: int | None) -> Fusion:
    """Fuse a bracketed capture's ``(E * F, H, W)`` frames into one ``(F, H, W)`` cycle.

    ``bit_depth`` (or the frames' dtype) sets the saturation level
    (:func:`fringe3d.phase.quality.saturation_level`).
    """
    ex = check_bracket(exposures)
    stacks = split_bracket(np.asarray(frames), len(ex), cycle_length)
    return fuse_exposures(stacks, saturation_level(stacks[0], bit_depth))
