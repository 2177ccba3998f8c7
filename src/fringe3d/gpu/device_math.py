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


# atan(x) ~= x * P(x^2) on [0, 1]: the coefficients of :func:`fringe3d.phase._kernels.fast_atan2_f32`
# (this layer sits below ``phase``, so they are repeated here; tests/test_cuda_temporal.py checks
# that they are the same numbers).
ATAN_COEFFICIENTS = (0.99999944, -0.33330106, 0.19948505, -0.1391578, 0.09656195, -0.05606228, 0.02194596,
                     -0.00407312)
FB0, FB1, FB2, FB3, FB4, FB5, FB6, FB7 = (np.float32(c) for c in ATAN_COEFFICIENTS)
FPI = np.float32(math.pi)
FHALFPI = np.float32(0.5 * math.pi)
#: 1.5 * 2**52: adding and subtracting it rounds a float64 of magnitude below 2**51 to the nearest
#: integer, ties to even (``np.rint``), in the default rounding mode.
RINT_MAGIC = 6755399441055744.0


@cuda.jit(device=True)
def fast_atan2_f32(y, x):
    """float32 ``atan2(y, x)`` by the CPU kernels' polynomial (|error| < 3e-7 rad), the same
    operations in the same order as :func:`fringe3d.phase._kernels.fast_atan2_f32`."""
    ax = abs(x)
    ay = abs(y)
    mx = ax if ax > ay else ay
    mn = ax if ax < ay else ay
    a = mn / mx if mx > F0 else F0
    s = a * a
    r = a * (FB0 + s * (FB1 + s * (FB2 + s * (FB3 + s * (FB4 + s * (FB5 + s * (FB6 + s * FB7)))))))
    r = (FHALFPI - r) if ay > ax else r
    r = (FPI - r) if x < F0 else r
    return -r if y < F0 else r


@cuda.jit(device=True)
def rint64(x):
    """float64 ``np.rint(x)`` (nearest integer, ties to even) of a finite ``x``."""
    if abs(x) >= 2251799813685248.0:  # 2**51: already an integer
        return x
    return (x + RINT_MAGIC) - RINT_MAGIC
