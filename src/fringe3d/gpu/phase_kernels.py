"""CUDA kernel of the N-step least-squares wrapped phase (Eq. 2.4; the 3-step set, Eq. 1.4, is
N = 3), one thread per pixel and cycle.

Same arithmetic as :func:`fringe3d.phase._kernels.psp_kernel`: float32 sums, atan2 and sqrt in
float32. Layout: ``frames (C, F, P)`` (cycles, frames, pixels ``P = H*W``), outputs ``(C, P)``.
"""
from __future__ import annotations

import math

from numba import cuda

from fringe3d.gpu.device_math import group_sums32


@cuda.jit
def psp_kernel(frames, idx, coef, sat_level, phase, average, modulation, saturated):
    """frames (C, F, P) any real dtype; idx (N,) int64; coef (3, N) float32 pseudo-inverse;
    sat_level float32: saturated when any used value (as float32) >= it (inf: never). Outputs (C, P): phase float32
    rad in (-pi, pi], average and modulation float32 (frames' units), saturated bool."""
    p, cyc = cuda.grid(2)
    if p >= frames.shape[2] or cyc >= frames.shape[0]:
        return
    a, bf, cf, peak = group_sums32(frames, cyc, idx, coef, p)
    phase[cyc, p] = math.atan2(-cf, bf)
    average[cyc, p] = a
    modulation[cyc, p] = math.sqrt(bf * bf + cf * cf)
    saturated[cyc, p] = peak >= sat_level
