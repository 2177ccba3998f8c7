"""High-dynamic-range fusion of an exposure-bracketed capture: per pixel, the frames of one exposure.

A bracketed capture holds the same pattern cycle (``F`` frames) at ``E`` exposures (or gains). A
shiny part saturates the long exposures on its highlights; a dark or black part drowns in noise in
the short ones. Per camera pixel this module keeps the whole cycle of **one** exposure: among the
exposures in which none of the pixel's ``F`` samples reaches the saturation level, the one with the
largest temporal range ``max_k I_k - min_k I_k`` (a pattern-independent modulation: ``2 B`` for an
N-step sinusoid of modulation ``B``; the largest range is the highest signal-to-noise ratio, since
phase noise falls as ``sigma / B``, Eq. 2.29). Where every exposure saturates, the exposure with
the fewest saturated samples (the first listed on ties: list the bracket shortest first), so that
the decoder's saturation handling (:mod:`fringe3d.phase.clipping`) sees the least-clipped cycle and
flags what it cannot use.

Phase, codes and the per-pixel code thresholds are ratios of the pixel's own samples, so no rescaling
between exposures is needed: the fused cycle keeps the frames' dtype and counts and decodes like
any single capture. The fused ``average`` and ``modulation`` maps are then patchwork across
exposures (divide by ``exposures[index]`` for radiance).

Cost: ``E`` times the frames and the capture time of one exposure (plus the exposure times
themselves: a 1, 4, 16 bracket of a 10 ms base exposure adds 210 ms per cycle).

>>> import numpy as np
>>> short = np.array([[[10]], [[30]], [[20]]], np.uint8)      # (F, H, W) = (3, 1, 1)
>>> long = np.array([[[40]], [[120]], [[80]]], np.uint8)
>>> longest = np.array([[[160]], [[255]], [[255]]], np.uint8)  # saturated
>>> f = fuse_exposures(np.stack([short, long, longest]), 255.0)
>>> int(f.index[0, 0]), f.frames[:, 0, 0].tolist(), bool(f.saturated[0, 0])
(1, [40, 120, 80], False)
"""
from __future__ import annotations

from dataclasses import dataclass

import numpy as np


@dataclass(frozen=True)
class Fusion:
    """Result of :func:`fuse_exposures`.

    Attributes
    ----------
    frames : (F, H, W) array, the stacks' dtype
        Per pixel the cycle of the chosen exposure.
    index : (H, W) uint8
        The chosen exposure (index into the bracket).
    saturated : (H, W) bool
        Every exposure has a saturated sample at the pixel.
    share : (E,) float
        Share of the pixels that took each exposure.
    """

    frames: np.ndarray
    index: np.ndarray
    saturated: np.ndarray
    share: np.ndarray


def fuse_exposures(stacks: np.ndarray, saturation_level: float) -> Fusion:
    """Per-pixel exposure choice of the module's rule.

    Parameters
    ----------
    stacks : (E, F, H, W) array
        The same ``F``-frame pattern cycle at ``E`` exposures (any order).
    saturation_level : float
        Value at or above which a sample is saturated (:func:`fringe3d.phase.quality.saturation_level`;
        ``inf``: nothing saturates, the largest range wins everywhere).

    Returns
    -------
    Fusion
    """
    s = np.asarray(stacks)
    if s.ndim != 4 or s.shape[0] < 1 or s.shape[1] < 1:
        raise ValueError(f"exposure stacks must have shape (exposures, frames, H, W), got {s.shape}")
    if s.shape[0] > 255:
        raise ValueError(f"at most 255 exposures can be fused, got {s.shape[0]}")
    E = s.shape[0]
    score = np.empty((E,) + s.shape[2:])
    sat = np.empty((E,) + s.shape[2:], bool)
    for e in range(E):  # per exposure: (H, W) maps only, no (E, F, H, W) temporaries
        hi, lo = s[e].max(axis=0), s[e].min(axis=0)
        sat[e] = hi >= saturation_level
        score[e] = np.where(sat[e], -np.inf, hi.astype(np.float64) - lo)
    best = np.argmax(score, axis=0)
    all_sat = np.asarray(sat.all(axis=0))
    if all_sat.any():  # the fewest saturated samples; first (lowest index) on ties
        rows = np.flatnonzero(all_sat)
        clipped = np.stack([(s[e].reshape(s.shape[1], -1)[:, rows] >= saturation_level).sum(axis=0)
                            for e in range(E)])
        best.flat[rows] = np.argmin(clipped, axis=0)
    index = best.astype(np.uint8)
    frames = np.array(s[0])
    for e in range(1, E):
        np.copyto(frames, s[e], where=(index == e)[None])
    share = np.bincount(index.ravel(), minlength=E) / index.size
    return Fusion(frames=frames, index=index, saturated=all_sat, share=share)


def split_bracket(frames: np.ndarray, n_exposures: int, cycle_length: int) -> np.ndarray:
    """``(E * F, H, W)`` frames, exposure-major (all of exposure 0's cycle first), as
    ``(E, F, H, W)``; ``ValueError`` naming the counts when they do not fit."""
    f = np.asarray(frames)
    if n_exposures < 1 or f.shape[0] != n_exposures * cycle_length:
        raise ValueError(f"an exposure bracket of {n_exposures} exposures needs {n_exposures} x {cycle_length} = "
                         f"{n_exposures * cycle_length} frames (one pattern cycle per exposure), got {f.shape[0]}")
    return f.reshape((n_exposures, cycle_length) + f.shape[1:])
