"""Plain-NumPy reference of the clipping-bias kernel (:func:`fringe3d.phase.clipping.clipping_bias`),
used only by the tests: pixels grouped by clipping pattern, the unclipped samples' sinusoid from
:func:`fringe3d.phase.psp.lsq_coefficients`, the bound from the cone of the clipped samples'
weights and, for one clipped sample, the non-negative trough (module docstring of
:mod:`fringe3d.phase.clipping`)."""
from __future__ import annotations

import math
from typing import Sequence

import numpy as np

from fringe3d.phase.clipping import ClippingBias
from fringe3d.phase.psp import lsq_coefficients


def clipping_bias_reference(samples: np.ndarray, shifts: Sequence[float], level: float) -> ClippingBias:
    """:func:`clipping_bias` in NumPy, grouped by clipping pattern (the reference the numba kernel
    is tested against)."""
    s = np.asarray(samples, np.float64)
    d = np.asarray(shifts, np.float64)
    p = lsq_coefficients(d)
    w = p[1] - 1j * p[2]                                         # (N,) contribution to z
    z = (p[1] @ s) - 1j * (p[2] @ s)                             # (M,) measured B exp(i phi)
    clipped = s >= level
    bias = np.zeros(s.shape[1])
    estimated = np.zeros(s.shape[1], bool)
    modulation = np.abs(z)
    if not clipped.any():
        return ClippingBias(bias, estimated, modulation)
    dtype = np.dtype(np.uint16 if s.shape[0] <= 16 else np.int64)            # the clipping pattern's bits
    code: np.ndarray = np.zeros(s.shape[1], dtype)
    for k in range(s.shape[0]):
        code = code | (clipped[k].astype(dtype) << dtype.type(k))
    order = np.argsort(code, kind="stable")                      # a radix sort for 16-bit codes
    keys, starts = np.unique(code[order], return_index=True)
    for key, cols in zip(keys, np.split(order, starts[1:])):   # the pixels of one clipping pattern
        if key == 0:
            continue
        pattern = ((int(key) >> np.arange(s.shape[0])) & 1).astype(bool)
        fit = _unclipped_fit(d, pattern)
        if fit is not None:                                      # estimated from the unclipped samples
            deficit = fit @ s[np.ix_(~pattern, cols)] - level    # (k, m) signed
            z_true = z[cols] + w[pattern] @ deficit
            bias[cols] = np.angle(z_true * np.conj(z[cols]))
            estimated[cols] = True
            modulation[cols] = np.abs(z_true)
        else:                                                    # bounded: deficits >= 0 unknown
            theta = np.angle(w[pattern][:, None] * np.conj(z[cols])[None, :])   # (k, m)
            narrow = (theta.max(axis=0) - theta.min(axis=0)) < math.pi
            bias[cols] = np.where(narrow, np.abs(theta).max(axis=0), math.pi)
            if pattern.sum() == 1:
                k = int(np.flatnonzero(pattern)[0])
                bias[cols] = np.minimum(bias[cols], _trough_bound(z[cols], p[0] @ s[:, cols], w[k], p[0, k]))
    return ClippingBias(bias, estimated, modulation)


def _trough_bound(z: np.ndarray, a: np.ndarray, wk: complex, pk: float) -> np.ndarray:
    """(m,) bound (rad) on the bias of one clipped sample from a non-negative light: its deficit
    ``D`` raises the average to ``a + pk D`` and the amplitude to ``z + D wk``, and the true
    sinusoid's minimum ``A - B`` cannot fall below 0, so ``D`` is at most the root of
    ``|z + D wk|^2 = (a + pk D)^2`` (``pk``, ``wk`` the sample's weights in ``a`` and ``z``);
    the phase moves monotonically with ``D``, so the bias is at most ``|arg((z + D_max wk) / z)|``."""
    qa = abs(wk) ** 2 - pk * pk
    qb = 2.0 * np.real(z * np.conj(wk)) - 2.0 * a * pk
    qc = np.abs(z) ** 2 - a * a
    with np.errstate(invalid="ignore", divide="ignore"):
        d_max = (-qb + np.sqrt(qb * qb - 4.0 * qa * qc)) / (2.0 * qa)
    out = np.abs(np.angle((z + d_max * wk) * np.conj(z)))
    return np.where((qa > 0) & (qc <= 0) & np.isfinite(out), out, math.pi)


def _unclipped_fit(shifts: np.ndarray, clipped: np.ndarray) -> np.ndarray | None:
    """(k, N - k) matrix predicting the k clipped samples from the unclipped ones (the sinusoid
    fitted to the unclipped samples, evaluated at the clipped shifts), or None when fewer than
    3 unclipped samples (or shifts that cannot separate A, B and phi) remain."""
    keep = shifts[~clipped]
    if keep.size < 3:
        return None
    try:
        coef = lsq_coefficients(keep)                            # (3, N - k)
    except ValueError:
        return None
    dc = shifts[clipped]
    design = np.stack([np.ones_like(dc), np.cos(dc), np.sin(dc)], axis=1)   # (k, 3)
    return design @ coef
