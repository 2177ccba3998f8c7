"""The multi-frequency unwrapping residual of :func:`fringe3d.decode.edges.disagreement` in
numba (private): one pass per coarser group, ``wrap(x) = x - 2 pi round(x / 2 pi)`` in float64
on the float32 maps, no complex temporaries (``np.angle(np.exp(1j x))`` made five full-image
complex128/float64 arrays per group)."""
from __future__ import annotations

import math

import numba
import numpy as np

TWO_PI = 2.0 * math.pi


@numba.njit(parallel=True, cache=True)
def _max_wrapped_residual(phase, wrapped, scale, out):  # pragma: no cover - compiled
    H, W = phase.shape
    for i in numba.prange(H):
        for j in range(W):
            x = np.float64(wrapped[i, j]) - np.float64(phase[i, j]) * scale
            r = abs(x - TWO_PI * np.round(x / TWO_PI))
            if r > out[i, j]:  # NaN never wins: fmax semantics
                out[i, j] = np.float32(r)


def max_wrapped_residual(phase: np.ndarray, wrapped: np.ndarray, scale: float, out: np.ndarray) -> None:
    """``out = fmax(out, |wrap(wrapped - phase * scale)|)`` in place; (H, W) ``phase``,
    ``wrapped`` (rad, any float dtype), ``out`` (H, W) float32 C-contiguous."""
    _max_wrapped_residual(np.ascontiguousarray(phase), np.ascontiguousarray(wrapped), float(scale), out)
