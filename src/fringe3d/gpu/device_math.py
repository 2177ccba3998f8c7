"""Inline CUDA device functions the kernels share: one phase-shifted group's least-squares sums,
and floor / mod 2 pi that never convert a NaN or inf to an integer.

Imported only after :func:`fringe3d.gpu.runtime.cuda_module` has checked that ``numba.cuda``
can run. Same model as :mod:`fringe3d.phase._kernels`: ``I_k = a + b cos d_k + c sin d_k``,
``(a, b, c) = P @ I`` for the (3, N) pseudo-inverse ``P`` (Eq. 2.4).
"""
from __future__ import annotations

import math

import numpy as np
from numba import cuda

TWO_PI = 2.0 * math.pi
F2PI = np.float32(TWO_PI)
FINV2PI = np.float32(1.0 / TWO_PI)
F0 = np.float32(0.0)
FHALF = np.float32(0.5)


@cuda.jit(device=True)
def group_sums64(frames, cyc, idx, coef, p):
    """``(a, b, c, peak)`` float64 of the group ``frames[cyc, idx[k], p]``, k = 0..N-1; ``peak``
    is the largest value (for the saturation test)."""
    a = 0.0
    b = 0.0
    c = 0.0
    peak = -math.inf
    for k in range(idx.shape[0]):
        x = np.float64(frames[cyc, idx[k], p])
        a += coef[0, k] * x
        b += coef[1, k] * x
        c += coef[2, k] * x
        peak = x if x > peak else peak  # not max(): the built-in numba.cuda target cannot type it
    return a, b, c, peak


@cuda.jit(device=True)
def group_sums32(frames, cyc, idx, coef, p):
    """float32 version of :func:`group_sums64` (``coef`` float32), as the CPU three-frequency kernel."""
    a = F0
    b = F0
    c = F0
    peak = np.float32(-math.inf)
    for k in range(idx.shape[0]):
        x = np.float32(frames[cyc, idx[k], p])
        a += coef[0, k] * x
        b += coef[1, k] * x
        c += coef[2, k] * x
        peak = x if x > peak else peak  # not max(): the built-in numba.cuda target cannot type it
    return a, b, c, peak


@cuda.jit(device=True)
def smaller(a, b):
    """``min(a, b)`` (the builtin does not compile on numba's built-in CUDA target)."""
    return a if a < b else b


@cuda.jit(device=True)
def larger(a, b):
    """``max(a, b)``."""
    return a if a > b else b


@cuda.jit(device=True)
def floor_f(x):
    """``floor(x)`` as a float (NaN / inf pass through instead of becoming an integer)."""
    return math.floor(x) if math.isfinite(x) else x


@cuda.jit(device=True)
def ceil_f(x):
    """``ceil(x)`` as a float (NaN / inf pass through)."""
    return math.ceil(x) if math.isfinite(x) else x


@cuda.jit(device=True)
def floor_f32(x):
    """float32 ``floor(x)`` (NaN / inf pass through)."""
    return np.float32(math.floor(x)) if math.isfinite(x) else x


@cuda.jit(device=True)
def mod_2pi_f32(x):
    """``x mod 2 pi`` in float32, as :func:`fringe3d.phase._kernels.mod_2pi_f32`."""
    return x - F2PI * floor_f32(x * FINV2PI)
