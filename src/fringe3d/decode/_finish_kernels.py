"""The decoder's last per-pixel steps in one numba pass each (private; :mod:`fringe3d.decode.decoder`).

* :func:`masked_phase`: ``mask & isfinite(phase) & (quality & bits) == 0`` and the phase with
  NaN outside it (``np.where`` after two or three boolean passes before);
  :func:`quality_masked_phase` reads first whether that changes anything (a read, not a copy);
* :func:`valid_phase`: a phase group's mask (:meth:`fringe3d.decode.context.DecodeContext.group_mask`,
  ``modulation >= min_modulation & ~saturated``) and ``isfinite(phase)``, and the group's phase with
  NaN outside it (a copy, the mask's two boolean passes and :func:`masked_phase` before);
* :func:`texture_fraction`: ``clip(nan_to_num((A [+ B]) / full_scale), 0, 1)`` in float32
  (:func:`fringe3d.decode.texture.as_fraction` of ``np.add(A, B, dtype=float32)``: a sum, a
  divide, ``nan_to_num`` and ``clip`` were four passes and three temporaries).

Both make every operation in the dtype numpy makes it in, so the outputs are equal bit for bit
(``tests/test_fused_assess.py``).
"""
from __future__ import annotations

import numba
import numpy as np


@numba.njit(parallel=True, cache=True)
def _masked_phase(phase, mask, quality, bits, has_quality, out_mask, out_phase):  # pragma: no cover - compiled
    H, W = phase.shape
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            p = phase[i, j]
            m = mask[i, j] & (abs(p) < np.float32(np.inf))  # False for NaN and inf
            if has_quality:
                m = m & ((quality[i, j] & bits) == 0)
            out_mask[i, j] = m
            out_phase[i, j] = p if m else nan


def masked_phase(phase: np.ndarray, mask: np.ndarray, quality: np.ndarray | None = None,
                 bits: int = 0) -> tuple[np.ndarray, np.ndarray]:
    """``(mask, phase)``: ``mask & isfinite(phase)`` and, with ``quality`` (H, W) uint8, ``(quality
    & bits) == 0``; ``phase`` (H, W) float32 with NaN outside that mask (new arrays)."""
    p = np.ascontiguousarray(phase, np.float32)
    m = np.ascontiguousarray(mask, bool)
    q = np.ascontiguousarray(quality, np.uint8) if quality is not None else np.zeros((1, 1), np.uint8)
    out_mask = np.empty(p.shape, bool)
    out_phase = np.empty(p.shape, np.float32)
    _masked_phase(p, m, q, np.uint8(bits), quality is not None, out_mask, out_phase)
    return out_mask, out_phase


@numba.njit(parallel=True, cache=True)
def _texture_fraction(a, b, with_b, scale, out):  # pragma: no cover - compiled
    H, W = a.shape
    zero = np.float32(0.0)
    one = np.float32(1.0)
    for i in numba.prange(H):
        for j in range(W):
            x = (a[i, j] + b[i, j]) if with_b else a[i, j]
            t = x / scale
            out[i, j] = zero if t != t else min(max(t, zero), one)


def texture_fraction(average: np.ndarray, modulation: np.ndarray | None, full_scale: float) -> np.ndarray:
    """(H, W) float32 ``clip(nan_to_num((average + modulation) / full_scale), 0, 1)`` (without
    ``modulation``: of ``average`` alone), float32 ``average`` and ``modulation``."""
    a = np.ascontiguousarray(average, np.float32)
    b = np.ascontiguousarray(modulation, np.float32) if modulation is not None else a
    out = np.empty(a.shape, np.float32)
    _texture_fraction(a, b, modulation is not None, np.float32(full_scale), out)
    return out


@numba.njit(parallel=True, cache=True)
def _any_dropped(phase, mask, quality, bits):  # pragma: no cover - compiled
    H, W = phase.shape
    rows = np.zeros(H, np.bool_)
    for i in numba.prange(H):
        hit = False
        for j in range(W):  # branch-free: vectorises
            finite = abs(phase[i, j]) < np.float32(np.inf)
            hit |= mask[i, j] & (((quality[i, j] & bits) != 0) | (not finite))
        rows[i] = hit
    return rows.any()


def quality_masked_phase(phase: np.ndarray, mask: np.ndarray, quality: np.ndarray,
                         bits: int) -> tuple[np.ndarray, np.ndarray]:
    """:func:`masked_phase` of ``(phase, mask, quality, bits)``, or ``(mask, phase)`` themselves
    (the same objects) when no pixel of ``mask`` has a non-finite phase or a bit of ``bits`` set,
    which one read of ``mask``, ``quality`` and ``phase`` tells."""
    p = np.ascontiguousarray(phase, np.float32)
    m = np.ascontiguousarray(mask, bool)
    q = np.ascontiguousarray(quality, np.uint8)
    if p is phase and m is mask and not _any_dropped(p, m, q, np.uint8(bits)):
        return mask, phase
    return masked_phase(p, m, q, bits)


@numba.njit(parallel=True, cache=True)
def _valid_phase(phase, modulation, threshold, saturated, out_mask, out_phase):  # pragma: no cover - compiled
    H, W = phase.shape
    nan = np.float32(np.nan)
    for i in numba.prange(H):
        for j in range(W):
            p = phase[i, j]
            m = (modulation[i, j] >= threshold) & (not saturated[i, j]) & (abs(p) < np.float32(np.inf))
            out_mask[i, j] = m
            out_phase[i, j] = p if m else nan


def float32_threshold(threshold: float) -> np.float32:
    """The float32 ``T`` with ``x >= T`` exactly where NumPy's ``x >= threshold`` holds for every
    float32 ``x`` (NaN included): a Python number is cast to float32 first (NEP 50), a NumPy
    scalar compared in the promoted dtype; ``T`` is the least float32 not below that value."""
    with np.errstate(over="ignore"):
        t = float(np.float32(threshold)) if type(threshold) in (int, float) else float(threshold)
        T = np.float32(t)
    return np.nextafter(T, np.float32(np.inf)) if float(T) < t else T


def valid_phase(phase: np.ndarray, modulation: np.ndarray, min_modulation: float,
                saturated: np.ndarray) -> tuple[np.ndarray, np.ndarray]:
    """``(mask, phase)``: ``(modulation >= min_modulation) & ~saturated & isfinite(phase)`` and
    ``phase`` (H, W) float32 with NaN outside it (new arrays), one pass; ``modulation`` float32,
    compared as NumPy compares it with ``min_modulation`` (:func:`float32_threshold`)."""
    p = np.ascontiguousarray(phase, np.float32)
    b = np.ascontiguousarray(modulation, np.float32)
    out_mask = np.empty(p.shape, bool)
    out_phase = np.empty(p.shape, np.float32)
    _valid_phase(p, b, float32_threshold(min_modulation), np.ascontiguousarray(saturated, bool),
                 out_mask, out_phase)
    return out_mask, out_phase
