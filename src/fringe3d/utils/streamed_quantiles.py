"""Exact medians and percentiles of data too long to hold: a few passes over it, bounded memory.

``values`` is a callable returning a fresh iterable of 1D float arrays (e.g. one per frame, read
from disk); together they are the data set. :func:`streamed_percentile` and :func:`streamed_median`
return exactly what ``np.percentile`` (default ``linear`` method) and ``np.median`` return on the
concatenation: each needed order statistic is found by narrowing a value range with histograms
(one pass each) until the values inside it fit in ``hold`` elements, which are then sorted.
"""
from __future__ import annotations

from typing import Callable, Iterable

import numpy as np

__all__ = ["streamed_percentile", "streamed_median", "order_statistic"]

Values = Callable[[], Iterable[np.ndarray]]


def _count_min_max(values: Values) -> tuple[int, float, float]:
    n, lo, hi = 0, np.inf, -np.inf
    for v in values():
        v = np.asarray(v, np.float64).ravel()
        if v.size:
            n += v.size
            lo, hi = min(lo, float(v.min())), max(hi, float(v.max()))
    return n, lo, hi


def _in_range(v: np.ndarray, lo: float, hi: float, closed: bool) -> np.ndarray:
    return (v >= lo) & ((v <= hi) if closed else (v < hi))


def order_statistic(values: Values, k: int, bins: int = 4096, hold: int = 1 << 20,
                    bounds: tuple[int, float, float] | None = None) -> float:
    """The ``k``-th smallest value (0-based) of the data set.

    Parameters
    ----------
    values : callable
        Returns a fresh iterable of arrays on every call (one call per pass).
    k : int
        Rank, 0 ≤ k < n.
    bins : int
        Histogram bins per narrowing pass.
    hold : int
        Most values collected and sorted at once.
    bounds : (n, min, max), optional
        The data set's count and range when already known (saves a pass).
    """
    n, lo, hi = _count_min_max(values) if bounds is None else bounds
    if not 0 <= k < n:
        raise IndexError(f"rank {k} outside a data set of {n} values")
    below, closed = 0, True   # values < lo; whether hi itself is in the range
    while True:
        if lo == hi:
            return lo
        inside, vmin, vmax = 0, np.inf, -np.inf
        for v in values():
            x = np.asarray(v, np.float64).ravel()
            x = x[_in_range(x, lo, hi, closed)]
            if x.size:
                inside, vmin, vmax = inside + x.size, min(vmin, float(x.min())), max(vmax, float(x.max()))
        if vmin == vmax:   # every value left is the same (ties): that is the k-th
            return vmin
        if inside <= hold:
            got = np.sort(np.concatenate([x[_in_range(x, lo, hi, closed)]
                                          for x in (np.asarray(v, np.float64).ravel() for v in values())]
                                         + [np.empty(0)]))
            return float(got[k - below])
        edges = np.linspace(lo, hi, bins + 1)
        counts = np.zeros(bins, np.int64)
        for v in values():
            x = np.asarray(v, np.float64).ravel()
            x = x[_in_range(x, lo, hi, closed)]
            counts += np.bincount(np.clip(np.searchsorted(edges, x, side="right") - 1, 0, bins - 1),
                                  minlength=bins)
        cum = np.cumsum(counts)
        b = int(np.searchsorted(cum, k - below, side="right"))
        below += int(cum[b - 1]) if b else 0
        lo, hi, closed = float(edges[b]), float(edges[b + 1]), closed and b == bins - 1


def streamed_percentile(values: Values, p: float, **kw) -> float:
    """``np.percentile(concatenated values, p)`` (linear interpolation); NaN for no values."""
    n, lo, hi = bounds = _count_min_max(values)
    if n == 0:
        return float("nan")
    h = (n - 1) * (float(p) / 100.0)
    k0 = int(np.floor(h))
    k1 = min(k0 + 1, n - 1)
    a = order_statistic(values, k0, bounds=bounds, **kw)
    b = a if k1 == k0 else order_statistic(values, k1, bounds=bounds, **kw)
    t = h - k0
    diff = b - a
    return float(b - diff * (1 - t)) if t >= 0.5 else float(a + diff * t)   # numpy's _lerp


def streamed_median(values: Values, **kw) -> float:
    """``np.median(concatenated values)``; NaN for no values."""
    n, lo, hi = bounds = _count_min_max(values)
    if n == 0:
        return float("nan")
    a = order_statistic(values, (n - 1) // 2, bounds=bounds, **kw)
    if n % 2:
        return a
    b = order_statistic(values, n // 2, bounds=bounds, **kw)
    return float(np.mean([a, b]))
