"""Exact 5 x 5 median filter (numba; private, see :func:`fringe3d.decode.edges.gradient_jump`).

``scipy.ndimage.median_filter(g, size=5, mode="nearest")`` takes about half a second on a
1280 x 1024 map; this gives the same values (the 13th smallest of the 25 neighbours, the border
replicated) with a selection network applied to a whole row at once, so the inner loop
vectorises. The network is Batcher's odd-even merge sort of 32 inputs, cut to 25 inputs (the
7 missing ones are +inf, so every comparator that touches them is a no-op) and pruned to the
comparators the 13th output depends on.
"""
from __future__ import annotations

import numba
import numpy as np

SIZE = 5
_N = SIZE * SIZE
_MID = _N // 2


def batcher_pairs(n: int) -> list[tuple[int, int]]:
    """Comparators ``(lo, hi)`` of Batcher's odd-even merge sort of ``n`` (a power of 2) inputs."""
    pairs = []
    p = 1
    while p < n:
        k = p
        while k >= 1:
            for j in range(k % p, n - k, 2 * k):
                for i in range(min(k, n - j - k)):
                    if (i + j) // (2 * p) == (i + j + k) // (2 * p):
                        pairs.append((i + j, i + j + k))
            k //= 2
        p *= 2
    return pairs


def selection_pairs(n: int, rank: int) -> np.ndarray:
    """(M, 2) int64 comparators that put the ``rank``-th smallest of ``n`` inputs at index ``rank``."""
    size = 1 << (n - 1).bit_length()
    net = [(a, b) for a, b in batcher_pairs(size) if b < n]  # b >= n compares with +inf: a no-op
    needed, kept = {rank}, []
    for a, b in reversed(net):
        if a in needed or b in needed:
            kept.append((a, b))
            needed.update((a, b))
    return np.array(kept[::-1], np.int64)


PAIRS = selection_pairs(_N, _MID)


@numba.njit(parallel=True, cache=True)
def _median_kernel(g, pairs, out):  # pragma: no cover - compiled
    H, W = g.shape
    r = SIZE // 2
    for i in numba.prange(H):
        v = np.empty((SIZE * SIZE, W), g.dtype)
        k = 0
        for di in range(-r, r + 1):
            row = min(max(i + di, 0), H - 1)
            for dj in range(-r, r + 1):
                for j in range(W):
                    v[k, j] = g[row, min(max(j + dj, 0), W - 1)]
                k += 1
        for p in range(pairs.shape[0]):
            a = pairs[p, 0]
            b = pairs[p, 1]
            for j in range(W):
                x = v[a, j]
                y = v[b, j]
                v[a, j] = min(x, y)
                v[b, j] = max(x, y)
        for j in range(W):
            out[i, j] = v[SIZE * SIZE // 2, j]


def median5(g: np.ndarray) -> np.ndarray:
    """(H, W) 5 x 5 median of the (H, W) float map ``g`` (no NaN), border replicated: equal to
    ``scipy.ndimage.median_filter(g, size=5, mode="nearest")``."""
    g = np.ascontiguousarray(g)
    out = np.empty_like(g)
    _median_kernel(g, PAIRS, out)
    return out
