"""Plain-NumPy reference implementations of the engine's kernels (unwrap, decode), used only by
the tests to check the numba paths (:mod:`fringe3d.unwrap.temporal`)."""
from __future__ import annotations

import numpy as np

from fringe3d.patterns.conventions import TWO_PI, coarse_to_fine_order
from fringe3d.unwrap.temporal import (CodeUnwrapped, OrderedPhase, beat_chain, check_periods, coarse_window,
                                      stack_phases)


def hierarchical_reference(phases, periods, w_range=None) -> OrderedPhase:
    """Plain-NumPy reference of :func:`hierarchical`."""
    st = stack_phases(phases).astype(np.float64)
    p = check_periods(periods, st.shape[0], 1)
    lower = coarse_window(p[-1], w_range)
    big = lower + np.mod(st[-1] - lower, TWO_PI)
    k = coarse_to_fine_order(big, st[-1], 1.0, ties="up")
    for q in range(st.shape[0] - 2, -1, -1):
        k = coarse_to_fine_order(big, st[q], p[q + 1] / p[q], ties="up")
        big = st[q] + TWO_PI * k
    return OrderedPhase(big.astype(np.float32), k.astype(np.int32))


def heterodyne_reference(phases, periods, w_range=None) -> OrderedPhase:
    """Plain-NumPy reference of :func:`heterodyne`."""
    st = stack_phases(phases).astype(np.float64)
    p = check_periods(periods, st.shape[0], 2)
    beats, signs = beat_chain(p)
    lower = coarse_window(beats[-1], w_range)
    beat_phases = [np.mod(signs[0] * (st[0] - st[1]), TWO_PI)]
    for q in range(1, len(beats)):
        beat_phases.append(np.mod(signs[q] * (beat_phases[-1] - st[q + 1]), TWO_PI))
    big = lower + np.mod(beat_phases[-1] - lower, TWO_PI)
    for q in range(len(beats) - 2, -1, -1):
        kq = coarse_to_fine_order(big, beat_phases[q], beats[q + 1] / beats[q], ties="up")
        big = beat_phases[q] + TWO_PI * kq
    k = coarse_to_fine_order(big, st[0], beats[0] / p[0], ties="up")
    return OrderedPhase((st[0] + TWO_PI * k).astype(np.float32), k.astype(np.int32))


def gray_code_order_reference(frames, code_index, wrapped, period, stripes, inverse_index=None,
                              threshold=None, contrast=None) -> CodeUnwrapped:
    """Plain-NumPy reference of :func:`gray_code_order` (one pixel at a time for the edge fades)."""
    f = np.asarray(frames, dtype=np.float64)
    nb = len(code_index)
    diff = np.stack([f[i] - (f[inverse_index[q]] if inverse_index is not None else np.asarray(threshold, np.float64))
                     for q, i in enumerate(code_index)])
    code = np.zeros(f.shape[1:], np.int64)
    for q in range(nb):
        code = code * 2 + (diff[q] > 0)
    size = np.abs(diff)
    amp = size.max(axis=0) if contrast is None else np.maximum(size.max(axis=0), contrast)
    weights = [1 << (nb - 1 - q) for q in range(nb)]

    def fade(mask, pick, empty):
        sel = np.stack([(mask & wq) != 0 for wq in weights])
        vals = np.where(sel, size, empty[None])
        return np.where(mask != 0, pick(vals, axis=0), amp)

    fl, fh = stripes.lower_bits[code], stripes.upper_bits[code]
    el, eh = fl & ~fh, fh & ~fl
    d_lo = fade(fl, np.max, np.zeros_like(amp))
    d_hi = fade(fh, np.max, np.zeros_like(amp))
    e_lo = fade(el, np.min, amp)
    e_hi = fade(eh, np.min, amp)
    both = (fl != 0) & (fh != 0)
    d_hi = np.where(both & (eh == 0), np.maximum(d_hi, amp - e_lo), d_hi)
    d_lo = np.where(both & (el == 0), np.maximum(d_lo, amp - e_hi), d_lo)
    lo, hi, c = stripes.lower[code], stripes.upper[code], stripes.centre[code]
    valid = np.isfinite(c)
    with np.errstate(invalid="ignore", divide="ignore"):
        wc = np.where(d_lo + d_hi > 0, lo + (hi - lo) * d_lo / (d_lo + d_hi), c)
    phi = np.asarray(wrapped, np.float64)
    k = np.floor(np.where(valid, wc, 0.0) / period - phi / TWO_PI + 0.5)
    phase = np.where(valid, phi + TWO_PI * k, np.nan)
    return CodeUnwrapped(phase.astype(np.float32), np.where(valid, k, 0).astype(np.int32), valid)
