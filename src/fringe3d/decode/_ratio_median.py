"""The median of a float32 ratio over a mask without compacting or sorting every pixel
(private; the blur estimate of :func:`fringe3d.decode.edges.estimate_blur`).

``np.median(fine[m] / coarse[m])`` copies the masked pixels and partitions them all (~20 ns per
pixel, plus three full-size temporaries). Here (Floyd and Rivest's selection): the ratios of
every 8th row and column bracket the median, ``[lo, hi]`` holding a few percent of the pixels
with near certainty; one numba pass counts the ratios below ``lo`` and keeps those inside
the bracket with their histogram over :data:`BINS` bins, and only the median's bin (a few
dozen values) is partitioned, not the whole bracket (~8 % of the pixels, serial numpy). The
order statistics are the same as numpy's (exact); a bracket that misses the median (or
overflows its buffer) falls back to numpy.
"""
from __future__ import annotations

import math

import numba
import numpy as np

STRIDE = 8
#: Histogram bins over the bracket: the median is selected inside its bin only.
BINS = 4096


@numba.njit(cache=True, inline="always")
def _bin(r, lo, scale, nbins):  # pragma: no cover - compiled
    """The histogram bin of a bracketed ratio ``r >= lo`` (float32 arithmetic, monotone in ``r``;
    the last bin from ``nbins - 1`` up, and for an infinite ratio)."""
    x = (r - lo) * scale
    return np.int64(x) if x < nbins - 1 else nbins - 1


@numba.njit(parallel=True, cache=True, error_model="numpy")
def _bracket_pass(fine, coarse, mask, lo, hi, keep, counts, scale, hist):  # pragma: no cover - compiled
    """Per chunk of rows ``c``: ``counts[c] = (below lo, inside [lo, hi], all, NaN)`` of the
    ratios ``fine / coarse`` (float32) over ``mask & coarse > 0``; the inside ones into ``keep[c]``
    while they fit (``counts[c, 1] >= cap`` when they did not), with their histogram over the
    ``hist.shape[1]`` bins of :func:`_bin` in ``hist[c]``.

    Row by row: a branch-free loop (it vectorises: 32-bit counts of 0/1 integers, the mask read
    as bytes, and numpy's division semantics, no zero-divisor check; a ratio of ``coarse <= 0``
    is never counted) counts and parks the row's ratios in a row buffer (NaN outside the
    bracket); a second, branch-free loop over that buffer compacts the bracketed ones (every
    slot written, the write position advancing only on a kept one)."""
    H, W = fine.shape
    nch, cap = keep.shape
    nbins = hist.shape[1]
    for c in numba.prange(nch):
        below = 0
        inside = 0
        total = 0
        nan = 0
        row = np.empty(W, np.float32)
        for i in range(c * H // nch, (c + 1) * H // nch):
            n_in = np.int32(0)
            n_below = np.int32(0)
            n_all = np.int32(0)
            n_nan = np.int32(0)
            fr = fine[i]
            cr = coarse[i]
            mr = mask[i].view(np.uint8)
            for j in range(W):
                d = cr[j]
                r = fr[j] / d
                ok = np.int32(mr[j]) & np.int32(d > 0)
                n_all += ok
                n_below += ok & np.int32(r < lo)
                n_nan += ok & np.int32(r != r)
                isin = ok & np.int32(r >= lo) & np.int32(r <= hi)
                n_in += isin
                row[j] = r if isin else np.float32(np.nan)
            total += n_all
            below += n_below
            nan += n_nan
            if n_in > 0 and inside + n_in < cap:  # the last write lands at inside + n_in < cap
                k = inside
                for j in range(W):
                    r = row[j]
                    keep[c, k] = r
                    k += r == r
            inside += n_in
        counts[c, 0] = below
        counts[c, 1] = inside
        counts[c, 2] = total
        counts[c, 3] = nan
        if inside < cap:
            for k in range(inside):
                hist[c, _bin(keep[c, k], lo, scale, nbins)] += 1


@numba.njit(cache=True)
def _in_bin(keep, counts, lo, scale, nbins, b, out):  # pragma: no cover - compiled
    """The kept ratios of bin ``b`` (:func:`_bin`) into ``out``, in one pass."""
    n = 0
    for c in range(keep.shape[0]):
        for k in range(counts[c, 1]):
            r = keep[c, k]
            if _bin(r, lo, scale, nbins) == b:
                out[n] = r
                n += 1


def _numpy_median(fine: np.ndarray, coarse: np.ndarray, mask: np.ndarray) -> float:
    m = np.asarray(mask, bool) & (coarse > 0)
    return float(np.median(fine[m] / coarse[m])) if m.any() else float("nan")


def ratio_median(fine: np.ndarray, coarse: np.ndarray, mask: np.ndarray) -> float:
    """``float(np.median(fine[m] / coarse[m]))`` with ``m = mask & (coarse > 0)``: (H, W)
    float32 ``fine`` and ``coarse``, ``mask`` bool; NaN when ``m`` is empty or a ratio is NaN
    (as numpy). Exact: the same order statistics, averaged in float32 for an even count."""
    fine = np.ascontiguousarray(fine, np.float32)
    coarse = np.ascontiguousarray(coarse, np.float32)
    mask = np.ascontiguousarray(mask, bool)
    sm, sc = mask[::STRIDE, ::STRIDE] & (coarse[::STRIDE, ::STRIDE] > 0), coarse[::STRIDE, ::STRIDE]
    sample = fine[::STRIDE, ::STRIDE][sm] / sc[sm]
    if sample.size < 50 or np.isnan(sample).any():
        return _numpy_median(fine, coarse, mask)
    delta = min(0.5, 0.01 + 4.0 / math.sqrt(sample.size))  # ~8 standard errors of the sample median
    lo, hi = np.quantile(sample, [max(0.0, 0.5 - delta), min(1.0, 0.5 + delta)], method="inverted_cdf")
    nch = max(1, min(numba.get_num_threads(), fine.shape[0]))
    cap = int(2.5 * delta * fine.size / nch) + 1024
    keep = np.empty((nch, cap), np.float32)
    counts = np.zeros((nch, 4), np.int64)
    lo32, hi32 = np.float32(lo), np.float32(hi)
    width = float(hi32) - float(lo32)
    scale = np.float32(BINS / width if 0 < width < math.inf else 0.0)
    hist = np.zeros((nch, BINS), np.int64)
    _bracket_pass(fine, coarse, mask, lo32, hi32, keep, counts, scale, hist)
    below, inside, n, nans = (int(t) for t in counts.sum(axis=0))
    if nans:
        return float("nan")
    ranks = [n // 2] if n % 2 else [n // 2 - 1, n // 2]
    if n == 0 or (counts[:, 1] >= cap).any() or not below <= ranks[0] <= ranks[-1] < below + inside:
        return _numpy_median(fine, coarse, mask)
    upto = np.cumsum(hist.sum(axis=0))  # the bracketed ratios in bins 0 .. b
    values = []
    for r in ranks:  # the bin holding rank r (the histogram is monotone in the ratio), then its rank there
        b = int(np.searchsorted(upto, r - below, side="right"))
        first = int(upto[b - 1]) if b else 0
        members = np.empty(int(upto[b]) - first, np.float32)
        _in_bin(keep, counts, lo32, scale, BINS, b, members)
        values.append(np.partition(members, r - below - first)[r - below - first])
    if len(values) == 1:
        return float(values[0])
    return float((values[0] + values[1]) / np.float32(2))
