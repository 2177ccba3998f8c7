"""The decoder's fused three-frequency pass with its assessment inputs (private; the default
three-frequency plan of :func:`fringe3d.decode.methods.temporal.unwrap_heterodyne`).

:func:`fringe3d.unwrap.temporal.three_frequency_decode` reads the 15 frames once; the
assessment then read them again, several times: each group's clipping flags (a NumPy pass per
frame, :func:`fringe3d.phase.clipping.clipping_mask`), the 9-step group's fit residual
(:func:`fringe3d.phase.noise.fit_residual_variance`) and the coarser groups' wrapped phases and
modulation (two more least-squares passes) for the disagreement and the blur estimate. Here the
one pass of :func:`fringe3d.unwrap._kernels.three_frequency_assess_kernel` returns them all,
with the fringe coordinate ``w`` of the absolute phase the quality map reads (the float32 product
of :func:`fringe3d.patterns.conventions.phase_to_w`, bit for bit) and whether it is finite on the
mask (the map then needs no NaN test); it writes no texture plane (``average + modulation``,
which the decoder makes with the phase sigma).

Tolerances against those references (``tests/test_fused_assess.py``): the decode outputs equal
:func:`three_frequency_decode`'s bit for bit and the clipping flags are exact; the variance is
summed in float32 (relative 1e-4 of the float64 reference at 1 grey level of noise; the phase
sigma of the noise model fitted to it within 1e-4, or 1e-6 rad where c0 + c1 A nearly cancels); the
disagreement and the coarsest modulation come from the decode's own float32 sums of the coarser
groups (:func:`fringe3d.phase.psp.wrapped_phase` sums in float64): the modulation within 1e-6
relative + 2e-5 grey levels, the disagreement within 2e-6 rad and the blur estimate made from
that modulation within 1e-4 px, with the decoder's quality bits unchanged.
"""
from __future__ import annotations

import functools
import math
from typing import NamedTuple, Sequence

import numpy as np

from fringe3d.phase.frames import as_frame_stack
from fringe3d.phase.psp import lsq_coefficients
from fringe3d.unwrap import _kernels as kernels
from fringe3d.unwrap.temporal import FusedResult, beat_chain, coarse_window


class FusedAssessment(NamedTuple):
    """:class:`~fringe3d.unwrap.temporal.FusedResult` of the decode (its ``texture`` None: it is
    ``average + modulation`` in float32, which a caller adds when it needs it) and, each (H, W):
    ``clipped`` (3, H, W) bool per group (a frame at the saturation level; read-only, the same
    zero plane for the three groups, where no group clips), ``variance``
    float32 fit-residual variance of group 1 (None with fewer than 4 steps), ``residual``
    float32 disagreement (rad, 0 where invalid), ``modulation3`` float32 modulation of group 3,
    ``coordinate`` float32 fringe coordinate ``w`` of the absolute phase (px of the narrowest
    period, NaN where invalid; :func:`fringe3d.patterns.conventions.phase_to_w`), and whether
    ``coordinate`` is finite on the whole mask (False only for frames holding inf or NaN);
    ``clip_counts`` how many pixels of each group ``clipped`` holds."""

    decoded: FusedResult
    clipped: np.ndarray
    variance: np.ndarray | None
    residual: np.ndarray
    modulation3: np.ndarray
    coordinate: np.ndarray
    finite: bool
    clip_counts: tuple[int, int, int]


@functools.lru_cache(maxsize=1)
def _zero_planes(h: int, w: int) -> np.ndarray:
    """A read-only (3, h, w) bool view of one (h, w) plane of False, made once per image size
    (the last size kept)."""
    z = np.zeros((h, w), np.bool_)
    z.flags.writeable = False
    return np.broadcast_to(z, (3, h, w))


