"""Why a reconstruction kept no 3D point: the decoder's reason, else the geometry's."""
from __future__ import annotations

import warnings

import numpy as np

from fringe3d.decode import DecodeOptions, decode
from fringe3d.optics import Rig
from fringe3d.patterns.manifest import PatternSet


def why_no_points(frames: np.ndarray, patterns: PatternSet, rig: Rig | None = None,
                  options: DecodeOptions | None = None) -> str:
    """Explain, in a sentence, why no pixel of a capture's first cycle became a 3D point.

    Decodes the first cycle again (its warnings silenced: the reconstruction already gave them).

    Parameters
    ----------
    frames : ndarray
        The captured frames, ``(N, H, W)``; the first ``len(patterns)`` are used.
    patterns : PatternSet
        The manifest of one cycle.
    rig : Rig, optional
        The calibrated rig the reconstruction used.
    options : DecodeOptions, optional
        The decoding options the reconstruction used (its ``z_min``, ``bit_depth``,
        ``min_modulation``, ...); default ``DecodeOptions()``.

    Returns
    -------
    str
        The decoder's reason when no phase is valid (or why it could not start); otherwise that
        the phase is valid but nothing triangulated inside the calibrated volume.
    """
    opts = options if options is not None else DecodeOptions()
    try:
        with warnings.catch_warnings():
            warnings.simplefilter("ignore")
            why = decode(frames[:len(patterns)], patterns, rig=rig, options=opts).empty_reason()
    except ValueError as e:  # the decoder could not even start (e.g. geometric without z_min)
        return str(e)
    return why or ("the phase is valid but no pixel triangulated inside the calibrated volume; check that the "
                   "calibration belongs to this rig and the depth limits (`z_min`)")
