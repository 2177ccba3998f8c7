"""The median of a float32 ratio over a mask without compacting or sorting every pixel
(private; the blur estimate of :func:`fringe3d.decode.edges.estimate_blur`).

``np.median(fine[m] / coarse[m])`` copies the masked pixels and partitions them all (~20 ns per
pixel, plus three full-size temporaries). Here (Floyd and Rivest's selection): the ratios of
every 8th row and column bracket the median, ``[lo, hi]`` holding a few percent of the pixels
with near certainty (the sample and its quantiles in one compiled call); one numba pass counts
the ratios below ``lo`` and keeps those inside the bracket with their histogram over
:data:`BINS` bins (on one thread up to :data:`SERIAL_PIXELS`), and only the median's bin (a
few dozen values) is sorted, not the whole bracket, in one more compiled call. The order
statistics are the same as numpy's (exact, whatever the bracket); a bracket that misses the
median (or overflows its buffer) falls back to numpy. Three compiled calls and a few small
allocations in all: the fixed cost of a small image is a few tens of microseconds.
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


@numba.njit(cache=True, error_model="numpy")
def _sample_bracket(fine, coarse, mask, stride):  # pragma: no cover - compiled
    """``(n, delta, lo, hi)``: the count ``n`` of the sampled ratios ``fine / coarse`` (float32)
    of every ``stride``-th row and column over ``mask & coarse > 0``, the bracket's half width
    ``delta = min(0.5, 0.01 + 4 / sqrt(n))`` (~8 standard errors of the sample median) and the
    sample's ``0.5 -+ delta`` quantiles (numpy's ``method="inverted_cdf"``); ``n = -1`` for a
    NaN ratio; ``delta = lo = hi = 0`` when ``n < 50``."""
    h, w = fine.shape
    buf = np.empty(((h + stride - 1) // stride) * ((w + stride - 1) // stride), np.float32)
    n = 0
    for i in range(0, h, stride):
        fr = fine[i]
        cr = coarse[i]
        mr = mask[i]
        for j in range(0, w, stride):
            d = cr[j]
            if mr[j] and d > 0:
                r = fr[j] / d
                if r != r:
                    return -1, 0.0, np.float32(0), np.float32(0)
                buf[n] = r
                n += 1
    if n < 50:
        return n, 0.0, np.float32(0), np.float32(0)
    delta = min(0.5, 0.01 + 4.0 / math.sqrt(n))
    a = _inverted_cdf(n, max(0.0, 0.5 - delta))
    b = _inverted_cdf(n, min(1.0, 0.5 + delta))
    s = np.partition(buf[:n], b)  # quickselect: entries below b hold the b smallest
    return n, delta, np.partition(s[:b + 1], a)[a], s[b]


@numba.njit(cache=True, inline="always")
def _inverted_cdf(n, q):  # pragma: no cover - compiled
    """numpy's ``inverted_cdf`` index of quantile ``q`` of ``n`` sorted values (float64
    ``n q - 1``, its floor when whole, else the next index; -1 raised to 0)."""
    x = n * q - 1.0
    k = math.floor(x)
    i = np.int64(k) if x - k == 0 else np.int64(k) + 1
    return i + 1 if i < 0 else i


@numba.njit(cache=True)
def _select(keep, counts, hist, lo, scale, first, last):  # pragma: no cover - compiled
    """The ``first``-th and ``last``-th smallest (from 0, ``first <= last``) of the kept ratios
    (``counts[c, 1]`` of ``keep[c]``, histogram ``hist`` over the bins of :func:`_bin`): the
    bins holding them (the bins are monotone in the ratio), then their ranks among the members
    of those bins and the bins between, sorted (one scan of the kept ratios for both ranks)."""
    nch, nbins = hist.shape
    upto = 0  # ratios in the bins up to the one scanned
    below = 0  # ratios in the bins below the one holding ``first``
    b_first = -1
    b_last = 0
    for b in range(nbins):
        total = 0
        for c in range(nch):
            total += hist[c, b]
        if b_first < 0 and upto + total > first:
            b_first = b
            below = upto
        upto += total
        if upto > last:
            b_last = b
            break
    members = np.empty(upto - below, np.float32)
    n = 0
    for c in range(nch):
        for k in range(counts[c, 1]):
            r = keep[c, k]
            i = _bin(r, lo, scale, nbins)
            if i >= b_first and i <= b_last:
                members[n] = r
                n += 1
    members.sort()
    return members[first - below], members[last - below]


#: Pixels up to which the bracket pass runs on one thread (a parallel region's fork and join
#: cost more than a second thread saves on these).
SERIAL_PIXELS = 1 << 16


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
    if fine.ndim != 2:
        return _numpy_median(fine, coarse, mask)
    n_sample, delta, lo32, hi32 = _sample_bracket(fine, coarse, mask, STRIDE)
    if n_sample < 50:  # too few sampled ratios, or a NaN among them
        return _numpy_median(fine, coarse, mask)
    serial = fine.size <= SERIAL_PIXELS
    nch = 1 if serial else max(1, min(numba.get_num_threads(), fine.shape[0]))
    cap = int(2.5 * delta * fine.size / nch) + 1024
    keep = np.empty((nch, cap), np.float32)
    counts = np.zeros((nch, 4), np.int64)
    width = float(hi32) - float(lo32)
    scale = np.float32(BINS / width if 0 < width < math.inf else 0.0)
    hist = np.zeros((nch, BINS), np.int64)
    if serial:  # one thread runs the region in the calling thread: no fork and join
        threads = numba.get_num_threads()
        numba.set_num_threads(1)
        try:
            _bracket_pass(fine, coarse, mask, lo32, hi32, keep, counts, scale, hist)
        finally:
            numba.set_num_threads(threads)
    else:
        _bracket_pass(fine, coarse, mask, lo32, hi32, keep, counts, scale, hist)
    below, inside, n, nans = (int(t) for t in counts.sum(axis=0))
    if nans:
        return float("nan")
    ranks = [n // 2] if n % 2 else [n // 2 - 1, n // 2]
    if n == 0 or (counts[:, 1] >= cap).any() or not below <= ranks[0] <= ranks[-1] < below + inside:
        return _numpy_median(fine, coarse, mask)
    a, b = _select(keep, counts, hist, lo32, scale, ranks[0] - below, ranks[-1] - below)
    if len(ranks) == 1:
        return float(a)
    return float((a + b) / np.float32(2))
