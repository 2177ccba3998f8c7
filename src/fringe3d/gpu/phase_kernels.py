"""CUDA kernel of the N-step least-squares wrapped phase (Eq. 2.4; the 3-step set, Eq. 1.4, is
N = 3), one thread per pixel and cycle.

Same arithmetic as :func:`fringe3d.phase._kernels.psp_kernel`: float64 sums, atan2 and sqrt in
float32. Layout: ``frames (C, F, P)`` (cycles, frames, pixels ``P = H*W``), outputs ``(C, P)``.
"""
from __future__ import annotations

import math

import numpy as np
from numba import cuda

from fringe3d.gpu.device_math import group_sums64


@cuda.jit
def psp_kernel(frames, idx, coef, sat_level, phase, average, modulation, saturated):
    """frames (C, F, P) any real dtype; idx (N,) int64; coef (3, N) float64 pseudo-inverse;
    sat_level: saturated when any used value >= it (inf: never). Outputs (C, P): phase float32
    rad in (-pi, pi], average and modulation float32 (frames' units), saturated bool."""
    p, cyc = cuda.grid(2)
    if p >= frames.shape[2] or cyc >= frames.shape[0]:
        return
    a, b, c, peak = group_sums64(frames, cyc, idx, coef, p)
    bf = np.float32(b)
    cf = np.float32(c)
    phase[cyc, p] = math.atan2(-cf, bf)
    average[cyc, p] = np.float32(a)
    modulation[cyc, p] = math.sqrt(bf * bf + cf * cf)
    saturated[cyc, p] = peak >= sat_level
