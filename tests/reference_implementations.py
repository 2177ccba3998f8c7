"""Plain-NumPy reference implementations of the fused numba kernels, used only by the tests
(each states the equation it implements; the tests compare the fast paths against them)."""
from __future__ import annotations

import numpy as np

from fringe3d.phase.frames import as_frame_stack
from fringe3d.phase.psp import PhaseResult, default_shifts


def wrapped_phase_reference(frames, shifts=None) -> PhaseResult:
    """Plain-NumPy reference of :func:`wrapped_phase` (float64 math, float32 output).

    Equal shifts use the literal sums of Eq. (2.4); other shifts solve the least-squares
    system with ``numpy.linalg.lstsq``.
    """
    f = as_frame_stack(frames, layout="(N, H, W)").astype(np.float64)
    n = f.shape[0]
    d = default_shifts(n) if shifts is None else np.asarray(shifts, dtype=np.float64)
    if d.size != n:
        raise ValueError(f"got {d.size} phase shifts for {n} frames; expected one shift per frame")
    if n < 3:
        raise ValueError(f"phase shifting needs at least 3 frames, got {n}")
    rel = np.sort(np.mod(d - d[0] + 1e-12, 2 * np.pi) - 1e-12)
    if np.allclose(rel, default_shifts(n), atol=1e-9):  # N equally spaced shifts, any order
        num = -np.tensordot(np.sin(d), f, axes=1)
        den = np.tensordot(np.cos(d), f, axes=1)
        phase = np.arctan2(num, den)
        average = f.mean(axis=0)
        modulation = (2.0 / n) * np.abs(np.tensordot(np.exp(-1j * d), f, axes=1))
    else:
        design = np.stack([np.ones(n), np.cos(d), np.sin(d)], axis=1)
        sol, *_ = np.linalg.lstsq(design, f.reshape(n, -1), rcond=None)
        a, b, c = (s.reshape(f.shape[1:]) for s in sol)
        phase, average, modulation = np.arctan2(-c, b), a, np.hypot(b, c)
    return PhaseResult(phase.astype(np.float32), average.astype(np.float32), modulation.astype(np.float32))
