"""The median of a float32 ratio over a mask without compacting or sorting it (private; the
blur estimate of :func:`fringe3d.decode.edges.estimate_blur`).

``np.median(fine[m] / coarse[m])`` copies the masked pixels and partitions them (~20 ns per
pixel, plus three full-size temporaries). A non-negative float32 orders as its bit pattern read
as an unsigned integer, so two numba histogram passes over those bits (high 16 bits, then the
low 16 bits inside the bin that holds the wanted rank) select the exact order statistics.
"""
from __future__ import annotations

import numba
import numpy as np

BINS = 1 << 16


@numba.njit(parallel=True, cache=True)
def _histogram(fine, coarse, mask, high, hist, nans):  # pragma: no cover - compiled
    """``high < 0``: histogram of the high 16 bits of ``fine / coarse`` (float32) over ``mask &
    coarse > 0`` per chunk of rows; else of the low 16 bits of the ratios whose high bits are ``high``."""
    H, W = fine.shape
    nch = hist.shape[0]
    for c in numba.prange(nch):
        buf = np.empty(1, np.float32)
        bits = buf.view(np.uint32)
        nan = 0
        for i in range(c * H // nch, (c + 1) * H // nch):
            for j in range(W):
                if mask[i, j] and coarse[i, j] > 0:
                    r = np.float32(fine[i, j] / coarse[i, j])
                    if r != r:
                        nan += 1
                        continue
                    buf[0] = r if r > 0 else np.float32(0.0)  # -0.0 reads as 0
                    b = bits[0]
                    if high < 0:
                        hist[c, b >> 16] += 1
                    elif (b >> 16) == high:
                        hist[c, b & 0xFFFF] += 1
        nans[c] = nan


def _bin_of_rank(counts: np.ndarray, rank: int) -> tuple[int, int]:
    """(bin, rank within the bin) of the ``rank``-th (0-based) value of a histogram."""
    cum = np.cumsum(counts)
    b = int(np.searchsorted(cum, rank, side="right"))
    return b, rank - (int(cum[b - 1]) if b else 0)


def ratio_median(fine: np.ndarray, coarse: np.ndarray, mask: np.ndarray) -> float:
    """``float(np.median(fine[m] / coarse[m]))`` with ``m = mask & (coarse > 0)``: (H, W)
    float32 ``fine`` and ``coarse`` (non-negative), ``mask`` bool; NaN when ``m`` is empty or a
    ratio is NaN (as numpy). Exact: the same order statistics, averaged in float32 for an even count."""
    fine = np.ascontiguousarray(fine, np.float32)
    coarse = np.ascontiguousarray(coarse, np.float32)
    mask = np.ascontiguousarray(mask, bool)
    nch = max(1, min(numba.get_num_threads(), fine.shape[0]))
    hist = np.zeros((nch, BINS), np.int64)
    nans = np.zeros(nch, np.int64)
    _histogram(fine, coarse, mask, -1, hist, nans)
    high = hist.sum(axis=0)
    n = int(high.sum())
    if n == 0 or nans.sum():
        return float("nan")
    ranks = (n // 2,) if n % 2 else (n // 2 - 1, n // 2)
    values = []
    for rank in ranks:
        hb, within = _bin_of_rank(high, rank)
        hist[:] = 0
        _histogram(fine, coarse, mask, hb, hist, nans)
        lb, _ = _bin_of_rank(hist.sum(axis=0), within)
        values.append(np.array([(hb << 16) | lb], np.uint32).view(np.float32)[0])
    if len(values) == 1:
        return float(values[0])
    return float((values[0] + values[1]) / np.float32(2))