@functools.lru_cache(maxsize=16)
def _plan_constants(indices: tuple, shifts: tuple, periods: tuple) -> tuple:
    """What :func:`three_frequency_assess` hands its kernel for one plan, whatever the frames
    (cached per plan, never written: the decoder asks per direction and cycle): the (N_g,) int64
    frame indices and (3, N_g) float32 least-squares coefficients of each group, the beat
    periods and signs (:func:`fringe3d.unwrap.temporal.beat_chain`), group 1's (N_1, 3) float32
    design ``[1, cos d_k, sin d_k]`` and the float64 scales of the kernel."""
    idx = [np.asarray(i, dtype=np.int64) for i in indices]
    coef = [lsq_coefficients(s).astype(np.float32) for s in shifts]
    beats, signs = beat_chain(periods)
    d = np.asarray(shifts[0], np.float64)
    design = np.stack([np.ones_like(d), np.cos(d), np.sin(d)], axis=1).astype(np.float32)
    n1 = d.size
    scales = np.array([periods[0] / periods[1], periods[0] / periods[2], 1.0 / (n1 - 3) if n1 > 3 else 0.0,
                       periods[0] / (2.0 * math.pi)])  # the last as phase_to_w's scale
    return idx, coef, beats, signs, design, scales  # writeable (a read-only array is another kernel type)


def three_frequency_assess(frames: np.ndarray, indices: Sequence[Sequence[int]], shifts: Sequence[Sequence[float]],
                           periods: Sequence[float], w_range: tuple[float, float] | None,
                           thresholds: tuple[float, float, float]) -> FusedAssessment:
    """One pass: :func:`fringe3d.unwrap.temporal.three_frequency_decode` of ``frames`` (F, H, W)
    with ``thresholds = (min_modulation, max_residual, saturation level of the clipping flags)``
    (the mask ignores saturation, as the decoder's call does) and the assessment maps of
    :class:`FusedAssessment`."""
    frames = as_frame_stack(frames)
    min_modulation, max_residual, level = (float(t) for t in thresholds)
    idx, coef, beats, signs, design, scales = _plan_constants(
        tuple(tuple(int(k) for k in i) for i in indices), tuple(tuple(float(x) for x in np.ravel(s)) for s in shifts),
        tuple(float(p) for p in periods))
    for i in idx:
        if i.size and (i.min() < 0 or i.max() >= frames.shape[0]):
            raise ValueError(f"frame index {i.tolist()} out of range for {frames.shape[0]} frames")
    params = np.array([signs[0], signs[1], beats[1] / beats[0], beats[0] / periods[0],
                       coarse_window(beats[-1], w_range), min_modulation, 3e38, max_residual,
                       min(level, 3e38)], dtype=np.float32)
    n1 = design.shape[0]
    h, w = frames.shape[1:]
    out = FusedResult(np.empty((h, w), np.float32), np.empty((h, w), np.float32), np.empty((h, w), np.float32),
                      np.empty((h, w), np.float32), np.empty((h, w), np.bool_), None)
    coordinate = np.empty((h, w), np.float32)
    nonfinite = np.zeros(h, np.uint8)
    packed = np.empty((h, w), np.uint8)  # bit g: group g clipped
    clip_rows = np.empty((3, h), np.int32)
    variance = np.empty((h, w) if n1 >= 4 else (1, 1), np.float32)
    residual = np.empty((h, w), np.float32)
    modulation3 = np.empty((h, w), np.float32)
    kernels.three_frequency_assess_kernel(frames, idx[0], coef[0], idx[1], coef[1], idx[2], coef[2], params,
                                          design, scales, *out[:5], coordinate, packed, variance, residual,
                                          modulation3, nonfinite, clip_rows)
    counts = (tuple(int(c) for c in clip_rows.sum(axis=1, dtype=np.int64)) if math.isfinite(level)
              else (0, 0, 0))
    if any(counts):
        clipped = np.zeros((3, h, w), np.bool_)  # a group without a clipped pixel is never written
        for g, c in enumerate(counts):
            if c:
                np.not_equal(packed & np.uint8(1 << g), 0, out=clipped[g])
    else:  # most captures: one read-only zero plane for the three groups, kept between calls (no memset)
        clipped = _zero_planes(h, w)
    return FusedAssessment(out, clipped, variance if n1 >= 4 else None, residual, modulation3, coordinate,
                           not nonfinite.any(), (counts[0], counts[1], counts[2]))
